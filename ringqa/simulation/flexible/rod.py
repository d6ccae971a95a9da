"""The instrument cut into flexible beam elements (the flexible engine's discretisation).

Each element is a cubic Hermite curve between two nodes; a node carries its position ``x`` (m)
and its tangent ``t = dr/dsigma`` (dimensionless), sigma the arc length along the undeformed cable
from the distal tip. Node 0 is the tip, the last node the driven proximal end. Each flexible
section is cut into equal elements no longer than its ``element_length_m``; a rigid section (the
source capsule) is one element whose bending stiffness is :data:`RIGID_EI_FACTOR` times the
stiffest flexible section's (it bends by ~1e-3 of a cable element's curvature: its bow across a
13 mm bend is ~1e-6 mm). This shares nothing with :mod:`ringqa.simulation.chain` but the
instrument description.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ringqa.errors import SimulationError

#: bending stiffness of a rigid section relative to the stiffest flexible one
RIGID_EI_FACTOR = 1.0e2
#: coordinates per node: position (3) and tangent (3); with torsion also the twist angle
#: (:data:`ringqa.simulation.flexible.kernels.ND_TWIST`)
ND = 6
#: the cable length that carries the scene's wall stiffness with ``contact.stiffness_per_length``
#: (m; the paper's 3 mm elements, as the rigid engine)
WALL_REFERENCE_LENGTH_M = 3.0e-3


@dataclass(frozen=True)
class FlexRod:
    """The discretised instrument (SI).

    Attributes
    ----------
    el_len : (E,) float64
        Element lengths (m), tip first.
    el_ei : (E,) float64
        Bending stiffness of each element (N m^2).
    el_gj : (E,) float64
        Torsional stiffness of each element (N m^2; used with ``effects.torsion`` only).
    el_ro : (E,) float64
        Outer radius (m).
    el_mu : (E,) float64
        Mass per length (kg/m).
    el_section : (E,) int64
        Section index of each element.
    sigma : (E+1,) float64
        Arc length of each node from the tip (m).
    section_names : tuple of str
    """

    el_len: np.ndarray
    el_ei: np.ndarray
    el_gj: np.ndarray
    el_ro: np.ndarray
    el_mu: np.ndarray
    el_section: np.ndarray
    sigma: np.ndarray
    section_names: tuple[str, ...]

    @property
    def n_elements(self) -> int:
        """Number of elements."""
        return int(self.el_len.size)

    @property
    def n_nodes(self) -> int:
        """Number of nodes (elements + 1)."""
        return int(self.el_len.size + 1)


def build_rod(instrument, model_length_m: float) -> FlexRod:
    """Cut ``instrument`` (tip first) into beam elements, up to ``model_length_m`` of cable.

    Raises
    ------
    SimulationError
        If the instrument is shorter than the modelled length.
    """
    if model_length_m > instrument.length_m + 1e-12:
        raise SimulationError(
            f"instrument {instrument.name!r}: {instrument.length_m * 1e3:.1f} mm long, but "
            f"{model_length_m * 1e3:.1f} mm must be modelled to reach the deepest advance "
            "(lengthen the last section or request shallower advances)"
        )
    ei_scale = float(getattr(instrument, "ei_scale", 1.0))  # scene key instrument.ei_scale
    flex_ei = [s.ei_nm2 * ei_scale for s in instrument.sections if not s.rigid]
    ei_rigid = RIGID_EI_FACTOR * (max(flex_ei) if flex_ei else 1.0)
    flex_gj = [s.gj_nm2 for s in instrument.sections if not s.rigid]
    gj_rigid = RIGID_EI_FACTOR * (max(flex_gj) if flex_gj else 1.0)
    lens, eis, gjs, ros, mus, secs = [], [], [], [], [], []
    remaining = model_length_m
    for k, sec in enumerate(instrument.sections):
        if remaining <= 1e-12:
            break
        length = min(sec.length_m, remaining)
        remaining -= length
        n = 1 if sec.rigid else max(1, math.ceil(length / sec.element_length_m - 1e-9))
        for _ in range(n):
            lens.append(length / n)
            eis.append(ei_rigid if sec.rigid else sec.ei_nm2 * ei_scale)
            gjs.append(gj_rigid if sec.rigid else sec.gj_nm2)
            ros.append(sec.r_o_m)
            mus.append(sec.mass_per_length_kg_m)
            secs.append(k)
    if len(lens) < 2:
        raise SimulationError(
            "instrument: fewer than 2 flexible elements; reduce discretisation.element_length_mm"
        )
    el_len = np.asarray(lens, dtype=np.float64)
    return FlexRod(
        el_len=el_len,
        el_ei=np.asarray(eis, dtype=np.float64),
        el_gj=np.asarray(gjs, dtype=np.float64),
        el_ro=np.asarray(ros, dtype=np.float64),
        el_mu=np.asarray(mus, dtype=np.float64),
        el_section=np.asarray(secs, dtype=np.int64),
        sigma=np.concatenate(([0.0], np.cumsum(el_len))),
        section_names=tuple(s.name for s in instrument.sections),
    )


def contact_samples(
    rod: FlexRod, min_radius_m: float, clearance_m: float, bow_fraction: float, per_length: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Contact sample points along every element (not only at the nodes).

    Element e of length L gets ``n = max(2, ceil(L / sqrt(8 R c f)))`` points at
    ``xi = k / n`` (k = 0 .. n-1: its distal node and n-1 interior points; the last node is the
    driven end), so the sag of the cable between two samples across the tightest bend R is at
    most f of the clearance c.

    Returns
    -------
    el : (P,) int64
        Element of each sample.
    xi : (P,) float64
        Its parameter along the element (0 at the distal node).
    ro : (P,) float64
        Outer radius there (m).
    wt : (P,) float64
        Wall-stiffness weight: 1 (the scene's k at every contact point, the paper's law) or,
        with ``per_length``, the cable length it stands for / 3 mm.
    """
    spacing = math.sqrt(8.0 * min_radius_m * clearance_m * bow_fraction)
    el, xi, ro, wt = [], [], [], []
    for e in range(rod.n_elements):
        L = float(rod.el_len[e])
        n = max(2, math.ceil(L / spacing - 1e-9)) if math.isfinite(spacing) else 2
        for k in range(n):
            el.append(e)
            xi.append(k / n)
            ro.append(rod.el_ro[e])
            wt.append(L / n / WALL_REFERENCE_LENGTH_M if per_length else 1.0)
    return (
        np.asarray(el, dtype=np.int64),
        np.asarray(xi, dtype=np.float64),
        np.asarray(ro, dtype=np.float64),
        np.asarray(wt, dtype=np.float64),
    )
