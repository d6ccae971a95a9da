"""A measured source path that is a subset of the positions (a film, a CT marker wire, a panel).

Today's pipeline compares every dwell of a standard plan (every 5 mm) with a reference position.
A clinic's own measurement gives fewer positions (0, 5, 10, 25, 30, 50, 60 mm, or every 10 mm),
each with its own uncertainty. For such a *sparse* path (:func:`is_sparse`: it lacks some of the
standard plan's relative positions):

- the standard plan is built on the vendor/library path every plan step when the input has one
  (an RT Plan with Oncentra's library, a folder with a dense path, with the subset given by
  ``ringqa commission --measured FILE``: :func:`attach_measured`), and the dwell table compares
  with it as for any dense reference; otherwise on the SIMULATED path every plan step (the
  equal times set to the prescription on the simulated dwells, the centreline plan carrying the
  same times; the dwell table compares the simulated path with the centreline grid,
  :func:`centreline_grid`); the report and results.json (``measured_points``) say which
  (:data:`PLAN_PATHS`) and which positions were measured;
- the measured positions are compared with the simulated path at the SAME relative positions
  (the cable pushed to ``s_ref - p`` of each measured point; not the nearest simulated point):
  :func:`compare_measured_points`;
- each point's verdict uses its own uncertainty: a deviation ``d`` with standard uncertainty
  ``sd`` is PASS when ``d + 2 sd`` is within the recommended limit, FAIL when ``d - 2 sd``
  exceeds the required one, WARN when ``d - 2 sd`` exceeds the recommended and ``d + 2 sd`` is
  within the required limit, and NOT RESOLVABLE otherwise (the tolerance lies within its own
  2 sd: the measurement cannot tell);
- points that cannot lie in the lumen after registration, or are not along the channel, are
  named and left out of the verdict.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry.registration import FLAG_INFEASIBLE, FLAG_OUTSIDE
from ringqa.pipeline.dwells import ReferenceDwells, reference_dwells
from ringqa.pipeline.result import Verdict
from ringqa.pipeline.simulate import simulate_dwells

__all__ = [
    "CHECK_MEASURED_POINTS",
    "DEFAULT_POINT_SD_MM",
    "NOT_RESOLVABLE",
    "PLAN_PATHS",
    "MeasuredAttachment",
    "MeasuredPoints",
    "attach_measured",
    "centreline_grid",
    "compare_measured_points",
    "has_dense_path",
    "is_sparse",
    "point_status",
]

#: Check name (results.json ``check``).
CHECK_MEASURED_POINTS = "position: simulated vs measured points"
#: Status of a point whose tolerance lies within its own 2 sd.
NOT_RESOLVABLE = "NOT RESOLVABLE"
#: Uncertainty of a point whose file gives none, by method (mm; as ringqa calibrate assumes).
DEFAULT_POINT_SD_MM = {"film": 0.75, "ct": 0.4, "panel": 0.4, "vendor": 0.2, "": 0.5}
#: Coverage factor of the verdicts (2 sd).
COVERAGE = 2.0
#: Where the standard plan of a measured subset is built, and how the report says it.
PLAN_PATHS = {
    "library": "the input's own dense source path (the vendor/library path)",
    "simulated": "the SIMULATED source path (no vendor/library path in the input)",
}


@dataclass(frozen=True, eq=False)
class MeasuredAttachment:
    """A ``--measured FILE`` attached to the input's channel (:func:`attach_measured`).

    Attributes
    ----------
    applicator : Applicator
        The applicator with the channel carrying the file's path.
    channel : Channel
        That channel.
    own_channel : Channel
        The channel as the input gave it (its own measured path, e.g. the library's, or none).
    file : Path
    """

    applicator: Any
    channel: Any
    own_channel: Any
    file: Any


def attach_measured(app, ring, file) -> MeasuredAttachment:
    """The channel ``ring`` of ``app`` with the measured path of ``file`` (CSV/JSON in mm, most
    distal first, a ``relative_position_mm`` column; optional ``sd_mm`` / ``measured_sd_mm``
    and ``method``) in place of its own.

    Raises
    ------
    RingQAError
        The file cannot be read, has no relative positions, or is not along the channel (the
        message names the file, the field and the fix).
    """
    from pathlib import Path

    from ringqa.errors import InputFileError
    from ringqa.io.applicator_file import path_problem
    from ringqa.io.points import read_point_set
    from ringqa.units import mm_to_m

    path = Path(file)
    ps = read_point_set(path, kind="path")
    if ps.relative_position_mm is None:
        raise InputFileError(
            path, "relative_position_mm: missing (a measured path given with --measured must "
            "say where each position is along the path)",
            "add a relative_position_mm column (mm, 0 = the most distal position), e.g. "
            "0, 5, 10, 25 for a film subset",
        )  # fmt: skip
    rel_mm = np.asarray(ps.relative_position_mm, dtype=float)
    gaps = np.diff(rel_mm)
    even = gaps.size > 0 and np.allclose(gaps, gaps[0], rtol=0.0, atol=1e-6)
    try:
        new = dataclasses.replace(
            ring,
            measured_path_m=np.asarray(ps.points_m, dtype=float),
            measured_step_m=float(mm_to_m(gaps[0])) if even else None,
            measured_relative_m=mm_to_m(rel_mm),
            measured_source=f"user file {path.name} (--measured)",
            measured_sd_m=None if ps.sd_mm is None else mm_to_m(np.asarray(ps.sd_mm, float)),
            measured_method=ps.method or "",
        )
    except RingQAError as exc:
        raise InputFileError(path, str(exc), "correct the file's positions") from None
    problem = path_problem(new, new.measured_path_m, new.measured_relative_m)
    if problem:
        raise InputFileError(path, *problem)
    chans = tuple(new if c.name == ring.name else c for c in app.channels)
    return MeasuredAttachment(dataclasses.replace(app, channels=chans), new, ring, path)


def has_dense_path(app, ring, plan_step_mm: float) -> bool:
    """``ring`` carries its own measured path at every standard plan position (a vendor /
    library path that can carry the standard plan)."""
    if getattr(ring, "measured_path_m", None) is None:
        return False
    if ring.measured_relative_positions_m is None:
        return False
    return not is_sparse(reference_dwells(app, ring, plan_step_mm), plan_step_mm)


def is_sparse(reference: ReferenceDwells, plan_step_mm: float) -> bool:
    """A measured reference that lacks some of the standard plan's relative positions (every
    ``plan_step_mm`` up to its most proximal position) because it is a subset: unevenly spaced,
    or evenly at a step coarser than the plan's. (A dense path at a step that does not divide
    the plan step is not a subset: the standard plan's check refuses it, naming the fix.)"""
    if reference.kind != "measured":
        return False
    step = reference.step_mm
    if step is not None and step < plan_step_mm - 1e-9:
        return False
    rel = np.asarray(reference.relative_position_mm, dtype=float)
    wanted = np.arange(0.0, float(rel.max()) + 1e-9, plan_step_mm)
    return any(not np.any(np.abs(rel - w) < 1e-6) for w in wanted)


