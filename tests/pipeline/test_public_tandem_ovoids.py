"""A real public tandem-and-ovoids RT Plan + RT Struct commissioned end to end.

The files: ``data/examples/eclipse_tandem_ovoids`` - an Eclipse/BrachyVision HDR plan on a water
phantom (GammaMed Plus iX, GammaMed Plus HDR source, S_K 40700 U) with its structure set, from
github.com/livingag/pyTG43 (``examples/HDR/RP.HDR.dcm``, ``RS.HDR.dcm`` at commit a6aa553,
Alex Livingstone), licence GNU AGPL-3.0 (copied beside the files; no patient data). No lumen
diameter is published for these Varian applicators: the run gives ``--lumen-mm 2.0`` (the report
says so) and compares with the centrelines (no measured source path ships with an Eclipse plan).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from ringqa.cli import main
from ringqa.io.rtstruct import polyline_distance_mm, read_rtstruct
from ringqa.paths import data_dir

FOLDER = data_dir() / "examples" / "eclipse_tandem_ovoids"
PLAN = FOLDER / "RP_tandem_ovoids_eclipse.dcm"
STRUCTURES = FOLDER / "RS_tandem_ovoids_eclipse.dcm"
LUMEN_MM = 2.0
#: Eclipse's doses at the plan's points: BrachyApplicationSetupDose x the summed
#: CumulativeDoseReferenceCoefficient (tests/io/test_eclipse_tandem_ovoids.py).
ECLIPSE_GY = {"PtA_left": 6.0015571, "PtA_right": 6.1361608}
#: channel -> (ROI, total bend of its contour in degrees; README of the example)
CHANNELS = {"1": ("tandem", 45.0), "2": ("right ovoid", 60.0), "3": ("left ovoid", 60.0)}
#: Flexitron cable (the GammaMed source has no cable model: borrowed): capsule and thin-cable
#: outer radii (mm), ringqa.simulation.instruments.
CAPSULE_R_MM, THIN_R_MM = 0.425, 0.25


@pytest.mark.slow
def test_real_tandem_and_ovoids_commissioned_end_to_end(tmp_path):
    """``ringqa commission RP --structures RS --lumen-mm 2 --centreline-reference``:

    - three channels simulated (tandem, right ovoid, left ovoid; none left out), each with its
      numerical error (finite, < 0.1 mm: refined-run differences) and no stabilised-step storm
      (at most 5 stabilised steps; the ovoids' 60 deg tip bends at r = 13 mm are not refused);
    - every simulated source centre inside the lumen: its distance from the exported contour is
      at most r_lumen - r_capsule = 1.0 - 0.425 = 0.575 mm (+ 0.05 mm for the fitted spline vs
      the polyline);
    - the simulated positions along the channel differ from the centreline's by at most the
      path shortening of a cable on the inner wall of the channel's bends, (r_lumen - r_thin) x
      total bend = 0.75 mm x 0.785 rad = 0.59 mm (tandem, 45 deg) and 0.75 mm x 1.047 rad =
      0.79 mm (ovoids, 60 deg);
    - doses.csv: for every channel, the centreline and simulated plans at Point A (left/right)
      and at the plan's own points PtA_left and PtA_right; the plan's own dwells dosed with the
      GammaMed Plus consensus data reproduce Eclipse's doses (6.00156 and 6.13616 Gy) within
      0.1 % (independent: the TPS's own calculation);
    - one report.pdf with a section per channel (tandem, ovoid, ovoid), the lumen given and the
      borrowed cable said in the notes.
    """
    out = tmp_path / "to"
    args = ["commission", str(PLAN), "--structures", str(STRUCTURES), "--lumen-mm",
            str(LUMEN_MM), "--centreline-reference", "--quiet", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    record = json.loads((out / "results.json").read_text())
    assert [c["channel"] for c in record["channels"]] == list(CHANNELS)
    assert [c["family"] for c in record["channels"]] == ["tandem", "ovoid", "ovoid"]
    assert record["not_simulated"] == []
    assert record["conclusion"].startswith("3 channels commissioned")
    for c in record["channels"]:
        res = c["results"]
        assert res["simulation"]["status"] == 0
        assert res["simulation"]["settings"]["n_stabilised_steps"] <= 5
        err = res["numerical_check"]["max_numerical_error_mm"]
        assert np.isfinite(err) and 0.0 <= err < 0.1
        assert c["max_numerical_error_mm"] == err
        notes = " ".join(res["notes"])
        assert f"lumen {LUMEN_MM:g} mm (given (--lumen-mm" in notes
        assert "Cable model: flexitron" in notes and "BORROWED" in notes

    contours = {c.roi_name: c.points_mm for c in read_rtstruct(STRUCTURES).contours}
    dwells = pd.read_csv(out / "dwells.csv", dtype={"channel": str})
    for channel, (roi, bend_deg) in CHANNELS.items():
        sim = dwells[(dwells["channel"] == channel) & (dwells["path"] == "simulated")]
        assert len(sim) >= 5 and sim["numerical_error_mm"].notna().all()
        xyz = sim[["x_mm", "y_mm", "z_mm"]].to_numpy()
        assert polyline_distance_mm(xyz, contours[roi]).max() <= LUMEN_MM / 2 - CAPSULE_R_MM + 0.05
        bound = (LUMEN_MM / 2 - THIN_R_MM) * np.radians(bend_deg)
        assert sim["along_mm"].abs().max() <= bound

    doses = pd.read_csv(out / "doses.csv", dtype={"channel": str})
    assert np.isfinite(doses["dose_gy"]).all()
    for channel in CHANNELS:
        for plan in ("centreline", "simulated"):
            rows = doses[(doses["channel"] == channel) & (doses["plan"] == plan)]
            points = set(rows["point"])
            assert {"point_a_left", "point_a_right", "PtA_left", "PtA_right"} <= points
            assert set(rows.loc[rows["point"].str.startswith("PtA"), "kind"]) == {"tps"}
    own = doses[doses["plan"] == "rtplan"].set_index("point")
    for point, gy in ECLIPSE_GY.items():
        assert own.loc[point, "tps_dose_gy"] == pytest.approx(gy, abs=1e-5)
        assert own.loc[point, "dose_gy"] == pytest.approx(gy, rel=1e-3)

    from tests.report.conftest import pdf_pages_text

    pages = pdf_pages_text(out / "report.pdf")
    heads = [p.splitlines()[0] for p in pages if p.startswith("Channel ")]
    assert heads == ["Channel 1 (tandem): tandem channel (tandem)",
                     "Channel 2 (right ovoid): ovoid channel (ovoid)",
                     "Channel 3 (left ovoid): ovoid channel (ovoid)"]  # fmt: skip
