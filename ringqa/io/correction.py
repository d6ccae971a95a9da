"""Centreline correction files: a CT/film segment spliced over an applicator's library centreline.

Format
    The point-file format of :mod:`ringqa.io.points` (``docs/importers.md``): a CSV with the
    columns ``x_mm, y_mm, z_mm`` (or the JSON equivalent), one row per point, ordered PROXIMAL ->
    DISTAL like every centreline, at least 4 points, one every 0.5-1 mm (the joins take the
    segment's direction and curvature at its ends from its last few points), in the
    applicator's frame (for an RT Plan input: the plan's patient coordinates, the frame of its
    library centreline). The first and last points lie on the library centreline (within 1 mm)
    where the correction starts and ends; the rows between give the corrected course.

    A ``relative_position_mm`` column is refused: such a file is a measured source path (most
    distal first), not a centreline.

:func:`apply_centreline_correction` reads the file and splices it over one channel
(:func:`ringqa.geometry.splice.splice_applicator`); every problem, also a geometric one found
after reading (an end that does not meet the centreline, a segment that runs backwards or folds
back), raises :class:`~ringqa.io.points.PointsFileError` naming the file, the line and the fix.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringqa.geometry.applicator import Applicator
from ringqa.geometry.splice import (
    MAX_GAP_M,
    SplicedCentreline,
    SpliceError,
    splice_applicator,
)
from ringqa.io.points import REL_COLUMN, PointSet, PointsFileError, read_point_set
from ringqa.provenance import sha256_of

__all__ = [
    "CentrelineCorrection",
    "apply_centreline_correction",
    "read_correction_segment",
]


@dataclass(frozen=True, eq=False)
class CentrelineCorrection:
    """An applicator with a centreline correction applied, and what the report says about it.

    Attributes
    ----------
    applicator : Applicator
        The corrected applicator (the other channels and the ring frame unchanged).
    channel : str
        Name of the corrected channel.
    splice : SplicedCentreline
        Replaced range, new length, largest shift, gaps and angles at the joins (SI).
    path : str
        The correction file.
    sha256 : str
        SHA-256 of the correction file (for the provenance).
    """

    applicator: Applicator
    channel: str
    splice: SplicedCentreline
    path: str
    sha256: str


def _read(path: str | Path) -> PointSet:
    ps = read_point_set(path, kind="correction")
    if ps.relative_position_mm is not None:
        raise PointsFileError(
            ps.path,
            f"has a {REL_COLUMN} column: this looks like a measured source path (most distal "
            "first), not a centreline correction",
            "give the corrected centreline as x_mm,y_mm,z_mm rows from proximal to distal",
        )
    return ps


def read_correction_segment(path: str | Path) -> np.ndarray:
    """Read a centreline correction segment.

    Parameters
    ----------
    path : str or Path
        CSV (``x_mm, y_mm, z_mm``) or JSON point file in millimetres, proximal -> distal (see the
        module docstring).

    Returns
    -------
    numpy.ndarray
        (k, 3) points in METRES, k >= 4, proximal -> distal.

    Raises
    ------
    PointsFileError
        Missing file or column, metres, non-numbers, fewer than 4 points, duplicated or unordered
        points, a ``relative_position_mm`` column (naming the file, the line and the fix).
    """
    return _read(path).points_m


def apply_centreline_correction(
    applicator: Applicator,
    path: str | Path,
    channel: str = "ring",
    blend_m: float | None = None,
    max_gap_m: float = MAX_GAP_M,
) -> CentrelineCorrection:
    """Read a correction file and splice it over one channel's centreline.

    Parameters
    ----------
    applicator : Applicator
        The applicator as loaded (library centreline).
    path : str or Path
        The correction file (see the module docstring).
    channel : str
        Channel to correct (default ``"ring"``).
    blend_m : float, optional
        Length of each smooth join (m); default automatic: 5 mm, longer (up to 15 mm) where a
        join must absorb a larger gap or angle (:func:`ringqa.geometry.splice.splice_centreline`).
    max_gap_m : float
        Largest distance of the segment's ends from the library centreline (m), default 1 mm.

    Returns
    -------
    CentrelineCorrection

    Raises
    ------
    PointsFileError
        The file cannot be read, or its segment cannot be spliced: the message names the file,
        the line(s) and the fix (e.g. ``corr.csv: the correction segment does not meet the
        centreline: its first point (line 2) is 3.2 mm away (give a segment whose first and last
        points lie on the library centreline (within 1.0 mm), ...)``).
    GeometryError
        The applicator has no channel ``channel``; ``blend_m`` / ``max_gap_m`` invalid.
    """
    ps = _read(path)
    try:
        corrected, spliced = splice_applicator(
            applicator, channel, ps.points_m, blend_m=blend_m, max_gap_m=max_gap_m
        )
    except SpliceError as exc:
        if exc.argument != "segment_m":
            raise
        names = ps.labels or tuple(f"point {i}" for i in range(len(ps.points_m)))
        raise PointsFileError(
            ps.path, f"channel {channel!r}: {exc.describe(names)}", exc.fix
        ) from None
    return CentrelineCorrection(
        applicator=corrected,
        channel=channel,
        splice=spliced,
        path=ps.path,
        sha256=sha256_of(ps.path),
    )