def centreline_grid(app, ring, plan_step_mm: float) -> ReferenceDwells:
    """The centreline reference every ``plan_step_mm`` (the ring channel without its measured
    path; :func:`~ringqa.pipeline.dwells.reference_dwells`)."""
    bare = dataclasses.replace(
        ring,
        measured_path_m=None,
        measured_step_m=None,
        measured_relative_m=None,
        measured_sd_m=None,
    )
    return reference_dwells(app, bare, plan_step_mm)


def point_status(d_mm: float, sd_mm: float, rec_mm: float, req_mm: float) -> str:
    """PASS / WARN / FAIL / NOT RESOLVABLE of one point (module docstring)."""
    lo, hi = d_mm - COVERAGE * sd_mm, d_mm + COVERAGE * sd_mm
    if hi <= rec_mm:
        return "PASS"
    if lo > req_mm:
        return "FAIL"
    if lo > rec_mm and hi <= req_mm:
        return "WARN"
    return NOT_RESOLVABLE


@dataclass(frozen=True, eq=False)
class MeasuredPoints:
    """The measured positions against the simulated path at the same relative positions.

    Attributes
    ----------
    relative_position_mm : (m,) ndarray
    measured_mm : (m, 3) ndarray
        As compared (registered), mm.
    simulated_mm : (m, 3) ndarray
        The simulated source centres at the same relative positions, mm.
    distance_mm : (m,) ndarray
    sd_mm : (m,) ndarray
        Each point's standard uncertainty (as measured, or assumed: ``sd_assumed``).
    sd_assumed : bool
    method : str
    flags : (m,) ndarray of str
        ``""``, ``"infeasible"``, ``"outside_channel"``.
    status : (m,) ndarray of str
        :func:`point_status` of each compared point (``"-"`` for flagged ones).
    numerical_error_mm : (m,) ndarray
    limits_mm : tuple of float
        (recommended, required).
    source : str
    plan_path : str
        Where the standard plan was built (:data:`PLAN_PATHS`).
    plan_source : str
        That path's own source (the library's name), for ``"library"``.
    """

    relative_position_mm: np.ndarray
    measured_mm: np.ndarray
    simulated_mm: np.ndarray
    distance_mm: np.ndarray
    sd_mm: np.ndarray
    sd_assumed: bool
    method: str
    flags: np.ndarray
    status: np.ndarray
    numerical_error_mm: np.ndarray
    limits_mm: tuple[float, float]
    source: str
    plan_path: str = "simulated"
    plan_source: str = ""

    def verdict(self) -> Verdict:
        """One verdict over the compared points: FAIL if any point fails, else WARN if any
        warns or cannot be resolved, else PASS; the text counts each status."""
        used = self.flags == ""
        st = self.status[used]
        counts = {s: int(np.count_nonzero(st == s)) for s in ("PASS", "WARN", "FAIL",
                                                             NOT_RESOLVABLE)}  # fmt: skip
        if counts["FAIL"]:
            status = "FAIL"
        elif counts["WARN"] or counts[NOT_RESOLVABLE]:
            status = "WARN"
        else:
            status = "PASS"
        worst = float(np.max(self.distance_mm[used])) if np.any(used) else 0.0
        rec, req = self.limits_mm
        shown = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
        text = (
            f"Simulated vs the {int(np.count_nonzero(used))} measured points (at their own "
            f"relative positions): max {worst:.2f} mm; per point with its 2 sd: {shown}"
            + (f" ({NOT_RESOLVABLE}: the {rec:g}/{req:g} mm limit lies within the point's own "
               "2 sd)" if counts[NOT_RESOLVABLE] else "") + "."
        )  # fmt: skip
        return Verdict(CHECK_MEASURED_POINTS, worst, "mm", (rec, req), status, text,
                       "simulation check")  # fmt: skip

    def lines(self) -> tuple[str, ...]:
        """The report's statements (page 1 notes)."""
        rel = ", ".join(f"{r:g}" for r in self.relative_position_mm)
        used = self.flags == ""
        d = self.distance_mm[used]
        sd = "assumed for " + (self.method or "an unstated method") if self.sd_assumed else \
            "as measured"  # fmt: skip
        if self.plan_path == "library":
            plan = (
                f"The standard plan and the dwell table are built on {PLAN_PATHS['library']}"
                + (f" ({self.plan_source})" if self.plan_source else "")
                + " every plan step"
            )
        else:
            plan = (
                f"The standard plan is built on {PLAN_PATHS['simulated']} every plan step (its "
                "equal times set to the prescription there; the centreline plan carries the "
                "same times) and the dwell table compares the simulated path with the centreline"
            )
        out = [
            f"Measured path: a subset of {self.relative_position_mm.size} positions ({rel} mm; "
            f"{self.source}; method {self.method or 'not stated'}; uncertainty {sd}, median "
            f"{float(np.median(self.sd_mm)):.2f} mm). {plan}; the measured positions are "
            "compared with the simulated path at the same relative positions.",
        ]
        if d.size:
            out.append(
                f"Measured vs simulated at the measured positions: median "
                f"{float(np.median(d)):.2f} mm, max {float(np.max(d)):.2f} mm."
            )
        for flag, words in ((FLAG_INFEASIBLE, "cannot lie in the lumen"),
                            (FLAG_OUTSIDE, "are not along the channel")):  # fmt: skip
            bad = self.relative_position_mm[self.flags == flag]
            if bad.size:
                out.append(
                    f"{bad.size} measured point(s) {words} (relative "
                    f"{', '.join(f'{x:g}' for x in bad)} mm): left out of the verdict."
                )
        return tuple(out)

    def as_dict(self) -> dict:
        """Per point, for results files."""
        return {
            "plan_path": self.plan_path,
            "plan_path_text": PLAN_PATHS.get(self.plan_path, self.plan_path),
            "plan_source": self.plan_source,
            "source": self.source,
            "method": self.method,
            "sd_assumed": self.sd_assumed,
            "relative_position_mm": self.relative_position_mm.tolist(),
            "distance_mm": self.distance_mm.tolist(),
            "sd_mm": self.sd_mm.tolist(),
            "status": [str(s) for s in self.status],
            "flags": [str(f) for f in self.flags],
        }


