"""Synthetic measurements made by ringqa itself (the truth is known)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ringqa.calibration.measured import MeasuredApplicator
from ringqa.calibration.model import ForwardModel
from ringqa.pipeline.inputs import load_input

#: the issue's film-like positions on a ring (mm) and the "true" cable of the synthetic clinic
FILM_MM = np.array([0.0, 5.0, 10.0, 17.0, 25.0, 30.0, 40.0, 50.0, 60.0])
TRUTH = {"contact.mu_k": 0.15, "contact.mu_s": 0.19, "instrument.ei_scale": 1.25}
STEM_MM = 80.0


def synthetic(name="ring26x60", cable="flexitron", truth=None, rel=FILM_MM, noise_mm=0.2,
              seed=0, sd_mm=0.2) -> MeasuredApplicator:  # fmt: skip
    """The ring of ``name`` measured by ringqa at ``truth`` (the simulation the fit uses) plus
    seeded Gaussian noise of ``noise_mm`` per coordinate; each point's sd is ``sd_mm``."""
    app = load_input(name).applicator
    ring = app.channel("ring")
    rel = np.asarray(rel, dtype=float)
    m = MeasuredApplicator(
        label=name, input=name, file="", applicator=app, channel=ring, cable=cable,
        relative_position_mm=rel, measured_mm=np.zeros((rel.size, 3)),
        sd_mm=np.full(rel.size, sd_mm), sd_assumed=False, method="film",
        flags=np.full(rel.size, "", dtype=object).astype(str), registration="none",
        notes=(), files=(),
    )  # fmt: skip
    exact = ForwardModel((m,), cable, {}, STEM_MM).positions(truth or TRUTH)[0]
    noise = np.random.default_rng(seed).normal(0.0, noise_mm, exact.shape) if noise_mm else 0.0
    return replace(m, measured_mm=exact + noise)


@pytest.fixture(scope="session")
def truth():
    return dict(TRUTH)
