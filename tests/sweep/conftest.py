"""Fixtures of the sweep tests: a small spec on the fastest commissioning input (the shipped
synthetic ring26x60: a converged commissioning run takes ~0.2 s) and a real Dask LocalCluster of
processes, shared by the module that asks for it."""

from __future__ import annotations

from pathlib import Path

import pytest

SMALL_SPEC = """
description = "test: small sweep on the shipped ring26x60"
input = "ring26x60"
samples = {samples}
seed = 11
batch_size = 2

[parameters."contact.mu_k"]
distribution = "uniform"
low = 0.15
high = 0.2

[parameters."lumen.diameter_delta_mm"]
distribution = "uniform"
low = 0.0
high = 0.2

[parameters."instrument.ei_scale"]
distribution = "normal"
mean = 1.0
sd = 0.05
"""


def write_spec(folder: Path, samples: int = 4, text: str = SMALL_SPEC) -> Path:
    """Write the small spec (``samples`` samples) to ``folder/spec.toml``."""
    path = folder / "spec.toml"
    path.write_text(text.format(samples=samples), encoding="utf-8")
    return path


@pytest.fixture
def spec_writer():
    """:func:`write_spec`: ``spec_writer(folder, samples=4, text=SMALL_SPEC) -> Path``."""
    return write_spec


@pytest.fixture
def small_spec(tmp_path: Path) -> Path:
    """A 4-sample spec on ring26x60 varying mu_k, the lumen diameter and EI."""
    return write_spec(tmp_path)


@pytest.fixture(scope="module")
def local_cluster():
    """A real dask.distributed LocalCluster: 2 worker PROCESSES, one thread each."""
    import logging

    from distributed import LocalCluster

    cluster = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    try:
        yield cluster
    finally:
        cluster.close()