def compare_measured_points(
    app,
    ring,
    measured: ReferenceDwells,
    review,
    *,
    cable: str,
    scene_overrides: Mapping[str, Any],
    limits_mm: tuple[float, float],
    engine=None,
    stem_mm: float | None = None,
    sd_mm=None,
    method: str = "",
    plan_path: str = "simulated",
    plan_source: str = "",
) -> MeasuredPoints:
    """Simulate the cable to the measured relative positions and compare (module docstring).

    Parameters
    ----------
    app, ring : the applicator and its ring channel
    measured : ReferenceDwells
        The sparse measured path.
    review : ReferenceReview
        Its check and registration (:func:`~ringqa.pipeline.reference.review_reference`).
    cable : str
    scene_overrides : mapping
    limits_mm : (float, float)
        Recommended and required position limits, mm.
    engine : Engine, optional
    stem_mm : float or None
    sd_mm : (m,) array_like or None
        Each point's uncertainty (None: :data:`DEFAULT_POINT_SD_MM` of ``method``).
    method : str
    plan_path, plan_source : str
        Where the standard plan was built (:data:`PLAN_PATHS`), for the report.

    Returns
    -------
    MeasuredPoints
    """
    rel = np.asarray(measured.relative_position_mm, dtype=float)
    sim = simulate_dwells(app, ring, rel, cable=cable, scene_overrides=scene_overrides,
                          engine=engine, stem_mm=stem_mm)  # fmt: skip
    meas = np.asarray(review.registered.dwells.positions_mm, dtype=float)
    simulated = np.asarray(sim.dwells.positions_mm, dtype=float)
    dist = np.linalg.norm(meas - simulated, axis=1)
    assumed = sd_mm is None
    sd = (np.full(rel.size, DEFAULT_POINT_SD_MM.get(method, DEFAULT_POINT_SD_MM[""]))
          if assumed else np.asarray(sd_mm, dtype=float))  # fmt: skip
    flags = np.array([str(f) if f in (FLAG_INFEASIBLE, FLAG_OUTSIDE) else "" for f in
                      review.flags], dtype=object).astype(str)  # fmt: skip
    rec, req = limits_mm
    status = np.array([point_status(float(d), float(s), rec, req) if f == "" else "-"
                       for d, s, f in zip(dist, sd, flags, strict=True)], dtype=object)  # fmt: skip
    return MeasuredPoints(
        relative_position_mm=rel,
        measured_mm=meas,
        simulated_mm=simulated,
        distance_mm=dist,
        sd_mm=sd,
        sd_assumed=assumed,
        method=method,
        flags=flags,
        status=status.astype(str),
        numerical_error_mm=np.asarray(sim.numerics.error_mm, dtype=float),
        limits_mm=(float(rec), float(req)),
        source=measured.source,
        plan_path=plan_path,
        plan_source=plan_source,
    )
