"""The report files: contract columns, stable JSON keys, a PDF with the expected pages, staging."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from ringqa.pipeline import commission, commission_batch
from ringqa.report import SCHEMA, write_batch, write_report
from tests.pipeline.fakes import fake_engine, fake_simulator, make_applicator

DWELL_COLUMNS = {"applicator", "dwell", "path", "x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z",
                 "dist_to_measured_mm"}  # fmt: skip
DOSE_COLUMNS = {"applicator", "point", "plan", "dose_gy", "diff_pct"}
JSON_KEYS = {"schema", "applicator", "input", "input_kind", "reference", "passed", "verdicts",
             "summary", "notes", "settings", "simulation", "dose_points", "doses", "geometry",
             "timings_s", "provenance", "files", "conclusion", "reference_check",
             "numerical_check", "settings_origin", "warnings"}  # fmt: skip


#: The column order of summary.csv and the key order of results.json's typed sections, as
#: ringqa 0.1 wrote them before the result became typed (other tools read them by position too).
SUMMARY_COLUMNS = (
    "applicator,reference,source,n_dwells,n_plan_dwells_ring,n_plan_dwells_tandem,s_ref_mm,"
    "median_dist_sim_mm,max_dist_sim_mm,max_along_sim_mm,max_radial_sim_mm,"
    "max_out_of_plane_sim_mm,max_angle_sim_deg,max_angle_sim_vs_centreline_deg,"
    "median_dist_centreline_mm,max_dist_centreline_mm,max_along_centreline_mm,"
    "max_radial_centreline_mm,max_out_of_plane_centreline_mm,max_angle_centreline_deg,"
    "max_abs_diff_point_a_simulated_pct,max_abs_diff_surface_simulated_pct,"
    "max_abs_diff_depth5_simulated_pct,max_abs_diff_point_a_centreline_pct,"
    "max_abs_diff_surface_centreline_pct,max_abs_diff_depth5_centreline_pct,point_a_mean_gy,"
    "simulation_status,solve_time_s,verdict"
).split(",")
#: Issue 13's contract columns, appended after them.
SUMMARY_CONTRACT_13 = [
    "registration", "n_reference_infeasible", "median_dist_sim_registered_mm",
    "max_dist_sim_registered_mm", "median_dist_centreline_registered_mm",
    "max_dist_centreline_registered_mm", "max_numerical_error_mm", "median_radial_reference_mm",
    "median_radial_sim_mm", "median_radial_centreline_mm",
]  # fmt: skip
DWELL_CONTRACT_13 = {"radial_from_centreline_mm", "height_mm", "numerical_error_mm",
                     "reference_flag"}  # fmt: skip
SECTION_KEYS = {
    "settings": ["source", "sk_U", "prescription_gy", "cable", "channel", "plan_step_mm",
                 "tandem_dwells", "position_limits_mm", "dose_action_pct", "dose_points",
                 "scene_overrides", "scene", "register", "stem_mm", "centreline_correction"],
    "simulation": ["status", "message", "warnings", "solve_time_s", "wall_time_s", "n_elements",
                   "settings"],
    "geometry": ["ring_centre_mm", "ring_normal", "ring_lateral", "ring_radius_mm", "s_ref_mm",
                 "metadata"],
    "timings_s": ["load_s", "simulation_s", "dose_s", "total_s"],
}  # fmt: skip


@pytest.fixture(scope="module")
def result():
    return commission(make_applicator(tandem=True), engine=fake_engine(fake_simulator(z_m=2e-4)))


def test_contract_files(result, tmp_path):
    out = tmp_path / "out"
    write_report(result, out)
    for name in ("dwells.csv", "doses.csv", "plan_dwells.csv", "summary.csv", "results.json",
                 "report.pdf"):  # fmt: skip
        assert (out / name).is_file(), name
    dwells = pd.read_csv(out / "dwells.csv")
    assert DWELL_COLUMNS <= set(dwells.columns)
    assert set(dwells["path"]) == {"measured", "simulated", "centreline"}
    doses = pd.read_csv(out / "doses.csv")
    assert DOSE_COLUMNS <= set(doses.columns)
    assert len(pd.read_csv(out / "summary.csv")) == 1
    data = json.loads((out / "results.json").read_text())
    assert set(data) == JSON_KEYS
    header = (out / "summary.csv").read_text().splitlines()[0].split(",")
    assert header[: len(SUMMARY_COLUMNS)] == SUMMARY_COLUMNS  # old readers index by position
    assert set(SUMMARY_CONTRACT_13) <= set(header[len(SUMMARY_COLUMNS) :])
    assert DWELL_CONTRACT_13 <= set(dwells.columns)
    assert list(data["summary"]) == header
    for section, keys in SECTION_KEYS.items():
        assert list(data[section]) == keys, section
    assert data["schema"] == SCHEMA
    assert data["provenance"]["software"].startswith("ringqa ")
    assert {v["status"] for v in data["verdicts"]} <= {"PASS", "WARN", "FAIL", "ACTION"}
    # the CSV round-trips the numbers (6 significant digits)
    sim = dwells[dwells.path == "simulated"]["dist_to_measured_mm"].to_numpy()
    ref = result.dwells[result.dwells.path == "simulated"]["dist_to_measured_mm"].to_numpy()
    assert sim == pytest.approx(ref, rel=1e-5)
    pdf = (out / "report.pdf").read_bytes()
    # page 1 continues on a second text page (the numbers as supplied | registered, the notes)
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page") - pdf.count(b"/Type /Pages") == 7


def test_failed_write_leaves_nothing(result, tmp_path, monkeypatch):
    """An error while writing the PDF: no out folder, no staging folder left behind."""
    import ringqa.report as report

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(report, "write_pdf", boom)
    with pytest.raises(RuntimeError):
        write_report(result, tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


def test_batch_folder(tmp_path):
    apps = [make_applicator(name="a"), make_applicator(name="b", r_b=0.3e-3),
            make_applicator(name="c", n_measured=0)]  # fmt: skip
    batch = commission_batch(apps, progress=False, engine=fake_engine())
    write_batch(batch, tmp_path / "all")
    out = tmp_path / "all"
    expected = {"a", "c", "summary.csv", "all_dwells.csv", "all_doses.csv", "batch.json",
                "summary.pdf", ".ringqa-output.json"}  # fmt: skip
    assert {p.name for p in out.iterdir()} == expected
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["applicator"]) == ["a", "b", "c"]
    assert summary.loc[1, "verdict"] == "ERROR" and "cannot pass" in summary.loc[1, "error"]
    assert list(summary["reference"].fillna("")) == ["measured", "", "centreline"]
    info = json.loads((out / "batch.json").read_text())
    assert info["failures"][0]["input"] == "b"


def test_accuracy_page(result, tmp_path):
    """An accuracy.csv adds one page; a table without the contract columns is refused by name."""
    from ringqa.errors import RingQAError

    csv = tmp_path / "accuracy.csv"
    table = {"time_s": [0.1, 0.5, 2.0], "max_err_mm": [0.3, 0.05, 0.01], "status": [0, 0, 0],
             "pareto": [True, True, True]}  # fmt: skip
    pd.DataFrame(table).to_csv(csv, index=False)
    write_report(result, tmp_path / "out", accuracy_csv=csv)
    pdf = (tmp_path / "out" / "report.pdf").read_bytes()
    assert pdf.count(b"/Type /Page") - pdf.count(b"/Type /Pages") == 8
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(RingQAError, match="max_err_mm"):
        write_report(result, tmp_path / "out2", accuracy_csv=bad)
    assert not (tmp_path / "out2").exists()


def test_table2_rows_median_and_range():
    """Two applicators, reference 'measured'; centreline plan diffs at Point A left/right of
    (+1, -2) % and (+3, +0.5) %: per applicator max |diff| = 2 and 3, so median 2.5 (2.0 - 3.0);
    surface (4, -8) and (1, 1) -> 8 and 1 -> 4.5 (1.0 - 8.0)."""
    from types import SimpleNamespace

    from ringqa.report.pdf import table2_rows

    def fake(a, s, d):
        kinds = ["point_a", "point_a", "surface", "surface", "depth5", "depth5"]
        diffs = [*a, *s, *d]
        doses = pd.DataFrame({"plan": "centreline", "kind": kinds, "diff_pct": diffs})
        return SimpleNamespace(reference="measured", doses=doses)

    rows = table2_rows([fake((1, -2), (4, -8), (0, 0)), fake((3, 0.5), (1, 1), (2, 2))])
    # dose differences in their one printed form (ringqa.pipeline.numbers.DOSE_PCT)
    assert rows == [["measured - centreline (2)", "2.50 (2.00 - 3.00)", "4.50 (1.00 - 8.00)",
                     "1.00 (0.00 - 2.00)"]]  # fmt: skip
