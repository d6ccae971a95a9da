"""The report's settings page is made from the settings table
(:data:`ringqa.pipeline.settings.SETTINGS`): a new row appears on it without a report edit, and
every row of the table is on the page of the example's result."""

from __future__ import annotations

import dataclasses

import pytest

from ringqa.pipeline import settings as setting_table
from ringqa.pipeline.settings import Setting
from ringqa.report import layout
from ringqa.report.fields import ReportFields
from ringqa.report.pdf import page_stamp, settings_flowables
from tests.report.conftest import pdf_pages_text


def _page_text(res, path, fields=None) -> str:
    """The settings page of ``res`` alone, rendered to ``path``, as text without white space
    (cells wrap; the words stay in order)."""
    layout.build_pdf(path, settings_flowables(res, fields), page_stamp(res), title="settings")
    return "".join(" ".join(pdf_pages_text(path)).split())


def _dense(*cells: str) -> str:
    return "".join("".join(cells).split())


def test_a_new_setting_appears_without_a_report_edit(fake_result, tmp_path, monkeypatch):
    """Two rows added to a copy of the table (nothing else changed): ``report.label`` (a
    report field the table does not list today; its value comes from the fields, "Ring #7")
    and ``simulation.new_knob_mm`` (recorded nowhere: value ``-``, unit mm) both show with
    their table's group, and the origin given for the knob (a configuration file) is printed
    as ``--config [1]`` with the file named under the table."""
    rows = (
        *setting_table.SETTINGS,
        Setting("report.label", "", "", "text", "a short label for the applicator"),
        Setting("simulation.new_knob_mm", "mm", 1.5, "number", "a knob added tomorrow"),
    )
    monkeypatch.setattr(setting_table, "SETTINGS", rows)
    origins = {s.key: "default" for s in rows}
    origins["simulation.new_knob_mm"] = "--config /site/ringqa.toml"
    res = dataclasses.replace(fake_result, settings_origin=origins)
    text = _page_text(res, tmp_path / "page.pdf", ReportFields(label="Ring #7"))
    assert _dense("label", "Ring #7", "default") in text
    assert _dense("new_knob_mm", "-", "mm", "--config [1]") in text
    assert _dense("[1] --config /site/ringqa.toml") in text
    for table in ("[tolerances]", "[plan]", "[dose_points]", "[simulation]", "[report]"):
        assert table in text, table


@pytest.fixture(scope="module")
def example_result(repo_root):
    """The example RT Plan commissioned with ``--register plane-height`` given on the command
    line (through the configuration, so every key has an origin), by the stand-in engine (the
    page shows settings, not the simulation)."""
    from ringqa.config import COMMAND_LINE, effective_config
    from ringqa.datasets import example_plan
    from ringqa.pipeline import commission
    from tests.pipeline.fakes import fake_simulator, stand_in_engine

    cfg = effective_config(command_line={"simulation.register": "plane-height"}, user_file=None)
    assert cfg.origins["simulation.register"] == COMMAND_LINE
    return commission(example_plan(), cfg.settings(), engine=stand_in_engine(fake_simulator()))


def test_every_row_of_the_table_is_on_the_example_page(example_result, tmp_path):
    """Every row of SETTINGS is on the example's settings page as ``name value unit origin``
    (value: :meth:`Setting.value_in` of the run's record, ``-`` for an empty one). By hand,
    from the example run: register ``plane-height`` from the command line; the tolerances
    1.0 / 2.0 mm and 5.0 %, 7.0 Gy, 5.0 mm plan step, 7 tandem dwells, stem 60.0 mm, whole
    channel False and cross-check True are the defaults; the source mhdr-v2, the plan's
    40820.0 U and the microselectron cable come from the plan; the physicist is the field
    given; the calibration keys are empty (no calibration file)."""
    from ringqa.report.pdf import settings_record

    fields = ReportFields(physicist="Dr. A. Physicist")
    text = _page_text(example_result, tmp_path / "page.pdf", fields)
    record = settings_record(example_result, fields)
    for s in setting_table.SETTINGS:
        value = s.value_in(record)
        recorded = value is not setting_table.NOT_RECORDED
        assert recorded or s.table == "calibration", s.key  # no calibration file: none
        shown = "-" if not recorded or value in ("", None) else str(value)
        origin = example_result.settings_origin[s.key] if s.table != "calibration" else "default"
        assert _dense(s.name, shown, s.unit, origin) in text, s.key
    by_hand = [
        ("register", "plane-height", "", "command line"),
        ("position_recommended_mm", "1.0", "mm", "default"),
        ("position_required_mm", "2.0", "mm", "default"),
        ("dose_action_pct", "5.0", "%", "default"),
        ("prescription_gy", "7.0", "Gy", "default"),
        ("step_mm", "5.0", "mm", "default"),
        ("tandem_dwells", "7", "", "default"),
        ("source", "mhdr-v2", "", "default"),
        ("sk_u", "40820.0", "U", "default"),
        ("cable", "microselectron", "", "default"),
        ("stem_mm", "60.0", "mm", "default"),
        ("whole_channel", "False", "", "default"),
        ("cross_check", "True", "", "default"),
        ("physicist", "Dr. A. Physicist", "", "default"),
        ("command", "-", "", "default"),
    ]
    for row in by_hand:
        assert _dense(*row) in text, row
    # what results.json records beyond the table: the channel, --set, the correction file
    for key in ("channel", "scene_overrides", "centreline_correction"):
        assert key in text, key


def test_value_in_reads_each_form_of_record():
    """:meth:`Setting.value_in` by hand: a plain key, a table's key by name, the tolerance
    pair by position, the whole-channel flag from a None stem, and a key not recorded."""
    by_key = {s.key: s for s in setting_table.SETTINGS}
    record = {
        "register": "rigid",
        "dose_points": {"point_a_height_mm": 20.0},
        "position_limits_mm": [0.5, 3.0],
        "stem_mm": None,
    }
    assert by_key["simulation.register"].value_in(record) == "rigid"
    assert by_key["dose_points.point_a_height_mm"].value_in(record) == 20.0
    assert by_key["tolerances.position_recommended_mm"].value_in(record) == 0.5
    assert by_key["tolerances.position_required_mm"].value_in(record) == 3.0
    assert by_key["simulation.whole_channel"].value_in(record) is True
    assert by_key["simulation.stem_mm"].value_in(record) is None
    assert by_key["simulation.whole_channel"].value_in({"stem_mm": 60.0}) is False
    assert by_key["plan.prescription_gy"].value_in(record) is setting_table.NOT_RECORDED
