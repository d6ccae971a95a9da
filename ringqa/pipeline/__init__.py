"""Commissioning: applicator -> simulated source path -> standard plans and doses -> verdicts.

Public API::

    from ringqa.pipeline import commission, commission_batch, CommissioningResult, BatchResult
    res = commission("ring26x60")                      # or a folder, JSON, RT Plan (.dcm)
    batch = commission_batch(shipped_applicators())    # one failure does not stop the rest
"""

from ringqa.pipeline.batch import BatchResult, commission_batch
from ringqa.pipeline.commission import (
    DOSE_ACTION_PCT,
    POSITION_RECOMMENDED_MM,
    POSITION_REQUIRED_MM,
    CommissioningResult,
    SimulationJammedError,
    Verdict,
    angle_deg,
    commission,
    deviation_components,
)

__all__ = [
    "DOSE_ACTION_PCT",
    "POSITION_RECOMMENDED_MM",
    "POSITION_REQUIRED_MM",
    "BatchResult",
    "CommissioningResult",
    "SimulationJammedError",
    "Verdict",
    "angle_deg",
    "commission",
    "commission_batch",
    "deviation_components",
]
