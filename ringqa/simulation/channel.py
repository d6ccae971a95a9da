"""The channel as the engine's kernels see it: a dense arc-length table plus the lumen segments.

:class:`ChannelTable` samples a channel's centreline through its public API
(``position``/``tangent``/``normal``/``curvature`` at a uniform arc-length spacing, default
0.25 mm) and takes the lumen's ``kernel_arrays()``. The kernels in
:mod:`ringqa.simulation._kernels` interpolate it by cubic Hermite pieces and continue it straight
before the entry (s < 0: the approach, the transfer tube) and beyond the tip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ringqa.errors import SimulationError
from ringqa.simulation import _kernels as K

#: table spacing (m); Hermite interpolation error ~ h^4 kappa^3 / 384 (< 1 nm at R = 5 mm)
TABLE_SPACING_M = 0.25e-3
#: a U-shaped lumen's flat side lies on the outside of the bend (along -normal, as
#: ringqa.geometry's wall_distance) where the centreline's curvature exceeds 2 x this (1/m:
#: radius < 20 mm, every ring), and fades out smoothly below (gone at radius > 40 mm): at an
#: S-bend's inflection the normal flips and the flat would jump to the other side (on the
#: Oncentra 26/60 library channel that made every load step past the inflection fail: 76
#: stabilised steps and 0.8 s; with the fade 12 and 0.24 s)
KAPPA_MIN_FLAT = 25.0


class ChannelArgs(NamedTuple):
    """The channel as the kernels take it (SI; the fields of :class:`ChannelTable`).

    Attributes
    ----------
    h : float
        Arc-length spacing of the table (m).
    pos, tan, flat_normal : (m, 3) float64
        Centreline positions (m), unit tangents and the unit directions pointing away from a
        flat side (:attr:`ChannelTable.flat_normal`) at ``s = k h``.
    kappa_min_flat : float
        Curvature (1/m) below which a flat side fades out (:data:`KAPPA_MIN_FLAT`; 0: never).
    seg_s : (k+1,) float64
        Lumen segment breaks (m).
    seg_rb, seg_ra, seg_flat : (k,) float64
        Wall radius r_b, transition radius r_a and flat-side distance (+inf: circular) (m).
    """

    h: float
    pos: np.ndarray
    tan: np.ndarray
    flat_normal: np.ndarray
    kappa_min_flat: float
    seg_s: np.ndarray
    seg_rb: np.ndarray
    seg_ra: np.ndarray
    seg_flat: np.ndarray


@dataclass(frozen=True)
class ChannelTable:
    """Dense uniform arc-length table of a channel (SI).

    Attributes
    ----------
    h : float
        Spacing (m).
    pos, tan, nor : (m, 3) float64
        Centreline positions (m), unit tangents (distal) and unit normals at ``s = k h``.
    kappa : (m,) float64
        Curvature (1/m).
    length_m : float
        Centreline length (m).
    seg_s, seg_rb, seg_ra, seg_flat : float64 arrays
        Lumen segments: breaks (k+1,), wall radius r_b (k,), transition radius r_a (k,), flat-side
        distance (k,) (+inf: circular).
    flat_normal : (m, 3) float64
        Unit direction pointing AWAY from a flat side at ``s = k h`` (the flat lies along
        ``-flat_normal``): the centreline normal for a flat on the outside of the bend, else the
        lumen's fixed orientation (:class:`ringqa.geometry.lumen.FlatSide`).
    kappa_min_flat : float
        Curvature (1/m) below which a flat on the outside of the bend fades out
        (:data:`KAPPA_MIN_FLAT`); 0 for a fixed orientation (no fade: it does not flip).
    """

    h: float
    pos: np.ndarray
    tan: np.ndarray
    nor: np.ndarray
    kappa: np.ndarray
    length_m: float
    seg_s: np.ndarray
    seg_rb: np.ndarray
    seg_ra: np.ndarray
    seg_flat: np.ndarray
    flat_normal: np.ndarray
    kappa_min_flat: float

    @classmethod
    def from_channel(cls, channel, spacing_m: float = TABLE_SPACING_M) -> ChannelTable:
        """Sample ``channel.centreline`` and ``channel.lumen`` (see module docstring)."""
        cl = getattr(channel, "centreline", None)
        lumen = getattr(channel, "lumen", None)
        if cl is None or lumen is None:
            raise SimulationError(
                "scene.channel: needs a centreline and a lumen (use ringqa.geometry.Channel)"
            )
        length = float(cl.length_m)
        m = max(int(np.ceil(length / spacing_m)), 4) + 1
        s = np.linspace(0.0, length, m)
        h = float(s[1] - s[0])
        pos = np.ascontiguousarray(cl.position(s), dtype=np.float64)
        tan = np.asarray(cl.tangent(s), dtype=np.float64)
        tan = np.ascontiguousarray(tan / np.linalg.norm(tan, axis=1)[:, None])
        nor = np.ascontiguousarray(cl.normal(s), dtype=np.float64)
        kappa = np.ascontiguousarray(cl.curvature(s), dtype=np.float64)
        flat_normal, kappa_min_flat = _flat_normals(lumen, s, pos, tan, nor)
        seg_s, seg_rb, seg_ra, seg_flat = (
            np.ascontiguousarray(a, dtype=np.float64) for a in lumen.kernel_arrays()
        )
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(tan))):
            raise SimulationError("scene.channel: centreline has non-finite samples")
        if np.any(seg_rb <= 0) or np.any(seg_ra > seg_rb):
            raise SimulationError("scene.channel.lumen: need 0 < r_a <= r_b in every segment")
        return cls(h, pos, tan, nor, kappa, length, seg_s, seg_rb, seg_ra, seg_flat,
                   flat_normal, kappa_min_flat)  # fmt: skip

    def args(self) -> ChannelArgs:
        """The table as the kernels take it."""
        return ChannelArgs(
            self.h, self.pos, self.tan, self.flat_normal, self.kappa_min_flat, self.seg_s,
            self.seg_rb, self.seg_ra, self.seg_flat,
        )  # fmt: skip

    # -- Python conveniences (tests, outputs) --------------------------------------------
    def point(self, s_m: float) -> np.ndarray:
        """Centreline position (3,) at arc length ``s_m`` (straight beyond both ends)."""
        c = np.empty(3)
        d1 = np.empty(3)
        d2 = np.empty(3)
        K.curve_eval(self.h, self.pos, self.tan, float(s_m), c, d1, d2)
        return c

    def tangent(self, s_m: float) -> np.ndarray:
        """Unit tangent (3,) at ``s_m``."""
        c = np.empty(3)
        d1 = np.empty(3)
        d2 = np.empty(3)
        K.curve_eval(self.h, self.pos, self.tan, float(s_m), c, d1, d2)
        return d1 / np.linalg.norm(d1)

    def closest(self, p: np.ndarray, s_hint: float | None = None) -> tuple[float, float]:
        """Closest centreline point of ``p``: (s (m), distance (m))."""
        work = np.empty(9)
        p = np.ascontiguousarray(p, dtype=np.float64)
        if s_hint is None:
            s = K.closest_point(self.h, self.pos, self.tan, p, 0.0, -1.0, work)
        else:
            s = K.closest_point(self.h, self.pos, self.tan, p, float(s_hint), 0.01, work)
        work = self.point(s)
        return float(s), float(np.linalg.norm(p - work))

    def min_radius_m(self) -> float:
        """Smallest radius of curvature along the channel (m)."""
        kmax = float(np.max(self.kappa)) if self.kappa.size else 0.0
        return 1.0 / kmax if kmax > 0 else np.inf

    def r_b_at(self, s_m: float) -> float:
        """Lumen wall radius r_b (m) at arc length ``s_m``."""
        g = int(
            np.clip(np.searchsorted(self.seg_s, s_m, side="right") - 1, 0, self.seg_rb.size - 1)
        )
        return float(self.seg_rb[g])


def _flat_normals(lumen, s: np.ndarray, pos, tan, nor) -> tuple[np.ndarray, float]:
    """The table of directions pointing away from a flat side, and the fade curvature.

    A flat fixed in the applicator's frame needs a cross-section direction wherever the lumen
    has a flat that cuts the circle; a fixed direction running along the centreline there has
    none (refused, naming where).
    """
    side = getattr(lumen, "flat_side", None)
    if side is None or not side.fixed:
        return nor, KAPPA_MIN_FLAT
    away = side.away(pos, tan, nor)
    seg_s, seg_rb, _seg_ra, seg_flat = lumen.kernel_arrays()
    g = np.clip(np.searchsorted(seg_s, s, side="right") - 1, 0, seg_rb.size - 1)
    flat_here = seg_flat[g] < seg_rb[g]
    bad = flat_here & np.isnan(away).any(axis=1)
    if bad.any():
        raise SimulationError(
            f"scene.channel.lumen: the flat side faces {side.towards!r}, which runs along the "
            f"centreline at s = {s[np.argmax(bad)] * 1e3:.1f} mm (no cross-section direction): "
            "use flat_towards = 'bend_outside' there"
        )
    away = np.where(np.isnan(away), nor, away)
    return np.ascontiguousarray(away, dtype=np.float64), 0.0
