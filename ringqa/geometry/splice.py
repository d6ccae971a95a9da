"""Correcting part of a centreline: splice a measured segment (CT, film) over the library's.

Straathof et al. (2024, section 2.4) adjusted the library centreline of the proximal ring "based on
CT measurements and digital images of specific applicators". :func:`splice_centreline` does that
for any part of any channel: a user-supplied segment (points in metres, PROXIMAL -> DISTAL, in
the frame of the centreline) replaces the centreline between the points nearest to its two ends,
and the centreline is joined to it smoothly on both sides.

The splice
    Let ``s_a`` and ``s_b`` be the arc lengths of the library centreline ``r(s)`` closest to the
    segment's first and last points (each end must lie within ``max_gap_m`` of the centreline).
    The segment's own course ``q(u)`` is the spline :meth:`Centreline.from_points` fits through
    its points (u = arc length from its first point, ``0 .. U``). The new centreline is, in order,

    1. the library centreline for ``s <= s_a - b`` (its own input points there, unchanged);
    2. a START BLEND for ``s_a - b <= s <= s_a``: the library centreline plus an offset,
       ``r(s) + dP h_p(x) + b dT h_t(x) + c**2 dK h_k(y)``, with ``x = (s - s_a + b) / b``
       running 0 -> 1 over the blend and ``y = (s - s_a + c) / c`` over its last ``c = min(b,
       2 mm)`` (``y = 0`` before). ``h_p = 10 x^3 - 15 x^4 + 6 x^5``, ``h_t = -4 x^3 + 7 x^4 -
       3 x^5``, ``h_k = x^3 / 2 - x^4 + x^5 / 2`` are the quintic Hermite functions: all three
       and their first two derivatives are 0 at 0; at 1, ``h_p`` is 1, ``h_t'`` is 1 and
       ``h_k''`` is 1, the rest 0. ``dP``, ``dT``, ``dK`` are the differences between the
       segment and the library centreline at the join in position, unit tangent and curvature
       vector (``q(0) - r(s_a)``, ...). The curvature term has its own, short length because
       its offset grows as ``c**2`` while its added curvature (up to ``|dK|``) does not shrink:
       digitised centrelines (library or CT) have curvature noise of several 0.01 1/mm at 1 mm
       spacing, which over a 15 mm blend would move the path by tenths of a millimetre;
    3. the segment ``q(u)``, ``0 <= u <= U``;
    4. an END BLEND for ``s_b <= s <= s_b + b``, the mirror image of 2 (``x = (s_b + b - s) /
       b``, ``y`` likewise, ``b dT`` replaced by ``-b dT``, differences taken at ``s_b`` and
       ``q(U)``);
    5. the library centreline for ``s >= s_b + b``.

    So the blended curve leaves the library centreline with the library's position, tangent and
    curvature and arrives at the segment with the segment's position, tangent and curvature
    vector: the construction is C2 at all four joins, and the new :class:`Centreline`, an
    interpolating spline (the library's degree, quintic: C4) through dense samples (<= 0.25 mm)
    of 1-5, is smooth; it passes exactly through every segment point. A blend only ever moves
    the library centreline by its offset. For a segment parallel to the centreline but
    offset by a gap ``g`` the blend is the curve ``g h_p(x / b)``: its direction turns by up to
    ``atan(15/8 g / b)`` and its added curvature is up to ``10 / sqrt(3) g / b**2`` (``h_p'``
    <= 15/8, ``|h_p''|`` <= 5.77). A segment meeting the centreline at an angle ``theta`` (gap 0)
    is reached by turning gradually from the library's direction to the segment's over ``b``
    (added curvature up to ``3.94 * 2 sin(theta / 2) / b``). A segment whose ends lie on the
    centreline and which meets it tangentially (``dP = dT = 0``) moves the library outside
    ``[s_a, s_b]`` by at most ``0.0173 c**2 |dK|`` (1.7 um for the 0.5 mm bulge of the tests).

Blend length (``blend_m``)
    The blend must absorb the digitisation error of the ends (CT voxels and film pixels
    ~0.2-0.5 mm) without bending the path much, and stay local. Default (``blend_m=None``):
    AUTOMATIC, per join: 5 mm (:data:`BLEND_M`), lengthened in 0.5 mm steps (at most to 15 mm,
    :data:`MAX_AUTO_BLEND_M`, and to the channel left beyond the join) until, wherever the
    library bends (curvature > 10 1/m), the blend of the gap and the angle (``dP``, ``dT``:
    the curvature term does not depend on ``b``) keeps at least a quarter of the library's
    curvature along its normal and turns its normal about the tangent by at most 20 deg.
    Why: the flat side of the ring's U-shaped lumen lies along ``-normal``; a blend that
    adds more curvature than the ring has reverses the bend over a few mm and turns the flat
    side to the inside (for an in-plane gap ``g`` on a ring of radius ``R`` this happens when
    ``5.77 g / b**2 > 1 / R``: ``b < 6.1 mm`` for ``g = 0.5 mm`` on the 26 mm ring); 20 deg
    moves the flat side outwards by at most 0.08 mm (1.2 mm / cos 20 deg). With ``g <= 0.2 mm``
    in the ring plane the blend stays 5 mm: it turns the direction by <= 4.3 deg and adds <=
    0.046 1/mm of curvature, below the 26 mm ring's own 0.077 1/mm (0.5 mm: 7 mm; 1 mm: 10 mm;
    0.2 mm out of the ring plane: 6.5 mm). 5 mm is local (one step of the 5 mm standard plan,
    6 % of the 26 mm ring's circle); 2 mm would turn the direction by 10.6 deg and add
    0.29 1/mm (a 3.5 mm bend radius) for a 0.2 mm gap. The lengths used are
    reported (``blend_start_m``, ``blend_end_m``). A number for ``blend_m`` uses exactly that
    length at both joins (no lengthening).

Gap (``max_gap_m``, default 1.0 mm)
    A correction's ends are meant to lie where CT/film and library AGREE (the joins are on the
    library centreline). 1 mm is the recommended source-position tolerance of the
    commissioning (so a larger gap is itself a deviation the correction would hide) and is
    well inside the 1.5 mm lumen radius (the end is certainly in the same channel, and the
    nearest other branch of a ring, 7-11 mm away, cannot be mistaken for it).

Arc lengths (:meth:`SplicedCentreline.map_arc_length`)
    Proximal of the change (``s <= s_a - b``, ``b`` the blend at that join) arc lengths are
    unchanged; distal of it (``s >= s_b + b``) they shift by the length difference
    ``length_m - old_length_m`` (the same physical point: the new centreline runs through the
    library's points there); in between they are mapped linearly between the four join points
    (``s_a - b, s_a, s_b, s_b + b`` and their arc lengths on the new centreline).
    :func:`splice_channel` maps the lumen segment bounds and ``s_ref_m`` this way, so ``s_ref``
    stays at the same physical point whenever it lies outside the changed range (the usual case:
    the correction is proximal, ``s_ref`` near the tip).

Refused (:class:`SpliceError`, naming the point, the problem and the fix): fewer than 4 points,
non-finite values, millimetres, two points closer than 1 um, a segment that folds back (turns by
more than 90 degrees between consecutive points, or whose points do not advance along the
channel), an end farther than ``max_gap_m`` from the centreline, a segment running distal ->
proximal, and a segment that ends less than ``blend_m`` (automatic: 5 mm) from either end of the
channel (no room for the join).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ringqa.geometry import _kernels as K
from ringqa.geometry.applicator import Applicator, Channel
from ringqa.geometry.centreline import TABLE_SPACING_M, Centreline, GeometryError
from ringqa.units import M_PER_MM, MM_PER_M, m_to_mm

#: Shortest blend (m), the automatic blend's starting length (module docstring).
BLEND_M = 5.0e-3
#: Longest automatic blend (m) and its step (m).
MAX_AUTO_BLEND_M = 15.0e-3
AUTO_BLEND_STEP_M = 0.5e-3
#: Where the library bends more than this (1/m, a 100 mm bend radius), an automatic blend must
#: keep KEEP_BEND of its curvature and turn its normal by at most NORMAL_TOL_DEG.
BEND_KAPPA_PER_M = 10.0
KEEP_BEND = 0.25
NORMAL_TOL_DEG = 20.0
#: The curvature difference is blended in over the last this much of each blend (m): its
#: offset grows as the square of this length, so it is kept short (module docstring).
CURVATURE_BLEND_M = 2.0e-3
#: A gap may exceed max_gap_m by this much (m): floating-point rounding of "exactly on it".
GAP_ROUNDING_M = 1.0e-9
#: Default largest distance of the segment's ends from the centreline (m).
MAX_GAP_M = 1.0e-3
#: Fewest points a segment may have (a spline needs 4).
MIN_SEGMENT_POINTS = 4
#: Two segment points closer than this (m) are duplicates.
DUPLICATE_TOL_M = 1.0e-6
#: Consecutive segment chords turning by more than this (deg) mean the segment folds back.
FOLD_DEG = 90.0
#: Spacing of the samples the new centreline is fitted through (m).
SAMPLE_SPACING_M = TABLE_SPACING_M
#: Spacing of the samples on which the report's numbers are measured (m).
CHECK_SPACING_M = 0.05e-3
#: Largest plausible segment span (m): anything larger was given in millimetres.
MAX_SPAN_M = 1.0


class SpliceError(GeometryError):
    """A correction segment that cannot be spliced (names the argument, the point and the fix).

    Attributes
    ----------
    argument : str
        The argument at fault (``"segment_m"``, ``"blend_m"``, ...).
    problem : str
        What is wrong; ``{0}``, ``{1}`` stand for the points listed in :attr:`points`.
    fix : str
        What to do about it.
    points : tuple of int
        Indices (into ``segment_m``) of the points the problem is about.
    """

    def __init__(self, argument: str, problem: str, fix: str, points: Sequence[int] = ()) -> None:
        self.argument = argument
        self.problem = problem
        self.fix = fix
        self.points = tuple(int(i) for i in points)
        super().__init__(f"{argument}: {self.describe()}; {fix}")

    def describe(self, names: Sequence[str] | None = None) -> str:
        """The problem with the points called ``names[i]`` (default ``"point i"``).

        Parameters
        ----------
        names : sequence of str, optional
            One name per point of the segment (e.g. a file's ``"line 7"``).
        """
        label = [f"point {i}" if names is None else str(names[i]) for i in self.points]
        return self.problem.format(*label)


@dataclass(frozen=True, eq=False)
class SplicedCentreline:
    """A centreline with a segment spliced in, and what a report needs to say about it.

    Arc lengths ``old_*`` are on the library (old) centreline, ``new_*`` on the new one; all in
    metres (degrees for angles, 1/m for curvature).

    Attributes
    ----------
    centreline : Centreline
        The corrected centreline.
    old_length_m : float
        Length of the library centreline (m).
    old_start_m, old_end_m : float
        Arc lengths on the library centreline closest to the segment's first and last points:
        the range REPLACED by the segment (m).
    new_start_m, new_end_m : float
        Arc lengths of the segment's first and last points on the new centreline (m).
    blend_start_m, blend_end_m : float
        Lengths of the two blends (m): the library centreline is also changed over
        ``[old_start_m - blend_start_m, old_start_m]`` and ``[old_end_m, old_end_m +
        blend_end_m]``.
    gap_start_m, gap_end_m : float
        Distances of the segment's first and last points from the library centreline (m).
    angle_start_deg, angle_end_deg : float
        Angles between the segment's tangent and the library centreline's at the two joins (deg):
        the kink there would be without a blend.
    turn_start_deg, turn_end_deg : float
        Largest angle between the new and the library centreline's tangents (at the closest
        points) within each blend (deg): how much the blend bends the path.
    max_shift_m : float
        Largest distance between the new and the library centreline over the changed range
        (both ways: new to library and library to new) (m).
    max_shift_at_m : float
        Library arc length of that largest distance (m).
    max_curvature_per_m : float
        Largest curvature of the new centreline over the changed range (1/m).
    old_max_curvature_per_m : float
        Largest curvature of the library centreline over the same range (1/m).
    max_normal_turn_deg : float
        Largest rotation about the tangent of the new centreline's normal relative to the
        library's (at the closest points) over the changed range, where both bend by more than
        10 1/m (deg; 0 if they do not). The flat side of a U-shaped lumen lies along
        ``-normal``, so it turns with it; more than 90 deg means the new centreline bends the
        other way there.
    """

    centreline: Centreline
    old_length_m: float
    old_start_m: float
    old_end_m: float
    new_start_m: float
    new_end_m: float
    blend_start_m: float
    blend_end_m: float
    gap_start_m: float
    gap_end_m: float
    angle_start_deg: float
    angle_end_deg: float
    turn_start_deg: float
    turn_end_deg: float
    max_shift_m: float
    max_shift_at_m: float
    max_curvature_per_m: float
    old_max_curvature_per_m: float
    max_normal_turn_deg: float

    @property
    def length_m(self) -> float:
        """Length of the new centreline (m)."""
        return self.centreline.length_m

    @property
    def length_change_m(self) -> float:
        """New minus library length (m); arc lengths distal of the change shift by this."""
        return self.centreline.length_m - self.old_length_m

    @property
    def changed_range_m(self) -> tuple[float, float]:
        """Library arc lengths ``(old_start_m - blend_start_m, old_end_m + blend_end_m)``
        changed (m)."""
        return self.old_start_m - self.blend_start_m, self.old_end_m + self.blend_end_m

    def changes(self, s_old_m: float) -> bool:
        """True when library arc length ``s_old_m`` (m) lies strictly inside the changed range
        (then :meth:`map_arc_length` interpolates instead of keeping the physical point)."""
        lo, hi = self.changed_range_m
        return bool(lo < float(s_old_m) < hi)

    def map_arc_length(self, s_old_m):
        """Arc length(s) on the new centreline of library arc length(s) ``s_old_m`` (m).

        Unchanged proximal of the changed range, shifted by :attr:`length_change_m` distal of it
        (same physical point), linear between the join points inside it. ``+-inf`` stay
        infinite. Scalar in, float out; ``(k,)`` in, ``(k,)`` out.
        """
        s = np.asarray(s_old_m, dtype=float)
        lo, hi = self.changed_range_m
        xp = np.array([lo, self.old_start_m, self.old_end_m, hi])
        fp = np.array([lo, self.new_start_m, self.new_end_m, hi + self.length_change_m])
        inner = np.interp(np.clip(s, lo, hi), xp, fp)
        out = np.where(s <= lo, s, np.where(s >= hi, s + self.length_change_m, inner))
        return float(out) if out.ndim == 0 else out

    def as_mm_dict(self) -> dict[str, float]:
        """The numbers for a report or JSON file, in millimetres and degrees."""
        mm = MM_PER_M
        return {
            "old_start_mm": self.old_start_m * mm,
            "old_end_mm": self.old_end_m * mm,
            "new_start_mm": self.new_start_m * mm,
            "new_end_mm": self.new_end_m * mm,
            "segment_mm": (self.new_end_m - self.new_start_m) * mm,
            "old_length_mm": self.old_length_m * mm,
            "new_length_mm": self.length_m * mm,
            "length_change_mm": self.length_change_m * mm,
            "blend_start_mm": self.blend_start_m * mm,
            "blend_end_mm": self.blend_end_m * mm,
            "gap_start_mm": self.gap_start_m * mm,
            "gap_end_mm": self.gap_end_m * mm,
            "angle_start_deg": self.angle_start_deg,
            "angle_end_deg": self.angle_end_deg,
            "turn_start_deg": self.turn_start_deg,
            "turn_end_deg": self.turn_end_deg,
            "max_shift_mm": self.max_shift_m * mm,
            "max_shift_at_mm": self.max_shift_at_m * mm,
            "max_curvature_per_mm": self.max_curvature_per_m * M_PER_MM,
            "old_max_curvature_per_mm": self.old_max_curvature_per_m * M_PER_MM,
            "max_normal_turn_deg": self.max_normal_turn_deg,
        }


# --------------------------------------------------------------------------------------------
# helpers


@dataclass(frozen=True)
class _Join:
    """One join: library arc length, side (+1 start, -1 end), blend length (m), differences
    (segment minus library: position (m), unit tangent, curvature vector (1/m)), angle (deg)."""

    s_m: float
    sign: float
    blend_m: float
    diff: tuple[np.ndarray, np.ndarray, np.ndarray]
    angle_deg: float

    def offset(self, s_m: np.ndarray, blend_m: float | None = None, curvature: bool = True):
        """Offset of the library centreline and its first and second derivatives in ``s`` at
        library arc lengths ``s_m (k,)`` of the blend: three ``(k, 3)`` arrays (m, 1, 1/m).

        ``dP h_p(x) + beta dT h_t(x) + gamma**2 dK h_k(y)`` with ``x`` running 0 -> 1 over the
        blend ``b`` (``beta = +-b``, ``d x / ds = 1 / beta``) and ``y`` over its last ``c =
        min(b, CURVATURE_BLEND_M)`` (``gamma = +-c``; ``y = 0`` before it, where ``h_k`` and its
        first two derivatives vanish). ``curvature=False`` leaves out the ``dK`` term.
        """
        b = self.blend_m if blend_m is None else blend_m
        c = min(b, CURVATURE_BLEND_M)
        u = self.sign * (np.asarray(s_m, dtype=float) - self.s_m)  # -b .. 0, towards the join
        x = ((u + b) / b)[:, None]
        y = np.clip((u + c) / c, 0.0, None)[:, None]
        beta, gamma = self.sign * b, self.sign * c
        d_p, d_t, d_k = self.diff
        if curvature:
            out = [
                _h_pos(x, nu) * d_p / beta**nu
                + _h_tan(x, nu) * d_t * beta ** (1 - nu)
                + _h_cur(y, nu) * d_k * gamma ** (2 - nu)
                for nu in range(3)
            ]
        else:
            out = [
                _h_pos(x, nu) * d_p / beta**nu + _h_tan(x, nu) * d_t * beta ** (1 - nu)
                for nu in range(3)
            ]
        return out[0], out[1], out[2]


def _h_pos(x: np.ndarray, nu: int) -> np.ndarray:
    """``nu``-th derivative of ``h_p = 10 x^3 - 15 x^4 + 6 x^5`` (0 -> 1, ends flat)."""
    return (
        x**3 * (10.0 - 15.0 * x + 6.0 * x * x),
        x**2 * (30.0 - 60.0 * x + 30.0 * x * x),
        x * (60.0 - 180.0 * x + 120.0 * x * x),
    )[nu]


def _h_tan(x: np.ndarray, nu: int) -> np.ndarray:
    """``nu``-th derivative of ``h_t = -4 x^3 + 7 x^4 - 3 x^5`` (slope 1 at x = 1)."""
    return (
        x**3 * (-4.0 + 7.0 * x - 3.0 * x * x),
        x**2 * (-12.0 + 28.0 * x - 15.0 * x * x),
        x * (-24.0 + 84.0 * x - 60.0 * x * x),
    )[nu]


def _h_cur(x: np.ndarray, nu: int) -> np.ndarray:
    """``nu``-th derivative of ``h_k = x^3 / 2 - x^4 + x^5 / 2`` (second derivative 1 at 1)."""
    return (
        x**3 * (0.5 - x + 0.5 * x * x),
        x**2 * (1.5 - 4.0 * x + 2.5 * x * x),
        x * (3.0 - 12.0 * x + 10.0 * x * x),
    )[nu]


def _normal_across(nor: np.ndarray, tan: np.ndarray) -> np.ndarray:
    """Library normals ``(k, 3)`` carried across to curves with unit tangents ``tan (k, 3)``
    (the component perpendicular to ``tan``, normalised): compared with the new normals they
    give the rotation ABOUT the tangent (which turns a U-shaped lumen's flat side), not the
    tilt that comes with a turned tangent."""
    v = nor - np.sum(nor * tan, axis=1)[:, None] * tan
    return v / np.linalg.norm(v, axis=1)[:, None]


def _keeps_bend(old: Centreline, join: _Join, blend_m: float) -> bool:
    """Does a blend of ``blend_m`` keep the library's bend wherever the library bends?

    At every sample where the library's curvature exceeds BEND_KAPPA_PER_M, the blended curve's
    curvature vector must keep :data:`KEEP_BEND` of the library's curvature along its normal and
    point within :data:`NORMAL_TOL_DEG` of it.
    """
    lo, hi = (join.s_m - blend_m, join.s_m) if join.sign > 0 else (join.s_m, join.s_m + blend_m)
    s = _uniform(lo, hi, SAMPLE_SPACING_M, include_end=True)
    kappa = old.curvature(s)
    bends = kappa > BEND_KAPPA_PER_M
    if not bends.any():
        return True
    s, kappa = s[bends], kappa[bends]
    nor = old.normal(s)
    _, d1, d2 = join.offset(s, blend_m, curvature=False)
    r1 = old.tangent(s) + d1
    r2 = kappa[:, None] * nor + d2
    sp2 = np.sum(r1 * r1, axis=1)
    tan = r1 / np.sqrt(sp2)[:, None]
    kv = (r2 - np.sum(r2 * tan, axis=1)[:, None] * tan) / sp2[:, None]
    along = np.sum(kv * _normal_across(nor, tan), axis=1)
    size = np.linalg.norm(kv, axis=1)
    cos_tol = np.cos(np.radians(NORMAL_TOL_DEG))
    return bool(np.all(along >= KEEP_BEND * kappa) and np.all(along >= cos_tol * size))


def _auto_blend(old: Centreline, s_m: float, sign: float, diff, upper_m: float) -> float:
    """The shortest blend from BLEND_M up (0.5 mm steps, at most ``upper_m``) that keeps the
    library's bend (:func:`_keeps_bend`); ``upper_m`` if none does."""
    join = _Join(s_m, sign, BLEND_M, diff, 0.0)
    n = 0
    while (b := round(BLEND_M + n * AUTO_BLEND_STEP_M, 12)) < upper_m:
        if _keeps_bend(old, join, b):
            return b
        n += 1
    return upper_m


def _curvature_vector(cl: Centreline, s: float) -> np.ndarray:
    """Curvature vector ``d2r/ds2`` (1/m, towards the centre of the bend) at ``s`` (m)."""
    t = cl.table
    d1 = K.eval_deriv(t.knots, t.coef, float(s), 1)
    d2 = K.eval_deriv(t.knots, t.coef, float(s), 2)
    sp2 = float(d1 @ d1)
    tan = d1 / np.sqrt(sp2)
    return (d2 - (d2 @ tan) * tan) / sp2


def _literal(text: str) -> str:
    """``text`` with its braces escaped for :meth:`str.format` (problems are templates)."""
    return text.replace("{", "{{").replace("}", "}}")


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (deg) between unit vectors (rows of) ``a`` and ``b`` (accurate near 0)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def _positive_length(name: str, value, upper_m: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SpliceError(name, f"{value!r} is not a number", "give a length in metres") from None
    if not np.isfinite(v) or v <= 0.0:
        raise SpliceError(name, f"must be a positive length, got {value!r}", "give metres")
    if v > upper_m:
        raise SpliceError(
            name,
            f"{v:g} m is implausibly long (more than {m_to_mm(upper_m):g} mm)",
            "give metres, e.g. 5e-3 for 5 mm",
        )
    return v


def _validate_segment(segment_m) -> np.ndarray:
    try:
        seg = np.array(segment_m, dtype=float)
    except (TypeError, ValueError) as exc:
        raise SpliceError(
            "segment_m", f"cannot be read as numbers ({exc})", "give an (n, 3) array in metres"
        ) from None
    if seg.ndim != 2 or seg.shape[1] != 3:
        raise SpliceError(
            "segment_m",
            f"expected an (n, 3) array of x, y, z, got shape {seg.shape}",
            "give one row of x, y, z (metres) per point",
        )
    n = seg.shape[0]
    if n < MIN_SEGMENT_POINTS:
        raise SpliceError(
            "segment_m",
            f"a correction segment needs at least {MIN_SEGMENT_POINTS} points, got {n}",
            "give points every 0.5-1 mm along the corrected part of the channel",
        )
    bad = ~np.isfinite(seg).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise SpliceError(
            "segment_m", "{0} is not finite (NaN or inf)", "remove or correct it", (i,)
        )
    span = float(np.ptp(seg, axis=0).max())
    if span > MAX_SPAN_M:
        raise SpliceError(
            "segment_m",
            f"the points span {span:.3g} m: they look like millimetres",
            "give metres (convert with ringqa.units.mm_to_m)",
        )
    # imported here, not at module level: scipy's subpackages take ~0.1 s to import and
    # the commissioning run does not come here
    from scipy.spatial import cKDTree

    pairs = cKDTree(seg).query_pairs(DUPLICATE_TOL_M)
    if pairs:
        i, j = sorted(min(pairs))
        raise SpliceError(
            "segment_m",
            f"{{1}} repeats {{0}} (closer than {m_to_mm(DUPLICATE_TOL_M):g} mm)",
            "remove duplicated points",
            (i, j),
        )
    chords = np.diff(seg, axis=0)
    lengths = np.linalg.norm(chords, axis=1)
    units = chords / lengths[:, None]
    turn = _angle_deg(units[:-1], units[1:])
    folds = np.flatnonzero(turn > FOLD_DEG)
    if folds.size:
        i = int(folds[0]) + 1
        raise SpliceError(
            "segment_m",
            f"the segment turns back by {turn[i - 1]:.0f} degrees at {{0}}: it folds back or "
            "overlaps itself",
            "give the points in order along the channel, proximal -> distal, without loops",
            (i,),
        )
    return seg


def _segment_curve(seg: np.ndarray) -> Centreline:
    try:
        return Centreline.from_points(seg)
    except GeometryError as exc:
        msg = _literal(str(exc).removeprefix("points_m: "))
        raise SpliceError(
            "segment_m",
            f"no smooth curve through the points ({msg})",
            "resample the segment evenly along the channel",
        ) from None


def _data_arc_lengths(cl: Centreline, points: np.ndarray) -> np.ndarray:
    """Arc lengths (m) of points the centreline interpolates (its own input points)."""
    s, _ = cl.closest(points)
    return np.asarray(s, dtype=float)


def _closest_in(cl: Centreline, points: np.ndarray, lo: float, hi: float):
    """Closest points searched only within arc lengths ``[lo, hi]`` (plus a 1 mm margin)."""
    mid = 0.5 * (lo + hi)
    return cl.closest(points, s_hint_m=mid, window_m=0.5 * (hi - lo) + 1.0e-3)


def _uniform(a: float, b: float, spacing: float, include_end: bool) -> np.ndarray:
    n = max(int(np.ceil((b - a) / spacing)), 1)
    return np.linspace(a, b, n + 1) if include_end else np.linspace(a, b, n + 1)[:-1]


# --------------------------------------------------------------------------------------------
# splice


def splice_centreline(
    centreline: Centreline,
    segment_m,
    blend_m: float | None = None,
    max_gap_m: float = MAX_GAP_M,
) -> SplicedCentreline:
    """Replace part of a centreline by a corrected segment, with smooth joins.

    Parameters
    ----------
    centreline : Centreline
        The library centreline (m), proximal -> distal.
    segment_m : (k, 3) array_like
        The corrected course of part of the channel (m), k >= 4 points ordered proximal ->
        distal, in the centreline's frame; its first and last points on the library centreline
        (within ``max_gap_m``), where the correction starts and ends.
    blend_m : float, optional
        Length of library centreline (m) over which each join is blended. Default (None):
        automatic, :data:`BLEND_M` (5 mm) lengthened per join in 0.5 mm steps up to
        :data:`MAX_AUTO_BLEND_M` (15 mm) until the blend keeps the channel's bend (module
        docstring). A number: exactly that length at both joins. There must be at least this
        much (automatic: 5 mm) centreline before the segment's start and after its end.
    max_gap_m : float
        Largest distance (m) of the segment's first and last points from the centreline
        (default 1 mm).

    Returns
    -------
    SplicedCentreline
        The new centreline and the numbers describing the change.

    Raises
    ------
    SpliceError
        Too few, non-finite, millimetre or duplicated points; a segment that folds back, runs
        distal -> proximal, does not meet the centreline, or leaves no room for a blend.
    """
    if not isinstance(centreline, Centreline):
        raise SpliceError("centreline", "must be a Centreline", "build one with from_points")
    auto = blend_m is None
    blend_min = BLEND_M if auto else _positive_length("blend_m", blend_m, 0.05)
    max_gap = _positive_length("max_gap_m", max_gap_m, 0.01)
    seg = _validate_segment(segment_m)
    old = centreline
    length = old.length_m

    # -- where the segment meets the centreline -------------------------------------------
    s_ends, gaps = old.closest(seg[[0, -1]])
    s_a, s_b = float(s_ends[0]), float(s_ends[1])
    g_a, g_b = float(gaps[0]), float(gaps[1])
    far = [
        (which, g, i)
        for which, g, i in (("first", g_a, 0), ("last", g_b, len(seg) - 1))
        if g > max_gap + GAP_ROUNDING_M
    ]
    if far:
        parts = [
            f"its {which} point ({{{k}}}) is {m_to_mm(g):.1f} mm away"
            for k, (which, g, _) in enumerate(far)
        ]
        where = " and ".join(parts)
        raise SpliceError(
            "segment_m",
            f"the correction segment does not meet the centreline: {where}",
            "give a segment whose first and last points lie on the library centreline (within "
            f"{m_to_mm(max_gap):.1f} mm), in the same frame as the centreline",
            [i for _, _, i in far],
        )
    if s_b <= s_a:
        raise SpliceError(
            "segment_m",
            f"the segment runs from distal to proximal: its first point ({{0}}) is at "
            f"{m_to_mm(s_a):.1f} mm along the channel, its last ({{1}}) at {m_to_mm(s_b):.1f} mm",
            "list the points from proximal to distal (reverse their order)",
            (0, len(seg) - 1),
        )
    room = (s_a, length - s_b)
    for k, start in ((0, True), (1, False)):
        if room[k] < blend_min:
            what = "starts" if start else "ends"
            where = "after the channel entry" if start else "before the channel tip"
            raise SpliceError(
                "segment_m",
                f"the segment {what} {m_to_mm(max(room[k], 0.0)):.1f} mm {where} ({{0}}); the "
                f"join needs blend_m = {m_to_mm(blend_min):.1f} mm of library centreline beyond it",
                f"let the segment {'start' if start else 'end'} further inside the channel, or "
                "give a smaller blend_m",
                (0 if start else len(seg) - 1,),
            )
    s_int, _ = _closest_in(old, seg[1:-1], s_a, s_b)
    s_all = np.concatenate([[s_a], s_int, [s_b]])
    back = np.flatnonzero(np.diff(s_all) <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise SpliceError(
            "segment_m",
            f"{{1}} is not distal of {{0}} along the channel ({m_to_mm(s_all[i]):.2f} mm vs "
            f"{m_to_mm(s_all[i - 1]):.2f} mm): the segment folds back or overlaps itself",
            "give the points in order along the channel, proximal -> distal, without loops",
            (i - 1, i),
        )

    # -- the segment's course, the join differences and the blend lengths ----------------------
    q = _segment_curve(seg)
    u_data = _data_arc_lengths(q, seg)
    u_data[0], u_data[-1] = 0.0, q.length_m
    joins = []
    for k, (s_j, u_j, sign) in enumerate(((s_a, 0.0, 1.0), (s_b, q.length_m, -1.0))):
        t_q, t_r = q.tangent(u_j), old.tangent(s_j)
        diff = (
            q.position(u_j) - old.position(s_j),
            t_q - t_r,
            _curvature_vector(q, u_j) - _curvature_vector(old, s_j),
        )
        if auto:
            b = _auto_blend(old, s_j, sign, diff, min(MAX_AUTO_BLEND_M, room[k]))
        else:
            b = blend_min
        joins.append(_Join(s_j, sign, b, diff, float(_angle_deg(t_q, t_r))))
    j_a, j_b = joins

    # -- samples of the new centreline --------------------------------------------------------
    s_old_data = _data_arc_lengths(old, old.points_m)
    pts_old = old.points_m
    margin = 0.5 * SAMPLE_SPACING_M
    before = pts_old[s_old_data < s_a - j_a.blend_m - margin]
    after = pts_old[s_old_data > s_b + j_b.blend_m + margin]
    s1 = _uniform(s_a - j_a.blend_m, s_a, SAMPLE_SPACING_M, include_end=False)
    blend1 = old.position(s1) + j_a.offset(s1)[0]
    s2 = _uniform(s_b, s_b + j_b.blend_m, SAMPLE_SPACING_M, include_end=True)[1:]
    blend2 = old.position(s2) + j_b.offset(s2)[0]
    inner = [seg[:1]]
    for i in range(len(seg) - 1):
        u = _uniform(u_data[i], u_data[i + 1], SAMPLE_SPACING_M, include_end=False)[1:]
        if u.size:
            inner.append(q.position(u))
        inner.append(seg[i + 1 : i + 2])
    course = np.vstack([before, blend1, *inner, blend2, after])
    try:
        new = Centreline.from_points(course, degree=old.degree)
    except GeometryError as exc:
        raise SpliceError(
            "segment_m",
            f"the spliced centreline could not be fitted ({_literal(str(exc))})",
            "resample the segment evenly (every 0.5-1 mm) along the channel",
        ) from None

    # -- where the joins are on the new centreline ---------------------------------------------
    lo, hi = s_a - j_a.blend_m, s_b + j_b.blend_m
    est = np.array([s_a, s_a + q.length_m])
    s_new_ends, _ = new.closest(seg[[0, -1]], s_hint_m=est, window_m=hi - lo + q.length_m)
    new_start, new_end = float(s_new_ends[0]), float(s_new_ends[1])
    d_len = new.length_m - length

    # -- what changed: distances, tangents, normals and curvature over the changed range -------
    s_new = _uniform(lo, hi + d_len, CHECK_SPACING_M, include_end=True)
    p_new = new.position(s_new)
    s_o, d_new_to_old = _closest_in(old, p_new, lo, hi)
    turn = _angle_deg(new.tangent(s_new), old.tangent(s_o))
    s_chk = _uniform(lo, hi, CHECK_SPACING_M, include_end=True)
    _, d_old_to_new = _closest_in(new, old.position(s_chk), lo, hi + d_len)
    if d_new_to_old.max() >= d_old_to_new.max():
        k = int(np.argmax(d_new_to_old))
        shift, shift_at = float(d_new_to_old[k]), float(s_o[k])
    else:
        k = int(np.argmax(d_old_to_new))
        shift, shift_at = float(d_old_to_new[k]), float(s_chk[k])
    kappa_new = new.curvature(s_new)
    bent = (kappa_new > BEND_KAPPA_PER_M) & (old.curvature(s_o) > BEND_KAPPA_PER_M)
    n_new, t_new = new.normal(s_new[bent]), new.tangent(s_new[bent])
    n_turn = _angle_deg(n_new, _normal_across(old.normal(s_o[bent]), t_new))
    return SplicedCentreline(
        centreline=new,
        old_length_m=length,
        old_start_m=s_a,
        old_end_m=s_b,
        new_start_m=new_start,
        new_end_m=new_end,
        blend_start_m=j_a.blend_m,
        blend_end_m=j_b.blend_m,
        gap_start_m=g_a,
        gap_end_m=g_b,
        angle_start_deg=j_a.angle_deg,
        angle_end_deg=j_b.angle_deg,
        turn_start_deg=float(turn[s_new <= new_start].max()),
        turn_end_deg=float(turn[s_new >= new_end].max()),
        max_shift_m=shift,
        max_shift_at_m=shift_at,
        max_curvature_per_m=float(np.max(kappa_new)),
        old_max_curvature_per_m=float(np.max(old.curvature(s_chk))),
        max_normal_turn_deg=float(n_turn.max()) if n_turn.size else 0.0,
    )


def splice_channel(
    channel: Channel,
    segment_m,
    blend_m: float | None = None,
    max_gap_m: float = MAX_GAP_M,
) -> tuple[Channel, SplicedCentreline]:
    """A channel with a corrected segment spliced into its centreline.

    The lumen's segment bounds and ``s_ref_m`` are moved to the new arc length with
    :meth:`SplicedCentreline.map_arc_length` (same physical point outside the changed range,
    proportional inside it; :meth:`SplicedCentreline.changes` tells which); the measured path
    (positions in space) is kept as it is.

    Parameters
    ----------
    channel : Channel
        The channel to correct.
    segment_m : (k, 3) array_like
        Corrected course (m), proximal -> distal; see :func:`splice_centreline`.
    blend_m : float, optional
        See :func:`splice_centreline` (m; default automatic, 5-15 mm).
    max_gap_m : float
        See :func:`splice_centreline` (m).

    Returns
    -------
    channel : Channel
        Same name, lumen cross-sections and measured path; new centreline, lumen bounds and
        ``s_ref_m``.
    splice : SplicedCentreline
        What changed (for the report).

    Raises
    ------
    SpliceError
        See :func:`splice_centreline`.
    """
    if not isinstance(channel, Channel):
        raise SpliceError("channel", "must be a Channel", "give e.g. applicator.channel('ring')")
    spliced = splice_centreline(channel.centreline, segment_m, blend_m, max_gap_m)
    lum = channel.lumen
    lumen = dataclasses.replace(lum, seg_s=spliced.map_arc_length(lum.seg_s))
    s_ref = min(max(spliced.map_arc_length(channel.s_ref_m), 0.0), spliced.length_m)
    new = dataclasses.replace(
        channel, centreline=spliced.centreline, lumen=lumen, s_ref_m=s_ref
    )  # the lumen keeps its flat side and source, the channel its measured path
    return new, spliced


def splice_applicator(
    applicator: Applicator,
    channel: str,
    segment_m,
    blend_m: float | None = None,
    max_gap_m: float = MAX_GAP_M,
) -> tuple[Applicator, SplicedCentreline]:
    """An applicator whose channel ``channel`` has a corrected segment spliced in.

    The other channels and the applicator frame are kept; ``metadata["centreline_correction"]``
    records :meth:`SplicedCentreline.as_mm_dict` under the channel's name.

    Parameters
    ----------
    applicator : Applicator
    channel : str
        Name of the channel to correct (e.g. ``"ring"``).
    segment_m : (k, 3) array_like
        Corrected course (m), proximal -> distal, in the applicator's frame.
    blend_m : float, optional
        See :func:`splice_centreline` (m; default automatic, 5-15 mm).
    max_gap_m : float
        See :func:`splice_centreline` (m).

    Returns
    -------
    applicator : Applicator
    splice : SplicedCentreline

    Raises
    ------
    GeometryError
        No such channel; :class:`SpliceError` for the segment (see :func:`splice_centreline`).
    """
    old = applicator.channel(channel)
    new, spliced = splice_channel(old, segment_m, blend_m, max_gap_m)
    meta = dict(applicator.metadata)
    record = dict(meta.get("centreline_correction", {}))
    record[channel] = spliced.as_mm_dict()
    meta["centreline_correction"] = record
    chans = tuple(new if c.name == channel else c for c in applicator.channels)
    return dataclasses.replace(applicator, channels=chans, metadata=meta), spliced
