"""Scene files: TOML in user units -> validated SI Scene; errors name the file and key."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.errors import SceneError
from ringqa.simulation.scenefile import (
    analytic_centreline_mm,
    apply_overrides,
    default_advances_mm,
    load_scene,
    parse_set_args,
    parse_value,
    scene_for_channel,
    scene_to_dict,
    scene_with_overrides,
)

SCENES = Path(__file__).resolve().parents[3] / "data" / "scenes"

ARC = {
    "channel": {"kind": "arc", "straight_mm": 20.0, "radius_mm": 13.0, "angle_deg": 180.0,
                "r_b_mm": 1.5, "r_a_mm": 1.4},
    "instrument": {"preset": "flexitron"},
    "motion": {"step_mm": 5.0, "span_mm": 30.0},
}  # fmt: skip


# ---- analytic centrelines (pure numpy)
def test_arc_points_lie_on_the_circle():
    """Arc of radius 13 mm after a 20 mm straight along +x bending towards +y: centre at
    (20, 13, 0); every arc point 13 mm from it; the 180 deg arc ends at (20, 26, 0) heading -x;
    total polyline length ~ 20 + 13 pi = 60.84 mm."""
    pts = analytic_centreline_mm(ARC["channel"])
    arc = pts[pts[:, 0] >= 20.0 - 1e-12]
    r = np.linalg.norm(arc - [20.0, 13.0, 0.0], axis=1)
    assert np.allclose(r[1:], 13.0, atol=1e-9)
    assert pts[-1] == pytest.approx([20.0, 26.0, 0.0], abs=1e-9)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
    assert seg == pytest.approx(20.0 + 13.0 * math.pi, rel=1e-4)


def test_s_curve_ends_parallel_to_its_start():
    """Two equal arcs bending opposite ways: the exit straight runs along +x again; lateral shift
    2 R (1 - cos a) = 2 * 40 * (1 - cos 60 deg) = 40 mm."""
    spec = {"kind": "s-curve", "radius_mm": 40.0, "angle_deg": 60.0, "straight_mm": 10.0,
            "exit_mm": 5.0}  # fmt: skip
    pts = analytic_centreline_mm(spec)
    d = pts[-1] - pts[-2]
    assert d / np.linalg.norm(d) == pytest.approx([1.0, 0.0, 0.0], abs=1e-9)
    assert pts[-1][1] == pytest.approx(40.0, abs=1e-9)


def test_helix_rises_one_pitch_per_turn():
    """Helix radius 13, pitch 20 mm, one turn: the end is 20 mm above the start of the helix and
    back at the same x-y point; every helix point is 13 mm from the axis (x = 0, y = 13)."""
    spec = {"kind": "helix", "radius_mm": 13.0, "pitch_mm": 20.0, "angle_deg": 360.0}
    pts = analytic_centreline_mm(spec)
    assert pts[-1] - pts[0] == pytest.approx([0.0, 0.0, 20.0], abs=1e-9)
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1] - 13.0), 13.0)


# ---- values and overrides
def test_set_values_are_typed():
    assert parse_value("0.5") == 0.5 and parse_value("true") is True
    assert parse_value("flexitron") == "flexitron"
    assert parse_value("{thin = 2.0, thick = 5.0}") == {"thin": 2.0, "thick": 5.0}
    assert parse_set_args(["solver.increment_mm=0.25", "effects.friction=coulomb"]) == {
        "solver.increment_mm": 0.25,
        "effects.friction": "coulomb",
    }
    with pytest.raises(SceneError, match="KEY=VALUE"):
        parse_set_args(["solver.increment_mm"])


def test_overrides_create_nested_keys_and_refuse_values_as_tables():
    out = apply_overrides({"solver": {"tol": 1e-8}}, {"discretisation.element_length_mm.thin": "2"})
    assert out["discretisation"]["element_length_mm"]["thin"] == 2
    with pytest.raises(SceneError, match="is a value, not a table"):
        apply_overrides({"solver": {"tol": 1e-8}}, {"solver.tol.x": 1})


# ---- whole scenes (need the geometry layer)
def test_units_are_converted_once_to_si():
    """increment 0.5 mm -> 5e-4 m; speed 500 mm/s -> 0.5 m/s; v_brk 2 mm/s -> 2e-3 m/s;
    element lengths 1.5 / 5 mm -> 1.5e-3 / 5e-3 m; jam length 20 mm -> 0.02 m."""
    over = {
        "solver.increment_mm": "0.5",
        "motion.speed_mm_s": 500,
        "contact.v_brk_mm_s": 2,
        "discretisation.element_length_mm": {"thin": 1.5, "thick": 5.0},
    }
    s = load_scene(ARC, over)
    assert s.solver.increment_m == pytest.approx(5e-4)
    assert s.motion.speed_m_s == pytest.approx(0.5)
    assert s.contact.v_brk_m_s == pytest.approx(2e-3)
    assert s.solver.jam_length_m == pytest.approx(0.02)
    cap, thin, thick = s.instrument.sections
    assert (thin.element_length_m, thick.element_length_m) == pytest.approx((1.5e-3, 5e-3))
    assert cap.element_length_m == pytest.approx(4.6e-3)  # rigid capsule untouched


def test_default_advances_follow_s_ref_back():
    """Arc channel length 20 + 13 pi = 60.84 mm, s_ref = length - 5 = 55.84 mm; step 5 over
    30 mm -> 7 advances 25.84 ... 55.84 mm, ascending."""
    s = load_scene(ARC)
    adv = np.array(s.motion.advances_m) * 1e3
    s_ref = 20.0 + 13.0 * math.pi - 5.0
    assert adv == pytest.approx(s_ref - 5.0 * np.arange(7)[::-1], abs=1e-3)


def test_default_advances_use_the_measured_path():
    """A channel with 5 measured points 2 mm apart: advances s_ref - 8, -6, -4, -2, 0."""
    s = load_scene(ARC)
    ch = s.channel.__class__(
        name="ring", centreline=s.channel.centreline, lumen=s.channel.lumen, s_ref_m=0.05,
        measured_path_m=np.zeros((5, 3)), measured_step_m=0.002,
    )  # fmt: skip
    assert default_advances_mm(ch) == pytest.approx([42.0, 44.0, 46.0, 48.0, 50.0])


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.toml")), ids=lambda p: p.stem)
def test_shipped_scenes_load_and_round_trip(path):
    """Every shipped scene loads, and its user-unit dict reloads to the same scene."""
    s = load_scene(path)
    assert s.name == path.stem
    again = load_scene(scene_to_dict(s))
    assert scene_to_dict(again) == scene_to_dict(s)  # exact in user units (12 significant digits)
    assert again.instrument.afterloader == s.instrument.afterloader
    assert again.solver == s.solver and again.contact == s.contact
    assert again.motion.advances_m == pytest.approx(s.motion.advances_m, rel=1e-11)
    for a, b in zip(again.instrument.sections, s.instrument.sections, strict=True):
        assert a.length_m == pytest.approx(b.length_m, rel=1e-11) and a.name == b.name


@given(
    inc=st.floats(0.05, 5.0),
    tol=st.floats(1e-12, 1e-3),
    thin=st.floats(0.2, 10.0),
    thick=st.floats(0.5, 20.0),
    friction=st.sampled_from(["none", "coulomb", "stribeck"]),
)
def test_round_trip_with_overrides(inc, tol, thin, thick, friction):
    """load(to_dict(scene)) reproduces the scene for any settings (to 12 significant digits)."""
    s = scene_with_overrides(
        load_scene(ARC),
        {"solver.increment_mm": inc, "solver.tol": tol, "effects.friction": friction,
         "discretisation.element_length_mm": {"thin": thin, "thick": thick}}
    )  # fmt: skip
    assert s.solver.increment_m == pytest.approx(inc * 1e-3, rel=1e-11)
    assert s.instrument.sections[1].element_length_m == pytest.approx(thin * 1e-3, rel=1e-11)
    again = load_scene(scene_to_dict(s))
    assert scene_to_dict(again) == scene_to_dict(s)


def test_for_channel_keeps_the_channel_object():
    base = load_scene(ARC)
    s = scene_for_channel(base.channel, cable="flexitron", solver={"increment_mm": 0.5})
    assert s.channel is base.channel
    assert s.solver.increment_m == pytest.approx(5e-4)
    assert scene_with_overrides(s, {"solver.tol": 1e-6}).channel is base.channel
    with pytest.raises(SceneError, match="unknown preset"):
        scene_for_channel(base.channel, cable="nope")


# ---- errors
def _write(tmp_path, text: str) -> Path:
    p = tmp_path / "bad.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[solver]\nincrement_mn = 1.0\n", r"bad.toml: solver.increment_mn: unknown key"),
        ("[solver]\nincrement_mm = 'big'\n", r"solver.increment_mm: got 'big' \(must be a number"),
        ("[solver]\nincrement_mm = -1\n", r"solver.increment_mm: got -1 \(must be > 0"),
        ("[solver]\nkind = 'explicit'\n", r"solver.kind: .*choose one of quasistatic, dynamic"),
        ("[solver]\nintegrator = 'rk4'\n", r"solver.integrator: .*of backward_euler, bdf2"),
        ("[effects]\nfriction = 'viscous'\n", r"effects.friction: .*none, coulomb, stribeck"),
        ("[effects]\ntorsion = 1\n", r"effects.torsion: got 1 \(must be true or false"),
        ("[instrument]\npreset = 'cable9'\n", r"instrument.preset: .*flexitron"),
        ("[solverr]\n", r"solverr: unknown top-level"),
        ("[solver\n", r"bad.toml: not valid TOML"),
        ("solver = 3\n", r"solver: must be a table"),
    ],
)
def test_bad_files_name_file_key_and_fix(tmp_path, text, words):
    with pytest.raises(SceneError, match=words):
        load_scene(_write(tmp_path, text))


def test_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(tmp_path / "nope.toml")


@pytest.mark.parametrize(
    ("over", "words"),
    [
        ({"channel.kind": "spiral"}, r"channel.kind: .*choose one of"),
        ({"channel.radius_mm": None}, r"channel.radius_mm"),
        ({"channel.lumen": "u"}, r"channel.flat_mm: missing"),
        ({"channel.flat_mm": -2.0, "channel.lumen": "u"}, r"channel.flat_mm: got -2"),
        (
            {"channel.flat_towards": "sideways", "channel.lumen": "u", "channel.flat_mm": 1.2},
            r"channel.flat_towards: .*choose one of bend_outside",
        ),
        ({"channel.lumen_diameter_mm": 3.0}, r"channel.lumen_diameter_mm: unknown key"),
        ({"channel.r_a_mm": 2.0}, r"channel.r_a_mm: .*\(0, r_b_mm"),
        ({"motion.advances_mm": [10.0, 500.0]}, r"motion.advances_mm: values outside"),
        ({"motion.advances_mm": [30.0, 10.0]}, r"motion.advances_mm: not ascending"),
        ({"discretisation.element_length_mm": {"thinn": 1.0}}, r"element_length_mm.thinn"),
        ({"contact.mu_k": 0.3}, r"contact.mu_k: .*must not exceed"),
        ({"instrument.length_mm": 50.0}, r"instrument.length_mm: .*shorter than the distal"),
    ],
)
def test_bad_settings_name_the_key(over, words):
    data = apply_overrides(ARC, {})
    if over.get("channel.radius_mm", 0) is None:
        del data["channel"]["radius_mm"]
        over = {}
    with pytest.raises(SceneError, match=words):
        load_scene(data, over)


def test_unknown_applicator_names_the_key():
    with pytest.raises(SceneError, match=r"channel.applicator: cannot load 'ring99x99'"):
        load_scene({"channel": {"applicator": "ring99x99"}})


@pytest.mark.parametrize("part", ["solver", "contact", "effects", "motion"])
def test_every_engine_setting_survives_the_round_trip(part):
    """Each field of SolverSettings / ContactParams / Effects / Motion changed in the SI scene
    comes back from scene_to_dict(scene) -> load_scene unchanged (so no setting the engine adds is
    silently dropped by scene files, --set or the accuracy study)."""
    import dataclasses

    base = load_scene(ARC)
    obj = getattr(base, part)
    for f in dataclasses.fields(obj):
        val = getattr(obj, f.name)
        if isinstance(val, bool):
            new = not val
        elif isinstance(val, int):
            new = val + 7
        elif isinstance(val, float):
            new = val * 0.5 if f.name != "mu_s" else val * 2
        elif f.name == "gravity_m_s2":
            new = (0.0, -9.81, 0.0)
        elif f.name == "friction":
            new = "coulomb"
        elif f.name == "kind":
            new = "dynamic" if part == "solver" else "stepwise"
        elif f.name == "integrator":
            new = "bdf2"
        elif f.name == "advances_m":
            new = tuple(a - 1e-3 for a in val)
        else:  # None-valued optional settings
            new = {"transition_m": 0.05e-3, "start_m": 0.01, "friction_v_reg_m_s": 2e-4}[f.name]
        changed = base.replace(**{part: dataclasses.replace(obj, **{f.name: new})})
        again = getattr(load_scene(scene_to_dict(changed)), part)
        got = getattr(again, f.name)
        if isinstance(new, float):
            assert got == pytest.approx(new, rel=1e-11), f.name
        elif isinstance(new, tuple):
            assert got == pytest.approx(new, rel=1e-11), f.name
        else:
            assert got == new, f.name


_toml_values = st.recursive(
    st.one_of(st.floats(allow_nan=False), st.integers(), st.text(max_size=5), st.booleans()),
    lambda children: st.one_of(
        st.lists(children, max_size=4), st.dictionaries(st.text(max_size=3), children, max_size=4)
    ),
    max_leaves=30,
)


@given(_toml_values)
def test_plain_copy_equals_deepcopy_and_is_independent(value):
    """plain_copy gives what copy.deepcopy gives for TOML data (equal), and no list or dict of
    the copy is an object of the original (so changing the copy cannot change the scene)."""
    import copy

    from ringqa.simulation.scenefile.read import plain_copy

    got = plain_copy(value)
    assert got == copy.deepcopy(value)

    def containers(v):
        if isinstance(v, dict):
            yield v
            for x in v.values():
                yield from containers(x)
        elif isinstance(v, list):
            yield v
            for x in v:
                yield from containers(x)

    original = {id(c) for c in containers(value)}
    assert not original & {id(c) for c in containers(got)}
