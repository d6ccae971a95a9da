"""Where the dwells are: the reference dwells, their centreline twins, the tandem's dwells.

The reference is the channel's measured source path, or (none shipped) the centreline on the part
its family simulates (the circular part of a ring; :mod:`ringqa.geometry.families`); the
centreline dwell of relative position ``p`` sits at arc length ``s_ref - p``. Also the ring geometry
the report's plots draw.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry.families import family_of
from ringqa.geometry.frame import frame_of
from ringqa.geometry.registration import RegistrationError, reference_positions
from ringqa.pipeline.result import RingGeometry
from ringqa.plan import PLAN_STEP_MM, DwellSet, path_directions
from ringqa.units import m_to_mm, mm_to_m


@dataclass(frozen=True, eq=False)
class PathDwells:
    """Where the source sits at each dwell of one path (measured, simulated or centreline).

    Attributes
    ----------
    positions_mm : (n, 3) ndarray
        Source centres, mm.
    directions : (n, 3) ndarray
        Unit source directions (towards the source tip).
    """

    positions_mm: np.ndarray
    directions: np.ndarray


@dataclass(frozen=True, eq=False)
class ReferenceDwells:
    """The dwells every other path is compared with.

    Attributes
    ----------
    kind : str
        ``"measured"`` (the channel's measured source path) or ``"centreline"`` (none given:
        the centreline on the circular part of the ring).
    relative_position_mm : (n,) ndarray
        Relative position of each dwell, mm (0 = most distal, increasing proximally).
    dwells : PathDwells
        Their positions and directions.
    step_mm : float or None
        Spacing of the relative positions, mm; None when they are unevenly spaced.
    source : str
        Where the path comes from (the channel's ``measured_source``; for a centreline
        reference, ``"channel centreline"``).
    """

    kind: str
    relative_position_mm: np.ndarray
    dwells: PathDwells
    step_mm: float | None
    source: str = ""


@dataclass(frozen=True, eq=False)
class PlanSelection:
    """Which reference dwells the standard plan uses.

    Attributes
    ----------
    in_plan : (n,) ndarray of bool
        True for the reference dwells whose relative position is a multiple of the plan step
        (and that are compared: not outside the channel).
    s_ref_mm : float
        The ring channel's reference arc length (relative position 0), mm.
    """

    in_plan: np.ndarray
    s_ref_mm: float


def centreline_dwells(channel, relative_position_mm: np.ndarray) -> PathDwells:
    """The centreline dwells: position at arc length ``s_ref - p``, direction the unit tangent.

    Parameters
    ----------
    channel : Channel
        Gives ``s_ref_m`` and the centreline.
    relative_position_mm : (n,) array_like
        Relative positions p, mm.

    Returns
    -------
    PathDwells
        (n, 3) positions in mm and unit directions.
    """
    s_m = channel.s_ref_m - mm_to_m(np.asarray(relative_position_mm, dtype=float))
    pos = m_to_mm(np.asarray(channel.centreline.position(s_m), dtype=float).reshape(-1, 3))
    tan = np.asarray(channel.centreline.tangent(s_m), dtype=float).reshape(-1, 3)
    return PathDwells(pos, tan / np.linalg.norm(tan, axis=1)[:, None])


def ring_arc_mm(app, channel, step_mm: float) -> float:
    """Largest relative position of the part of ``channel`` its family simulates without a
    measured path, mm (the ring's: still on the ring's circle; :meth:`ringqa.geometry.families
    .base.ApplicatorFamily.span_mm`)."""
    return float(family_of(app, channel).span_mm(app, channel, step_mm))


def reference_dwells(app, channel, step_mm: float | None) -> ReferenceDwells:
    """The reference dwells of the ring channel: its measured path, else the centreline.

    Parameters
    ----------
    app : Applicator
        Gives the applicator frame and the channel's family (its span without a measured path).
    channel : Channel
        The ring channel.
    step_mm : float or None
        Spacing of centreline reference dwells, mm (None: the plan step, 5 mm).

    Returns
    -------
    ReferenceDwells

    Raises
    ------
    RingQAError
        A measured path of fewer than 3 positions, duplicated positions or relative positions,
        fewer than 3 relative positions on the channel, neither relative positions nor a step;
        no measured path and no circular part of the ring near s_ref.
    """
    path = getattr(channel, "measured_path_m", None)
    if path is not None:
        try:
            given = reference_positions(
                path, channel, relative_m=channel.measured_relative_positions_m
            )
        except RegistrationError as exc:
            raise RingQAError(
                f"applicator {app.name}, channel {channel.name}: measured path: {exc}"
            ) from None
        pos = m_to_mm(given.points_m)
        rel = m_to_mm(given.relative_m)
        step_mm_path = None if given.step_m is None else m_to_mm(given.step_m)
        source = getattr(channel, "measured_source", "") or "source not stated"
        return ReferenceDwells(
            "measured", rel, PathDwells(pos, path_directions(pos)), step_mm_path, source
        )
    step = PLAN_STEP_MM if step_mm is None else float(step_mm)
    family = family_of(app, channel)
    arc = float(family.span_mm(app, channel, step))
    if arc < step:
        part = "circular ring part" if family.name == "ring" else f"{family.words.span}"
        raise RingQAError(
            f"applicator {app.name}: no measured source path and no {part} found "
            "near s_ref to place reference dwells (add the measured path, e.g. a path CSV in the "
            "applicator folder)"
        )
    rel = np.arange(0.0, arc + 1e-9, step)
    return ReferenceDwells(
        "centreline", rel, centreline_dwells(channel, rel), step, "channel centreline"
    )


def tandem_dwells(app, n_dwells: int, plan_step_mm: float) -> DwellSet | None:
    """The tandem's dwells of the standard plan (the same in every plan), or None.

    Parameters
    ----------
    app : Applicator
    n_dwells : int
        How many (0: none).
    plan_step_mm : float
        Their spacing, mm: every ``plan_step_mm`` of the tandem's measured path, else on its
        centreline from its s_ref.

    Returns
    -------
    DwellSet or None
        None without a ``"tandem"`` channel or with ``n_dwells`` 0.
    """
    names = [c.name for c in app.channels]
    if "tandem" not in names or n_dwells <= 0:
        return None
    ch = app.channel("tandem")
    path = getattr(ch, "measured_path_m", None)
    step = getattr(ch, "measured_step_m", None)
    if path is not None and len(path) >= 2 and step:
        pos = m_to_mm(np.asarray(path, dtype=float))
        rel_path = np.arange(pos.shape[0]) * m_to_mm(float(step))
        keep = np.isclose(np.mod(rel_path + 1e-6, plan_step_mm), 0.0, atol=1e-5)
        keep &= np.cumsum(keep) <= n_dwells
        return DwellSet("tandem", rel_path[keep], pos[keep], path_directions(pos)[keep])
    rel = np.arange(n_dwells) * plan_step_mm
    rel = rel[rel <= m_to_mm(ch.s_ref_m)]
    cl = centreline_dwells(ch, rel)
    return DwellSet("tandem", rel, cl.positions_mm, cl.directions)


def plan_selection(
    app, ring, reference: ReferenceDwells, plan_step_mm: float, compared=None
) -> PlanSelection:
    """Which reference dwells the standard plan uses (every ``plan_step_mm``), checked.

    Parameters
    ----------
    app : Applicator
    ring : Channel
        The ring channel (gives s_ref).
    reference : ReferenceDwells
    plan_step_mm : float
        Dwell spacing of the standard plan, mm: the dwells at relative positions 0, step, ...
    compared : (n,) array_like of bool, optional
        Dwells that may be used (default all): positions outside the channel are not.

    Returns
    -------
    PlanSelection

    Raises
    ------
    RingQAError
        A multiple of the plan step (up to the most proximal position) without a reference
        position (the message lists them), or reference dwells beyond the channel entry.
    """
    rel = reference.relative_position_mm
    on_grid = np.abs(rel / plan_step_mm - np.round(rel / plan_step_mm)) * plan_step_mm < 1e-6
    wanted = np.arange(0.0, float(rel.max()) + 1e-9, plan_step_mm)
    missing = [w for w in wanted if not np.any(np.abs(rel - w) < 1e-6)]
    if missing:
        listed = ", ".join(f"{x:g}" for x in missing[:6]) + (", ..." if len(missing) > 6 else "")
        step = reference.step_mm
        raise RingQAError(
            f"applicator {app.name}: the standard plan needs reference positions every "
            f"{plan_step_mm:g} mm, but the path has none at {listed} mm"
            + (f" (the plan step is not a multiple of the path's step {step:g} mm)" if step
               else "") + ": choose a plan step that matches the path"
        )  # fmt: skip
    in_plan = on_grid & (np.ones(rel.size, bool) if compared is None else np.asarray(compared))
    s_ref_mm = m_to_mm(ring.s_ref_m)
    if np.any(rel > s_ref_mm + 1e-9):
        n_out = int(np.sum(rel > s_ref_mm + 1e-9))
        raise RingQAError(
            f"applicator {app.name}: {n_out} measured positions lie beyond the channel entry "
            f"(relative position > s_ref = {s_ref_mm:.1f} mm): check s_ref / the measured path"
        )
    return PlanSelection(in_plan, s_ref_mm)


def reference_note(reference: ReferenceDwells) -> str:
    """The report's statement of which reference the comparison uses."""
    if reference.kind == "centreline":
        return (
            "No measured source path ships with this applicator: the reference is the channel "
            "CENTRELINE, and the comparison is simulated vs centreline (no measurement involved)."
        )
    n, step = reference.relative_position_mm.size, reference.step_mm
    spacing = f"{step:g} mm apart" if step is not None else "unevenly spaced, as given"
    return f"Reference: the supplied source path ({reference.source}; {n} positions, {spacing})."


def ring_geometry(app, s_ref_mm: float) -> RingGeometry:
    """The applicator frame and every channel's centreline (mm), for the report's plots.

    Parameters
    ----------
    app : Applicator
    s_ref_mm : float
        The ring channel's reference arc length, mm.

    Returns
    -------
    RingGeometry
    """
    frame = frame_of(app)
    return RingGeometry(
        ring_centre_mm=m_to_mm(np.asarray(frame.centre_m, dtype=float)),
        ring_normal=np.asarray(frame.normal, dtype=float),
        ring_lateral=np.asarray(frame.lateral, dtype=float),
        ring_radius_mm=m_to_mm(float(frame.scale_m)),
        s_ref_mm=float(s_ref_mm),
        centrelines_mm={c.name: _dense_centreline_mm(c) for c in app.channels},
        metadata=dict(getattr(app, "metadata", {}) or {}),
    )


def _dense_centreline_mm(channel, spacing_mm: float = 0.5) -> np.ndarray:
    length_mm = m_to_mm(float(channel.centreline.length_m))
    s = np.linspace(0.0, length_mm, max(2, int(length_mm / spacing_mm) + 1))
    return m_to_mm(np.asarray(channel.centreline.position(mm_to_m(s)), dtype=float))
