"""One source of truth per number: every number the report prints more than once reads the same
everywhere it appears (PDF pages, CSV files, results.json, the batch's summary.pdf and box plot,
the uncertainty page).

Two runs, as a user makes them:

- the shipped example with ``--register plane-height --uncertainty 16`` (README's quick start
  plus the uncertainty page; the sweep's numerical check calibrated on 2 samples, see
  ``example_run``);
- a batch of two copies of the example plan in two folders, registered (two inputs of the same
  model, told apart by summary.csv's ``input``).

What is checked (each number against the one it must equal; printed numbers are the file's
numbers in their one printed form, :mod:`ringqa.pipeline.numbers`):

- every verdict's value is the largest judged number of the tables it judges: the largest
  ``dist_to_reference_mm`` of the compared (registered, outside-channel positions left out)
  simulated / centreline dwells in dwells.csv, the largest ``|diff_registered_pct|`` of the
  plan's standard points in doses.csv, summary.csv's ``*_registered`` columns;
- the verdict texts, the conclusion and page 1's "registered" column print those values in
  the verdict's form (the conclusion used to say 15.6 % where the dose table said 15.96 %);
- every dose-table cell prints doses.csv's differences;
- the uncertainty page judges the same comparison: its dwells are the compared ones (dwells
  29-30, outside the channel, are not failed there), its dose intervals are those of
  uncertainty.csv and of the registered dose differences;
- summary.pdf's table and box plot show the judged (registered) numbers of summary.csv, one row
  per input with its input file;
- no absolute path of the installation in results.json, the CSV files or the PDF text.

How it was shown to fail on the main of issue 27: the checks were run against that main's
output (the same commands), where the conclusion's "15.6 %" is no verdict value, the uncertainty
page judges 30 dwells (the compared ones are 28) and its Point A intervals lie around the
unregistered differences, and summary.pdf prints the unregistered medians.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import ringqa
from ringqa.cli import main
from ringqa.datasets import example_plan
from ringqa.pipeline.numbers import DIST_MM, DOSE_GY, DOSE_PCT, SIGNED_PCT, fmt, fmt_verdict_value
from ringqa.pipeline.verdicts import CHECK_CENTRELINE, CHECK_NUMERICS, CHECK_SIMULATED
from tests.report.conftest import pdf_pages_text

pytestmark = pytest.mark.slow

INSTALL = str(Path(ringqa.__file__).resolve().parent.parent)
REPO = Path(__file__).resolve().parents[2]


def flat(text: str) -> str:
    """Whitespace (line breaks of table cells and paragraphs) as single spaces."""
    return " ".join(text.split())


def pdf_text(path: Path) -> str:
    return flat(" ".join(pdf_pages_text(path)))


@pytest.fixture(scope="module")
def example_run(tmp_path_factory):
    """``ringqa commission --example --register plane-height --uncertainty 16``, given as what
    ``--uncertainty 16`` stands for (``--sweep`` with the shipped ring26-uncertainty.toml at 16
    samples) with the sweep's numerical check calibrated on 2 samples instead of 5: each is a
    run at the tight settings (~8 s of CPU each), and no check here reads the calibration."""
    root = tmp_path_factory.mktemp("consistency")
    shipped = (REPO / "data" / "sweeps" / "ring26-uncertainty.toml").read_text(encoding="utf-8")
    text, n = re.subn(r"(?m)^samples = 256\b.*$", "samples = 16\ncalibration_samples = 2", shipped)
    assert n == 1, "the shipped spec's 'samples = 256' line moved: update this fixture"
    spec = root / "uncertainty16.toml"
    spec.write_text(text, encoding="utf-8")
    out = root / "example"
    code = main(["commission", "--example", "--register", "plane-height", "--sweep", str(spec),
                 "--out", str(out), "--quiet"])  # fmt: skip
    assert code == 0
    return out


@pytest.fixture(scope="module")
def batch_run(tmp_path_factory):
    """Two copies of the example plan (a/ and b/), one batch, registered."""
    root = tmp_path_factory.mktemp("consistency-batch")
    inputs = []
    for name in ("a", "b"):
        (root / name).mkdir()
        inputs.append(str(shutil.copy(example_plan(), root / name / example_plan().name)))
    out = root / "out"
    code = main(["commission", *inputs, "--register", "plane-height", "--out", str(out),
                 "--quiet", "--workers", "1"])  # fmt: skip
    assert code == 0
    return out


def _verdicts(info: dict) -> dict[str, dict]:
    return {v["check"]: v for v in info["verdicts"]}


def check_applicator(folder: Path) -> None:
    """Every number of one applicator's outputs that appears more than once, compared."""
    info = json.loads((folder / "results.json").read_text())
    summary = pd.read_csv(folder / "summary.csv").iloc[0]
    dwells = pd.read_csv(folder / "dwells.csv", keep_default_na=False, na_values=[""])
    doses = pd.read_csv(folder / "doses.csv", keep_default_na=False, na_values=[""])
    text = pdf_text(folder / "report.pdf")
    by = _verdicts(info)
    registered = info["summary"]["registration"] != "none"
    assert registered
    # summary.csv and results.json's summary are one row
    for key, value in info["summary"].items():
        if isinstance(value, float) and math.isfinite(value):
            assert summary[key] == pytest.approx(value, rel=1e-5, abs=1e-9), key
    assert summary["input"] == info["input"]

    # positions: the verdict = summary's registered max = dwells.csv's compared max
    compared = dwells[dwells["reference_flag"].astype(str) != "outside_channel"]
    for check, path, column in (
        (CHECK_SIMULATED, "simulated", "max_dist_sim_registered_mm"),
        (CHECK_CENTRELINE, "centreline", "max_dist_centreline_registered_mm"),
    ):
        value = by[check]["value"]
        worst = compared[compared["path"] == path]["dist_to_reference_mm"].max()
        assert worst == pytest.approx(value, abs=1e-5), check
        assert summary[column] == pytest.approx(value, abs=1e-5), check
        shown = fmt(value, DIST_MM)
        assert f"max {shown} mm" in by[check]["text"]
        # page 1: "as supplied | registered": the registered column is the verdict's number
        name = "Simulated" if path == "simulated" else "Centreline"
        row = re.search(rf"{name} vs reference: max distance \(mm\) (\S+) (\S+)", text)
        assert row is not None and row.group(2) == shown, (check, row and row.group(0))
    # doses: the verdict = the largest |registered difference| at the plan's standard points
    standard = doses[doses["kind"] != "tps"]
    for plan in ("simulated", "centreline"):
        v = by[f"dose: {plan} plan vs reference plan"]
        diffs = standard[standard["plan"] == plan]["diff_registered_pct"].abs()
        assert diffs.max() == pytest.approx(v["value"], abs=1e-4), plan
        kinds = [summary[f"max_abs_diff_{k}_{plan}_registered_pct"]
                 for k in ("point_a", "surface", "depth5")]  # fmt: skip
        assert max(kinds) == pytest.approx(v["value"], abs=1e-4), plan
        # every dose-table cell prints doses.csv's two differences
        for row in standard[standard["plan"] == plan].itertuples():
            raw, reg = fmt(row.diff_pct, SIGNED_PCT), fmt(row.diff_registered_pct, SIGNED_PCT)
            cell = f"({raw} / {reg} %)"
            assert cell in text, (plan, row.point, cell)
    assert by[CHECK_NUMERICS]["value"] == pytest.approx(summary["max_numerical_error_mm"])
    # every verdict text and the conclusion are printed as results.json has them, and every
    # number in the conclusion is a verdict's value in the verdict's form
    for v in info["verdicts"]:
        assert flat(v["text"]) in text, v["check"]
        assert fmt_verdict_value(v["value"], v["unit"], v["check"]) in v["text"], v["check"]
    forms = {fmt_verdict_value(v["value"], v["unit"], v["check"]) for v in info["verdicts"]}
    conclusion = info["conclusion"]
    assert flat(conclusion) in text
    quoted = re.findall(r"\d+\.\d+ (?:mm|%)", conclusion)
    assert quoted and set(quoted) <= forms, (quoted, forms)
    # no install path anywhere
    assert INSTALL not in text
    for name in ("results.json", "summary.csv", "dwells.csv", "doses.csv", "plan_dwells.csv"):
        assert INSTALL not in (folder / name).read_text(encoding="utf-8-sig"), name

    def strings(x):
        if isinstance(x, dict):
            yield from (s for k, v in x.items() for s in (k, *strings(v)))
        elif isinstance(x, list):
            yield from (s for v in x for s in strings(v))
        elif isinstance(x, str):
            yield x

    # the input is named as the user gave it; every other file relative to its folder or as
    # ringqa:data/...
    given = info["input"]
    absolute = [s for s in strings(info) if s.startswith("/") and Path(s).exists() and s != given]
    assert not absolute, absolute[:3]


