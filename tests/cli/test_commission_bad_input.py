"""Issue 13's bad inputs on the command line: one clear line, exit 2, nothing written; and a
centreline correction that is used (real applicators and engine)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ringqa.cli import main
from ringqa.geometry import ring_applicator
from ringqa.io.points import write_points


def _one_line_exit_2(args, tmp_path, capsys, fragment):
    out = tmp_path / "out"
    assert main(["commission", *args, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()  # nothing written, no staging folder
    return err


def _correction_points(radius_mm: float, s_mm: np.ndarray) -> np.ndarray:
    """ring26x60's circle (centre 0, radius 13 mm, z = 0) starts at arc length 88 mm at 1.5 deg
    azimuth; points at arc lengths s (mm) on a circle of ``radius_mm`` instead (m)."""
    phi = np.deg2rad(1.5) + (s_mm - 88.0) / 13.0
    return np.column_stack([radius_mm * np.cos(phi), radius_mm * np.sin(phi), 0 * phi]) * 1e-3


def test_unknown_registration_mode(tmp_path, capsys):
    _one_line_exit_2(["ring26x60", "--register", "affine"], tmp_path, capsys,
                     "--register 'affine': unknown registration mode")  # fmt: skip


def test_correction_that_does_not_meet_the_centreline(tmp_path, capsys):
    """A segment 3 mm outside the ring's circle at both ends: its ends do not meet the library
    centreline (1 mm at most)."""
    bad = tmp_path / "bad.csv"
    write_points(bad, _correction_points(16.0, np.linspace(98.0, 118.0, 41)))
    _one_line_exit_2(["ring26x60", "--centreline-correction", str(bad)], tmp_path, capsys,
                     "does not meet the centreline")  # fmt: skip


def test_correction_is_refused_in_batch_mode(tmp_path, capsys):
    seg = tmp_path / "seg.csv"
    write_points(seg, _correction_points(13.0, np.linspace(98.0, 118.0, 41)))
    _one_line_exit_2(["--all-shipped", "--centreline-correction", str(seg)], tmp_path, capsys,
                     "--centreline-correction: give one applicator")  # fmt: skip


def test_reference_path_with_fewer_than_three_positions_on_the_channel(tmp_path, capsys):
    """A folder whose 5-position path has 3 positions 20 mm above the ring (not along the
    channel): 2 < 3 positions on the channel."""
    ring = ring_applicator(26, 60).channel("ring")
    folder = tmp_path / "app"
    folder.mkdir()
    write_points(folder / "centreline.csv", ring.centreline.points_m)
    path = ring.centreline.position(ring.s_ref_m - np.arange(5) * 2.5e-3)
    path[2:, 2] += 0.02
    write_points(folder / "measured_path.csv", path)
    spec = {"name": "few", "lumen": {"kind": "circular", "r_b_mm": 1.5, "r_a_mm": 1.4},
            "s_ref_mm": ring.s_ref_m * 1e3, "measured_step_mm": 2.5}  # fmt: skip
    (folder / "applicator.json").write_text(json.dumps(spec))
    _one_line_exit_2([str(folder)], tmp_path, capsys, "only 2 reference position(s)")


@pytest.mark.slow
def test_a_correction_is_used_and_reported(tmp_path):
    """The proximal ring of ring26x60 (arc length 98-118 mm) moved 0.5 mm outward: the run
    succeeds, the notes say which file replaced which range, and the provenance lists it."""
    seg = tmp_path / "ct_ring.csv"
    write_points(seg, _correction_points(13.5, np.linspace(98.0, 118.0, 41)))
    out = tmp_path / "out"
    assert main(["commission", "ring26x60", "--out", str(out), "--quiet", "--no-pdf",
                 "--centreline-correction", str(seg)]) == 0  # fmt: skip
    data = json.loads((out / "results.json").read_text())
    assert any(n.startswith("Centreline correction: ct_ring.csv replaces the ring channel")
               for n in data["notes"])  # fmt: skip
    assert data["settings"]["centreline_correction"] == str(seg)
    assert any(str(seg) in json.dumps(i) for i in data["provenance"]["inputs"])
