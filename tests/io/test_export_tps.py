"""Back to the planning system (issue 15 part 4): ``source_path_<channel>.csv`` and
``RP_simulated.dcm`` from a commissioning run of the shipped Oncentra example.

The run uses ringqa's real geometry and scenes with a stand-in simulator (the centreline
positions pushed 0.3 mm outward, :func:`tests.pipeline.fakes.fake_simulator`), so the simulated
positions differ from the plan's by a known, non-zero amount and the test takes seconds.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import pydicom
import pytest

from ringqa.io.export_tps import (
    PLAN_LABEL,
    SOURCE_PATH_COLUMNS,
    ExportError,
    check_export,
    simulated_paths,
    simulated_rtplan,
    write_exports,
)
from ringqa.io.rtplan import read_rtplan
from ringqa.pipeline import commission
from tests.pipeline.fakes import fake_simulator, stand_in_engine

EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"


@pytest.fixture(scope="module")
def example_result(repo_root):
    return commission(repo_root / EXAMPLE, engine=stand_in_engine(fake_simulator()))


@pytest.fixture(scope="module")
def exported(example_result, tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # pydicom's writing checks: no warning
        written = write_exports(example_result, folder)
    return folder, written


def _simulated(result) -> pd.DataFrame:
    d = result.dwells
    return d[d["path"] == "simulated"].sort_values("relative_position_mm")


def test_source_path_csv_is_the_simulated_path(example_result, exported):
    """Columns exactly the contract's; every row equals the simulated row of dwells (6
    decimals written: 1e-6 mm); directions are unit vectors."""
    folder, written = exported
    assert written == ["export/source_path_ring.csv", "export/RP_simulated.dcm"]
    table = pd.read_csv(folder / "export" / "source_path_ring.csv")
    assert tuple(table.columns) == SOURCE_PATH_COLUMNS
    sim = _simulated(example_result)
    assert len(table) == len(sim) == 30  # the library path: 30 positions 2.5 mm apart
    np.testing.assert_allclose(table["relative_position_mm"], sim["relative_position_mm"])
    cols = ["x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z"]
    np.testing.assert_allclose(table[cols].to_numpy(), sim[cols].to_numpy(), atol=1e-6)
    norms = np.linalg.norm(table[["dir_x", "dir_y", "dir_z"]].to_numpy(), axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-5)


def test_rtplan_reimported_gives_simulated_positions_and_original_times(
    repo_root, example_result, exported
):
    """Re-imported by ringqa's reader (as ``ringqa import``): the ring channel's dwells are the
    simulated positions at the same relative positions within 0.01 mm (written to 1e-4 mm),
    and moved (the stand-in pushes them ~0.3 mm: a copy of the input would fail); every dwell
    time and channel total time equals the original exactly; the tandem is untouched."""
    folder, _ = exported
    original = read_rtplan(repo_root / EXAMPLE)
    new = read_rtplan(folder / "export" / "RP_simulated.dcm")
    sim = _simulated(example_result).set_index("relative_position_mm")
    ring_o, ring_n = original.channel(1), new.channel(1)
    np.testing.assert_array_equal(ring_n.relative_position_mm, ring_o.relative_position_mm)
    expected = sim.loc[ring_o.relative_position_mm, ["x_mm", "y_mm", "z_mm"]].to_numpy()
    assert np.abs(ring_n.positions_mm - expected).max() < 0.01
    assert np.linalg.norm(ring_n.positions_mm - ring_o.positions_mm, axis=1).min() > 0.1
    for o, n in zip(original.channels, new.channels, strict=True):
        np.testing.assert_array_equal(n.times_s, o.times_s)
        assert n.total_time_s == o.total_time_s
    np.testing.assert_array_equal(new.channel(2).positions_mm, original.channel(2).positions_mm)
    assert new.library is not None and 1 in new.library  # the private library still read


def test_rtplan_header_says_simulated_and_passes_pydicom_validation(repo_root, exported, tmp_path):
    """New SOP instance and series UIDs, label/description saying it is for verification;
    read and written again by pydicom with file-format enforcement, without a warning."""
    folder, _ = exported
    old = pydicom.dcmread(repo_root / EXAMPLE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = pydicom.dcmread(folder / "export" / "RP_simulated.dcm")
        ds.save_as(tmp_path / "again.dcm", enforce_file_format=True)
    assert ds.SOPInstanceUID != old.SOPInstanceUID
    assert ds.file_meta.MediaStorageSOPInstanceUID == ds.SOPInstanceUID
    assert ds.SeriesInstanceUID != old.SeriesInstanceUID
    assert ds.StudyInstanceUID == old.StudyInstanceUID
    assert ds.RTPlanLabel == PLAN_LABEL
    assert "COMMISSIONING VERIFICATION" in ds.RTPlanDescription
    assert "NOT FOR TREATMENT" in ds.RTPlanDescription
    assert ds.ApprovalStatus == "UNAPPROVED"


def test_second_plan_refused(example_result, rtplan_factory):
    """A second plan whose channel 1 dwells (0, 5, 10 mm... of the factory) are not all among
    the simulated relative positions (0, 2.5, ..., 72.5 mm): 0/5/10 are, so the factory plan is
    edited to 7 mm; and a plan without channel 1 at all. Both refused."""
    sim = simulated_paths(example_result)["ring"]
    other = rtplan_factory(channels=({"number": 1, "dwells": [(7.0, (1.0, 2.0, 3.0), 5.0)]},))
    with pytest.raises(ExportError, match=r"relative position 7 mm was not simulated"):
        simulated_rtplan(other, 1, sim)
    no_ring = rtplan_factory(channels=({"number": 2, "dwells": [(0.0, (0, 0, 0), 5.0)]},))
    with pytest.raises(ExportError, match="no channel 1 with dwells"):
        simulated_rtplan(no_ring, 1, sim)


def test_nothing_simulated_refused(example_result):
    """A result without simulated dwells: refused, naming the input."""
    d = example_result.dwells
    empty = dataclasses.replace(example_result, dwells=d[d["path"] != "simulated"])
    with pytest.raises(ExportError, match="no simulated channel"):
        check_export(empty)


def _edited_plan(repo_root, tmp_path, shift_mm: float, control_point: int = 0):
    """The example plan with ring channel 1's control point moved along its relative positions
    by ``shift_mm`` (its 3D position unchanged)."""
    ds = pydicom.dcmread(repo_root / EXAMPLE)
    for setup in ds.ApplicationSetupSequence:
        for item in setup.ChannelSequence:
            if int(item.ChannelNumber) == 1:
                cp = item.BrachyControlPointSequence[control_point]
                cp.ControlPointRelativePosition = float(cp.ControlPointRelativePosition) + shift_mm
    path = tmp_path / "RP_edited.dcm"
    ds.save_as(path)
    return path


def test_plan_whose_relative_and_3d_positions_disagree_is_refused(
    repo_root, example_result, tmp_path
):
    """Control point 0's relative position moved by +2.5 mm (one dwell) and +26.8 mm (the issue's
    case), its 3D position kept: matched by 3D position to the commissioned dwell, whose
    relative position then differs by 2.5 / 26.8 mm > RELATIVE_TOL_MM = 0.1 mm: refused naming
    the channel and the control point. A 0.05 mm edit (within the tolerance) is exported, each
    dwell at the simulated position of its 3D match."""
    sim = simulated_paths(example_result)["ring"]
    for shift in (2.5, 26.8):
        plan = _edited_plan(repo_root, tmp_path, shift)
        with pytest.raises(ExportError, match=r"channel 1, control point 0: its relative posit"):
            simulated_rtplan(plan, 1, sim)
    plan = _edited_plan(repo_root, tmp_path, 0.05)
    ds = simulated_rtplan(plan, 1, sim)
    original = read_rtplan(repo_root / EXAMPLE).channel(1)
    ring = ds.ApplicationSetupSequence[0].ChannelSequence
    cps = next(i for i in ring if int(i.ChannelNumber) == 1).BrachyControlPointSequence
    k = int(np.argmin(np.linalg.norm(sim.reference_mm - original.positions_mm[0], axis=1)))
    np.testing.assert_allclose([float(v) for v in cps[0].ControlPoint3DPosition],
                               sim.positions_mm[k], atol=1e-4)  # fmt: skip


def test_exported_plan_names_ringqa_as_its_maker(exported):
    """Manufacturer / ManufacturerModelName 'ringqa', SoftwareVersions 'ringqa <version>' (the
    input's 'Nucletron' / 'OTP V4.3.0.410' are gone)."""
    from ringqa import __version__

    folder, _ = exported
    ds = pydicom.dcmread(folder / "export" / "RP_simulated.dcm")
    assert ds.Manufacturer == "ringqa" and ds.ManufacturerModelName == "ringqa"
    assert ds.SoftwareVersions == f"ringqa {__version__}"


def test_results_json_lists_the_export_with_sha256(repo_root, example_result, tmp_path):
    """write_report with export: results.json 'export' lists both files with their size and
    SHA-256 (recomputed here with hashlib) and 'files' names them; the report's note names
    them (export_note)."""
    import hashlib
    import json

    from ringqa.io.export_tps import check_export, export_note
    from ringqa.report import write_report

    out = tmp_path / "out"
    write_report(example_result, out, pdf=False, export=True)
    record = json.loads((out / "results.json").read_text())
    names = ["export/source_path_ring.csv", "export/RP_simulated.dcm"]
    assert [e["path"] for e in record["export"]] == names
    for e in record["export"]:
        data = (out / e["path"]).read_bytes()
        assert e["sha256"] == hashlib.sha256(data).hexdigest() and e["size"] == len(data)
    assert set(names) <= set(record["files"])
    (line,) = export_note(check_export(example_result))
    assert all(n in line for n in names)
