"""``ringqa commission ... --export`` on the command line, and Oncentra's private tags read by
their creator (pydicom's ``private_block``), not by a fixed tag number."""

from __future__ import annotations

import dataclasses
import importlib

import pandas as pd
import pydicom
import pytest

from ringqa.cli import main
from ringqa.io.export_tps import SOURCE_PATH_COLUMNS
from ringqa.io.rtplan import read_rtplan
from ringqa.pipeline.inputs import LoadedInput
from tests.pipeline.fakes import fake_engine, make_applicator

pc = importlib.import_module("ringqa.pipeline.commission")
ps = importlib.import_module("ringqa.pipeline.simulate")
pipeline = importlib.import_module("ringqa.pipeline")

EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"


@pytest.fixture
def fakes(monkeypatch):
    def loader(item):
        return LoadedInput(make_applicator(name=str(item)), None, "shipped", ())

    monkeypatch.setattr(pc, "load_input", loader)
    monkeypatch.setattr(ps, "default_engine", lambda: fake_engine())


def test_export_single_and_batch(fakes, tmp_path):
    """One input: DIR/export/source_path_ring.csv with the contract's columns, one row per
    simulated dwell (30: the stand-in's path); no RT Plan for a non-plan input. Two inputs:
    the same per applicator folder."""
    out = tmp_path / "one"
    assert main(["commission", "fakeA", "--out", str(out), "--export", "--no-pdf", "--quiet"]) == 0
    table = pd.read_csv(out / "export" / "source_path_ring.csv")
    assert tuple(table.columns) == SOURCE_PATH_COLUMNS and len(table) == 30
    assert sorted(p.name for p in (out / "export").iterdir()) == ["source_path_ring.csv"]
    out = tmp_path / "batch"
    code = main(["commission", "fakeA", "fakeB", "--out", str(out), "--export", "--no-pdf",
                 "--quiet"])  # fmt: skip
    assert code == 0
    for name in ("fakeA", "fakeB"):
        assert (out / name / "export" / "source_path_ring.csv").is_file()


def test_export_without_simulated_channel_refused(fakes, tmp_path, monkeypatch, capsys):
    """A run that simulated nothing, with --export: one line, exit 2, no output folder."""
    real = pipeline.commission

    def no_simulation(*args, **kwargs):
        res = real(*args, **kwargs)
        return dataclasses.replace(res, dwells=res.dwells[res.dwells["path"] != "simulated"])

    monkeypatch.setattr(pipeline, "commission", no_simulation)
    out = tmp_path / "out"
    assert main(["commission", "fakeA", "--out", str(out), "--export", "--no-pdf"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no simulated channel" in err and "--export" in err
    assert not out.exists()


def _move_block(item, other_creator=True):
    """Move the NUCLETRON block of ``item`` from slot 0x10 to 0x11; put another vendor's
    block with junk at the old slot."""
    old = [el for el in item if el.tag.group == 0x300B and 0x1000 <= el.tag.element < 0x1100]
    for el in old:
        del item[el.tag]
        item.add_new((0x300B, 0x1100 + (el.tag.element & 0xFF)), el.VR, el.value)
    item[(0x300B, 0x0011)] = pydicom.DataElement((0x300B, 0x0011), "LO", "NUCLETRON")
    if other_creator:
        item[(0x300B, 0x0010)].value = "OTHER VENDOR"
        item.add_new((0x300B, 0x100D), "OB", b"not a library")
        item.add_new((0x300B, 0x1013), "LO", "@.WRONG")
    else:
        del item[(0x300B, 0x0010)]


@pytest.mark.parametrize("other_creator", [True, False])
def test_oncentra_tags_found_by_creator(repo_root, tmp_path, other_creator):
    """The example plan with Oncentra's block reserved at (300B,0011) instead of (300B,0010)
    (and, in one case, another vendor's junk at the usual numbers): the library, joint
    addresses and applicator name read exactly as from the original."""
    ds = pydicom.dcmread(repo_root / EXAMPLE)
    for setup in ds.ApplicationSetupSequence:
        _move_block(setup, other_creator)
        for ch in setup.ChannelSequence:
            _move_block(ch, other_creator)
    moved = tmp_path / "moved.dcm"
    ds.save_as(moved)
    a, b = read_rtplan(repo_root / EXAMPLE), read_rtplan(moved)
    assert b.applicator_name == a.applicator_name == "Interstitial Ring CT/MR d=26mm, 60°"
    assert [c.joint_address for c in b.channels] == [c.joint_address for c in a.channels]
    assert sorted(b.library) == sorted(a.library) == [1, 2]
    assert b.library[1].part_id == a.library[1].part_id
    assert (b.library[1].measured_path_mm == a.library[1].measured_path_mm).all()
