"""Paths in outputs: shipped files as ``ringqa:data/...``, an input's own files relative to its
folder, never an install path (ringqa.provenance.display_path / relative_paths)."""

from __future__ import annotations

from ringqa.datasets import example_plan
from ringqa.paths import data_dir
from ringqa.provenance import Provenance, display_path, relative_paths


def test_shipped_files_are_named_by_the_package(tmp_path):
    """The example plan and a TG-43 data file: ``ringqa:data/<path inside data/>``; the same
    from a checkout (data/) or a wheel (ringqa/_data), because both are data_dir()."""
    plan = example_plan()
    rel = plan.resolve().relative_to(data_dir().resolve()).as_posix()
    assert (
        display_path(plan)
        == f"ringqa:data/{rel}"
        == ("ringqa:data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm")
    )
    meta = data_dir() / "sources" / "mhdr-v2" / "meta.json"
    assert display_path(meta) == "ringqa:data/sources/mhdr-v2/meta.json"


def test_an_inputs_own_files_are_relative_to_its_folder(tmp_path):
    folder = tmp_path / "my_ring"
    folder.mkdir()
    (folder / "centreline.csv").write_text("x_mm,y_mm,z_mm\n")
    (tmp_path / "elsewhere.csv").write_text("x\n")
    assert display_path(folder / "centreline.csv", folder) == "centreline.csv"
    assert display_path(tmp_path / "elsewhere.csv", folder) == str(tmp_path / "elsewhere.csv")
    prov = Provenance.now(inputs=[folder / "centreline.csv"])
    assert list(prov.inputs) == ["centreline.csv"]


def test_relative_paths_walks_json_data(tmp_path):
    """Absolute paths of existing files anywhere in a JSON-like structure are renamed; other
    strings (and paths that do not exist) are left alone."""
    data = {"a": [str(example_plan()), "text /not/a/path"], "b": {"c": "/no/such/file.csv"}}
    out = relative_paths(data)
    assert out["a"][0].startswith("ringqa:data/examples/")
    assert out["a"][1] == "text /not/a/path" and out["b"]["c"] == "/no/such/file.csv"
