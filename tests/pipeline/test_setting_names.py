"""Every commissioning setting's names in one table (ringqa.pipeline.settings.SETTING_NAMES),
checked against where each name is actually used: the configuration's keys, the command line's
options and results.json. A new or renamed setting fails here until the table says its names."""

from __future__ import annotations

import argparse
import dataclasses

import pytest

from ringqa.config import KEYS
from ringqa.pipeline.result import RunSettings
from ringqa.pipeline.settings import SETTING_NAMES, CommissionSettings
from ringqa.plan import DosePointSpec


def test_every_field_has_one_row():
    fields = {f.name for f in dataclasses.fields(CommissionSettings)} - {"settings_origin"}
    rows = [r.field for r in SETTING_NAMES]
    assert sorted(rows) == sorted(fields)


def test_config_keys_exist_and_defaults_agree():
    """Each configuration key exists; a one-key setting's configuration default is the
    CommissionSettings default (the two lists cannot drift apart unnoticed)."""
    keys = {k.key: k for k in KEYS}
    defaults = CommissionSettings()
    for row in SETTING_NAMES:
        for key in row.config_keys:
            if key != "scene.*":
                assert key in keys, (row.field, key)
        if len(row.config_keys) == 1 and row.config_keys[0] != "scene.*":
            assert keys[row.config_keys[0]].default == getattr(defaults, row.field), row.field


def test_cli_flags_exist():
    from ringqa.cli.commission import add_parser

    sub = argparse.ArgumentParser().add_subparsers()
    add_parser(sub)
    options = set(sub.choices["commission"]._option_string_actions)
    for row in SETTING_NAMES:
        for flag in row.cli_flags:
            assert flag in options, (row.field, flag)


def test_results_keys_exist():
    run = RunSettings(
        source="flexisource", sk_U=1.0, prescription_gy=7.0, cable="flexitron", channel="ring",
        register="none", stem_mm=60.0, plan_step_mm=5.0, tandem_dwells=7,
        position_limits_mm=(1.0, 2.0), dose_action_pct=5.0, dose_points=DosePointSpec(),
        scene_overrides={}, scene={},
    )  # fmt: skip
    keys = set(run.as_dict())
    for row in SETTING_NAMES:
        if row.results_key is not None:
            assert row.results_key in keys, (row.field, row.results_key)


def _run(**kw) -> RunSettings:
    base = dict(
        source="flexisource", sk_U=1.0, prescription_gy=7.0, cable="flexitron", channel="ring",
        register="none", stem_mm=60.0, plan_step_mm=5.0, tandem_dwells=7,
        position_limits_mm=(1.0, 2.0), dose_action_pct=5.0, dose_points=DosePointSpec(),
        scene_overrides={"solver.increment_mm": 0.5}, scene={"k": 1},
    )  # fmt: skip
    return RunSettings(**{**base, **kw})


def test_results_json_settings_are_made_from_the_table(monkeypatch):
    """results.json ``settings`` holds exactly the table's results.json keys (each setting once,
    in the order results.json has always had) plus ``scene`` (and ``calibration`` only when one
    is used); a row taken out of the table (monkeypatched) is no longer written, so the keys
    are read from the table, not written by hand. Values by hand: the limits pair as the list
    [1.0, 2.0], the dose points as their spec's dict, the overrides as given."""
    import ringqa.pipeline.settings as settings_mod
    from ringqa.pipeline.result import SETTINGS_KEY_ORDER

    out = _run().as_dict()
    assert set(out) == {*settings_mod.results_keys(), "scene"}
    assert list(out) == list(SETTINGS_KEY_ORDER)  # the order readers have always seen
    assert out["position_limits_mm"] == [1.0, 2.0]
    assert out["dose_points"] == DosePointSpec().as_dict()
    assert out["scene_overrides"] == {"solver.increment_mm": 0.5} and out["scene"] == {"k": 1}
    cal = _run(calibration={"file": "c.toml", "sha256": "ab"}).as_dict()
    assert list(cal)[-1] == "calibration" and cal["calibration"]["sha256"] == "ab"
    fewer = tuple(r for r in settings_mod.SETTING_NAMES if r.results_key != "tandem_dwells")
    monkeypatch.setattr(settings_mod, "SETTING_NAMES", fewer)
    assert "tandem_dwells" not in _run().as_dict()


@pytest.mark.parametrize("row", SETTING_NAMES, ids=lambda r: r.field)
def test_a_name_that_differs_says_so(row):
    """Where a configuration key (its last part, or the whole key with . as _) or a flag differs
    from the field's name (beyond - for _), the row's note says how."""
    tails = {
        k.split(".")[-1]
        for k in row.config_keys
        if k != "scene.*" and row.field not in (k.split(".")[-1], k.replace(".", "_"))
    }
    flags = {f.lstrip("-").replace("-", "_") for f in row.cli_flags}
    names = (tails | flags | {row.results_key or row.field}) - {row.field}
    if names - {"set"}:
        assert row.note, (row.field, names)


def test_commission_options_are_made_from_the_settings_table():
    """Each row of SETTINGS with an option is an option of ringqa commission with the row's
    help, placeholder and default None (the configuration decides what is not given), and
    option_keys() maps it back to the row's configuration key: the option is written once, in
    the table."""
    import argparse

    from ringqa.cli.commission import add_parser, option_keys
    from ringqa.pipeline.settings import SETTINGS

    sub = argparse.ArgumentParser().add_subparsers()
    add_parser(sub)
    parser = sub.choices["commission"]
    actions = {a.option_strings[0]: a for a in parser._actions if a.option_strings}
    rows = [s for s in SETTINGS if s.option]
    assert len(rows) >= 10
    for s in rows:
        action = actions[s.option]
        assert action.help == (s.help or s.doc) and action.default is None
        if s.kind != "flag":
            assert action.metavar == s.metavar
        assert option_keys()[action.dest] == s.key
