"""Shared fixtures for the whole suite.

- ``shared_dir``: the read-only reference material beside the checkout (``../shared``); tests that
  need it skip with a clear reason when it is absent (a user's clone does not have it). This is
  the ONLY skip in the suite outside tests/simulation and tests/tg43: anything else a test needs
  must exist, and its absence is a failure.
- Hypothesis runs with a deterministic profile so CI results are reproducible.
- The longest test files start first (:data:`LONG_FIRST`, :func:`pytest_collection_modifyitems`),
  so the suite does not end on one core.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ringqa",
    derandomize=True,
    database=None,  # no replays of examples another profile or version found: same examples
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ringqa"))

REPO_ROOT = Path(__file__).resolve().parents[1]

#: The test files that take longest, longest first (seconds of test time in one run with an empty
#: numba cache, `pytest -q --durations=0`, 2026-11-29; the first compile of a kernel lands on
#: whichever file needs it first). pytest-xdist (``--dist loadfile --no-loadscope-reorder`` in
#: pyproject.toml) hands out whole files in collection order, each to the next free worker, so
#: these start first and the short files fill the end: the suite does not end with one core
#: still working through a long file. The second worker starts on kernels the first (the
#: corpus: the commissioning kernels) does not need, so on an empty cache the two do not compile
#: the same geometry and engine kernels at the same time (the engine's tests came second in a
#: full run at load 6: 82 s for their first test).
#: A file missing from the list runs after these (more tests first); a name that no longer
#: exists is ignored. Only the order changes: every test runs, in its file's own order.
LONG_FIRST = (
    "tests/corpus/test_corpus.py",  # ~190 s: 141 cases, most of them commissioning runs
    "tests/tg43/test_tg43_kernels.py",  # ~15 s: TG-43 kernels only, while the corpus compiles
    "tests/simulation/test_engine_api.py",  # ~100 s: the engine's effect specialisations
    "tests/cli/test_commission_cli.py",  # ~120 s: the example, every shipped ring, a batch
    "tests/report/test_consistency.py",  # ~100 s: the example's and a batch's reports
    "tests/sweep/test_sweep_cluster.py",  # ~70 s: Dask clusters, an interrupted sweep
    "tests/simulation/test_validation.py",  # ~45 s
    "tests/pipeline/test_commission_numerics.py",  # ~40 s
    "tests/cli/test_output_transactions.py",  # ~35 s
    "tests/pipeline/test_measured_points.py",  # ~24 s
    "tests/simulation/flexible/test_flexible_validation.py",  # ~22 s
    "tests/calibration/test_per_applicator_lumen.py",  # ~15 s
    "tests/geometry/test_geometry_centreline.py",  # ~17 s
    "tests/pipeline/test_public_tandem_ovoids.py",  # ~14 s
    "tests/needle/test_needle_sweep.py",  # ~14 s
    "tests/test_wheel_paths.py",  # ~15 s: late enough that the checkout's kernels are compiled
    "tests/cli/test_warmup.py",  # ~13 s
    "tests/simulation/effects/test_add_effect.py",  # ~12 s
    "tests/simulation/solvers/test_stress_regressions.py",  # ~12 s
    "tests/calibration/test_commission_with_calibration.py",  # ~11 s
    "tests/simulation/test_hard_cases.py",  # ~11 s
    "tests/calibration/test_leave_one_out.py",  # ~10 s
)
SHARED_DIR = Path(os.environ.get("RINGQA_SHARED", REPO_ROOT.parent / "shared")).resolve()


def pytest_collection_modifyitems(config, items):
    """Order the files: :data:`LONG_FIRST` in its order, then the rest, more tests first (what
    pytest-xdist's own reordering does, which ``--no-loadscope-reorder`` switches off so that
    this order is kept). A stable sort: the tests of a file keep their order."""
    rank = {name: k for k, name in enumerate(LONG_FIRST)}
    counts: dict[str, int] = {}
    for item in items:
        name = item.nodeid.split("::", 1)[0]
        counts[name] = counts.get(name, 0) + 1

    def key(item):
        name = item.nodeid.split("::", 1)[0]
        return (rank.get(name, len(rank)), -counts[name] if name not in rank else 0)

    items.sort(key=key)


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The checkout's root folder."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def load_script():
    """Import a script of the checkout that is not in a package (``benchmarks/``, ``tools/``) by
    its path: ``load_script("tools/compare_outputs.py")`` -> the module."""

    def load(relpath: str):
        path = REPO_ROOT / relpath
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """``../shared`` reference material; skips the test when it is absent."""
    if not (SHARED_DIR / "reference").is_dir():
        pytest.skip(f"reference material not found at {SHARED_DIR} (only in the developers' setup)")
    return SHARED_DIR


@pytest.fixture(scope="session")
def oncentra_plan_path(shared_dir: Path) -> Path:
    """The shared Oncentra 26 mm / 60 degree tandem-and-ring RT Plan."""
    plan_dir = shared_dir / "reference" / "rtplans" / "oncentra_ring26x60"
    path = plan_dir / "RP_ring26x60_oncentra43.dcm"
    assert path.is_file(), f"{path}: missing from the shared reference material"
    return path


@pytest.fixture(autouse=True)
def no_user_config(monkeypatch):
    """No test reads the developer's own clinic configuration (``RINGQA_CONFIG`` empty: none);
    tests of the user configuration set the variable themselves."""
    monkeypatch.setenv("RINGQA_CONFIG", "")


@pytest.fixture(autouse=True)
def no_compile_notice(monkeypatch):
    """The commands' stderr holds only what they say, cold numba cache or warm (the notice and
    the compile helper have their own tests: tests/cli/test_warmup.py)."""
    monkeypatch.setenv("RINGQA_COMPILE_NOTICE", "0")
