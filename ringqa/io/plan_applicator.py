"""An :class:`~ringqa.geometry.Applicator` from an RT Plan's embedded applicator library.

Conventions (interfaces.md):

- channels ``"ring"`` and ``"tandem"`` (other parts keep their library label), centrelines
  proximal -> distal in metres, DICOM patient coordinates;
- lumen: ``r_b`` = library lumen diameter / 2, contact-transition radius ``r_a = r_b - 0.1 mm``
  (the paper's 1.5 / 1.4 mm ring). The library gives only the diameter; as in the parametric
  rings (:mod:`ringqa.geometry.parametric`) the RING lumen is the paper's U (flat side at the
  circle, ``FLAT_MM``, facing the outside of the ring in the applicator's frame) from the end of
  the straight stem to the tip, circular along the stem; other channels are circular; each lumen
  carries its source (library diameter; the paper's shape);
- ``s_ref_m``: arc length of the library's first marker (``marker1``), where the plan's relative
  position 0 lies (checked on the Oncentra 26/60 plan: the tandem's relative-position-0 dwell is
  the marker to < 0.05 mm, and the marker's arc length on the centreline equals
  SourceApplicatorLength to 0.01 mm on both channels).
  Without a marker: ``SourceApplicatorLength`` when given, else the lumen tip minus 5 mm, with
  a note in ``metadata["notes"]``;
- measured path (most distal first, relative positions 0, step, ...) attached to its channel;
- ring frame: :func:`ringqa.geometry.fit_ring_frame` of the circular distal part of the ring
  centreline (found by :func:`fit_ring_circle`); ``ring_normal`` points to the tandem tip side
  (cranially), else away from the stem entry; ``ring_lateral`` = patient left (+x in DICOM LPS)
  projected into the ring plane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import InputFileError
from ringqa.geometry import Applicator, Centreline, Channel, Lumen, fit_ring_frame
from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.lumen import FlatSide
from ringqa.geometry.parametric import FLAT_MM, LUMEN_SOURCE
from ringqa.geometry.shape_checks import check_channel_shape
from ringqa.io.applicator_file import RING_RADIUS_MM, path_problem
from ringqa.units import m_to_mm, mm_to_m

#: Contact-transition radius below the wall radius (paper: r_b 1.5 mm, r_a 1.4 mm).
RA_BELOW_RB_MM = 0.1
#: Distance of the first marker from the lumen tip when the library has no marker (domain.md).
MARKER_FROM_TIP_MM = 5.0
#: Points within this distance (mm) of the fitted circle belong to the ring's circular part.
ON_CIRCLE_MM = 0.02
#: A library lumen diameter above this (mm) is not a brachytherapy channel.
MAX_LUMEN_DIAMETER_MM = 20.0
#: Notices of :func:`ringqa.io.rtplan.read_rtplan` meaning the library could not be used: the
#: applicator is refused with them rather than built from what is left.
_LIBRARY_UNUSABLE = "library not usable"
_LIBRARY_UNREADABLE = "applicator library (300B,100D) not readable"


@dataclass(frozen=True)
class RingCircle:
    """A circle fitted to the ring's circular part, and its axes (mm).

    Attributes
    ----------
    centre_mm : numpy.ndarray
        (3,) circle centre.
    normal : numpy.ndarray
        (3,) unit plane normal: towards the tandem tip when it was given, else away from the
        ring channel's entry (cranial).
    lateral : numpy.ndarray
        (3,) unit in-plane vector towards the patient's left (DICOM +x projected).
    radius_mm : float
        Circle radius.
    n_points : int
        Centreline points (from the tip) within :data:`ON_CIRCLE_MM` of the circle.
    max_error_mm : float
        Largest distance of those points from the circle.
    """

    centre_mm: np.ndarray
    normal: np.ndarray
    lateral: np.ndarray
    radius_mm: float
    n_points: int
    max_error_mm: float


def stem_end_mm(centreline_mm: np.ndarray, tol_mm: float = 0.01) -> float:
    """Arc length (polyline, mm) where the centreline leaves its straight proximal stem.

    The stem line runs through the first point along the first segment; the stem ends at the
    last point before the first one farther than ``tol_mm`` from that line.
    """
    cl = np.asarray(centreline_mm, dtype=float)
    d = cl[1] - cl[0]
    d = d / np.linalg.norm(d)
    q = cl - cl[0]
    off = np.linalg.norm(q - np.outer(q @ d, d), axis=1)
    k = int(np.argmax(off > tol_mm)) if np.any(off > tol_mm) else len(cl)
    seg = np.linalg.norm(np.diff(cl, axis=0), axis=1)
    return float(np.sum(seg[: max(k - 1, 0)]))


def _circle_error(points, centre, normal, radius) -> np.ndarray:
    q = points - centre
    h = q @ normal
    rho = np.linalg.norm(q - np.outer(h, normal), axis=1)
    return np.hypot(rho - radius, h)


def fit_ring_circle(
    centreline_mm: np.ndarray, seed_mm: float = 20.0, tandem_tip_mm: np.ndarray | None = None
) -> RingCircle:
    """Fit the circle of a ring channel from its distal end.

    Parameters
    ----------
    centreline_mm : (n, 3) array_like
        Ring centreline, proximal -> distal (mm).
    seed_mm : float
        Arc length from the tip used for the first fit; the fit then grows proximally over every
        point within :data:`ON_CIRCLE_MM` of the circle and is refitted.
    tandem_tip_mm : (3,) array_like, optional
        The tandem's tip (cranial of the ring); without it the normal points away from the ring
        channel's entry.

    Returns
    -------
    RingCircle
    """
    cl = np.asarray(centreline_mm, dtype=float)
    seg = np.linalg.norm(np.diff(cl, axis=0), axis=1)
    from_tip = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])
    k = max(int(np.count_nonzero(from_tip <= seed_mm)), 4)
    for _ in range(5):
        frame = fit_ring_frame(
            mm_to_m(cl[-k:]),
            cranial_point_m=None if tandem_tip_mm is None else mm_to_m(tandem_tip_mm),
            caudal_point_m=mm_to_m(cl[0]),
        )
        centre, normal, radius = m_to_mm(frame.centre_m), frame.normal, m_to_mm(frame.radius_m)
        err = _circle_error(cl, centre, normal, radius)
        off = np.flatnonzero(err[::-1] > ON_CIRCLE_MM)  # from the tip backwards
        k_new = int(off[0]) if off.size else len(cl)
        if k_new <= k:
            break
        k = k_new
    err = _circle_error(cl[-k:], centre, normal, radius)
    return RingCircle(centre, normal, frame.lateral, float(radius), int(k), float(err.max()))


def applicator_from_rtplan(plan):
    """Build the applicator (ring + tandem channels) from the plan's embedded library.

    Parameters
    ----------
    plan : RTPlan
        From :func:`ringqa.io.rtplan.read_rtplan`.

    Returns
    -------
    ringqa.geometry.Applicator

    Raises
    ------
    InputFileError
        The plan has no applicator library (other TPSs) or no ring channel in it.
    """
    unusable = [w for w in plan.warnings if _LIBRARY_UNUSABLE in w or _LIBRARY_UNREADABLE in w]
    if unusable:
        raise InputFileError(
            plan.path,
            "the embedded Oncentra applicator library cannot be used: " + "; ".join(unusable),
            "export the plan again from Oncentra, or give the applicator instead (a shipped name "
            "such as ring26x60, or a folder with the centreline and measured path CSV files)",
        )
    if not plan.library:
        raise InputFileError(
            plan.path,
            "the plan has no embedded applicator library (Oncentra private tag (300B,100D)), so "
            "there is no channel centreline",
            "give the applicator instead (a shipped name such as ring26x60, or a folder with the "
            "centreline and measured path CSV files)",
        )
    notes: list[str] = []
    channels = []
    info = {}
    roles: dict = {}
    for _, lc in sorted(plan.library.items()):
        roles.setdefault(lc.role, lc)
    if "ring" not in roles:
        raise InputFileError(
            plan.path,
            "the applicator library has no ring channel "
            f"(parts: {', '.join(lc.description or lc.name for lc in plan.library.values())})",
            "ringqa commissions ring applicators; give a ring applicator plan",
        )
    ring_cl_mm = roles["ring"].centreline_mm
    tandem_tip = roles["tandem"].centreline_mm[-1] if "tandem" in roles else None
    circle = fit_ring_circle(ring_cl_mm, tandem_tip_mm=tandem_tip)
    lo, hi = RING_RADIUS_MM
    if not lo <= circle.radius_mm <= hi:
        raise InputFileError(
            plan.path,
            f"library part {roles['ring'].part_id} (ring): the fitted ring radius "
            f"{circle.radius_mm:.4g} mm is implausible (ring applicators: {lo:g}-{hi:g} mm)",
            "the library is not in millimetres or its ring is damaged: export the plan again, or "
            "give the applicator instead",
        )
    for number, lc in sorted(plan.library.items()):
        name = lc.role if lc.role in ("ring", "tandem") else lc.name or f"channel {number}"
        if any(c.name == name for c in channels):
            name = f"{name}_{number}"
        cl_mm = lc.centreline_mm
        centreline = Centreline.from_points(mm_to_m(cl_mm))
        diam = lc.lumen_diameter_mm
        if diam is None:
            raise InputFileError(
                plan.path, f"library part {lc.part_id} (channel {number}) has no lumen diameter"
            )
        if not 2 * RA_BELOW_RB_MM < diam <= MAX_LUMEN_DIAMETER_MM:
            raise InputFileError(
                plan.path,
                f"library part {lc.part_id} (channel {number}): <lumen diameter> is {diam:g} mm, "
                f"not a lumen (a diameter is positive, at most {MAX_LUMEN_DIAMETER_MM:g} mm; "
                "ring and tandem lumens are 2-4 mm)",
                "the library is damaged: export the plan again, or give the applicator instead",
            )
        r_b = 0.5 * diam
        r_a = r_b - RA_BELOW_RB_MM
        lumen_note = "circular"
        source = f"{diam:g} mm: the Oncentra library; r_a = r_b - {RA_BELOW_RB_MM:g} mm assumed"
        if name == "ring":
            s0 = stem_end_mm(cl_mm)
            side = FlatSide("ring_outside", mm_to_m(circle.centre_mm), circle.normal)
            lumen = Lumen.u_shaped(
                mm_to_m(r_b), mm_to_m(r_a), mm_to_m(max(FLAT_MM, r_b)), mm_to_m(s0), flat_side=side,
                source=f"{source}; U shape: {LUMEN_SOURCE}",
            )  # fmt: skip
            lumen_note = (
                f"U-shaped from the end of the straight stem (s = {s0:.1f} mm) to the tip, flat "
                f"side at the circle ({max(FLAT_MM, r_b):g} mm), facing the outside of the ring "
                "(the paper's U, as the parametric rings)"
            )
        else:
            circ = Lumen.circular(mm_to_m(r_b), mm_to_m(r_a))
            lumen = Lumen(circ.seg_s, circ.seg_rb, circ.seg_ra, circ.seg_flat, source=source)
        ch = plan.channel(number)
        if lc.marker_mm is not None:
            s_m, _ = centreline.closest(mm_to_m(np.asarray(lc.marker_mm)[None, :]))
            s_ref_mm = m_to_mm(float(s_m[0]))
            how = "library first marker"
        elif ch.applicator_length_mm is not None:
            s_ref_mm = ch.applicator_length_mm
            how = "SourceApplicatorLength"
            notes.append(f"channel {name}: no marker in the library; s_ref = {how}")
        else:
            s_ref_mm = m_to_mm(centreline.length_m) - MARKER_FROM_TIP_MM
            how = "lumen tip - 5 mm"
            notes.append(f"channel {name}: no marker in the library; s_ref = {how}")
        path_m = None if lc.measured_path_mm is None else mm_to_m(lc.measured_path_mm)
        step_m = None if lc.measured_step_mm is None else mm_to_m(lc.measured_step_mm)
        channel = Channel(
            name=name,
            centreline=centreline,
            lumen=lumen,
            s_ref_m=mm_to_m(s_ref_mm),
            measured_path_m=path_m,
            measured_step_m=step_m,
            measured_source=lc.measured_path_origin if path_m is not None else "",
            label=str(number),
        )
        try:
            check_channel_shape(channel, f"library part {lc.part_id} (channel {number})")
        except GeometryError as exc:
            raise InputFileError(
                plan.path, str(exc), "export the plan again, or give the applicator instead"
            ) from None
        if path_m is not None:
            problem = path_problem(channel, path_m, None, lc.measured_step_mm)
            if problem:
                raise InputFileError(
                    plan.path,
                    f"library source path {lc.measured_path_name!r} (part {lc.part_id}, channel "
                    f"{number}): {problem[0]}",
                    problem[1].replace("the rows", "the positions")
                    + "; or give the applicator with a corrected measured path",
                )
        channels.append(channel)
        info[name] = {
            "plan_channel": number,
            "library_part": lc.part_id,
            "description": lc.description,
            "lumen_diameter_mm": diam,
            "r_a_mm": r_a,
            "lumen": lumen_note,
            "s_ref_mm": s_ref_mm,
            "s_ref_from": how,
            "measured_path": lc.measured_path_name,
        }
    normal = circle.normal
    stem = ring_cl_mm[min(20, len(ring_cl_mm) - 1)] - ring_cl_mm[0]
    stem = stem / np.linalg.norm(stem)
    angle = float(np.degrees(np.arcsin(min(1.0, abs(stem @ normal)))))
    metadata = {
        "source": "RT Plan with Oncentra's embedded applicator library",
        "plan": plan.path,
        "applicator_name": plan.applicator_name,
        "diameter_mm": 2.0 * circle.radius_mm,
        "angle_deg": angle,
        "ring_fit": {
            "radius_mm": circle.radius_mm,
            "points_on_circle": circle.n_points,
            "max_error_mm": circle.max_error_mm,
        },
        "channels": info,
        "notes": notes,
    }
    return Applicator(
        name=plan.applicator_name or plan.plan_label or "rtplan",
        channels=tuple(channels),
        ring_centre_m=mm_to_m(circle.centre_mm),
        ring_normal=normal,
        ring_lateral=circle.lateral,
        ring_radius_m=mm_to_m(circle.radius_mm),
        metadata=metadata,
    )
