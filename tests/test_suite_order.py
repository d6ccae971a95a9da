"""The suite's own schedule (tests/conftest.py): the longest files start first under xdist."""

from __future__ import annotations

from types import SimpleNamespace

import tests.conftest as suite_conftest

ROOT = suite_conftest.REPO_ROOT


def test_every_long_first_file_exists():
    """A renamed or removed file in LONG_FIRST would silently stop being scheduled first."""
    missing = [name for name in suite_conftest.LONG_FIRST if not (ROOT / name).is_file()]
    assert missing == []
    assert len(set(suite_conftest.LONG_FIRST)) == len(suite_conftest.LONG_FIRST)


def test_long_files_first_then_more_tests_first_and_each_file_keeps_its_order():
    """Items of a listed file come first (in the list's order), then the other files by their
    number of tests (3 before 1); within a file the collection order is kept."""
    first, second = suite_conftest.LONG_FIRST[:2]
    ids = ["tests/a.py::t1", f"{second}::x1", "tests/b.py::u1", "tests/b.py::u2", f"{first}::y1",
           f"{second}::x2", "tests/b.py::u3", f"{first}::y2"]  # fmt: skip
    items = [SimpleNamespace(nodeid=i) for i in ids]
    suite_conftest.pytest_collection_modifyitems(None, items)
    assert [i.nodeid for i in items] == [
        f"{first}::y1", f"{first}::y2", f"{second}::x1", f"{second}::x2",
        "tests/b.py::u1", "tests/b.py::u2", "tests/b.py::u3", "tests/a.py::t1",
    ]  # fmt: skip
