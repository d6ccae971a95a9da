"""Adding an applicator family touches one file: this one (docs/architecture.md, "How to add an
applicator family", steps 1-4).

The toy family: a channel on a quarter circle of radius 30 mm in the z = 0 plane; its span (the
reference dwells without a measured path) is the distal 15 mm; its own dose points sit 10 mm
beyond relative position 0 along the channel's tangent and 10 mm outside the circle there; it is
not gynaecological (no Point A).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from ringqa.geometry import Applicator, Centreline, Channel, Lumen
from ringqa.geometry.families import FAMILIES, FamilyPoint, FamilyWords, register_family
from ringqa.pipeline import CommissionSettings, commission
from tests.pipeline.fakes import centreline_simulator, stand_in_engine

R_MM = 30.0
WORDS = FamilyWords("toy applicator", "toy channel", "the distal 15 mm")


@dataclass(frozen=True)
class ToyFamily:
    """Step 1-2: a class with the family's members (ringqa.geometry.families.base)."""

    name: str = "toy"
    words: FamilyWords = WORDS
    gynae: bool = False

    def span_mm(self, app, channel, step_mm):
        return 15.0

    def points(self, app, channel, spec):
        s = channel.s_ref_m
        p = np.asarray(channel.centreline.position(s)) * 1e3
        t = np.asarray(channel.centreline.tangent(s))
        out = p.copy()
        out[:2] *= (R_MM + 10.0) / R_MM
        return (FamilyPoint("toy_beyond", "toy", p + 10.0 * t),
                FamilyPoint("toy_outside", "toy", out))  # fmt: skip

    def curvature_scale_m(self, app, channel):
        return R_MM * 1e-3

    def checks(self, app, channel):
        return ("The toy family checked the channel.",)


@pytest.fixture
def toy():
    family = register_family(ToyFamily())  # step 3: register it
    yield family
    FAMILIES.pop("toy")


def _toy_applicator():
    """Step 4: an applicator (or a channel) of the family."""
    phi = np.linspace(0.0, np.pi / 2, 91)
    pts = np.column_stack([R_MM * np.cos(phi), R_MM * np.sin(phi), np.zeros_like(phi)]) * 1e-3
    cl = Centreline.from_points(pts)
    ch = Channel("arc", cl, Lumen.circular(1.5e-3, 1.4e-3), cl.length_m - 0.005)
    return Applicator("toy1", (ch,), family="toy")


def test_toy_family_is_commissioned_through_its_rules(toy):
    """The pipeline asks the family: the reference dwells cover 0..15 mm every 5 mm (4 dwells),
    the dose points are the toy's two (no Point A), its check is a report note, and the
    stand-in engine's 0.3 mm offset along the normal is the simulated-vs-centreline distance.

    By hand: the simulated source sits 0.3 mm from the centreline point at every dwell, so
    max_dist_sim_mm = 0.3 (to 1e-6 mm, the spline's error at 1 degree sampling is far below)."""
    res = commission(
        _toy_applicator(), CommissionSettings(require_measured=False),
        engine=stand_in_engine(centreline_simulator(0.3e-3)),
    )  # fmt: skip
    ref = res.dwells[res.dwells["path"] == "centreline"]
    assert ref["relative_position_mm"].tolist() == [0.0, 5.0, 10.0, 15.0]
    assert sorted(set(res.doses["point"])) == ["toy_beyond", "toy_outside"]
    assert "The toy family checked the channel." in res.notes
    assert res.summary.as_row()["max_dist_sim_mm"] == pytest.approx(0.3, abs=1e-6)
    assert res.channel == "arc"


def test_the_guide_names_the_steps_this_test_follows():
    """docs/architecture.md has the section and names this file."""
    text = (Path(__file__).parents[3] / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert "## How to add an applicator family" in text
    assert "tests/geometry/families/test_toy_family.py" in text
