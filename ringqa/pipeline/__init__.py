"""Commissioning: applicator -> simulated source path -> standard plans and doses -> verdicts.

Public API::

    from ringqa.pipeline import commission, commission_batch, CommissionSettings
    res = commission("ring26x60")                      # or a folder, JSON, RT Plan (.dcm)
    res = commission("ring26x60", CommissionSettings(prescription_gy=6.0))
    batch = commission_batch(shipped_applicators())    # one failure does not stop the rest

The steps (one module each) are public too: :mod:`ringqa.pipeline.commission` lists them.

The names above are imported when first used (PEP 562 ``__getattr__``), so that importing one
step (``ringqa.pipeline.settings`` for ``ringqa commission --help``, ``ringqa.pipeline.numbers``)
does not import every other one and pandas with the batch (measured: ``import
ringqa.pipeline.settings`` 1.9 -> 0.5 s under load, ``python -X importtime``). The names and
what they are do not change: ``ringqa.pipeline.commission`` is the function, as when this
package imported it eagerly.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

#: public name -> the module that defines it (imported on first use of the name)
EXPORTS: dict[str, str] = {
    "BatchResult": "ringqa.pipeline.batch",
    "commission_batch": "ringqa.pipeline.batch",
    "commission": "ringqa.pipeline.commission",
    "DeviationComponents": "ringqa.pipeline.deviations",
    "angle_deg": "ringqa.pipeline.deviations",
    "deviation_components": "ringqa.pipeline.deviations",
    "CommissioningResult": "ringqa.pipeline.result",
    "PathNumbers": "ringqa.pipeline.result",
    "RingGeometry": "ringqa.pipeline.result",
    "RunSettings": "ringqa.pipeline.result",
    "SimulationInfo": "ringqa.pipeline.result",
    "Summary": "ringqa.pipeline.result",
    "Timings": "ringqa.pipeline.result",
    "Verdict": "ringqa.pipeline.result",
    "CommissionSettings": "ringqa.pipeline.settings",
    "Engine": "ringqa.pipeline.simulate",
    "SimulationJammedError": "ringqa.pipeline.simulate",
    "default_engine": "ringqa.pipeline.simulate",
    "DOSE_ACTION_PCT": "ringqa.pipeline.settings",
    "POSITION_RECOMMENDED_MM": "ringqa.pipeline.settings",
    "POSITION_REQUIRED_MM": "ringqa.pipeline.settings",
}

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

if TYPE_CHECKING:  # what the names are (for readers, type checkers and the layer test)
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
    from ringqa.pipeline.settings import (
        DOSE_ACTION_PCT,
        POSITION_RECOMMENDED_MM,
        POSITION_REQUIRED_MM,
        CommissionSettings,
    )
    from ringqa.pipeline.simulate import Engine, SimulationJammedError, default_engine


def __getattr__(name: str):
    """A public name of :data:`EXPORTS`, imported from its module on first use."""
    module = EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *EXPORTS})


class _Package(types.ModuleType):
    """This package's module type: importing the step module ``ringqa.pipeline.commission``
    would bind it as the package's attribute ``commission``, hiding the public function of that
    name; that binding is skipped (the step module stays in ``sys.modules``)."""

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, types.ModuleType) and EXPORTS.get(name) == f"{__name__}.{name}":
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
