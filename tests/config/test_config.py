"""The clinic configuration (issue 15 part 2): keys, precedence, origins, bad files.

Each key of :data:`ringqa.config.KEYS` changed in a file must change the settings it maps to;
the end-to-end test changes every key at once and finds each in results.json (settings and
settings_origin) of a ``ringqa commission`` run with the stand-in engine.
"""

from __future__ import annotations

import json

import pytest

from ringqa.cli import main
from ringqa.config import (
    COMMAND_LINE,
    DEFAULT,
    KEYS,
    ConfigError,
    config_keys_table,
    effective_config,
    read_config_file,
)
from ringqa.pipeline import CommissionSettings

#: a value different from the default for every key (and inside its range)
CHANGED = {
    "tolerances.position_recommended_mm": 0.5,
    "tolerances.position_required_mm": 3.0,
    "tolerances.dose_action_pct": 3.0,
    "plan.prescription_gy": 6.0,
    "plan.step_mm": 10.0,
    "plan.tandem_dwells": 3,
    "dose_points.point_a_height_mm": 25.0,
    "dose_points.point_a_lateral_mm": 21.0,
    "dose_points.surface_offset_mm": 6.0,
    "dose_points.depth_mm": 4.0,
    "simulation.source": "flexisource",
    "simulation.sk_u": 30000.0,
    "simulation.cable": "microselectron",
    "simulation.register": "rigid",
    "simulation.stem_mm": 50.0,
    "simulation.whole_channel": True,
    "simulation.cross_check": False,
    "report.institution": "St Elsewhere, Radiotherapy",
    "report.physicist": "J. Jansen",
    "report.afterloader": "Flexitron #123",
    "report.applicator_serial": "SN 4711",
    "report.source_calibration": "cert. 99, 2026-01-05",
    "report.notes": "Ring with new CT markers",
    "report.strict": True,
    "calibration.command": "ringqa calibrate ring26x60 --measured film.csv --out cal",
    "calibration.created_utc": "2026-11-28T22:00:00Z",
    "calibration.calibration_json_sha256": "ab" * 32,
}


def _toml(values: dict) -> str:
    tables: dict[str, list[str]] = {}
    for dotted, v in values.items():
        table, name = dotted.split(".", 1)
        if isinstance(v, bool):
            text = "true" if v else "false"
        elif isinstance(v, str):
            text = json.dumps(v)
        else:
            text = repr(v)
        tables.setdefault(table, []).append(f"{name} = {text}")
    return "\n".join(f"[{t}]\n" + "\n".join(rows) + "\n" for t, rows in tables.items())


def _attr(settings: CommissionSettings, fields, key: str):
    """The CommissionSettings / ReportFields value a key maps to."""
    table, name = key.split(".", 1)
    spec = settings.point_spec
    if table == "calibration":  # the calibration file's record (named in the report)
        return (settings.calibration or {}).get(name)
    return {
        "tolerances.position_recommended_mm": settings.position_limits_mm[0],
        "tolerances.position_required_mm": settings.position_limits_mm[1],
        "tolerances.dose_action_pct": settings.dose_action_pct,
        "plan.prescription_gy": settings.prescription_gy,
        "plan.step_mm": settings.plan_step_mm,
        "plan.tandem_dwells": settings.tandem_dwells,
        "simulation.source": settings.source,
        "simulation.sk_u": settings.sk_U,
        "simulation.cable": settings.cable,
        "simulation.register": settings.register,
        "simulation.stem_mm": settings.stem_mm,
        "simulation.whole_channel": settings.stem_mm is None,
        "simulation.cross_check": settings.cross_check,
    }.get(key, getattr(spec, name, None) if table == "dose_points" else getattr(fields, name, None))


def test_every_key_is_in_the_test():
    assert set(CHANGED) == {k.key for k in KEYS}


@pytest.mark.parametrize("key", sorted(set(CHANGED) - {"simulation.stem_mm"}))
def test_each_key_changes_its_setting(key, write_config):
    """One key in a file: its setting changes from the default to the file's value, its origin
    is the file, every other key stays at the default."""
    path = write_config(_toml({key: CHANGED[key]}))
    base = effective_config(user_file=None)
    cfg = effective_config(path, user_file=None)
    before = _attr(base.settings(), base.report_fields(), key)
    after = _attr(cfg.settings(), cfg.report_fields(), key)
    assert after != before
    assert after == CHANGED[key]
    assert cfg.origins[key] == f"--config {path}"
    assert {k for k, o in cfg.origins.items() if o != DEFAULT} == {key}


