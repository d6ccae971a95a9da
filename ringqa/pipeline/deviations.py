"""How far the simulated and centreline dwells lie from the reference, and the dwell table.

Each distance is split into along-channel, radial (in the ring plane) and out-of-plane parts
(:func:`deviation_components`); source directions are compared by angle (:func:`angle_deg`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ringqa.units import m_to_mm


def deviation_components(ref_mm, ref_dir, other_mm, centre_mm, normal) -> dict[str, np.ndarray]:
    """Split ``other - ref`` into along-channel, radial (in the ring plane) and out-of-plane parts.

    The frame at each reference dwell: ``out`` = ring normal (cranial positive); ``radial`` = the
    in-plane direction from the ring centre to the reference dwell (outward positive); ``along`` =
    the remaining in-plane direction, signed so that DISTAL is positive (along ``ref_dir``).

    Returns
    -------
    dict
        ``dist_mm``, ``along_mm``, ``radial_mm``, ``out_of_plane_mm``, each (n,).
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
    return {
        "dist_mm": np.linalg.norm(d, axis=1),
        "along_mm": np.sum(d * along, axis=1),
        "radial_mm": np.sum(d * rad, axis=1),
        "out_of_plane_mm": d @ n,
    }


def angle_deg(a, b) -> np.ndarray:
    """Angle between unit vectors row by row, degrees."""
    c = np.sum(np.asarray(a, dtype=float) * np.asarray(b, dtype=float), axis=1)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


@dataclass(frozen=True)
class Deviations:
    """The simulated and centreline dwells compared with the reference dwells.

    Attributes
    ----------
    simulated, centreline : dict
        :func:`deviation_components` of each path against the reference (``dist_mm``,
        ``along_mm``, ``radial_mm``, ``out_of_plane_mm``, each (n,)).
    angle_simulated_deg, angle_centreline_deg : ndarray
        Angle between each path's source direction and the reference's, degrees (n,).
    angle_sim_vs_centreline_deg : ndarray
        Angle between the simulated and the centreline source direction, degrees (n,).
    """

    simulated: dict
    centreline: dict
    angle_simulated_deg: np.ndarray
    angle_centreline_deg: np.ndarray
    angle_sim_vs_centreline_deg: np.ndarray


def _deviations(app, ref, simulated, centreline) -> Deviations:
    """Compare the simulated and centreline dwells with the reference in the ring's frame.

    Parameters
    ----------
    app : Applicator
        Gives the ring frame (``ring_centre_m``, ``ring_normal``).
    ref, simulated, centreline : (ndarray, ndarray)
        Positions (n, 3) in mm and unit source directions (n, 3) of each path.

    Returns
    -------
    Deviations
    """
    ref_pos, ref_dir = ref
    sim_pos, sim_dir = simulated
    cl_pos, cl_dir = centreline
    centre = m_to_mm(np.asarray(app.ring_centre_m, dtype=float))
    normal = np.asarray(app.ring_normal, dtype=float)
    return Deviations(
        simulated=deviation_components(ref_pos, ref_dir, sim_pos, centre, normal),
        centreline=deviation_components(ref_pos, ref_dir, cl_pos, centre, normal),
        angle_simulated_deg=angle_deg(sim_dir, ref_dir),
        angle_centreline_deg=angle_deg(cl_dir, ref_dir),
        angle_sim_vs_centreline_deg=angle_deg(sim_dir, cl_dir),
    )


def _dwell_table(
    app_name: str,
    rel: np.ndarray,
    in_plan: np.ndarray,
    ref_kind: str,
    ref,
    simulated,
    centreline,
    dev: Deviations,
) -> pd.DataFrame:
    """One row per dwell and path: the reference path first, then simulated (and centreline).

    Parameters
    ----------
    app_name : str
    rel : ndarray
        Relative positions of the dwells, mm (n,).
    in_plan : ndarray of bool
        Which dwells the standard plan uses (n,).
    ref_kind : str
        ``"measured"`` or ``"centreline"`` (then the centreline is the reference path).
    ref, simulated, centreline : (ndarray, ndarray)
        Positions (n, 3) in mm and unit source directions (n, 3) of each path.
    dev : Deviations

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`CommissioningResult.dwells`.
    """
    zero = {k: np.zeros(rel.size) for k in dev.simulated}
    paths = [("simulated", *simulated, dev.simulated, dev.angle_simulated_deg)]
    if ref_kind == "measured":
        paths = [
            ("measured", *ref, zero, np.zeros(rel.size)),
            *paths,
            ("centreline", *centreline, dev.centreline, dev.angle_centreline_deg),
        ]
    else:
        paths = [("centreline", *centreline, zero, np.zeros(rel.size)), *paths]
    rows = []
    for name, pos, dirs, comp, ang in paths:
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
                    "dist_to_measured_mm": comp["dist_mm"][i] if ref_kind == "measured" else np.nan,
                    "dist_to_reference_mm": comp["dist_mm"][i],
                    "along_mm": comp["along_mm"][i],
                    "radial_mm": comp["radial_mm"][i],
                    "out_of_plane_mm": comp["out_of_plane_mm"][i],
                    "angle_deg": ang[i],
                    "in_plan": bool(in_plan[i]),
                }
            )
    return pd.DataFrame(rows)
