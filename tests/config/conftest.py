"""Fixtures for the clinic-configuration tests: stand-in applicators and engine (fast runs of
``ringqa commission``), and a writer of configuration files."""

from __future__ import annotations

import importlib
import textwrap

import pytest

from ringqa.pipeline.inputs import LoadedInput
from tests.pipeline.fakes import fake_engine, make_applicator

pc = importlib.import_module("ringqa.pipeline.commission")
ps = importlib.import_module("ringqa.pipeline.simulate")


@pytest.fixture
def fake_inputs(monkeypatch):
    """Inputs ``fakeA`` / ``fakeB`` load stand-in rings (a measured path 0.5 mm outward of the
    centreline, 30 positions 2.5 mm apart, and a tandem); the engine is the fake one."""

    def loader(item):
        name = str(item)
        if name not in ("fakeA", "fakeB"):
            from ringqa.errors import RingQAError

            raise RingQAError(f"{name}: no such applicator")
        return LoadedInput(make_applicator(name=name, tandem=True), None, "shipped", ())

    monkeypatch.setattr(pc, "load_input", loader)
    monkeypatch.setattr(ps, "default_engine", lambda: fake_engine())


@pytest.fixture
def write_config(tmp_path):
    """``write(text, name="site.toml") -> Path``: a configuration file in tmp_path."""

    def write(text: str, name: str = "site.toml"):
        path = tmp_path / name
        path.write_text(textwrap.dedent(text), encoding="utf-8")
        return path

    return write