def test_example_report_numbers_agree(example_run):
    """The example (registered, with the uncertainty page): see the module docstring."""
    check_applicator(example_run)


def test_uncertainty_page_judges_what_the_verdicts_judge(example_run):
    """The uncertainty page's dwells are the compared ones, its dose intervals are
    uncertainty.csv's, and its samples' dose differences are the registered ones."""
    text = pdf_text(example_run / "report.pdf")
    dwells = pd.read_csv(example_run / "dwells.csv", keep_default_na=False, na_values=[""])
    sim = dwells[dwells["path"] == "simulated"]
    out = sim[sim["reference_flag"].astype(str) == "outside_channel"]["dwell"].astype(int)
    n_compared = len(sim) - len(out)
    page = text[text.index("Uncertainty of the simulated positions and doses") :]
    m = re.search(r"Position: (holds at all (\d+) dwells|does NOT hold at \d+ of (\d+) dwells "
                  r"\(([^)]*)\))", page)  # fmt: skip
    assert m is not None
    assert int(m.group(2) or m.group(3)) == n_compared
    failed = {int(x) for x in (m.group(4) or "").replace("...", "").split(",") if x.strip()}
    assert not failed & set(out), "the page fails dwells the verdicts leave out"
    # the page's dose rows are uncertainty.csv's intervals
    csv = pd.read_csv(example_run / "uncertainty.csv", keep_default_na=False, na_values=[""])
    points = csv[csv["quantity"] == "dose_diff_pct"]
    all_doses = pd.read_csv(example_run / "doses.csv", keep_default_na=False, na_values=[""])
    standard = set(all_doses[all_doses["kind"] != "tps"]["point"])
    for row in points[points["point"].isin(standard)].itertuples():
        cells = f"{row.point} {fmt(row.p2_5, SIGNED_PCT)} {fmt(row.p97_5, SIGNED_PCT)}"
        assert cells in page, cells
    # the samples' dose differences are to the registered reference plan, as the verdicts':
    # where registration moves a point's difference by more than 1 %, the sampled mean lies
    # nearer the registered difference than the one as supplied (the sampling spread of the
    # example is a few tenths of a %; registration moves Point A by about 2 %)
    record = json.loads((example_run / "uncertainty_sweep.json").read_text())
    doses = pd.read_csv(example_run / "doses.csv", keep_default_na=False, na_values=[""])
    sim_doses = doses[(doses["plan"] == "simulated") & (doses["kind"] != "tps")]
    means = points.set_index("point")["mean"]
    moved = 0
    for row in sim_doses.itertuples():
        if abs(row.diff_pct - row.diff_registered_pct) > 1.0:
            moved += 1
            mean = means[row.point]
            assert abs(mean - row.diff_registered_pct) < abs(mean - row.diff_pct), row.point
    assert moved >= 2  # Point A left and right at least
    assert INSTALL not in json.dumps(record)


