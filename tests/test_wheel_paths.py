"""No absolute path in the outputs of a wheel-installed ``ringqa commission --example`` (issue 27):
tools/check_wheel_paths.py builds the wheel, installs it into a temporary folder, runs the
example from another folder and searches results.json, the CSVs, the log, the PDF's text and
report.html's text for the installation, home, temporary and checkout folders."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tool(load_script):
    return load_script("tools/check_wheel_paths.py")


def test_search_finds_an_install_path_and_passes_package_names(tmp_path, tool):
    """The search itself: a log line naming the installed example (as pipeline.commission once
    logged it) is a hit; ``ringqa:data/...`` and a relative output folder are not."""
    site = tmp_path / "venv" / "lib" / "python3.11" / "site-packages"
    bad = tool.forbidden(site, tmp_path / "elsewhere")
    texts = {
        "run.log": f"INFO {site}/ringqa/_data/examples/x.dcm: loaded ring\n"
        "INFO input: ringqa:data/examples/x.dcm\nINFO 7 file(s) written in example\n",
        "results.json": '{"input": "ringqa:data/examples/x.dcm"}',
    }
    found = tool.hits(texts, bad)
    assert len(found) == 1 and found[0].startswith("run.log:1:")


def _numba_cache_dir(package_dir: Path) -> Path:
    """Where numba keeps the cache of the kernels defined in ``package_dir``'s modules: under
    ``NUMBA_CACHE_DIR`` (this process's environment, which the installed run inherits) in a
    folder named after the source folder's absolute path (numba's own rule), else the source
    folder's ``__pycache__``."""
    from numba.core.caching import UserProvidedCacheLocator

    cache_dir = os.environ.get("NUMBA_CACHE_DIR", "")
    if cache_dir:
        sub = UserProvidedCacheLocator.get_suitable_cache_subpath(str(package_dir / "x.py"))
        return Path(cache_dir) / sub
    return package_dir / "__pycache__"


def seed_numba_cache(site: Path, root: Path = ROOT) -> int:
    """Copy the checkout's compiled kernels (numba's ``*.nbi`` index and ``*.nbc`` data) to where
    numba looks for the installed copy's, so the installed run loads rather than recompiles them.

    Numba keys a cache entry by the source file's content hash (numba >= 0.59: not its mtime or
    path), the function's name, first line and bytecode, and finds the files in a folder derived
    from the source folder's path. The wheel's modules are byte copies of the checkout's, so an
    entry compiled from the checkout is valid for the installed copy; only the folder differs.
    A kernel the checkout has not compiled yet (or a stale entry) is simply compiled by the
    installed run, as before. Returns the number of files copied."""
    copied = 0
    for top in ("ringqa", "tg43"):
        for src_dir in [root / top, *(root / top).rglob("*")]:
            if not src_dir.is_dir() or "__pycache__" in src_dir.parts:
                continue
            dst_dir = site / src_dir.relative_to(root)
            src_cache = _numba_cache_dir(src_dir)
            if not dst_dir.is_dir() or not src_cache.is_dir():
                continue
            files = [*src_cache.glob("*.nbi"), *src_cache.glob("*.nbc")]
            if not files:
                continue
            dst_cache = _numba_cache_dir(dst_dir)
            dst_cache.mkdir(parents=True, exist_ok=True)
            for f in files:
                shutil.copy2(f, dst_cache / f.name)
                copied += 1
    return copied


@pytest.mark.parametrize("cache_dir", [True, False], ids=["NUMBA_CACHE_DIR", "in-tree"])
def test_seed_numba_cache_copies_to_numba_s_folder_for_the_copy(tmp_path, monkeypatch, cache_dir):
    """The seeding puts a kernel's index where numba itself looks for the copied module's cache:
    a module with a cached kernel compiled in one folder, copied byte for byte to another folder
    (the wheel's install), loads there without compiling (numba's cache hit counter); with
    ``NUMBA_CACHE_DIR`` set (the lead's runs) and without (CI: ``__pycache__`` beside the code)."""
    if cache_dir:
        monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    else:
        monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    code = (
        "import sys, importlib\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "m = importlib.import_module('kern')\n"
        "assert m.twice(2.0) == 4.0\n"
        "print(sum(m.twice.stats.cache_hits.values()), sum(m.twice.stats.cache_misses.values()))\n"
    )
    src = "from numba import njit\n\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n"
    a, b = tmp_path / "checkout" / "ringqa", tmp_path / "site" / "ringqa"
    for d in (a, b):
        d.mkdir(parents=True)
        (d / "kern.py").write_text(src)

    def run(where):
        return subprocess.run(
            [sys.executable, "-c", code, str(where)],
            check=True, capture_output=True, text=True,
        ).stdout.split()  # fmt: skip

    assert run(a) == ["0", "1"]  # compiled in the "checkout"
    assert seed_numba_cache(tmp_path / "site", root=tmp_path / "checkout") == 2
    assert run(b) == ["1", "0"]  # loaded, not compiled, in the "installed copy"


@pytest.mark.slow
def test_wheel_installed_example_names_no_absolute_path(tool):
    """The whole check: the wheel, installed elsewhere, runs the example there. The checkout's
    compiled kernels are copied to the installed copy's numba cache first (:func:`seed_numba_cache`;
    the example then loads them instead of compiling them again under the new path, which took
    ~60 s of CPU); whatever the checkout has not compiled yet, the installed copy compiles."""
    install = tool.install

    def install_and_seed(wheel, where, fresh_venv):
        cmd, env, site = install(wheel, where, fresh_venv)
        seed_numba_cache(site)
        return cmd, env, site

    tool.install = install_and_seed
    try:
        found, texts = tool.check()
    except subprocess.CalledProcessError as exc:  # no build backend to be had (offline)
        pytest.skip(f"the wheel could not be built or installed here: {exc}")
    assert {"results.json", "dwells.csv", "doses.csv", "run.log", "report.pdf (text)"} <= set(texts)
    assert "ringqa:data/examples/" in texts["results.json"]
    assert found == []
