"""Commissioning: applicator -> simulated source path -> standard plans and doses -> verdicts.

Public API::

    from ringqa.pipeline import commission, commission_batch, CommissionSettings
    res = commission("ring26x60")                      # or a folder, JSON, RT Plan (.dcm)
    res = commission("ring26x60", CommissionSettings(prescription_gy=6.0))
    batch = commission_batch(shipped_applicators())    # one failure does not stop the rest

The steps (one module each) are public too: :mod:`ringqa.pipeline.commission` lists them.
"""

from ringqa.pipeline.batch import BatchResult, commission_batch
from ringqa.pipeline.commission import commission
from ringqa.pipeline.deviations import DeviationComponents, angle_deg, deviation_components
from ringqa.pipeline.result import (
    CommissioningResult,
    PathNumbers,
    RingGeometry,
    RunSettings,
    SimulationInfo,
    Summary,
    Timings,
    Verdict,
)
from ringqa.pipeline.settings import CommissionSettings
from ringqa.pipeline.simulate import Engine, SimulationJammedError, default_engine
from ringqa.pipeline.verdicts import DOSE_ACTION_PCT, POSITION_RECOMMENDED_MM, POSITION_REQUIRED_MM

__all__ = [
    "DOSE_ACTION_PCT",
    "POSITION_RECOMMENDED_MM",
    "POSITION_REQUIRED_MM",
    "BatchResult",
    "CommissionSettings",
    "CommissioningResult",
    "DeviationComponents",
    "Engine",
    "PathNumbers",
    "RingGeometry",
    "RunSettings",
    "SimulationInfo",
    "SimulationJammedError",
    "Summary",
    "Timings",
    "Verdict",
    "angle_deg",
    "commission",
    "commission_batch",
    "default_engine",
    "deviation_components",
]
