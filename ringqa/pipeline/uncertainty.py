"""Perturbed commissioning runs for uncertainty studies (``ringqa sweep``).

Most uncertain inputs of a commissioning run are scene keys (``contact.mu_k``,
``motion.speed_mm_s``) and reach the engine through
:attr:`~ringqa.pipeline.settings.CommissionSettings.scene_overrides`. Three are not settings of
one scene key, because they change the applicator's channel or every section of the cable; they
are the *perturbation keys* of :data:`PERTURBATION_KEYS`, applied by an :class:`Engine` wrapper
(:func:`perturbed_engine`) to the channel and scene the pipeline builds:

- ``lumen.diameter_delta_mm``: added to the lumen's diameter (each segment's wall radius r_b, its
  transition radius r_a and a U-lumen's flat distance grow by half of it);
- ``instrument.ei_scale``: every cable section's bending stiffness EI times this factor;
- ``centreline.displacement_mm``: the channel centreline moved by a smooth random displacement
  whose largest value is this many mm (its shape: :func:`smooth_displacement`, drawn from the
  sample's own seed; its sign flips the shape).

The reference (measured) path, the dose points and the plan are not perturbed: a sample answers
"if the channel and cable were like this, where would the source go, and what dose would result".
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ringqa.pipeline.simulate import Engine, default_engine
from ringqa.units import M_PER_MM

__all__ = [
    "PERTURBATION_KEYS",
    "Perturbation",
    "perturbed_engine",
    "smooth_displacement",
]

#: perturbation key -> (nominal value, lower bound (exclusive) or None, meaning)
PERTURBATION_KEYS: dict[str, tuple[float, float | None, str]] = {
    "lumen.diameter_delta_mm": (
        0.0,
        None,
        "mm added to the lumen diameter (r_b, r_a and a U-lumen's flat distance grow by half)",
    ),
    "instrument.ei_scale": (1.0, 0.0, "factor on every cable section's bending stiffness EI"),
    "centreline.displacement_mm": (
        0.0,
        None,
        "largest distance of a smooth random displacement of the channel centreline, mm "
        "(entry and tip fixed; shape drawn from the sample's seed)",
    ),
}

#: sine modes of the centreline displacement (1: one half-wave over the channel)
DISPLACEMENT_MODES = 3


@dataclass(frozen=True)
class Perturbation:
    """How one sample's channel and cable differ from the nominal ones.

    Attributes
    ----------
    lumen_diameter_delta_mm : float
        Added to the lumen diameter, mm.
    ei_scale : float
        Factor on every section's bending stiffness (> 0).
    centreline_displacement_mm : float
        Largest centreline displacement, mm (0: none; negative: the shape reversed).
    shape_seed : tuple of int
        Seed of the displacement's shape (the sweep's seed and the sample's index).
    """

    lumen_diameter_delta_mm: float = 0.0
    ei_scale: float = 1.0
    centreline_displacement_mm: float = 0.0
    shape_seed: tuple[int, ...] = (0,)

    @classmethod
    def from_values(cls, values: dict[str, float], shape_seed: Sequence[int]) -> Perturbation:
        """The perturbation of a sample's ``{key: value}`` (keys of :data:`PERTURBATION_KEYS`;
        other keys are ignored)."""
        return cls(
            lumen_diameter_delta_mm=float(values.get("lumen.diameter_delta_mm", 0.0)),
            ei_scale=float(values.get("instrument.ei_scale", 1.0)),
            centreline_displacement_mm=float(values.get("centreline.displacement_mm", 0.0)),
            shape_seed=tuple(int(s) for s in shape_seed),
        )

    @property
    def is_nominal(self) -> bool:
        """True when nothing is perturbed."""
        return (
            self.lumen_diameter_delta_mm == 0.0
            and self.ei_scale == 1.0
            and self.centreline_displacement_mm == 0.0
        )


def smooth_displacement(s_m: np.ndarray, length_m: float, rng: np.random.Generator) -> np.ndarray:
    """A smooth displacement shape along a channel, largest magnitude 1, zero at both ends.

    ``d(s) = sum_k (a_k n(s) + b_k b(s)) sin(k pi s / L)`` for k = 1..:data:`DISPLACEMENT_MODES`
    with standard-normal a_k, b_k, then scaled to a largest magnitude of 1; returned as the two
    coefficients of the normal and binormal.

    Parameters
    ----------
    s_m : (n,) ndarray
        Arc lengths, m.
    length_m : float
        Channel length, m.
    rng : numpy.random.Generator
        The sample's generator.

    Returns
    -------
    (n, 2) ndarray
        Normal and binormal components (dimensionless, max norm 1).
    """
    k = np.arange(1, DISPLACEMENT_MODES + 1)
    coef = rng.standard_normal((DISPLACEMENT_MODES, 2))
    basis = np.sin(np.pi * np.outer(s_m / length_m, k))  # (n, K)
    d = basis @ coef
    peak = float(np.max(np.linalg.norm(d, axis=1)))
    return d / peak if peak > 0 else d


def _perturb_channel(channel, p: Perturbation):
    """``channel`` with the lumen widened and the centreline displaced as ``p`` says."""
    from ringqa.geometry.centreline import Centreline

    out = channel
    if p.lumen_diameter_delta_mm != 0.0:
        half = 0.5 * p.lumen_diameter_delta_mm * M_PER_MM
        lum = out.lumen
        flat = np.where(np.isfinite(lum.seg_flat), lum.seg_flat + half, lum.seg_flat)
        out = dataclasses.replace(
            out,
            lumen=dataclasses.replace(
                lum, seg_rb=lum.seg_rb + half, seg_ra=lum.seg_ra + half, seg_flat=flat
            ),
        )
    if p.centreline_displacement_mm != 0.0:
        cl = out.centreline
        n = max(50, int(cl.length_m / (M_PER_MM * 1.0)) + 1)  # a point every ~1 mm
        s = np.linspace(0.0, cl.length_m, n)
        pos, tan, nor = cl.frame(s)
        # directions of the displacement: a rotation-minimising frame (double reflection, Wang
        # et al. 2008) from the entry's normal; the curvature normal turns over where a bend
        # starts or changes plane, which kinked the displaced channel tighter than the capsule
        # can pass (a 0.36 mm displacement gave a 0.8 mm bend radius on the Oncentra example)
        nor = nor.copy()
        for j in range(1, len(s)):
            v1 = pos[j] - pos[j - 1]
            r = nor[j - 1] - 2.0 * (v1 @ nor[j - 1]) / (v1 @ v1) * v1
            tl = tan[j - 1] - 2.0 * (v1 @ tan[j - 1]) / (v1 @ v1) * v1
            v2 = tan[j] - tl
            r = r - 2.0 * (v2 @ r) / max(v2 @ v2, 1e-300) * v2
            nor[j] = r / np.linalg.norm(r)
        bino = np.cross(tan, nor)
        shape = smooth_displacement(s, cl.length_m, np.random.default_rng(list(p.shape_seed)))
        amp = p.centreline_displacement_mm * M_PER_MM
        moved = pos + amp * (shape[:, :1] * nor + shape[:, 1:] * bino)
        out = dataclasses.replace(out, centreline=Centreline.from_points(moved))
    return out


def _scale_ei(scene, factor: float):
    inst = scene.instrument
    sections = tuple(dataclasses.replace(sec, ei_nm2=sec.ei_nm2 * factor) for sec in inst.sections)
    return dataclasses.replace(scene, instrument=dataclasses.replace(inst, sections=sections))


def perturbed_engine(p: Perturbation, base: Engine | None = None) -> Engine:
    """An :class:`Engine` that builds every scene on the perturbed channel and cable.

    Parameters
    ----------
    p : Perturbation
        The sample's perturbation.
    base : Engine, optional
        The engine wrapped (default :func:`~ringqa.pipeline.simulate.default_engine`).

    Returns
    -------
    Engine
        ``base`` itself when ``p`` perturbs nothing.
    """
    base = base or default_engine()
    if p.is_nominal:
        return base

    def scene_for_channel(channel, cable):
        scene = base.scene_for_channel(_perturb_channel(channel, p), cable)
        if p.ei_scale != 1.0:
            scene = _scale_ei(scene, p.ei_scale)
        return scene

    return dataclasses.replace(base, scene_for_channel=scene_for_channel)