def test_batch_numbers_agree(batch_run):
    """Two inputs of the same model: two rows told apart by their input, each row's printed
    numbers are summary.csv's registered ones, each folder's report agrees with itself, and
    the box plot's boxes are the judged distances (medians = summary.csv's)."""
    summary = pd.read_csv(batch_run / "summary.csv", keep_default_na=False, na_values=[""])
    assert len(summary) == 2 and summary["input"].nunique() == 2
    assert all(INSTALL not in str(x) for x in summary["input"])
    text = pdf_text(batch_run / "summary.pdf")
    for row in summary.itertuples():
        cells = " ".join(
            fmt(getattr(row, c), form)
            for c, form in (
                ("median_dist_sim_registered_mm", DIST_MM),
                ("max_dist_sim_registered_mm", DIST_MM),
                ("max_dist_centreline_registered_mm", DIST_MM),
                ("max_abs_diff_surface_simulated_registered_pct", DOSE_PCT),
            )
        )
        # (cells wrap inside a table: compared without white space)
        line = f"{row.input} measured plane-height {cells} {row.verdict}"
        assert "".join(line.split()) in "".join(text.split()), line
        check_applicator(batch_run / row.folder)
        dwells = pd.read_csv(batch_run / row.folder / "dwells.csv",
                             keep_default_na=False, na_values=[""])  # fmt: skip
        judged = dwells[(dwells["path"] == "simulated")
                        & (dwells["reference_flag"].astype(str) != "outside_channel")]  # fmt: skip
        assert np.median(judged["dist_to_reference_mm"]) == pytest.approx(
            row.median_dist_sim_registered_mm, abs=1e-5
        )


