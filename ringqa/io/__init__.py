"""Importers and exporters: CSV/JSON points, DICOM RT Plans, Oncentra's applicator library.

Submodules (import them directly; this package imports nothing eagerly):

- :mod:`ringqa.io.points`: centreline and source-path points (CSV ``x_mm,y_mm,z_mm`` or JSON).
- :mod:`ringqa.io.rtplan`: :func:`~ringqa.io.rtplan.read_rtplan` for brachytherapy RT Plans and
  :func:`~ringqa.io.rtplan.applicator_from_rtplan`.
- :mod:`ringqa.io.oncentra`: Oncentra's embedded applicator library (private tag (300B,100D)).
- :mod:`ringqa.io.applicator_file`: ringqa's own applicator format.
"""