def test_stem_key(write_config):
    """stem_mm (default 60) -> 50 mm in the settings."""
    cfg = effective_config(write_config("[simulation]\nstem_mm = 50\n"), user_file=None)
    assert cfg.settings().stem_mm == 50.0


def test_precedence_default_user_file_command_line(write_config, monkeypatch):
    """default < user config (RINGQA_CONFIG) < --config < command line, key by key."""
    user = write_config(
        "[plan]\nprescription_gy = 6\nstep_mm = 10\n[tolerances]\ndose_action_pct = 4\n",
        "user.toml",
    )
    site = write_config("[plan]\nprescription_gy = 6.5\nstep_mm = 2.5\n")
    monkeypatch.setenv("RINGQA_CONFIG", str(user))
    cfg = effective_config(site, {"plan.step_mm": 7.5})
    assert cfg.values["tolerances.dose_action_pct"] == 4.0
    assert cfg.origins["tolerances.dose_action_pct"] == f"user config {user}"
    assert cfg.values["plan.prescription_gy"] == 6.5
    assert cfg.origins["plan.prescription_gy"] == f"--config {site}"
    assert cfg.values["plan.step_mm"] == 7.5
    assert cfg.origins["plan.step_mm"] == COMMAND_LINE
    assert cfg.origins["plan.tandem_dwells"] == DEFAULT


