"""How far the simulated and centreline dwells lie from the reference, and the dwell table.

Each distance is split into along-channel, radial (in the ring plane) and out-of-plane parts
(:func:`deviation_components`); source directions are compared by angle (:func:`angle_deg`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ringqa.pipeline.dwells import PathDwells, PlanSelection, ReferenceDwells
from ringqa.units import m_to_mm


@dataclass(frozen=True, eq=False)
class DeviationComponents:
    """One path's displacement from the reference dwells, split in the ring frame (mm).

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
        Gives the ring frame (``ring_centre_m``, ``ring_normal``).
    reference, simulated, centreline : PathDwells
        Each path's (n, 3) positions in mm and unit directions, in the same dwell order.

    Returns
    -------
    Deviations
    """
    ref_pos, ref_dir = reference.positions_mm, reference.directions
    centre = m_to_mm(np.asarray(app.ring_centre_m, dtype=float))
    normal = np.asarray(app.ring_normal, dtype=float)
    return Deviations(
        simulated=deviation_components(ref_pos, ref_dir, simulated.positions_mm, centre, normal),
        centreline=deviation_components(ref_pos, ref_dir, centreline.positions_mm, centre, normal),
        angle_simulated_deg=angle_deg(simulated.directions, ref_dir),
        angle_centreline_deg=angle_deg(centreline.directions, ref_dir),
        angle_sim_vs_centreline_deg=angle_deg(simulated.directions, centreline.directions),
    )


def dwell_table(
    app_name: str,
    reference: ReferenceDwells,
    selection: PlanSelection,
    simulated: PathDwells,
    centreline: PathDwells,
    dev: Deviations,
) -> pd.DataFrame:
    """One row per dwell and path: the reference path first, then simulated (and centreline).

    Parameters
    ----------
    app_name : str
    reference : ReferenceDwells
        Its kind says which path is the reference (``"centreline"``: the centreline itself).
    selection : PlanSelection
        Which dwells the standard plan uses.
    simulated, centreline : PathDwells
    dev : Deviations

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`CommissioningResult.dwells`.
    """
    rel, in_plan, ref_kind = reference.relative_position_mm, selection.in_plan, reference.kind
    zeros = np.zeros(rel.size)
    zero = DeviationComponents(zeros, zeros, zeros, zeros)
    paths = [("simulated", simulated, dev.simulated, dev.angle_simulated_deg)]
    if ref_kind == "measured":
        paths = [
            ("measured", reference.dwells, zero, zeros),
            *paths,
            ("centreline", centreline, dev.centreline, dev.angle_centreline_deg),
        ]
    else:
        paths = [("centreline", centreline, zero, zeros), *paths]
    rows = []
    for name, path, comp, ang in paths:
        pos, dirs = path.positions_mm, path.directions
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
                    "dist_to_measured_mm": comp.dist_mm[i] if ref_kind == "measured" else np.nan,
                    "dist_to_reference_mm": comp.dist_mm[i],
                    "along_mm": comp.along_mm[i],
                    "radial_mm": comp.radial_mm[i],
                    "out_of_plane_mm": comp.out_of_plane_mm[i],
                    "angle_deg": ang[i],
                    "in_plan": bool(in_plan[i]),
                }
            )
    return pd.DataFrame(rows)
