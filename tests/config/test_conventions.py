"""Notebook and logging conventions (issue 15 part 5, the parts of the configuration session):
the example plan after installation, logging, CSV encoding, provenance, help texts."""

from __future__ import annotations

import hashlib
import json
import logging
from importlib import metadata

import pandas as pd

from ringqa.cli import main
from ringqa.datasets import example_plan
from ringqa.jsonio import csv_encoding
from ringqa.provenance import (
    Provenance,
    dependency_versions,
    display_path,
    tg43_data_files,
)


def test_example_plan_is_the_shipped_plan(repo_root):
    path = example_plan()
    assert path.is_file() and path.suffix == ".dcm"
    assert path.read_bytes() == (repo_root / "data/examples/oncentra_ring26x60" / path.name
                                 ).read_bytes()  # fmt: skip


def test_example_option_commissions_the_example(fake_inputs, monkeypatch, tmp_path):
    """--example hands the example plan's path to the pipeline (the stand-in loader records
    what it was given and loads a stand-in ring)."""
    import importlib

    pc = importlib.import_module("ringqa.pipeline.commission")
    seen = []
    loader = pc.load_input

    def record(item):
        seen.append(str(item))
        return loader("fakeA")

    monkeypatch.setattr(pc, "load_input", record)
    assert main(["commission", "--example", "--out", str(tmp_path / "o"), "--no-pdf",
                 "--quiet"]) == 0  # fmt: skip
    assert seen == [str(example_plan())]


def test_verbose_and_log_file(fake_inputs, tmp_path, capsys):
    """-v: the pipeline's INFO lines on stderr; --log-file: the same and DEBUG lines in the
    file; afterwards the ringqa logger has no handler left (the library configures none)."""
    log = tmp_path / "run.log"
    code = main(["-v", "--log-file", str(log), "commission", "fakeA", "--out",
                 str(tmp_path / "o"), "--no-pdf", "--quiet"])  # fmt: skip
    assert code == 0
    err = capsys.readouterr().err
    assert "ringqa: fakeA: loaded fakeA" in err and "simulating the" in err
    text = log.read_text(encoding="utf-8")
    assert "INFO ringqa.pipeline.commission: fakeA: simulated in" in text
    assert "DEBUG ringqa.cli" in text
    ours = [h for h in logging.getLogger("ringqa").handlers
            if type(h) in (logging.StreamHandler, logging.FileHandler)]  # fmt: skip
    assert ours == [] and logging.getLogger("ringqa").propagate
    code = main(["commission", "fakeA", "--out", str(tmp_path / "q"), "--no-pdf", "--quiet"])
    assert code == 0
    assert "loaded" not in capsys.readouterr().err  # quiet without -v


def test_csv_with_degree_sign_is_utf8_sig(monkeypatch, tmp_path):
    """An applicator named with a degree sign: dwells.csv starts with the UTF-8 byte-order mark
    and reads back with the sign intact; an ASCII name: no mark (files as before)."""
    import importlib

    from ringqa.pipeline.inputs import LoadedInput
    from tests.pipeline.fakes import fake_engine, make_applicator

    pc = importlib.import_module("ringqa.pipeline.commission")
    ps = importlib.import_module("ringqa.pipeline.simulate")
    monkeypatch.setattr(ps, "default_engine", lambda: fake_engine())
    monkeypatch.setattr(pc, "load_input",
                        lambda item: LoadedInput(make_applicator(name=str(item)), None,
                                                 "shipped", ()))  # fmt: skip
    for name, bom in (("Ring 26mm, 60°", True), ("ring26", False)):
        out = tmp_path / ("deg" if bom else "ascii")
        assert main(["commission", name, "--out", str(out), "--no-pdf", "--quiet"]) == 0
        raw = (out / "dwells.csv").read_bytes()
        assert raw.startswith(b"\xef\xbb\xbf") is bom
        assert pd.read_csv(out / "dwells.csv", encoding="utf-8-sig")["applicator"][0] == name
    assert csv_encoding([["a", "60°"]]) == "utf-8-sig" and csv_encoding([["a", 1.0]]) == "utf-8"


def test_provenance_versions_and_tg43_hashes(repo_root):
    """Versions equal importlib.metadata's; the data hashes are the SHA-256 of the source
    folder's files (computed here with hashlib on the bytes)."""
    versions = dependency_versions()
    for name in ("numpy", "scipy", "numba", "pandas", "pydicom", "matplotlib", "h5py"):
        assert versions[name] == metadata.version(name)
    folder = repo_root / "data" / "sources" / "mhdr-v2"
    files = tg43_data_files(folder)
    assert {f.name for f in files} >= {"meta.json", "gL.csv", "F_r_theta.csv"}
    prov = Provenance.now(data=files).as_dict()
    for f in files:
        assert prov["data"][display_path(f)] == hashlib.sha256(f.read_bytes()).hexdigest()
    assert prov["dependencies"]["numpy"] == metadata.version("numpy")


def test_results_json_carries_provenance(fake_inputs, tmp_path):
    out = tmp_path / "o"
    assert main(["commission", "fakeA", "--out", str(out), "--no-pdf", "--quiet"]) == 0
    prov = json.loads((out / "results.json").read_text())["provenance"]
    assert prov["dependencies"]["pandas"] == metadata.version("pandas")
    assert prov["data"] and all(len(h) == 64 for h in prov["data"].values())


def test_constraints_pin_every_runtime_dependency(repo_root):
    """constraints/clinical.txt pins (==) each runtime dependency of pyproject.toml."""
    import re
    import tomllib

    deps = tomllib.loads((repo_root / "pyproject.toml").read_text())["project"]["dependencies"]
    names = {re.split(r"[<>=!~ ]", d, maxsplit=1)[0].lower().replace("_", "-") for d in deps}
    pins = {}
    for line in (repo_root / "constraints" / "clinical.txt").read_text().splitlines():
        if line and not line.startswith("#"):
            name, _, version = line.partition("==")
            pins[name.lower().replace("_", "-")] = version
    assert names <= set(pins), names - set(pins)
    assert all(re.fullmatch(r"[0-9][0-9a-z.]*", v) for v in pins.values())
    readme = (repo_root / "README.md").read_text()
    assert "pip install -c constraints/clinical.txt -e ." in readme


def test_commission_help_speaks_to_physicists(capsys):
    """No developer words in ringqa commission --help: no reST markup, no 'scene key', no
    'staged', no capitalised CHANNEL, no argparse placeholders like PRESCRIPTION_GY."""
    try:
        main(["commission", "--help"])
    except SystemExit:
        pass
    text = capsys.readouterr().out
    for word in ("``", "scene key", "staged", "CHANNEL", "PRESCRIPTION_GY", "SK_U", "STEM_MM",
                 "ACCURACY_CSV", "kwargs", "dataclass"):  # fmt: skip
        assert word not in text, word
    assert "--config FILE" in text and "--export" in text and "--example" in text
