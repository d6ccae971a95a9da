"""Kinks in channel centrelines: none in the shipped designs, the Oncentra library's one found."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.geometry import Centreline, Channel, Lumen, ring_applicator
from ringqa.geometry.kinks import find_kinks


@pytest.mark.parametrize(("diameter", "angle"), [(26, 45), (26, 60), (30, 45), (30, 60),
                                                  (34, 45), (34, 60)])  # fmt: skip
def test_the_shipped_designs_have_no_kink(diameter, angle):
    app = ring_applicator(diameter, angle)
    assert find_kinks(app.channel("ring"), app.ring_radius_m) == ()


def test_a_tight_arc_inside_a_ring_is_found():
    """A 13 mm circle with a 2 mm stretch bent at radius 6 mm (curvature 167 1/m) in its middle:
    one kink there, its curvature 1/6 mm within 10 % (the interpolating quintic overshoots at the
    steps of the curvature), its length about 2 mm, the median around it the ring's 1/13 mm."""
    ds = 0.1e-3
    s = np.arange(0.0, 0.08, ds)
    kappa = np.where((s > 0.04) & (s < 0.042), 1 / 6e-3, 1 / 13e-3)
    phi = np.cumsum(kappa) * ds
    pts = np.column_stack([np.cumsum(np.cos(phi)) * ds, np.cumsum(np.sin(phi)) * ds, 0 * s])
    ch = Channel("ring", Centreline.from_points(pts[::5]), Lumen.circular(1.5e-3, 1.4e-3), 0.07)
    (k,) = find_kinks(ch, 13e-3)
    assert k.s_m == pytest.approx(0.041, abs=1.5e-3)
    assert k.curvature_per_m == pytest.approx(1 / 6e-3, rel=0.10)
    assert k.median_per_m == pytest.approx(1 / 13e-3, rel=0.03)
    assert 1e-3 < k.length_m < 3e-3


def test_the_oncentra_library_ring_has_its_kink(repo_root):
    """The example's library ring: curvature 164 1/m at relative position 61 mm (domain check of
    the numbers quoted in docs/commissioning.md)."""
    from ringqa.pipeline.inputs import load_input

    app = load_input(
        repo_root / "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"
    ).applicator
    ring = app.channel("ring")
    (k,) = find_kinks(ring, app.ring_radius_m)
    assert (ring.s_ref_m - k.s_m) * 1e3 == pytest.approx(61.0, abs=1.0)
    assert k.curvature_per_m == pytest.approx(164, abs=5)
