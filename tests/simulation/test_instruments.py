"""The instrument presets carry the paper's Table 1 and the egs_brachy capsule geometry."""

from __future__ import annotations

import math

import pytest

from ringqa.errors import SceneError
from ringqa.simulation.instruments import (
    BORROWED_MECHANICS,
    CABLE_PRESETS,
    CONTACT_PRESETS,
    PRESET_SOURCES,
    REAL_MASS_PER_LENGTH_KG_M,
    cable_preset,
)


def test_flexitron_matches_table_1():
    """Straathof 2024 Table 1 + domain.md: capsule 4.6 mm rigid r_o 0.425 mm, centre 2.4 mm from
    the tip; thin 105 mm r_o 0.25 mm EI 5.2e-5 GJ 4.0e-5, 3 mm links; thick r_o 0.425 mm EI 1.8e-4
    GJ 1.4e-4, 10 mm links; mu_s 0.25, mu_k 0.20, k 1e5 N/m, c_w 10 N s/m, v_brk 1 mm/s."""
    inst = CABLE_PRESETS["flexitron"]
    cap, thin, thick = inst.sections
    assert (cap.name, thin.name, thick.name) == ("capsule", "thin", "thick")
    assert cap.rigid and not thin.rigid and not thick.rigid
    assert cap.length_m == pytest.approx(4.6e-3) and cap.r_o_m == pytest.approx(0.425e-3)
    assert inst.centre_from_tip_m == pytest.approx(2.4e-3)
    assert 0 < inst.centre_from_tip_m < cap.length_m  # the source centre lies inside the capsule
    assert (thin.length_m, thin.r_o_m, thin.ei_nm2, thin.gj_nm2) == pytest.approx(
        (0.105, 0.25e-3, 5.2e-5, 4.0e-5)
    )
    assert (thick.r_o_m, thick.ei_nm2, thick.gj_nm2) == pytest.approx((0.425e-3, 1.8e-4, 1.4e-4))
    assert (thin.element_length_m, thick.element_length_m) == pytest.approx((3e-3, 10e-3))
    c = CONTACT_PRESETS["flexitron"]
    assert (c.mu_s, c.mu_k, c.stiffness_n_m, c.damping_ns_m, c.v_brk_m_s) == pytest.approx(
        (0.25, 0.20, 1e5, 10.0, 1e-3)
    )


def test_microselectron_has_the_mhdr_v2_geometry_and_says_its_mechanics_are_borrowed():
    """domain.md (egs_brachy mHDR-v2): capsule 0.90 mm diameter (r_o 0.45 mm), 4.5 mm long,
    centre of activity 2.0 mm from the tip; cable 0.70 mm diameter (r_o 0.35 mm). EI, GJ and the
    wall contact are the Flexitron thick section's and contact (1.8e-4, 1.4e-4 N m^2; mu_s 0.25,
    mu_k 0.20), and the preset's source text says ASSUMED."""
    inst = CABLE_PRESETS["microselectron"]
    cap, cable = inst.sections
    assert cap.rigid and not cable.rigid
    assert (cap.length_m, cap.r_o_m, inst.centre_from_tip_m) == pytest.approx(
        (4.5e-3, 0.45e-3, 2.0e-3)
    )
    assert cable.r_o_m == pytest.approx(0.35e-3)
    thick = CABLE_PRESETS["flexitron"].sections[2]
    assert (cable.ei_nm2, cable.gj_nm2) == (thick.ei_nm2, thick.gj_nm2)
    assert CONTACT_PRESETS["microselectron"] == CONTACT_PRESETS["flexitron"]
    assert inst.afterloader == "microselectron"
    assert "microselectron" in BORROWED_MECHANICS and "flexitron" not in BORROWED_MECHANICS
    assert "ASSUMED" in PRESET_SOURCES["microselectron"]
    assert set(PRESET_SOURCES) == set(CABLE_PRESETS)


def test_catheter_matches_table_1():
    """Table 1 needle insertion: EI 1.2e-2, GJ 9.6e-3, r_o 0.99 mm, 120 mm, 3.3 mm links,
    mu_k 0.074, mu_s 0.094, k 1e6 N/m."""
    (sec,) = CABLE_PRESETS["catheter"].sections
    assert (sec.ei_nm2, sec.gj_nm2, sec.r_o_m, sec.length_m, sec.element_length_m) == pytest.approx(
        (1.2e-2, 9.6e-3, 0.99e-3, 0.12, 3.3e-3)
    )
    c = CONTACT_PRESETS["catheter"]
    assert (c.mu_k, c.mu_s, c.stiffness_n_m) == pytest.approx((0.074, 0.094, 1e6))


def test_real_masses_are_physical():
    """Steel 7.9 g/cm^3: a 0.50 mm wire weighs 7900 pi (0.25e-3)^2 = 1.551e-3 kg/m, a 0.85 mm
    wire 4.483e-3 kg/m; the capsule (Ir core) is denser than the thick cable; the paper's 0.04 kg/m
    is a scale-up by ~10-25x."""
    m = REAL_MASS_PER_LENGTH_KG_M["flexitron"]
    assert m["thin"] == pytest.approx(1.551e-3, rel=1e-3)
    assert m["thick"] == pytest.approx(4.483e-3, rel=1e-3)
    assert m["thick"] < m["capsule"] < 2 * m["thick"]
    inst = cable_preset("flexitron", real_mass=True)
    assert [s.mass_per_length_kg_m for s in inst.sections] == pytest.approx(
        [m["capsule"], m["thin"], m["thick"]]
    )


def test_cable_preset_rediscretises_and_trims():
    """Per-section element lengths replace only flexible sections; the rigid capsule stays one
    link; a total length of 0.3 m leaves the thick section 0.3 - 0.0046 - 0.105 = 0.1904 m."""
    inst = cable_preset("flexitron", element_length_m={"thin": 1e-3, "thick": 2e-3}, length_m=0.3)
    cap, thin, thick = inst.sections
    assert cap.element_length_m == pytest.approx(4.6e-3)
    assert (thin.element_length_m, thick.element_length_m) == pytest.approx((1e-3, 2e-3))
    assert thick.length_m == pytest.approx(0.1904)
    assert inst.length_m == pytest.approx(0.3)
    uniform = cable_preset("flexitron", element_length_m=5e-3)
    assert [s.element_length_m for s in uniform.sections] == pytest.approx([4.6e-3, 5e-3, 5e-3])
    assert CABLE_PRESETS["flexitron"].sections[1].element_length_m == 3e-3  # preset untouched


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"name": "nope"}, "instrument.preset"),
        ({"name": "flexitron", "element_length_m": {"thinn": 1e-3}}, "thinn"),
        ({"name": "flexitron", "element_length_m": -1.0}, "positive"),
        ({"name": "flexitron", "element_length_m": math.nan}, "positive"),
        ({"name": "flexitron", "length_m": 0.05}, "instrument.length_mm"),
    ],
)
def test_bad_preset_arguments_name_the_key(kwargs, words):
    with pytest.raises(SceneError, match=words):
        cable_preset(**kwargs)
