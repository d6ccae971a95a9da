"""No absolute path in the outputs of a wheel-installed ``ringqa commission --example`` (issue 27):
tools/check_wheel_paths.py builds the wheel, installs it into a temporary folder, runs the
example from another folder and searches results.json, the CSVs, the log, the PDF's text and
report.html's text for the installation, home, temporary and checkout folders."""

from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location(
        "check_wheel_paths", ROOT / "tools" / "check_wheel_paths.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_search_finds_an_install_path_and_passes_package_names(tmp_path):
    """The search itself: a log line naming the installed example (as pipeline.commission once
    logged it) is a hit; ``ringqa:data/...`` and a relative output folder are not."""
    tool = _tool()
    site = tmp_path / "venv" / "lib" / "python3.11" / "site-packages"
    bad = tool.forbidden(site, tmp_path / "elsewhere")
    texts = {
        "run.log": f"INFO {site}/ringqa/_data/examples/x.dcm: loaded ring\n"
        "INFO input: ringqa:data/examples/x.dcm\nINFO 7 file(s) written in example\n",
        "results.json": '{"input": "ringqa:data/examples/x.dcm"}',
    }
    found = tool.hits(texts, bad)
    assert len(found) == 1 and found[0].startswith("run.log:1:")


@pytest.mark.slow
def test_wheel_installed_example_names_no_absolute_path():
    """The whole check (about 35 s on 2 quiet cores: the wheel, and numba compiling the kernels
    of the installed copy once)."""
    tool = _tool()
    try:
        found, texts = tool.check()
    except subprocess.CalledProcessError as exc:  # no build backend to be had (offline)
        pytest.skip(f"the wheel could not be built or installed here: {exc}")
    assert {"results.json", "dwells.csv", "doses.csv", "run.log", "report.pdf (text)"} <= set(texts)
    assert "ringqa:data/examples/" in texts["results.json"]
    assert found == []
