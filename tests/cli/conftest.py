"""Fixtures for the command-line tests (the synthetic RT Plan factory lives in tests/io)."""

from tests.io.conftest import rtplan_factory  # noqa: F401  (re-exported fixture)
