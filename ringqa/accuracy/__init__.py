"""The accuracy/time study: what each numerical setting of a simulation costs and buys.

Public API::

    from ringqa.accuracy import run_study, AccuracyStudy, default_grid, pareto_mask, recommend
    from ringqa.accuracy import scaled_overrides  # element lengths and step x factors
    from ringqa.accuracy import compare_formulations  # rigid vs flexible engine, refined
"""

from ringqa.accuracy.formulations import FormulationStudy, compare_formulations
from ringqa.accuracy.grid import scaled_overrides
from ringqa.accuracy.study import (
    AccuracyError,
    AccuracyStudy,
    ReferenceInfo,
    RunRecord,
    default_grid,
    pareto_mask,
    recommend,
    run_study,
)

__all__ = [
    "AccuracyError",
    "AccuracyStudy",
    "FormulationStudy",
    "ReferenceInfo",
    "RunRecord",
    "compare_formulations",
    "default_grid",
    "pareto_mask",
    "recommend",
    "run_study",
    "scaled_overrides",
]
