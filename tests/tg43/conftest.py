"""Shared fixtures for the tg43 tests."""

from __future__ import annotations

import shutil

import pytest

import tg43


@pytest.fixture(scope="session")
def flexisource():
    return tg43.load_source("flexisource")


@pytest.fixture(scope="session")
def mhdr_v2():
    return tg43.load_source("mhdr-v2")


@pytest.fixture
def source_copy(tmp_path):
    """A writable copy of the shipped Flexisource folder, for malformed-file tests."""
    src = tg43.load_source("flexisource")
    dst = tmp_path / "mysource"
    shutil.copytree(src.folder, dst)
    return dst
