"""How far the simulated and centreline dwells lie from the reference, and the dwell table.

Each distance is split into along-channel, radial (in the ring plane) and out-of-plane parts
(:func:`deviation_components`); source directions are compared by angle (:func:`angle_deg`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ringqa.geometry.frame import frame_of
from ringqa.pipeline.dwells import PathDwells, PlanSelection, ReferenceDwells
from ringqa.units import m_to_mm, mm_to_m


@dataclass(frozen=True, eq=False)
class DeviationComponents:
    """One path's displacement from the reference dwells, split in the applicator frame (mm).

    Attributes
    ----------
    dist_mm : (n,) ndarray
        3D distance.
    along_mm : (n,) ndarray
        In the ring plane along the channel, distal positive.
    radial_mm : (n,) ndarray
        In the ring plane, outward from the ring centre positive.
    out_of_plane_mm : (n,) ndarray
        Along the ring normal, cranial positive.
    """

    dist_mm: np.ndarray
    along_mm: np.ndarray
    radial_mm: np.ndarray
    out_of_plane_mm: np.ndarray


def deviation_components(ref_mm, ref_dir, other_mm, centre_mm, normal) -> DeviationComponents:
    """Split ``other - ref`` into along-channel, radial (in the ring plane) and out-of-plane parts.

    The frame at each reference dwell: ``out`` = ring normal (cranial positive); ``radial`` = the
    in-plane direction from the ring centre to the reference dwell (outward positive); ``along`` =
    the remaining in-plane direction, signed so that DISTAL is positive (along ``ref_dir``).

    Parameters
    ----------
    ref_mm : (n, 3) array_like
        Reference dwell positions, mm.
    ref_dir : (n, 3) array_like
        Reference source directions (unit; give the sign of ``along``).
    other_mm : (n, 3) array_like
        The other path's positions, mm.
    centre_mm : (3,) array_like
        Ring centre, mm.
    normal : (3,) array_like
        Ring normal (cranial).

    Returns
    -------
    DeviationComponents
    """
    ref = np.asarray(ref_mm, dtype=float)
    d = np.asarray(other_mm, dtype=float) - ref
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    rad = ref - np.asarray(centre_mm, dtype=float)
    rad -= np.outer(rad @ n, n)
    norm = np.linalg.norm(rad, axis=1)
    rad = np.where(norm[:, None] > 1e-9, rad / np.maximum(norm, 1e-12)[:, None], 0.0)
    along = np.cross(n, rad)
    sign = np.sign(np.sum(along * np.asarray(ref_dir, dtype=float), axis=1))
    along *= np.where(sign == 0, 1.0, sign)[:, None]
    return DeviationComponents(
        dist_mm=np.linalg.norm(d, axis=1),
        along_mm=np.sum(d * along, axis=1),
        radial_mm=np.sum(d * rad, axis=1),
        out_of_plane_mm=d @ n,
    )


def angle_deg(a, b) -> np.ndarray:
    """Angle between unit vectors row by row, degrees."""
    c = np.sum(np.asarray(a, dtype=float) * np.asarray(b, dtype=float), axis=1)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


@dataclass(frozen=True, eq=False)
class Deviations:
    """The simulated and centreline dwells compared with the reference dwells.

    Attributes
    ----------
    simulated, centreline : DeviationComponents
        Each path against the reference.
    angle_simulated_deg, angle_centreline_deg : ndarray
        Angle between each path's source direction and the reference's, degrees (n,).
    angle_sim_vs_centreline_deg : ndarray
        Angle between the simulated and the centreline source direction, degrees (n,).
    """

    simulated: DeviationComponents
    centreline: DeviationComponents
    angle_simulated_deg: np.ndarray
    angle_centreline_deg: np.ndarray
    angle_sim_vs_centreline_deg: np.ndarray


def compare_with_reference(
    app, reference: PathDwells, simulated: PathDwells, centreline: PathDwells
) -> Deviations:
    """Compare the simulated and centreline dwells with the reference in the ring's frame.

    Parameters
    ----------
    app : Applicator
        Gives the applicator frame (:func:`ringqa.geometry.frame.frame_of`: centre, normal).
    reference, simulated, centreline : PathDwells
        Each path's (n, 3) positions in mm and unit directions, in the same dwell order.

    Returns
    -------
    Deviations
    """
    ref_pos, ref_dir = reference.positions_mm, reference.directions
    frame = frame_of(app)
    centre = m_to_mm(np.asarray(frame.centre_m, dtype=float))
    normal = np.asarray(frame.normal, dtype=float)
    return Deviations(
        simulated=deviation_components(ref_pos, ref_dir, simulated.positions_mm, centre, normal),
        centreline=deviation_components(ref_pos, ref_dir, centreline.positions_mm, centre, normal),
        angle_simulated_deg=angle_deg(simulated.directions, ref_dir),
        angle_centreline_deg=angle_deg(centreline.directions, ref_dir),
        angle_sim_vs_centreline_deg=angle_deg(simulated.directions, centreline.directions),
    )


@dataclass(frozen=True, eq=False)
class CentrelineOffsets:
    """Signed offsets of one path's dwells from the channel centreline (mm).

    For each position P, C is its closest centreline point; ``radial_mm`` is the in-plane
    distance of P from the ring's axis minus that of C (outward positive), ``height_mm`` is
    ``(P - C) . ring normal`` (cranial positive). On the ring's circle these are the offset from
    the circle of radius R and the height above the ring channel's plane.

    Attributes
    ----------
    radial_mm, height_mm : (n,) ndarray
    """

    radial_mm: np.ndarray
    height_mm: np.ndarray


def centreline_offsets(app, channel, positions_mm) -> CentrelineOffsets:
    """Signed radial and height offsets of positions from the channel centreline (see
    :class:`CentrelineOffsets`).

    Parameters
    ----------
    app : Applicator
        Gives the applicator frame (centre, normal).
    channel : Channel
    positions_mm : (n, 3) array_like
        Positions, mm.

    Returns
    -------
    CentrelineOffsets
    """
    p = np.asarray(positions_mm, dtype=float).reshape(-1, 3)
    s, _ = channel.centreline.closest(mm_to_m(p))
    c = m_to_mm(np.asarray(channel.centreline.position(np.asarray(s)), dtype=float)).reshape(-1, 3)
    frame = frame_of(app)
    centre = m_to_mm(np.asarray(frame.centre_m, dtype=float))
    n = np.asarray(frame.normal, dtype=float)

    def rho(x):
        d = x - centre
        return np.linalg.norm(d - np.outer(d @ n, n), axis=1)

    return CentrelineOffsets(rho(p) - rho(c), (p - c) @ n)


@dataclass(frozen=True, eq=False)
class DwellColumns:
    """Per-dwell values the dwell table carries beside the positions.

    Attributes
    ----------
    flags : (n,) ndarray of str
        ``reference_flag`` of each dwell (``""``, ``"infeasible"``, ``"outside_channel"``).
    numerical_error_mm : (n,) ndarray
        The simulation's numerical error per dwell (0 on the other paths).
    offsets : dict of str to CentrelineOffsets
        Per path name.
    supplied : DeviationComponents or None
        The supplied reference against the compared (registered) one, when they differ.
    """

    flags: np.ndarray
    numerical_error_mm: np.ndarray
    offsets: dict[str, CentrelineOffsets]
    supplied: DeviationComponents | None = None


def dwell_table(
    app_name: str,
    reference: ReferenceDwells,
    registered: ReferenceDwells | None,
    selection: PlanSelection,
    simulated: PathDwells,
    centreline: PathDwells,
    dev: Deviations,
    dev_raw: Deviations,
    columns: DwellColumns,
) -> pd.DataFrame:
    """One row per dwell and path: the reference path(s) first, then simulated and centreline.

    Parameters
    ----------
    app_name : str
    reference : ReferenceDwells
        The reference as supplied; its kind says which path it is (``"centreline"``: the
        centreline itself).
    registered : ReferenceDwells or None
        The reference as compared, when registration moved it (rows ``path = "registered"``).
    selection : PlanSelection
        Which dwells the standard plan uses.
    simulated, centreline : PathDwells
    dev : Deviations
        Against the compared reference (``dist_to_reference_mm`` and the components).
    dev_raw : Deviations
        Against the supplied reference (``dist_to_measured_mm``).
    columns : DwellColumns

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`CommissioningResult.dwells`.
    """
    rel, in_plan, ref_kind = reference.relative_position_mm, selection.in_plan, reference.kind
    zeros = np.zeros(rel.size)
    zero = DeviationComponents(zeros, zeros, zeros, zeros)
    measured = ref_kind == "measured"
    if measured:
        supplied = columns.supplied if registered is not None else None
        paths = [("measured", reference.dwells, supplied or zero, zeros, zeros, zeros)]
        if registered is not None:
            to_raw = zero.dist_mm if supplied is None else supplied.dist_mm
            paths.append(("registered", registered.dwells, zero, zeros, zeros, to_raw))
        paths += [
            ("simulated", simulated, dev.simulated, dev.angle_simulated_deg,
             columns.numerical_error_mm, dev_raw.simulated.dist_mm),
            ("centreline", centreline, dev.centreline, dev.angle_centreline_deg, zeros,
             dev_raw.centreline.dist_mm),
        ]  # fmt: skip
    else:
        nan = np.full(rel.size, np.nan)
        paths = [
            ("centreline", centreline, zero, zeros, zeros, nan),
            ("simulated", simulated, dev.simulated, dev.angle_simulated_deg,
             columns.numerical_error_mm, nan),
        ]  # fmt: skip
    rows = []
    for name, path, comp, ang, err, dist_measured in paths:
        pos, dirs = path.positions_mm, path.directions
        off = columns.offsets[name]
        for i in range(rel.size):
            rows.append(
                {
                    "applicator": app_name,
                    "dwell": i + 1,
                    "relative_position_mm": rel[i],
                    "path": name,
                    "x_mm": pos[i, 0],
                    "y_mm": pos[i, 1],
                    "z_mm": pos[i, 2],
                    "dir_x": dirs[i, 0],
                    "dir_y": dirs[i, 1],
                    "dir_z": dirs[i, 2],
                    "dist_to_measured_mm": dist_measured[i],
                    "dist_to_reference_mm": comp.dist_mm[i],
                    "along_mm": comp.along_mm[i],
                    "radial_mm": comp.radial_mm[i],
                    "out_of_plane_mm": comp.out_of_plane_mm[i],
                    "angle_deg": ang[i],
                    "in_plan": bool(in_plan[i]),
                    "radial_from_centreline_mm": off.radial_mm[i],
                    "height_mm": off.height_mm[i],
                    "numerical_error_mm": err[i],
                    "reference_flag": str(columns.flags[i]),
                }
            )
    return pd.DataFrame(rows)
