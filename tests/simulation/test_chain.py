"""The rigid-link discretisation and contact sampling (hypothesis over instruments and bends)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.errors import SimulationError
from ringqa.simulation.chain import build_chain, contact_samples
from ringqa.simulation.scene import CableSection, Instrument


def _inst(l_thin, l_thick, thin_len=0.105, capsule=True):
    secs = []
    if capsule:
        secs.append(CableSection("capsule", 4.6e-3, 0.425e-3, 1.0, 1.0, 0.04, 4.6e-3, rigid=True))
    secs += [
        CableSection("thin", thin_len, 0.25e-3, 5.2e-5, 4.0e-5, 0.04, l_thin),
        CableSection("thick", 0.6, 0.425e-3, 1.8e-4, 1.4e-4, 0.1, l_thick),
    ]
    return Instrument("t", tuple(secs), 2.4e-3)


@given(
    l_thin=st.floats(0.5e-3, 6e-3),
    l_thick=st.floats(1e-3, 12e-3),
    model=st.floats(0.02, 0.7),
)
def test_chain_covers_the_model_length_with_bounded_links(l_thin, l_thick, model):
    """Links sum to the modelled length, none longer than its section's element length, the
    capsule one link, mass conserved, hinge stiffness EI/l between equal links of one section."""
    ch = build_chain(_inst(l_thin, l_thick), model)
    assert ch.cum[-1] == pytest.approx(model, rel=1e-12)
    assert ch.link_len[0] == pytest.approx(4.6e-3) and not np.isfinite(ch.link_ei[0])
    for k, lmax in ((1, l_thin), (2, l_thick)):
        sel = ch.link_section == k
        assert np.all(ch.link_len[sel] <= lmax * (1 + 1e-9))
    total_mass = float(np.sum(ch.node_mass))
    mpl = np.array([0.04, 0.04, 0.1])[ch.link_section]
    expected = float(np.sum(mpl * ch.link_len))
    assert total_mass == pytest.approx(expected, rel=1e-12)
    same = (ch.link_section[1:-1] == ch.link_section[2:]) & (ch.link_section[1:-1] == 1)
    k_expect = 5.2e-5 / ch.link_len[2:][same]
    np.testing.assert_allclose(ch.hinge_k[1:][same], k_expect, rtol=1e-12)


def test_hinge_between_sections_is_springs_in_series():
    """Across the thin/thick joint the moment is continuous: k = 1/(l1/(2 EI1) + l2/(2 EI2));
    next to the rigid capsule only the flexible half-link counts: k = 2 EI / l."""
    ch = build_chain(_inst(3e-3, 10e-3), 0.2)
    j = int(np.argmax(ch.link_section == 2))  # first thick link
    l1, l2 = ch.link_len[j - 1], ch.link_len[j]
    assert ch.hinge_k[j - 1] == pytest.approx(1 / (l1 / (2 * 5.2e-5) + l2 / (2 * 1.8e-4)))
    assert ch.hinge_k[0] == pytest.approx(2 * 5.2e-5 / ch.link_len[1])


@given(
    length=st.floats(1e-3, 12e-3),
    radius=st.floats(4e-3, 0.05),
    clearance=st.floats(0.03e-3, 1.5e-3),
)
def test_contact_samples_bound_the_bow(length, radius, clearance):
    """Between consecutive samples a link piece bows at most 10 % of the clearance."""
    ch = build_chain(
        Instrument("u", (CableSection("u", 1.0, 0.3e-3, 1e-4, 1e-4, 0.04, length),), 0.0), 0.1
    )
    link, alpha, _, wt = contact_samples(ch, radius, clearance, 0.1)
    np.testing.assert_allclose(np.sum(wt) * 3e-3, ch.cum[-1], rtol=1e-12)  # stiffness per length
    for j in range(ch.n_links):
        a = np.sort(alpha[link == j])
        assert a[0] == 0.0
        gaps = np.diff(np.concatenate([a, [1.0]])) * ch.link_len[j]
        assert np.all(gaps**2 / (8 * radius) <= 0.1 * clearance * (1 + 1e-9))


def test_instrument_too_short_is_refused_by_name():
    with pytest.raises(SimulationError, match=r"must be modelled"):
        build_chain(_inst(3e-3, 10e-3), 5.0)
