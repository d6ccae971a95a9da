"""Closed-form channels for validation, warm-up and examples (independent of the spline fits).

These duck-type the parts of :class:`ringqa.geometry.Channel` the engine uses (``centreline`` with
``length_m``, ``position``, ``tangent``, ``normal``, ``curvature``; ``lumen.kernel_arrays()``;
``s_ref_m``), so the engine can be validated against exact geometry: a straight entry followed by a
circular arc (and optionally a straight exit), or a straight entry followed by a helix.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ArcCentreline:
    """Straight entry of length ``entry_m`` along +x, then an arc of radius ``radius_m`` turning
    towards +y through ``angle_rad``, then a straight exit of ``exit_m`` (all in the z = 0 plane).
    """

    entry_m: float
    radius_m: float
    angle_rad: float
    exit_m: float = 0.0

    @property
    def length_m(self) -> float:
        """Total arc length (m)."""
        return self.entry_m + self.radius_m * self.angle_rad + self.exit_m

    def _phi(self, s):
        return np.clip(
            (np.asarray(s, dtype=float) - self.entry_m) / self.radius_m, 0.0, self.angle_rad
        )

    def position(self, s):
        """Position(s) (m): (3,) or (k, 3)."""
        s = np.asarray(s, dtype=float)
        phi = self._phi(s)
        R = self.radius_m
        x = self.entry_m + R * np.sin(phi)
        y = R * (1.0 - np.cos(phi))
        s_arc_end = self.entry_m + R * self.angle_rad
        before = np.minimum(s - self.entry_m, 0.0)
        after = np.maximum(s - s_arc_end, 0.0)
        x = x + before + after * np.cos(phi)
        y = y + after * np.sin(phi)
        return np.stack([x, y, np.zeros_like(x)], axis=-1)

    def tangent(self, s):
        """Unit tangent (distal)."""
        phi = self._phi(s)
        return np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1)

    def normal(self, s):
        """Unit normal towards the centre of the arc (continued into the straight parts)."""
        phi = self._phi(s)
        return np.stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)], axis=-1)

    def curvature(self, s):
        """Curvature (1/m): 1/R on the arc, 0 on the straight parts."""
        s = np.asarray(s, dtype=float)
        on = (s > self.entry_m) & (s < self.entry_m + self.radius_m * self.angle_rad)
        return np.where(on, 1.0 / self.radius_m, 0.0)


@dataclass(frozen=True)
class HelixCentreline:
    """Straight entry of ``entry_m`` then a helix of radius ``radius_m`` and pitch
    ``2 pi pitch_m`` per turn (axis +z), ``turns`` turns, joined tangentially."""

    entry_m: float
    radius_m: float
    pitch_m: float
    turns: float

    @property
    def _c(self) -> float:
        return float(np.hypot(self.radius_m, self.pitch_m))

    @property
    def length_m(self) -> float:
        """Total arc length (m)."""
        return self.entry_m + 2 * np.pi * self.turns * self._c

    def _helix(self, t):
        R, p = self.radius_m, self.pitch_m
        return np.stack([R * np.sin(t), R * (1 - np.cos(t)), p * t], axis=-1)

    def position(self, s):
        """Position(s) (m)."""
        s = np.asarray(s, dtype=float)
        t = np.maximum(s - self.entry_m, 0.0) / self._c
        t0 = np.array([self.radius_m, 0.0, self.pitch_m]) / self._c
        before = np.minimum(s - self.entry_m, 0.0)
        return self._helix(t) + before[..., None] * t0

    def tangent(self, s):
        """Unit tangent."""
        s = np.asarray(s, dtype=float)
        t = np.maximum(s - self.entry_m, 0.0) / self._c
        R, p = self.radius_m, self.pitch_m
        return np.stack([R * np.cos(t), R * np.sin(t), p * np.ones_like(t)], axis=-1) / self._c

    def normal(self, s):
        """Unit principal normal (towards the helix axis)."""
        s = np.asarray(s, dtype=float)
        t = np.maximum(s - self.entry_m, 0.0) / self._c
        return np.stack([-np.sin(t), np.cos(t), np.zeros_like(t)], axis=-1)

    def curvature(self, s):
        """Curvature R / (R^2 + p^2) on the helix, 0 on the entry."""
        s = np.asarray(s, dtype=float)
        return np.where(s > self.entry_m, self.radius_m / self._c**2, 0.0)


@dataclass(frozen=True)
class SimpleLumen:
    """Piecewise-constant lumen: breaks ``seg_s`` (k+1,), r_b, r_a and flat distance per segment."""

    seg_s: tuple[float, ...]
    r_b: tuple[float, ...]
    r_a: tuple[float, ...]
    flat: tuple[float, ...]

    @classmethod
    def circular(cls, r_b_m: float, r_a_m: float) -> SimpleLumen:
        """One circular segment."""
        return cls((0.0, np.inf), (r_b_m,), (r_a_m,), (np.inf,))

    def kernel_arrays(self):
        """(seg_s, seg_rb, seg_ra, seg_flat) as float64 arrays."""
        return tuple(
            np.asarray(a, dtype=np.float64) for a in (self.seg_s, self.r_b, self.r_a, self.flat)
        )


@dataclass(frozen=True)
class SimpleChannel:
    """The parts of a :class:`ringqa.geometry.Channel` the engine reads."""

    name: str
    centreline: object
    lumen: SimpleLumen
    s_ref_m: float
    measured_path_m: np.ndarray | None = None
    measured_step_m: float | None = None


def arc_channel(
    radius_m: float = 0.013,
    angle_rad: float = 1.5 * np.pi,
    entry_m: float = 0.04,
    exit_m: float = 0.0,
    r_b_m: float = 1.5e-3,
    r_a_m: float = 1.4e-3,
) -> SimpleChannel:
    """A straight entry + circular arc channel with a circular lumen (the ring's essence)."""
    cl = ArcCentreline(entry_m, radius_m, angle_rad, exit_m)
    return SimpleChannel("arc", cl, SimpleLumen.circular(r_b_m, r_a_m), cl.length_m - 5e-3)