def test_batch_box_plot_is_the_summary(batch_run):
    """What summary.pdf's box plot draws (:func:`ringqa.report.figures.batch_distances`) has
    the medians and maxima of summary.csv's judged columns, rebuilt here from the batch."""
    from ringqa.pipeline import commission_batch
    from ringqa.pipeline.settings import CommissionSettings
    from ringqa.report.figures import batch_distances

    summary = pd.read_csv(batch_run / "summary.csv", keep_default_na=False, na_values=[""])
    batch = commission_batch([example_plan()], CommissionSettings(register="plane-height"),
                             progress=False, workers=1)  # fmt: skip
    data, labels, _ = batch_distances(batch)
    row = summary.iloc[0]
    assert [lab.split("\n")[1] for lab in labels] == ["cen. vs meas.", "sim. vs meas."]
    for box, tag in ((data[0], "centreline"), (data[1], "sim")):
        assert np.median(box) == pytest.approx(row[f"median_dist_{tag}_registered_mm"], abs=1e-5)
        assert np.max(box) == pytest.approx(row[f"max_dist_{tag}_registered_mm"], abs=1e-5)


@pytest.fixture(scope="module")
def channels_run(tmp_path_factory):
    """``ringqa commission --example --register plane-height --centreline-reference``: the
    example's ring (channel 1) AND its tandem (channel 2, compared with its centreline) in one
    report."""
    out = tmp_path_factory.mktemp("consistency") / "channels"
    code = main(["commission", "--example", "--register", "plane-height",
                 "--centreline-reference", "--out", str(out), "--quiet"])  # fmt: skip
    assert code == 0
    return out


def test_several_channels_numbers_agree(channels_run, example_run):
    """One report for two channels: the front page's conclusion is results.json's, its verdict
    table prints every channel's verdict values (in the verdict's form) and statuses, every
    verdict text and channel conclusion is in the PDF, each channel's section prints its
    dose-table cells from doses.csv; the combined CSVs hold each channel folder's rows; the
    ring channel's numbers are the one-channel example's, digit for digit."""
    record = json.loads((channels_run / "results.json").read_text())
    pages = pdf_pages_text(channels_run / "report.pdf")
    front, text = flat(pages[0]), flat(" ".join(pages))
    assert [c["channel"] for c in record["channels"]] == ["1", "2"]
    assert flat(record["conclusion"]) in front
    read = {"keep_default_na": False, "na_values": [""], "dtype": {"channel": str}}
    combined = {name: pd.read_csv(channels_run / name, **read)
                for name in ("dwells.csv", "doses.csv", "summary.csv")}  # fmt: skip
    for ch in record["channels"]:
        info = ch["results"]
        assert info == json.loads((channels_run / ch["folder"] / "results.json").read_text())
        for v in info["verdicts"]:
            shown = fmt_verdict_value(v["value"], v["unit"], v["check"])
            assert f"{v['check']} {shown} {v['status']}" in front, (ch["channel"], v["check"])
            assert flat(v["text"]) in text, (ch["channel"], v["check"])
        assert flat(info["conclusion"]) in text
        for name, table in combined.items():
            own = pd.read_csv(channels_run / ch["folder"] / name, **read)
            rows = table[table["channel"] == ch["channel"]].reset_index(drop=True)
            assert list(table.columns)[-1] == "channel"
            rows = rows[list(own.columns)]  # a column of the other channel only: left out
            if name == "doses.csv":
                own = own[own["channel"] != "all"].reset_index(drop=True)
            if name == "summary.csv":
                rows, own = rows.drop(columns="solve_time_s"), own.drop(columns="solve_time_s")
            pd.testing.assert_frame_equal(  # the same cells (5 and 5.0 alike)
                rows, own, check_exact=True, check_dtype=False, obj=f"{ch['folder']}/{name}"
            )
        doses = combined["doses.csv"]
        mine = doses[(doses["channel"] == ch["channel"]) & (doses["kind"] != "tps")]
        registered = info["summary"]["registration"] != "none"
        for row in mine[mine["plan"].isin(["simulated", "centreline"])].itertuples():
            if row.plan == info["reference"]:
                continue  # the reference plan: its doses, no difference
            raw, reg = fmt(row.diff_pct, SIGNED_PCT), fmt(row.diff_registered_pct, SIGNED_PCT)
            cell = f"({raw} / {reg} %)" if registered else f"{fmt(row.dose_gy, DOSE_GY)} ({raw} %)"
            assert cell in text, (ch["channel"], row.plan, row.point, cell)
    # the ring channel = the one-channel example (the same comparison, the same digits)
    for name in ("dwells.csv", "doses.csv"):
        single = pd.read_csv(example_run / name, **read)
        rows = combined[name][combined[name]["channel"].isin(["1", "all"])].reset_index(drop=True)
        pd.testing.assert_frame_equal(rows, single, check_exact=True, check_dtype=False, obj=name)
