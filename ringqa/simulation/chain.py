"""Discretisation of the instrument into a rigid-link chain (the paper's rigid multibody model).

Nodes ``x_0`` (distal tip) ... ``x_N`` (proximal, driven); link ``j`` joins nodes ``j`` and
``j + 1``. Each section is cut into equal links no longer than its element length; a rigid section
(the source capsule) is one link. Only the part of the cable that can be in the channel plus a
straight approach is modelled (``model_length_m``); the last section is cut there.

Hinge stiffness (mechanics.md item 9): between links of lengths l1, l2 and stiffnesses EI1, EI2
the moment is continuous, so the half-links act in series:
``k = 1 / (l1 / (2 EI1) + l2 / (2 EI2))`` -> ``EI / l`` for equal links; a rigid link adds no
compliance. Twist stiffness ``GJ / l`` per link (rigid: 100 x the stiffest flexible link).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import SimulationError

#: the cable length that carries the scene's wall stiffness and damping (m): the paper's
#: contact parameters (Table 1) are per node of its 3 mm rigid-link elements
WALL_REFERENCE_LENGTH_M = 3.0e-3


@dataclass(frozen=True)
class Chain:
    """The discretised instrument (SI).

    Attributes
    ----------
    link_len : (N,) float64
        Link lengths (m), tip first.
    link_ro : (N,) float64
        Outer radius of each link (m).
    link_ei : (N,) float64
        Bending stiffness of each link's section (N m^2; inf for a rigid link).
    link_section : (N,) int64
        Index of the section each link belongs to.
    hinge_k : (N-1,) float64
        Hinge stiffness at interior nodes 1..N-1 (N m / rad).
    twist_k : (N,) float64
        Twist stiffness per link (N m / rad).
    node_mass : (N+1,) float64
        Lumped mass per node (kg).
    node_rot : (N+1,) float64
        Lumped polar inertia per node (kg m^2).
    cum : (N+1,) float64
        Arc length of each node from the tip along the undeformed cable (m).
    section_names : tuple of str
    """

    link_len: np.ndarray
    link_ro: np.ndarray
    link_ei: np.ndarray
    link_section: np.ndarray
    hinge_k: np.ndarray
    twist_k: np.ndarray
    node_mass: np.ndarray
    node_rot: np.ndarray
    cum: np.ndarray
    section_names: tuple[str, ...]

    @property
    def n_links(self) -> int:
        """Number of links (elements)."""
        return int(self.link_len.size)

    @property
    def n_nodes(self) -> int:
        """Number of nodes (links + 1)."""
        return int(self.link_len.size + 1)


def build_chain(instrument, model_length_m: float) -> Chain:
    """Cut ``instrument`` (tip first) into links, up to ``model_length_m`` of cable.

    Raises
    ------
    SimulationError
        If the instrument is shorter than the modelled length or a section is invalid.
    """
    if model_length_m > instrument.length_m + 1e-12:
        raise SimulationError(
            f"instrument {instrument.name!r}: {instrument.length_m * 1e3:.1f} mm long, but "
            f"{model_length_m * 1e3:.1f} mm must be modelled to reach the deepest advance "
            "(lengthen the last section or request shallower advances)"
        )
    lens, ros, eis, gjs, ms, secs = [], [], [], [], [], []
    ei_scale = float(getattr(instrument, "ei_scale", 1.0))  # scene key instrument.ei_scale
    remaining = model_length_m
    for k, sec in enumerate(instrument.sections):
        if remaining <= 1e-12:
            break
        for name, val in (
            ("length_m", sec.length_m),
            ("r_o_m", sec.r_o_m),
            ("element_length_m", sec.element_length_m),
        ):
            if not (np.isfinite(val) and val > 0):
                raise SimulationError(
                    f"instrument.sections[{k}] ({sec.name}): {name} must be > 0, got {val}"
                )
        if not sec.rigid and not (sec.ei_nm2 > 0 and np.isfinite(sec.ei_nm2)):
            raise SimulationError(
                f"instrument.sections[{k}] ({sec.name}): ei_nm2 must be > 0, got {sec.ei_nm2}"
            )
        length = min(sec.length_m, remaining)
        remaining -= length
        if sec.rigid:
            n = 1
        else:
            n = max(1, int(np.ceil(length / sec.element_length_m - 1e-9)))
        for _ in range(n):
            lens.append(length / n)
            ros.append(sec.r_o_m)
            eis.append(np.inf if sec.rigid else sec.ei_nm2 * ei_scale)
            gjs.append(np.inf if sec.rigid else max(sec.gj_nm2, 0.0))
            ms.append(sec.mass_per_length_kg_m)
            secs.append(k)
    link_len = np.asarray(lens, dtype=np.float64)
    if link_len.size < 3:
        raise SimulationError(
            "instrument: fewer than 3 links; reduce discretisation.element_length_mm"
        )
    link_ei = np.asarray(eis, dtype=np.float64)
    comp = link_len / (2.0 * link_ei)  # inf EI -> 0 compliance
    hinge_k = 1.0 / (comp[:-1] + comp[1:])
    gj = np.asarray(gjs, dtype=np.float64)
    twist = gj / link_len
    finite = np.isfinite(twist)
    if np.any(~finite):
        twist[~finite] = 100.0 * (twist[finite].max() if np.any(finite) else 1.0)
    m = np.asarray(ms, dtype=np.float64) * link_len
    ro = np.asarray(ros, dtype=np.float64)
    node_mass = np.zeros(link_len.size + 1)
    node_mass[:-1] += 0.5 * m
    node_mass[1:] += 0.5 * m
    rot = 0.5 * m * ro**2
    node_rot = np.zeros(link_len.size + 1)
    node_rot[:-1] += 0.5 * rot
    node_rot[1:] += 0.5 * rot
    cum = np.concatenate([[0.0], np.cumsum(link_len)])
    return Chain(
        link_len=link_len,
        link_ro=ro,
        link_ei=link_ei,
        link_section=np.asarray(secs, dtype=np.int64),
        hinge_k=np.ascontiguousarray(hinge_k),
        twist_k=np.ascontiguousarray(twist),
        node_mass=node_mass,
        node_rot=node_rot,
        cum=cum,
        section_names=tuple(s.name for s in instrument.sections),
    )


def contact_samples(
    chain: Chain, min_radius_m: float, min_clearance_m: float, bow_fraction: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contact sample points along the links so that no link cuts through the wall.

    A straight piece of length l across a bend of radius R bows ``l^2 / (8 R)`` (mechanics.md
    item 9). Each link gets ``m = ceil(l / sqrt(8 R bow_fraction c))`` samples at fractions
    ``0, 1/m, ..., (m-1)/m``, so the bow between samples is at most ``bow_fraction`` of the
    clearance c. The tip node is a sample; the driven proximal node is not.

    Each sample stands for the cable length ``l / m`` of its link; with
    ``contact.stiffness_per_length`` its wall stiffness and damping are the scene's values times
    ``(l / m) / WALL_REFERENCE_LENGTH_M``: a stiffness per unit length (a Winkler foundation), so
    the contact converges as the links shrink instead of stiffening with every added sample. The
    paper's k = 1e5 N/m is per node of its 3 mm links (the default: weight 1 at every sample).

    Returns
    -------
    samp_link : (P,) int64
    samp_alpha : (P,) float64
    samp_ro : (P,) float64
    samp_wt : (P,) float64
        Stiffness weight of each sample (1 for a 3 mm piece of cable).
    """
    if np.isfinite(min_radius_m):
        spacing = np.sqrt(8.0 * min_radius_m * bow_fraction * max(min_clearance_m, 1e-6))
    else:
        spacing = np.inf
    links, alphas, ros, wts = [], [], [], []
    for j, length in enumerate(chain.link_len):
        m = 1 if not np.isfinite(spacing) else max(1, int(np.ceil(length / spacing - 1e-9)))
        for k in range(m):
            links.append(j)
            alphas.append(k / m)
            ros.append(chain.link_ro[j])
            wts.append(length / m / WALL_REFERENCE_LENGTH_M)
    return (
        np.asarray(links, dtype=np.int64),
        np.asarray(alphas, dtype=np.float64),
        np.asarray(ros, dtype=np.float64),
        np.asarray(wts, dtype=np.float64),
    )
