"""Uncertainty and sensitivity sweeps of commissioning runs on Dask (``ringqa sweep``).

Public API::

    from ringqa.sweep import load_spec, run_sweep
    spec = load_spec("data/sweeps/ring26-uncertainty.toml", {"samples": 24})
    res = run_sweep(spec, "out/sweep")                    # LocalCluster of all cores
    res = run_sweep(spec, "out/sweep", scheduler="tcp://host:8786")

Modules: :mod:`~ringqa.sweep.spec` (the TOML spec, checked), :mod:`~ringqa.sweep.sampling`
(the design), :mod:`~ringqa.sweep.runner` (one sample = one commissioning run; the Dask task),
:mod:`~ringqa.sweep.execute` (Dask), :mod:`~ringqa.sweep.store` (``samples.h5``),
:mod:`~ringqa.sweep.analysis` (``summary.csv``, ``sensitivity.csv``),
:mod:`~ringqa.sweep.figures` (the uncertainty figure), :mod:`~ringqa.sweep.study` (runs them
in order). See docs/sweeps.md.
"""

from ringqa.sweep.spec import Parameter, SweepSpec, SweepSpecError, load_spec
from ringqa.sweep.study import SweepResult, run_sweep

__all__ = ["Parameter", "SweepResult", "SweepSpec", "SweepSpecError", "load_spec", "run_sweep"]