def test_scene_keys_and_recommended_toml(write_config):
    """[scene] takes dotted keys and nested tables; ringqa accuracy's recommended.toml (a scene
    file, as written by ringqa.accuracy.output.write_recommended) gives its flexible sections'
    element lengths and its increment and tolerance, and nothing else."""
    cfg = read_config_file(
        write_config('[scene]\n"solver.increment_mm" = 0.5\n[scene.contact]\nmu_k = 0.15\n')
    )
    assert cfg == {"scene.solver.increment_mm": 0.5, "scene.contact.mu_k": 0.15}
    rec = write_config(
        """\
        # ringqa accuracy: cheapest settings meeting 0.1 mm for ring26-flexitron
        name = "ring26-flexitron"
        description = "recommended by ringqa accuracy for 0.1 mm"
        [channel]
        kind = "arc"
        radius_mm = 13.0
        [instrument]
        preset = "flexitron"
        [[instrument.sections]]
        name = "capsule"
        element_length_mm = 4.6
        rigid = true
        [[instrument.sections]]
        name = "thin"
        element_length_mm = 1.5
        rigid = false
        [[instrument.sections]]
        name = "thick"
        element_length_mm = 5.0
        rigid = false
        [solver]
        kind = "quasistatic"
        increment_mm = 0.25
        tol = 1e-6
        """,
        "recommended.toml",
    )
    cfg = effective_config(rec, user_file=None)
    assert cfg.scene_overrides == {
        "discretisation.element_length_mm.thin": 1.5,
        "discretisation.element_length_mm.thick": 5.0,
        "solver.increment_mm": 0.25,
        "solver.tol": 1e-6,
    }
    assert cfg.origins["scene.solver.tol"] == f"--config {rec}"


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (
            "[plan]\nprescripton_gy = 7\n",
            ["plan.prescripton_gy", "did you mean plan.prescription_gy"],
        ),
        ("[tolerance]\nx = 1\n", ["'tolerance'", "did you mean tolerances"]),
        (
            '[scene]\n"solver.incremnt_mm" = 1\n',
            ["scene.solver.incremnt_mm", "solver.increment_mm"],
        ),
        (
            "[tolerances]\ndose_action_pct = 150\n",
            ["tolerances.dose_action_pct = 150", "allowed > 0 and <= 100 %"],
        ),
        ("[plan]\ntandem_dwells = 2.5\n", ["plan.tandem_dwells = 2.5", "whole number"]),
        (
            '[simulation]\nregister = "affine"\n',
            ["simulation.register = 'affine'", "one of none, plane-height, rigid"],
        ),
        ("[tolerances]\nposition_recommended_mm = 3\n", ["required tolerance must be >="]),
        ("[plan\n", ["not valid TOML"]),
    ],
)
def test_bad_file_one_line_exit_2_nothing_written(text, words, write_config, tmp_path, capsys):
    """A bad key or value: one line naming the file and the key (the nearest known key, or the
    value and the allowed range), exit 2, the output folder not created, for both commands."""
    path = write_config(text)
    out = tmp_path / "out"
    assert main(["commission", "fakeA", "--config", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(path) in err
    for w in words:
        assert w in err
    assert not out.exists()
    assert main(["config", "show", "--config", str(path)]) == 2
    assert str(path) in capsys.readouterr().err


def test_command_line_value_out_of_range(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["commission", "fakeA", "--prescription-gy", "-1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--prescription-gy -1.0" in err and "> 0" in err
    assert not out.exists()


def test_config_show_prints_values_and_origins(write_config, monkeypatch, capsys):
    user = write_config('[report]\nphysicist = "J. Jansen"\n', "user.toml")
    site = write_config('[tolerances]\ndose_action_pct = 3\n[scene]\n"solver.tol" = 1e-5\n')
    monkeypatch.setenv("RINGQA_CONFIG", str(user))
    assert main(["config", "show", "--config", str(site)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(ln.startswith("dose_action_pct = 3") and f"# --config {site}" in ln for ln in lines)
    assert any(ln.startswith('physicist = "J. Jansen"') and f"user config {user}" in ln
               for ln in lines)  # fmt: skip
    assert any(ln.startswith('"solver.tol" = 1e-05') for ln in lines)
    assert any(ln.startswith("prescription_gy = 7") and "# default" in ln for ln in lines)


def test_every_key_reaches_results_json(fake_inputs, write_config, tmp_path):
    """``ringqa commission --config`` with every key changed: results.json's settings carry each
    new value and settings_origin names the file for each key; the command line wins over the
    file for --dose-action-pct. (whole_channel=true makes stem_mm None, so stem_mm is checked
    in test_stem_key; cable microselectron, source flexisource as set.)"""
    values = dict(CHANGED)
    path = write_config(_toml(values) + '[scene]\n"solver.tol" = 1e-5\n')
    out = tmp_path / "out"
    code = main(["commission", "fakeA", "--config", str(path), "--dose-action-pct", "2.5",
                 "--out", str(out), "--no-pdf", "--quiet"])  # fmt: skip
    assert code == 1  # report.strict = true and a verdict ACTION: exit status 1
    res = json.loads((out / "results.json").read_text())
    s, origin = res["settings"], res["settings_origin"]
    assert s["position_limits_mm"] == [0.5, 3.0]
    assert s["dose_action_pct"] == 2.5 and origin["tolerances.dose_action_pct"] == COMMAND_LINE
    assert s["prescription_gy"] == 6.0
    assert s["plan_step_mm"] == 10.0
    assert s["tandem_dwells"] == 3
    assert s["dose_points"] == {"point_a_height_mm": 25.0, "point_a_lateral_mm": 21.0,
                                "surface_offset_mm": 6.0, "depth_mm": 4.0}  # fmt: skip
    assert s["source"] == "flexisource" and s["sk_U"] == 30000.0
    assert s["cable"] == "microselectron" and s["register"] == "rigid"
    assert s["stem_mm"] is None
    assert s["scene_overrides"] == {"solver.tol": 1e-5}
    for key in CHANGED:
        if key != "tolerances.dose_action_pct":
            assert origin[key] == f"--config {path}", key
    # the standard plan: 10 mm spacing and 3 tandem dwells
    plan = json.loads((out / "results.json").read_text())["summary"]
    assert plan["n_plan_dwells_tandem"] == 3


def test_keys_table_in_docs(repo_root):
    """docs/config.md carries the generated keys table (defaults, units, ranges)."""
    text = (repo_root / "docs" / "config.md").read_text(encoding="utf-8")
    assert config_keys_table() in text


def test_every_key_shows_in_the_report(fake_inputs, write_config, tmp_path):
    """``ringqa commission --config site.toml`` with every key changed, PDF written: the report's
    text carries each report field, and the settings page lists every key with the value the
    run used, its unit and the file as its origin (``--config [1]``, the file named under the
    table). Expected values by hand from CHANGED: as given, but ``stem_mm`` is ``-`` because
    ``whole_channel = true`` (the whole channel: no stem length)."""
    from tests.report.conftest import pdf_pages_text

    path = write_config(_toml(dict(CHANGED)))
    out = tmp_path / "out"
    code = main(["commission", "fakeA", "--config", str(path), "--out", str(out), "--quiet"])
    assert code == 1  # report.strict = true and a verdict ACTION: exit status 1
    text = " ".join(pdf_pages_text(out / "report.pdf"))
    flat = " ".join(text.split())
    for key, value in CHANGED.items():
        if key.startswith("report.") and isinstance(value, str):
            assert value in flat, key
    dense = "".join(text.split())  # cells wrap: compare without white space
    units = {k.key: k.unit for k in KEYS}
    for key, value in CHANGED.items():
        shown = "-" if key == "simulation.stem_mm" else str(value)
        row = f"{key.split('.', 1)[1]}{shown}{units[key]}--config[1]"
        assert "".join(row.split()) in dense, key
    assert "".join(f"[1] --config {path}".split()) in dense


def test_report_fields_reach_the_report_writer(fake_inputs, write_config, tmp_path, monkeypatch):
    """[report] of the configuration is handed to the PDF writer as ReportFields (the writer is
    replaced by a recorder: the layout is another part's)."""
    import ringqa.report as report
    from ringqa.report.fields import ReportFields

    seen = []

    def recorder(result, path, *, accuracy=None, fields=None, **kw):
        seen.append(fields)
        path.write_bytes(b"%PDF stand-in")
        return path

    monkeypatch.setattr(report, "write_pdf", recorder)
    path = write_config('[report]\nphysicist = "J. Jansen"\nnotes = "new ring"\n')
    out = tmp_path / "out"
    assert main(["commission", "fakeA", "--config", str(path), "--out", str(out), "--quiet"]) == 0
    assert seen == [ReportFields(physicist="J. Jansen", notes="new ring")]


def test_ringqa_config_naming_a_missing_file_is_an_error(tmp_path, monkeypatch, capsys):
    """RINGQA_CONFIG names a file that is not there (a share not mounted): commission and
    config show refuse, naming the variable and the file, instead of running on defaults;
    the platform's default file may be absent (RINGQA_CONFIG unset)."""
    missing = tmp_path / "share" / "site.toml"
    monkeypatch.setenv("RINGQA_CONFIG", str(missing))
    with pytest.raises(ConfigError, match=r"RINGQA_CONFIG=.*site.toml: configuration file not"):
        effective_config()
    out = tmp_path / "out"
    assert main(["commission", "fakeA", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(missing) in err and not out.exists()
    assert main(["config", "path"]) == 0  # where it is looked for still prints
    assert "not present" in capsys.readouterr().out
    monkeypatch.delenv("RINGQA_CONFIG")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "nothing"))
    assert effective_config().origins["plan.step_mm"] == "default"


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (
            "[solver]\nincrement_mm = 0.5\n[contact]\nmu_k = 0.3\n",
            ["[solver], [contact]", "[scene.solver]"],
        ),
        ("[plan]\nstep_mm = 5\n[contact]\nmu_k = 0.3\n", ["'contact'", "[scene.contact]"]),
    ],
)
def test_scene_tables_outside_scene_are_refused_not_dropped(write_config, text, words):
    """A site file with [solver] and [contact] (friction) tables but no [channel]/[instrument]
    used to be taken for recommended.toml, its friction dropped silently: now refused naming the
    tables and the fix ([scene.contact]); beside configuration tables, the same hint."""
    with pytest.raises(ConfigError) as info:
        read_config_file(write_config(text))
    for w in words:
        assert w in str(info.value)


def test_recommended_toml_names_what_it_does_not_take(write_config, caplog):
    """A complete scene file: its numerical settings are taken and a warning names the rest
    (here channel, instrument but its element lengths, contact, solver.kind)."""
    rec = write_config(
        """\
        [channel]
        kind = "arc"
        [instrument]
        preset = "flexitron"
        [contact]
        mu_k = 0.3
        [solver]
        kind = "quasistatic"
        increment_mm = 0.25
        """,
        "recommended.toml",
    )
    with caplog.at_level("WARNING", logger="ringqa.config"):
        cfg = read_config_file(rec)
    assert cfg == {"scene.solver.increment_mm": 0.25}
    text = caplog.text
    assert "not taken: channel, instrument (but its sections' element lengths), contact" in text
    assert "solver.kind" in text
