"""Each scene key is described once (ringqa.simulation.scene_keys) and used everywhere: the
dataclasses' defaults and checks, the TOML reader and writer, --set, the docs table and errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ringqa.errors import SceneError
from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.scene import (
    CableSection,
    ContactParams,
    Effects,
    Instrument,
    Motion,
    Outputs,
    SolverSettings,
)
from ringqa.simulation.scene_keys import KEYS, field_key, markdown_table
from ringqa.simulation.scenefile import load_scene, scene_to_dict

ROOT = Path(__file__).resolve().parents[3]
ARC = {
    "channel": {"kind": "arc", "straight_mm": 20.0, "radius_mm": 13.0, "angle_deg": 180.0,
                "r_b_mm": 1.5, "r_a_mm": 1.4},
    "motion": {"step_mm": 5.0, "span_mm": 30.0},
}  # fmt: skip
SECTION_CLASSES = {
    "effects": Effects,
    "contact": ContactParams,
    "motion": Motion,
    "solver": SolverSettings,
    "outputs": Outputs,
    "section": CableSection,
    "instrument": Instrument,
}


@pytest.mark.parametrize("section", sorted(SECTION_CLASSES))
def test_every_dataclass_field_has_one_key(section):
    """Every SI field of a scene dataclass is set by exactly one scene key (so the reader, the
    writer and --set cannot forget one), apart from the few that are not user settings."""
    not_keys = {"name", "sections", "afterloader"} if section == "instrument" else set()
    cls = SECTION_CLASSES[section]
    fields = {f.name for f in dataclasses.fields(cls)} - not_keys
    keyed = [k.field for k in KEYS if k.section == section and k.field]
    assert sorted(keyed) == sorted(fields)


@pytest.mark.parametrize("section", ["effects", "contact", "solver", "outputs"])
def test_dataclass_defaults_are_the_keys_defaults(section):
    """The dataclass default of each field is its key's default converted to SI (e.g. solver
    increment 1.0 mm -> 1e-3 m, contact v_brk 1.0 mm/s -> 1e-3 m/s)."""
    obj = SECTION_CLASSES[section]()
    for k in KEYS:
        if k.section == section and k.field and k.default is not None:
            assert getattr(obj, k.field) == k.to_si(k.default), k.dotted
    assert SolverSettings().increment_m == 1e-3 and ContactParams().v_brk_m_s == 1e-3


def test_readme_keys_table_is_generated_from_the_registry():
    """data/scenes/README.md carries the table :func:`markdown_table` writes (regenerate it with
    ``python tools/scene_keys_table.py``)."""
    text = (ROOT / "data" / "scenes" / "README.md").read_text()
    assert markdown_table() in text


@pytest.mark.parametrize(
    ("build", "words"),
    [
        (
            lambda: SolverSettings(increment_m=-1e-3),
            r"solver\.increment_mm: must be > 0, got -1 mm",
        ),
        (lambda: SolverSettings(kind="explicit"), r"solver\.kind: choose one of"),
        (lambda: ContactParams(mu_s=0.1, mu_k=0.2), r"contact\.mu_k: .*exceeds mu_s"),
        (lambda: ContactParams(transition_max_fraction=1.5), r"transition_max_fraction"),
        (lambda: Effects(friction="sticky"), r"effects\.friction: choose one of none"),
        (lambda: Effects(gravity_m_s2=(0.0, 1.0)), r"effects\.gravity_m_s2"),
        (lambda: Motion(speed_m_s=0.0), r"motion\.speed_mm_s: must be > 0, got 0 mm/s"),
        (lambda: Motion(advances_m=(0.01, float("nan"))), r"motion\.advances_mm"),
        (lambda: CableSection("thin", 0.1, -0.25e-3, 5e-5, 4e-5, 0.04, 3e-3), r"r_o_mm"),
        (lambda: SolverSettings(max_iter=2.5), r"solver\.max_iter"),
    ],
)
def test_python_scenes_are_validated_like_files(build, words):
    """A scene built in Python is refused exactly where a file would be, naming the key as
    written in a file (user units)."""
    with pytest.raises(SceneError, match=words):
        build()


def test_coulomb_friction_with_mu_k_above_mu_s_is_refused_both_ways():
    """The rule mu_k <= mu_s holds whatever the law, from a file and from Python (they used to
    disagree: refused from TOML, accepted from Python for Coulomb friction)."""
    with pytest.raises(SceneError, match=r"contact\.mu_k"):
        load_scene({**ARC, "effects": {"friction": "coulomb"}, "contact": {"mu_k": 0.3}})
    with pytest.raises(SceneError, match=r"contact\.mu_k"):
        ContactParams(mu_s=0.25, mu_k=0.3)


def test_replacing_the_channel_drops_the_files_channel_description():
    """A scene read from a file writes its channel back as the file gave it; give it another
    channel and the stale description is gone: the new channel is written inline."""
    s = load_scene("ring26-flexitron")
    assert scene_to_dict(s)["channel"]["applicator"] == "ring26x60"
    # 161 mm long (a 342 deg arc would come back 0.7 mm from its own entry: self-intersecting)
    other = arc_channel(radius_m=0.013, angle_rad=1.5 * np.pi, entry_m=0.1)
    from ringqa.geometry import Centreline, Channel, Lumen

    length = other.centreline.length_m
    pts = other.centreline.position(np.linspace(0.0, length, 501))
    ch = Channel("arc", Centreline.from_points(pts), Lumen.circular(1.5e-3, 1.4e-3), 0.15)
    t = s.replace(channel=ch)
    assert t.channel_spec is None
    spec = scene_to_dict(t)["channel"]
    assert spec["kind"] == "points" and "applicator" not in spec
    again = load_scene(scene_to_dict(t))
    assert again.channel.length_m == pytest.approx(ch.length_m, abs=1e-9)


def test_scene_knows_nothing_of_the_file_format():
    """The Scene has no serialised copy of itself and no method that reaches the file format."""
    from ringqa.simulation.scene import Scene

    names = {f.name for f in dataclasses.fields(Scene)}
    assert "source" not in names
    for method in ("to_dict", "with_overrides", "for_channel"):
        assert not hasattr(Scene, method)


def test_field_key_names_the_file_key():
    """Errors about an SI field name the key as written in a file."""
    assert field_key("solver", "increment_m").dotted == "solver.increment_mm"
    assert field_key("contact", "v_brk_m_s").name == "v_brk_mm_s"
