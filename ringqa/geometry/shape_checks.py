"""Plausibility of a channel's shape against its lumen and the instrument (issue 18).

Three named checks (docs/validation.md):

``channel.curvature`` (error)
    Somewhere the centreline bends with a radius of curvature smaller than the lumen radius
    ``r_b``: the inner wall of such a tube folds over itself, so no real channel has it (a
    centreline in the wrong unit, a kink from joined parts, or a wrong lumen).
``channel.self_intersection`` (error)
    Two parts of the centreline lie closer than the lumen diameter ``2 r_b`` while they are at
    least ``pi x 2 r_b`` apart along the channel (further apart than any legal bend, of radius
    >= r_b, can bring two points of one tube that close): the tube overlaps itself (a helix of
    pitch 0, a loop, a doubled centreline).
``channel.tight_bend`` (warning)
    A bend that the source capsule (rigid, length ``L``, radius ``a``) cannot pass: a straight
    capsule fits in a bend of centreline radius ``R`` with clearance ``c = r_b - a`` on either
    side only if ``sqrt((R + c)^2 - (L/2)^2) >= R - c``, i.e. ``R >= L^2 / (16 c)`` (to first
    order). Tighter bends jam the capsule or force it through the wall.

The checks use the centreline's arc-length table (:class:`~ringqa.geometry.centreline.
CentrelineTable`, SI).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.units import m_to_mm


@dataclass(frozen=True)
class Bend:
    """The sharpest bend of a centreline (SI).

    Attributes
    ----------
    radius_m : float
        Smallest radius of curvature (m); ``inf`` for a straight line.
    s_m : float
        Arc length where it occurs (m).
    """

    radius_m: float
    s_m: float


def sharpest_bend(centreline) -> Bend:
    """The smallest radius of curvature of ``centreline`` and where it is."""
    tab = centreline.table
    kappa = np.asarray(tab.kappa, dtype=float)
    s = np.asarray(tab.s, dtype=float)
    if kappa.size == 0 or not np.isfinite(kappa).any():
        return Bend(math.inf, 0.0)
    i = int(np.nanargmax(kappa))
    k = float(kappa[i])
    return Bend(math.inf if k <= 0 else 1.0 / k, float(s[i]))


def lumen_radius_range_m(lumen) -> tuple[float, float] | None:
    """(smallest, largest) lumen radius ``r_b`` along the channel (m), None if unknown."""
    if lumen is None or not hasattr(lumen, "kernel_arrays"):
        return None
    rb = np.asarray(lumen.kernel_arrays()[1], dtype=float)
    rb = rb[np.isfinite(rb) & (rb > 0)]
    if rb.size == 0:
        return None
    return float(rb.min()), float(rb.max())


def close_pairs(pts: np.ndarray, r: float, strict: bool = False):
    """Every pair of points closer than ``r``, in O(n) memory (a sorted sweep).

    Parameters
    ----------
    pts : (n, 3) ndarray
        Points (m).
    r : float
        Distance (m).
    strict : bool, optional
        ``|p_i - p_j| < r`` when True, ``<= r`` otherwise.

    Returns
    -------
    i, j : (k,) ndarray of int
        The pairs, ``i < j``, sorted by ``i`` then ``j``.
    d : (k,) ndarray
        Their distances (m).

    Notes
    -----
    The points are sorted along the axis of their largest extent; a pair can be close only if
    its two points are within ``r`` on that axis, so the sweep compares each point with its
    1st, 2nd, ... successor in that order until no successor is that near. Time O(n m) for m
    points within ``r`` on the axis (a few for a channel's samples), memory O(n) per
    successor plus the pairs found (issue 25: the all-pairs differences it replaced took
    21.6 GB for 20 000 positions). No scipy.spatial (0.1 s of import on the commissioning path).
    """
    pts = np.asarray(pts, dtype=float)
    n = pts.shape[0]
    found_i, found_j, found_d = [], [], []
    if n >= 2:
        axis = int(np.argmax(np.ptp(pts, axis=0)))
        order = np.argsort(pts[:, axis], kind="stable")
        key = pts[order, axis]
        for k in range(1, n):
            near = np.flatnonzero((key[k:] - key[:-k]) <= r)
            if near.size == 0:
                break  # key is sorted: no later successor is nearer on the axis
            a = order[near]
            b = order[near + k]
            diff = pts[a] - pts[b]
            d2 = np.sum(diff * diff, axis=1)
            hit = d2 < r * r if strict else d2 <= r * r
            found_i.append(np.minimum(a[hit], b[hit]))
            found_j.append(np.maximum(a[hit], b[hit]))
            found_d.append(np.sqrt(d2[hit]))
    if not found_i:
        return np.empty(0, dtype=int), np.empty(0, dtype=int), np.empty(0)
    i = np.concatenate(found_i)
    j = np.concatenate(found_j)
    d = np.concatenate(found_d)
    o = np.lexsort((j, i))
    return i[o], j[o], d[o]


def _close_far_pairs(pts: np.ndarray, s: np.ndarray, r: float, gap: float) -> np.ndarray:
    """Index pairs ``i < j`` with ``|p_i - p_j| <= r`` and ``s_j - s_i >= gap`` (s increasing),
    sorted by i then j (:func:`close_pairs`)."""
    i, j, _ = close_pairs(pts, r)
    far = (s[j] - s[i]) >= gap
    return np.c_[i[far], j[far]]


def self_intersection(centreline, diameter_m: float) -> tuple[float, float, float] | None:
    """Two parts of ``centreline`` closer than ``diameter_m`` but at least ``pi diameter_m``
    apart along it.

    Returns
    -------
    tuple of float or None
        ``(s1_m, s2_m, distance_m)`` of the closest such pair, or None.
    """
    length = float(centreline.length_m)
    if diameter_m <= 0 or length <= math.pi * diameter_m:
        return None
    h = min(diameter_m / 4.0, 0.5e-3)
    s = np.linspace(0.0, length, max(2, math.ceil(length / h) + 1))
    pts = np.asarray(centreline.position(s), dtype=float)
    pairs = _close_far_pairs(pts, s, diameter_m, math.pi * diameter_m)
    if pairs.size == 0:
        return None
    d = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1)
    i = int(np.argmin(d))
    return float(s[pairs[i, 0]]), float(s[pairs[i, 1]]), float(d[i])


def check_channel_shape(channel, where: str) -> None:
    """Refuse a channel whose centreline bends tighter than its lumen radius
    (``channel.curvature``) or overlaps itself (``channel.self_intersection``).

    Parameters
    ----------
    channel : Channel
        A channel with ``centreline`` and ``lumen``.
    where : str
        What to call it in the message (file and channel).

    Raises
    ------
    GeometryError
        The message names the check, the place (arc length), the value and the fix.
    """
    rb = lumen_radius_range_m(getattr(channel, "lumen", None))
    if rb is None:
        return
    rb_min = rb[0]
    bend = sharpest_bend(channel.centreline)
    if bend.radius_m < rb_min:
        raise GeometryError(
            f"{where}: [channel.curvature] the centreline bends with a radius of curvature of "
            f"{m_to_mm(bend.radius_m):.2f} mm at arc length {m_to_mm(bend.s_m):.1f} mm, smaller "
            f"than the lumen radius {m_to_mm(rb_min):.2f} mm: no tube can bend that sharply "
            "(check the centreline's unit and points there, e.g. a kink where parts join, and "
            "the lumen size)"
        )
    hit = self_intersection(channel.centreline, 2.0 * rb_min)
    if hit is not None:
        s1, s2, d = hit
        raise GeometryError(
            f"{where}: [channel.self_intersection] the centreline at arc length "
            f"{m_to_mm(s1):.1f} mm and at {m_to_mm(s2):.1f} mm is only {m_to_mm(d):.2f} mm apart, "
            f"less than the lumen diameter {m_to_mm(2 * rb_min):.2f} mm: the channel overlaps "
            "itself (check for a repeated turn or a helix pitch smaller than the lumen diameter)"
        )


def capsule_bow_m(capsule_length_m: float, curvature_per_m: float) -> float:
    """How far a straight rigid capsule of length ``L`` bows across a bend of curvature
    ``kappa`` (m): the sagitta ``L^2 kappa / 8`` (to first order)."""
    return capsule_length_m**2 * curvature_per_m / 8.0


def capsule_pass_radius_m(
    capsule_length_m: float, capsule_r_m: float, r_b_m: float, bow_clearances: float = 2.0
) -> float:
    """The smallest bend radius (m) a rigid capsule passes in a lumen of radius ``r_b_m``: its
    bow ``L^2 / (8 R)`` may take ``bow_clearances`` times the clearance ``c = r_b - a`` (2: the
    whole width left, ``L^2 / (16 c)``, module docstring; the engine refuses only past 2.5);
    ``inf`` without clearance."""
    c = r_b_m - capsule_r_m
    if c <= 0:
        return math.inf
    return capsule_length_m**2 / (8.0 * bow_clearances * c)


def tight_bend_warning(channel, capsule_length_m: float, capsule_r_m: float, where: str) -> str:
    """The ``channel.tight_bend`` warning for ``channel`` (empty string: none).

    Parameters
    ----------
    channel : Channel
    capsule_length_m, capsule_r_m : float
        The source capsule's length and radius (m).
    where : str
        What to call the channel in the message.
    """
    rb = lumen_radius_range_m(getattr(channel, "lumen", None))
    if rb is None or not capsule_length_m:
        return ""
    r_pass = capsule_pass_radius_m(capsule_length_m, capsule_r_m, rb[0])
    bend = sharpest_bend(channel.centreline)
    if bend.radius_m >= r_pass:
        return ""
    return (
        f"{where}: bends with a radius of {m_to_mm(bend.radius_m):.2f} mm at arc length "
        f"{m_to_mm(bend.s_m):.1f} mm; the {m_to_mm(capsule_length_m):.1f} mm source capsule "
        f"(radius {m_to_mm(capsule_r_m):.3f} mm) in its {2 * m_to_mm(rb[0]):.2f} mm lumen passes "
        f"bends of radius {m_to_mm(r_pass):.2f} mm or more: the source may jam or not reach the "
        "dwells beyond (check the centreline there)"
    )
