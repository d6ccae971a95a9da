"""Channel cross-sections (lumens), piecewise constant along the arc length.

A lumen is a circle of radius ``r_b`` (the wall) with a contact-transition radius ``r_a < r_b``
(used by the contact laws), optionally with a flat side at distance ``flat`` from the centreline:
the U-shaped lumen of the ring applicator. A flat at or beyond the circle (``flat >= r_b``) does
not cut the circle: the cross-section the cable meets is then the circle (the paper's U, whose
flat lets the source reach about 1.1 mm off the centreline of a 3 mm lumen, is such a lumen).
Which way the flat faces is the :class:`FlatSide`: fixed in the applicator's frame (towards the
outside of the ring, cranially, caudally) or following the bend (along ``-normal``, the outside of
the bend, the earlier default, which turns with the Frenet normal through an S-shaped stem
transition). The cross-section is constant on segments ``[seg_s[k], seg_s[k+1])`` of the arc
length (m); the first and last bounds are ``-inf`` / ``+inf`` so every arc length (also beyond the
channel ends) has a cross-section. ``source`` says where the dimensions come from (a citation, a
measurement, or ``"assumed"``): reports print it.

The signed wall distance (positive inside) and the outward wall normal come from the numba kernel
:func:`ringqa.geometry._kernels.wall_distance`; :meth:`Lumen.wall_distance` wraps it for tests and
plots.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ringqa.geometry import _kernels as K
from ringqa.geometry.centreline import GeometryError


def _positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GeometryError(f"{name}: expected a number in metres, got {value!r}") from None
    if not np.isfinite(v) or v <= 0.0:
        raise GeometryError(f"{name}: must be a positive finite length in metres, got {value!r}")
    if v > 0.05:
        raise GeometryError(
            f"{name}: {v:g} m is not a plausible lumen size; give metres (e.g. 1.5e-3 for 1.5 mm)"
        )
    return v


#: which way a flat side can face
FLAT_TOWARDS = ("bend_outside", "ring_outside", "cranial", "caudal")


@dataclass(frozen=True, eq=False)
class FlatSide:
    """Which way a U-shaped lumen's flat side faces.

    Attributes
    ----------
    towards : str
        ``"bend_outside"``: on the outside of the bend (along ``-normal`` of the centreline; the
        direction turns with the Frenet normal, and the flat fades out where the centreline is
        nearly straight); ``"ring_outside"``: away from the ring's axis (the line through
        ``ring_centre_m`` along ``ring_normal``), fixed in the applicator's frame;
        ``"cranial"`` / ``"caudal"``: along ``+ring_normal`` / ``-ring_normal``.
    ring_centre_m : (3,) ndarray or None
        The ring's centre (m): needed by ``"ring_outside"``.
    ring_normal : (3,) ndarray or None
        The ring's unit normal (cranial): needed by every fixed orientation.
    """

    towards: str = "bend_outside"
    ring_centre_m: np.ndarray | None = None
    ring_normal: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.towards not in FLAT_TOWARDS:
            raise GeometryError(
                f"flat_towards: {self.towards!r} is not one of {', '.join(FLAT_TOWARDS)}"
            )
        if self.towards != "bend_outside":
            if self.ring_normal is None or (
                self.towards == "ring_outside" and self.ring_centre_m is None
            ):
                raise GeometryError(
                    f"flat_towards = {self.towards!r} is fixed in the applicator's frame: it needs "
                    "the frame's centre and normal (give the channel an applicator frame, or "
                    "use 'bend_outside')"
                )
            n = np.asarray(self.ring_normal, dtype=float)
            if n.shape != (3,) or not np.isfinite(n).all() or np.linalg.norm(n) == 0:
                raise GeometryError("FlatSide.ring_normal: expected a non-zero 3-vector")
            object.__setattr__(self, "ring_normal", n / np.linalg.norm(n))
        if self.ring_centre_m is not None:
            c = np.asarray(self.ring_centre_m, dtype=float)
            if c.shape != (3,) or not np.isfinite(c).all():
                raise GeometryError("FlatSide.ring_centre_m: expected a finite 3-vector (m)")
            object.__setattr__(self, "ring_centre_m", c)

    @property
    def fixed(self) -> bool:
        """True when the flat faces a direction fixed in the applicator's frame."""
        return self.towards != "bend_outside"

    def describe(self) -> str:
        """Where the flat faces, in words."""
        return {
            "bend_outside": "on the outside of the bend (turning with the centreline's normal)",
            "ring_outside": "towards the outside of the ring (fixed in the applicator's frame)",
            "cranial": "cranially (fixed in the applicator's frame)",
            "caudal": "caudally (fixed in the applicator's frame)",
        }[self.towards]

    def away(self, positions_m, tangents, normals) -> np.ndarray:
        """Unit vectors pointing AWAY from the flat (the flat lies along ``-away``), in each
        cross-section's plane (perpendicular to the tangent).

        Parameters
        ----------
        positions_m, tangents, normals : (m, 3) array_like
            Centreline points (m), unit tangents and unit normals.

        Returns
        -------
        (m, 3) ndarray
            Unit vectors; NaN rows where a fixed direction runs along the centreline (no
            cross-section direction), which a caller must not use.
        """
        pos = np.asarray(positions_m, dtype=float).reshape(-1, 3)
        tan = np.asarray(tangents, dtype=float).reshape(-1, 3)
        nor = np.asarray(normals, dtype=float).reshape(-1, 3)
        if self.towards == "bend_outside":
            return nor.copy()
        n = self.ring_normal
        if self.towards == "ring_outside":
            rad = pos - self.ring_centre_m
            toward_flat = rad - np.outer(rad @ n, n)
        else:
            toward_flat = np.tile(n if self.towards == "cranial" else -n, (pos.shape[0], 1))
        v = -(toward_flat - np.sum(toward_flat * tan, axis=1)[:, None] * tan)
        norm = np.linalg.norm(v, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = v / norm[:, None]
        out[norm < 1e-9] = np.nan
        return out


@dataclass(frozen=True, eq=False)
class Lumen:
    """Piecewise-constant lumen cross-section (SI).

    Attributes
    ----------
    seg_s : (k+1,) ndarray
        Segment bounds in arc length (m), increasing, ``seg_s[0] = -inf``, ``seg_s[-1] = +inf``.
    seg_rb : (k,) ndarray
        Wall radius r_b per segment (m).
    seg_ra : (k,) ndarray
        Contact-transition radius r_a per segment (m), ``0 < r_a < r_b``.
    seg_flat : (k,) ndarray
        Distance from the centreline to the flat side (m); ``+inf`` where the lumen is circular;
        ``>= r_b``: at or beyond the circle, where it does not cut it.
    flat_side : FlatSide
        Which way the flat faces.
    source : str
        Where the dimensions come from (a citation or measurement), or ``"assumed"``.
    """

    seg_s: np.ndarray
    seg_rb: np.ndarray
    seg_ra: np.ndarray
    seg_flat: np.ndarray
    flat_side: FlatSide = field(default_factory=FlatSide)
    source: str = ""

    def __post_init__(self) -> None:
        seg_s = np.ascontiguousarray(self.seg_s, dtype=float)
        rb = np.ascontiguousarray(self.seg_rb, dtype=float)
        ra = np.ascontiguousarray(self.seg_ra, dtype=float)
        flat = np.ascontiguousarray(self.seg_flat, dtype=float)
        k = rb.size
        if k < 1 or seg_s.shape != (k + 1,) or ra.shape != (k,) or flat.shape != (k,):
            raise GeometryError(
                "Lumen: seg_s needs one more entry than seg_rb, seg_ra and seg_flat "
                f"(got {seg_s.shape}, {rb.shape}, {ra.shape}, {flat.shape})"
            )
        if np.isnan(seg_s).any() or np.any(np.diff(seg_s) <= 0):
            raise GeometryError("Lumen: seg_s (segment bounds, m) must increase strictly")
        for i in range(k):
            _positive(f"Lumen segment {i} r_b", rb[i])
            _positive(f"Lumen segment {i} r_a", ra[i])
            if not ra[i] < rb[i]:
                raise GeometryError(
                    f"Lumen segment {i}: r_a ({ra[i]:g} m) must be smaller than r_b ({rb[i]:g} m)"
                )
            if np.isnan(flat[i]) or flat[i] <= 0.0:
                raise GeometryError(
                    f"Lumen segment {i}: flat distance must be > 0 m (or inf for a circle), "
                    f"got {flat[i]!r}"
                )
        if not isinstance(self.flat_side, FlatSide):
            raise GeometryError("Lumen.flat_side: expected a FlatSide")
        if not isinstance(self.source, str):
            raise GeometryError("Lumen.source: expected a string (a citation or 'assumed')")
        object.__setattr__(self, "seg_s", seg_s)
        object.__setattr__(self, "seg_rb", rb)
        object.__setattr__(self, "seg_ra", ra)
        object.__setattr__(self, "seg_flat", flat)

    # -- constructors ---------------------------------------------------------------------
    @classmethod
    def circular(cls, r_b_m: float, r_a_m: float) -> Lumen:
        """A circular lumen of wall radius ``r_b_m`` and transition radius ``r_a_m`` (m)."""
        rb = _positive("r_b_m", r_b_m)
        ra = _positive("r_a_m", r_a_m)
        return cls(np.array([-np.inf, np.inf]), np.array([rb]), np.array([ra]), np.array([np.inf]))

    @classmethod
    def stepped(cls, s_breaks_m, r_b_m, r_a_m) -> Lumen:
        """A circular lumen whose radius steps at the given arc lengths.

        Parameters
        ----------
        s_breaks_m : (k-1,) array_like
            Arc lengths (m) where the diameter changes, increasing.
        r_b_m, r_a_m : (k,) array_like
            Wall and transition radii (m) of the k segments, proximal first.
        """
        brk = np.atleast_1d(np.asarray(s_breaks_m, dtype=float))
        rb = np.atleast_1d(np.asarray(r_b_m, dtype=float))
        ra = np.atleast_1d(np.asarray(r_a_m, dtype=float))
        if rb.shape != (brk.size + 1,) or ra.shape != rb.shape:
            raise GeometryError(
                f"Lumen.stepped: {brk.size} breaks need {brk.size + 1} radii in r_b_m and r_a_m "
                f"(got {rb.size} and {ra.size})"
            )
        if not np.isfinite(brk).all():
            raise GeometryError("Lumen.stepped: s_breaks_m must be finite arc lengths (m)")
        seg_s = np.concatenate([[-np.inf], brk, [np.inf]])
        return cls(seg_s, rb, ra, np.full(rb.size, np.inf))

    @classmethod
    def u_shaped(
        cls,
        r_b_m: float,
        r_a_m: float,
        flat_m: float,
        s_start_m: float = -np.inf,
        s_end_m: float = np.inf,
        flat_side: FlatSide | None = None,
        source: str = "",
    ) -> Lumen:
        """A U-shaped lumen: a circle of radius ``r_b_m`` with a flat side at ``flat_m`` (m)
        from the centreline (facing as ``flat_side`` says; default the outside of the bend), for
        arc lengths in ``[s_start_m, s_end_m)``; circular elsewhere (e.g. along a straight stem).
        A flat at or beyond the circle (``flat_m >= r_b_m``) does not cut it.
        """
        rb = _positive("r_b_m", r_b_m)
        ra = _positive("r_a_m", r_a_m)
        flat = _positive("flat_m", flat_m)
        a = float(s_start_m)
        b = float(s_end_m)
        if not a < b:
            raise GeometryError("Lumen.u_shaped: s_start_m must be smaller than s_end_m")
        bounds = [-np.inf]
        flats = []
        if np.isfinite(a):
            bounds.append(a)
            flats.append(np.inf)
        flats.append(flat)
        if np.isfinite(b):
            bounds.append(b)
            flats.append(np.inf)
        bounds.append(np.inf)
        k = len(flats)
        return cls(
            np.array(bounds), np.full(k, rb), np.full(k, ra), np.array(flats),
            flat_side if flat_side is not None else FlatSide(), source,
        )  # fmt: skip

    # -- access ---------------------------------------------------------------------------
    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(seg_s (k+1,), seg_rb (k,), seg_ra (k,), seg_flat (k,))`` for the kernels."""
        return self.seg_s, self.seg_rb, self.seg_ra, self.seg_flat

    def radii_at(self, s_m: float) -> tuple[float, float, float]:
        """``(r_b, r_a, flat)`` (m) of the cross-section at arc length ``s_m``."""
        k = int(
            np.clip(np.searchsorted(self.seg_s, s_m, side="right") - 1, 0, self.seg_rb.size - 1)
        )
        return float(self.seg_rb[k]), float(self.seg_ra[k]), float(self.seg_flat[k])

    @property
    def cuts_circle(self) -> np.ndarray:
        """Per segment: True where a flat side cuts the circle (``flat < r_b``)."""
        return self.seg_flat < self.seg_rb

    def describe(self) -> str:
        """The cross-section in words (mm), with its source, for reports."""
        from ringqa.units import m_to_mm

        parts = []
        for i in range(self.seg_rb.size):
            d = f"{2 * m_to_mm(self.seg_rb[i]):.2f} mm"
            f = self.seg_flat[i]
            if np.isfinite(f):
                where = "cuts the circle" if f < self.seg_rb[i] else "at or beyond the circle"
                shape = (f"U-shaped, {d}, flat side {m_to_mm(f):.2f} mm from the centreline "
                         f"{self.flat_side.describe()} ({where})")  # fmt: skip
            else:
                shape = f"circular, {d}"
            lo, hi = self.seg_s[i], self.seg_s[i + 1]
            if self.seg_rb.size > 1:
                rng = "from the entry" if not np.isfinite(lo) else f"from s = {m_to_mm(lo):.1f} mm"
                rng += "" if not np.isfinite(hi) else f" to s = {m_to_mm(hi):.1f} mm"
                shape = f"{shape} {rng}"
            parts.append(shape)
        text = "; ".join(parts)
        return f"{text} (source: {self.source})" if self.source else text

    @property
    def max_radius_m(self) -> float:
        """Largest wall radius r_b (m)."""
        return float(self.seg_rb.max())

    def wall_distance(self, s_m, offset_m, normal) -> tuple[np.ndarray, np.ndarray]:
        """Signed wall distance and outward wall normal (wrapper of the kernel).

        Parameters
        ----------
        s_m : float or (k,) array_like
            Arc length(s) of the cross-section (m).
        offset_m : (3,) or (k, 3) array_like
            Point minus centreline point, in the normal plane (m).
        normal : (3,) or (k, 3) array_like
            Unit centreline normal (towards the centre of the bend).

        Returns
        -------
        d_m : float or (k,) ndarray
            Distance to the nearest wall (m), positive inside the lumen.
        n : (3,) or (k, 3) ndarray
            Outward unit wall normal.
        """
        s = np.atleast_1d(np.asarray(s_m, dtype=float))
        off = np.atleast_2d(np.asarray(offset_m, dtype=float))
        nor = np.atleast_2d(np.asarray(normal, dtype=float))
        k = max(s.size, off.shape[0], nor.shape[0])
        s = np.broadcast_to(s, (k,))
        off = np.ascontiguousarray(np.broadcast_to(off, (k, 3)))
        nor = np.ascontiguousarray(np.broadcast_to(nor, (k, 3)))
        d = np.empty(k)
        n = np.empty((k, 3))
        for i in range(k):
            d[i], n[i, 0], n[i, 1], n[i, 2] = K.wall_distance(
                self.seg_s, self.seg_rb, self.seg_flat, float(s[i]), off[i], nor[i]
            )
        scalar = np.ndim(s_m) == 0 and np.ndim(offset_m) == 1 and np.ndim(normal) == 1
        if scalar:
            return float(d[0]), n[0]
        return d, n
