"""Needle insertion forces in S-shaped channels: the paper's second model (docs/needle.md).

One module a job:

- :mod:`.scene`: the settings (``data/scenes/needle-paper.toml``), the paper's channel for a radius,
  torsion and diameter with the checks that reject impossible ones, and the engine scene of one
  insertion (depth = the engine's advance; the clamped link behind the free length);
- :mod:`.peaks`: the measurements' moving-average filter and the 1st peak, plateau and 2nd peak;
- :mod:`.run`: one insertion (:func:`~ringqa.needle.run.run_channel` -> ``NeedleRun``);
- :mod:`.sweep`: the paper's three families over a process pool (``run_sweep`` -> ``SweepResult``);
- :mod:`.figures`, :mod:`.output`: the force-depth plot, Figures 8 and 9, and the files.

Layer: beside the pipeline; it uses geometry and the simulation engine's public API, and only the
command line (``ringqa needle``) uses it.
"""
