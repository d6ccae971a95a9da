"""The S-shaped needle channels of the paper's 3D-printed templates (Straathof et al. 2024).

The centreline is built from five pieces, proximal -> distal (the authors' public MATLAB code,
``m20221212_RS_WP2_MAT_CatheterInsertionForce_V5.m``, MIT; ``shared/seed/README.md``):

1. a straight ENTRY of ``d1`` = 10 mm, starting where the catheter's tip starts (the catheter
   lies straight in a guide behind it);
2. BEND 1: radius ``r`` over the angle ``t1``;
3. a straight MIDDLE piece of length ``d2``;
4. BEND 2: radius ``r`` over ``t1``, in a plane turned about the middle piece's tangent by
   ``pi - tau`` from bend 1's plane (``tau`` = 0: the planar S; ``tau`` = pi: both bends turn the
   same way);
5. a straight EXIT of ``d3`` = 30 mm.

``t1`` and ``d2`` make the planar S (``tau`` = 0) ``w`` = 30 mm wide and ``h`` = 120 mm high::

    d2 sin t1 + 2 r (1 - cos t1) = w
    d1 + d3 + d2 cos t1 + 2 r sin t1 = h

Eliminating ``d2`` gives ``(w - 2 r) cos t1 + 2 r = H sin t1`` with ``H = h - d1 - d3``, solved in
closed form; of its roots with ``d2 >= 0`` the one with the larger ``d2`` is taken (the code's
choice). r = 20 mm: t1 = 22.6 deg, d2 = 70.0 mm; r = 60 mm: t1 = 36.87 deg, d2 = 10.0 mm (a
3-4-5 triangle). There is no such S above ``r_max = H / (2 sin t)``, ``tan(t / 2) = w / H``
(60.8 mm for the paper's sizes), where ``d2`` reaches 0.

Frame (mm in the arguments, metres in the returned channel): the entry starts at the origin
heading +x; bend 1 turns towards +y in the x-y plane; the bending plane then turns right-handed
about the middle piece's tangent by ``pi - tau``, so bend 2 of the planar S (``tau`` = 0) turns
back towards -y and the exit ends at ``(h, w, 0)``; with ``tau`` = pi/2 bend 2 turns towards +z.

Lumen: circular, ``r_b = diameter / 2`` (2.6 mm nominal: r_b = 1.3 mm) and
``r_a = r_b - 0.1 mm`` (Table 1: r_a 1.2, r_b 1.3 mm; the printing tolerance adds 0.1 mm to
both, diameter 2.8 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ringqa.geometry.applicator import Channel
from ringqa.geometry.centreline import Centreline, GeometryError
from ringqa.geometry.lumen import Lumen
from ringqa.units import mm_to_m

#: Defaults (mm) and their source: the authors' MATLAB code (shared/seed/README.md).
ENTRY_MM = 10.0  # d1: straight ahead of the catheter tip's start position
EXIT_MM = 30.0  # d3: straight exit
WIDTH_MM = 30.0  # w: planar width of the S
HEIGHT_MM = 120.0  # h: height of the S (entry start to exit end)
#: Nominal channel diameter (mm): r_b = 1.3 mm (Table 1, needle insertion).
NOMINAL_DIAMETER_MM = 2.6
#: r_b - r_a (mm): Table 1 r_a = 1.2, r_b = 1.3 mm (the tolerance adds 0.1 mm to both).
TRANSITION_MM = 0.1
#: Printing tolerance on the diameter (mm): the paper runs every channel at D and D + 0.2 mm.
DIAMETER_TOLERANCE_MM = 0.2
#: Spacing of the points handed to Centreline.from_points (mm).
POINT_SPACING_MM = 0.25
#: Distal dwell reference: s_ref = length - 5 mm (as the scene files' analytic channels).
TIP_GAP_MM = 5.0

SOURCES = (
    "Five-piece centreline, d1 = 10 mm, d3 = 30 mm, w = 30 mm, h = 120 mm, root with the larger "
    "d2, torsion as a turn of the bending plane by pi - tau over the middle straight: the "
    "authors' MATLAB code m20221212_RS_WP2_MAT_CatheterInsertionForce_V5.m "
    "(github.com/roepnaamstraat/FlexibleInstrumentSimulation, MIT), shared/seed/README.md.",
    "Channel r_b = 1.3 mm, r_a = 1.2 mm (2.6 mm nominal), +0.1 mm on both for the printing "
    "tolerance; r = 20..60 mm, tau = 0..pi, diameter 2.6..3.0 mm: Straathof et al., Med Phys "
    "2024, Table 1 and section 2.4.",
)


@dataclass(frozen=True)
class SChannelLayout:
    """The solved S channel: its pieces and where they are along the centreline (mm, rad).

    Attributes
    ----------
    radius_mm : float
        Bend radius r (mm).
    torsion_rad : float
        Torsion tau (rad), 0..pi: bend 2's plane is turned by ``pi - tau`` from bend 1's.
    diameter_mm : float
        Channel diameter 2 r_b (mm).
    bend_angle_rad : float
        Angle t1 of each bend (rad).
    entry_mm, middle_mm, exit_mm : float
        Straight lengths d1, d2, d3 (mm).
    width_mm, height_mm : float
        Planar width w and height h of the S (mm).
    """

    radius_mm: float
    torsion_rad: float
    diameter_mm: float
    bend_angle_rad: float
    entry_mm: float
    middle_mm: float
    exit_mm: float
    width_mm: float
    height_mm: float

    @property
    def bend_length_mm(self) -> float:
        """Arc length of one bend, r t1 (mm)."""
        return self.radius_mm * self.bend_angle_rad

    @property
    def bend1_mm(self) -> tuple[float, float]:
        """Arc lengths (mm) where bend 1 starts and ends."""
        return self.entry_mm, self.entry_mm + self.bend_length_mm

    @property
    def bend2_mm(self) -> tuple[float, float]:
        """Arc lengths (mm) where bend 2 starts and ends."""
        start = self.entry_mm + self.bend_length_mm + self.middle_mm
        return start, start + self.bend_length_mm

    @property
    def length_mm(self) -> float:
        """Centreline length d1 + 2 r t1 + d2 + d3 (mm)."""
        return self.bend2_mm[1] + self.exit_mm

    @property
    def r_b_mm(self) -> float:
        """Lumen wall radius (mm)."""
        return self.diameter_mm / 2.0

    @property
    def r_a_mm(self) -> float:
        """Lumen contact-transition radius r_b - 0.1 mm (mm)."""
        return self.r_b_mm - TRANSITION_MM


def _finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GeometryError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise GeometryError(f"{name}: expected a finite number, got {value!r}")
    return v


def max_radius_mm(
    entry_mm: float = ENTRY_MM,
    exit_mm: float = EXIT_MM,
    width_mm: float = WIDTH_MM,
    height_mm: float = HEIGHT_MM,
) -> float:
    """Largest bend radius (mm) for which the S exists (the middle straight d2 shrinks to 0).

    With ``d2 = 0``: ``w = 2 r (1 - cos t)``, ``H = 2 r sin t`` so ``tan(t/2) = w / H`` and
    ``r = H / (2 sin t)``, ``H = h - d1 - d3`` (60.8 mm for 10/30/30/120 mm).
    """
    rise = height_mm - entry_mm - exit_mm
    t = 2.0 * math.atan2(width_mm, rise)
    return rise / (2.0 * math.sin(t))


def bend_angle(
    radius_mm: float,
    entry_mm: float = ENTRY_MM,
    exit_mm: float = EXIT_MM,
    width_mm: float = WIDTH_MM,
    height_mm: float = HEIGHT_MM,
) -> tuple[float, float]:
    """Bend angle t1 (rad) and middle straight d2 (mm) of the S (module docstring).

    Solves ``A cos t - H sin t = -2 r`` (``A = w - 2 r``, ``H = h - d1 - d3``): with
    ``R = hypot(A, H)``, ``phi = atan2(H, A)``: ``t = +-acos(-2 r / R) - phi`` (mod 2 pi). ``d2``
    is the projection ``(w - 2 r (1 - cos t)) sin t + (H - 2 r sin t) cos t`` (both equations at
    once). Of the roots in (0, pi) with ``d2 >= 0`` the one with the larger ``d2`` is returned.

    Raises
    ------
    GeometryError
        If no root has ``d2 >= 0`` (radius above :func:`max_radius_mm`) or the sizes are not
        positive.
    """
    r = _finite("radius_mm", radius_mm)
    for name, v in (("entry_mm", entry_mm), ("exit_mm", exit_mm)):
        if _finite(name, v) < 0.0:
            raise GeometryError(f"{name} = {v:g}: must be >= 0 mm")
    if r <= 0.0:
        raise GeometryError(f"radius_mm = {r:g}: the bend radius must be > 0 mm")
    if _finite("width_mm", width_mm) <= 0.0:
        raise GeometryError(f"width_mm = {width_mm:g}: must be > 0 mm")
    rise = _finite("height_mm", height_mm) - entry_mm - exit_mm
    if rise <= 0.0:
        raise GeometryError(
            f"height_mm = {height_mm:g}: must exceed entry_mm + exit_mm = {entry_mm + exit_mm:g} mm"
        )
    a = width_mm - 2.0 * r
    big_r = math.hypot(a, rise)
    phi = math.atan2(rise, a)
    best: tuple[float, float] | None = None
    if abs(2.0 * r / big_r) <= 1.0:
        base = math.acos(-2.0 * r / big_r)
        for sign in (1.0, -1.0):
            t = math.remainder(sign * base - phi, 2.0 * math.pi)
            if not 0.0 < t < math.pi:
                continue
            d2 = (width_mm - 2.0 * r * (1.0 - math.cos(t))) * math.sin(t) + (
                rise - 2.0 * r * math.sin(t)
            ) * math.cos(t)
            if d2 >= -1e-9 and (best is None or d2 > best[1]):
                best = (t, max(d2, 0.0))
    if best is None:
        r_max = max_radius_mm(entry_mm, exit_mm, width_mm, height_mm)
        raise GeometryError(
            f"radius_mm = {r:g}: no S channel {width_mm:g} mm wide and {height_mm:g} mm high has "
            f"two bends of that radius (the largest is {r_max:.1f} mm); choose a smaller radius"
        )
    return best


def s_channel_layout(
    radius_mm: float,
    torsion_rad: float = 0.0,
    diameter_mm: float = NOMINAL_DIAMETER_MM,
    *,
    entry_mm: float = ENTRY_MM,
    exit_mm: float = EXIT_MM,
    width_mm: float = WIDTH_MM,
    height_mm: float = HEIGHT_MM,
) -> SChannelLayout:
    """Solve the S channel's pieces without building the centreline (see :func:`s_channel`).

    Raises
    ------
    GeometryError
        Torsion outside 0..pi, a non-positive diameter, or no S of that radius.
    """
    tau = _finite("torsion_rad", torsion_rad)
    if not 0.0 <= tau <= math.pi + 1e-12:
        raise GeometryError(
            f"torsion_rad = {tau:g}: the torsion must lie in 0..pi (0 = planar S, pi = both bends "
            "turning the same way)"
        )
    dia = _finite("diameter_mm", diameter_mm)
    if dia <= 2.0 * TRANSITION_MM:
        raise GeometryError(
            f"diameter_mm = {dia:g}: the channel diameter must exceed {2 * TRANSITION_MM:g} mm"
        )
    t1, d2 = bend_angle(radius_mm, entry_mm, exit_mm, width_mm, height_mm)
    return SChannelLayout(
        radius_mm=float(radius_mm),
        torsion_rad=min(tau, math.pi),
        diameter_mm=dia,
        bend_angle_rad=t1,
        entry_mm=float(entry_mm),
        middle_mm=d2,
        exit_mm=float(exit_mm),
        width_mm=float(width_mm),
        height_mm=float(height_mm),
    )


def _count(length_mm: float, spacing_mm: float) -> int:
    return max(3, math.ceil(length_mm / spacing_mm) + 1)


def s_centreline_mm(layout: SChannelLayout, spacing_mm: float = POINT_SPACING_MM) -> np.ndarray:
    """Points of the S centreline (mm), proximal -> distal, at most ``spacing_mm`` apart.

    Returns
    -------
    (n, 3) ndarray
        Exact points on the five pieces (each piece sampled uniformly, joints not repeated).
    """
    r, t1 = layout.radius_mm, layout.bend_angle_rad
    pos = np.zeros(3)
    tan = np.array([1.0, 0.0, 0.0])
    nor = np.array([0.0, 1.0, 0.0])
    parts = [pos[None, :]]

    def line(p0, t, length):
        s = np.linspace(0.0, length, _count(length, spacing_mm))[1:]
        return p0 + np.outer(s, t)

    def arc(p0, t, n):
        phi = np.linspace(0.0, t1, _count(r * t1, spacing_mm))[1:]
        centre = p0 + r * n
        pts = centre - r * np.outer(np.cos(phi), n) + r * np.outer(np.sin(phi), t)
        return pts, math.cos(t1) * t + math.sin(t1) * n, math.cos(t1) * n - math.sin(t1) * t

    if layout.entry_mm > 0:
        parts.append(line(pos, tan, layout.entry_mm))
        pos = parts[-1][-1]
    pts, tan, nor = arc(pos, tan, nor)
    parts.append(pts)
    pos = pts[-1]
    # bending plane turned right-handed about the tangent by pi - tau (Rodrigues; nor is normal
    # to tan): tau = 0 reverses the normal (the planar S)
    turn = math.pi - layout.torsion_rad
    nor = math.cos(turn) * nor + math.sin(turn) * np.cross(tan, nor)
    if layout.middle_mm > 0:
        parts.append(line(pos, tan, layout.middle_mm))
        pos = parts[-1][-1]
    pts, tan, nor = arc(pos, tan, nor)
    parts.append(pts)
    pos = pts[-1]
    if layout.exit_mm > 0:
        parts.append(line(pos, tan, layout.exit_mm))
    return np.vstack(parts)


def s_channel(
    radius_mm: float,
    torsion_rad: float = 0.0,
    diameter_mm: float = NOMINAL_DIAMETER_MM,
    *,
    entry_mm: float = ENTRY_MM,
    exit_mm: float = EXIT_MM,
    width_mm: float = WIDTH_MM,
    height_mm: float = HEIGHT_MM,
    spacing_mm: float = POINT_SPACING_MM,
    name: str | None = None,
) -> Channel:
    """The paper's S-shaped needle channel (module docstring) as a :class:`Channel`.

    Parameters
    ----------
    radius_mm : float
        Radius r of both bends (mm); the paper's templates: 20..60 mm.
    torsion_rad : float
        Torsion tau (rad) in 0..pi: bend 2's plane is turned by ``pi - tau`` from bend 1's about
        the middle straight's tangent (0: planar S).
    diameter_mm : float
        Channel diameter (mm): r_b = D / 2, r_a = r_b - 0.1 mm (default 2.6 mm, Table 1).
    entry_mm, exit_mm : float
        Straights d1 (10 mm) before bend 1 and d3 (30 mm) after bend 2.
    width_mm, height_mm : float
        Planar width w (30 mm) and height h (120 mm) that fix t1 and d2.
    spacing_mm : float
        Spacing of the exact points the centreline spline interpolates (0.25 mm).
    name : str, optional
        Channel name; default ``s-r<r>-tau<tau>-d<D>``.

    Returns
    -------
    Channel
        Centreline from the start of the entry (s = 0) to the end of the exit, metres;
        ``s_ref_m`` = length - 5 mm.

    Raises
    ------
    GeometryError
        Bad sizes, torsion outside 0..pi, or a radius above :func:`max_radius_mm`.
    """
    layout = s_channel_layout(
        radius_mm,
        torsion_rad,
        diameter_mm,
        entry_mm=entry_mm,
        exit_mm=exit_mm,
        width_mm=width_mm,
        height_mm=height_mm,
    )
    if not (_finite("spacing_mm", spacing_mm) > 0.0):
        raise GeometryError(f"spacing_mm = {spacing_mm:g}: must be > 0 mm")
    cl = Centreline.from_points(mm_to_m(s_centreline_mm(layout, spacing_mm)))
    lumen = Lumen.circular(mm_to_m(layout.r_b_mm), mm_to_m(layout.r_a_mm))
    label = name or (f"s-r{layout.radius_mm:g}-tau{layout.torsion_rad:.3g}-d{layout.diameter_mm:g}")
    s_ref = max(cl.length_m - mm_to_m(TIP_GAP_MM), 0.0)
    return Channel(label, cl, lumen, s_ref)
