"""Fixtures for the pipeline tests: the stand-ins of tests/pipeline/fakes.py."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from tests.pipeline.fakes import fake_engine, fake_scene_factory, fake_simulator, make_applicator


@pytest.fixture
def fakes():
    return SimpleNamespace(
        applicator=make_applicator,
        simulator=fake_simulator,
        scene_factory=fake_scene_factory,
        engine=fake_engine,
    )
