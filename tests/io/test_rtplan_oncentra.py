"""Must-show 2: the Oncentra 26 mm / 60 degree plan, read from ../shared and from data/examples.

Expected values come from the plan's README (reference/rtplans/oncentra_ring26x60), not from the
reader: ring channel 1 has 6 dwells, tandem channel 2 has 7; ChannelTotalTime 202.329602 s and
236.051202 s shared equally (202.329602 / 6 = 236.051202 / 7 = 33.721600 s); S_K 40820 U; dose
points A1 7.157785, A2 7.042215, Bladder 3.872681, ICRU 3.510379 Gy. The ring centreline is a
circle of radius 13.0 mm (d = 26 mm is the source-to-source diameter), checked here with a
circumscribed circle through three far-apart centreline points (independent of any fit in the
package); the measured path has 30 positions at 2.5 mm and the plan's ring dwells (relative
positions 5, 10, 15, 50, 55, 60 mm) are path positions 2, 4, 6, 20, 22, 24 (index = rel / 2.5).
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.io.rtplan import read_rtplan

EXAMPLE = ("data", "examples", "oncentra_ring26x60", "RP_ring26x60_oncentra43.dcm")


@pytest.fixture(params=["shared", "example"])
def plan(request, repo_root):
    if request.param == "shared":
        path = request.getfixturevalue("oncentra_plan_path")
    else:
        path = repo_root.joinpath(*EXAMPLE)
    return read_rtplan(path)


def _circumcircle(a, b, c):
    """Centre, unit normal and radius of the circle through three points (closed form)."""
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    centre = a + (np.cross(n, ab) * (ac @ ac) + np.cross(ac, n) * (ab @ ab)) / (2 * (n @ n))
    return centre, n / np.linalg.norm(n), np.linalg.norm(a - centre)


def test_channels_dwells_and_times(plan):
    ring, tandem = plan.channel(1), plan.channel(2)
    assert ring.n_dwells == 6 and tandem.n_dwells == 7
    assert ring.times_s.sum() == pytest.approx(202.33, abs=0.005)
    assert tandem.times_s.sum() == pytest.approx(236.05, abs=0.005)
    np.testing.assert_allclose(ring.times_s, 202.329602136311 / 6, rtol=1e-9)
    np.testing.assert_allclose(tandem.times_s, 236.051202492361 / 7, rtol=1e-9)
    np.testing.assert_allclose(ring.relative_position_mm, [5, 10, 15, 50, 55, 60])
    np.testing.assert_allclose(tandem.relative_position_mm, [0, 5, 12.5, 20, 27.5, 37.5, 47.5])
    assert ring.step_mm == 2.5 and ring.length_mm == 1500.0
    np.testing.assert_allclose(ring.positions_mm[0], [-19.977323, -0.998617, -119.996292])
    assert ring.directions is None and tandem.directions is None  # no orientation tag


def test_source_and_points(plan):
    assert plan.source.sk_U == 40820.0
    assert plan.source.isotope == "Ir-192"
    assert plan.source.tg43_name == "mhdr-v2"
    assert str(plan.source.reference_date) == "2012-01-01"
    doses = {p.name: p.tps_dose_gy for p in plan.points}
    assert doses == {"A1": 7.157785, "A2": 7.042215, "Bladder": 3.872681, "ICRU": 3.510379}
    np.testing.assert_allclose(plan.points[0].position_mm, [-26.263365, -6.806701, -94.109772])


def test_library_ring_centreline_is_a_13mm_circle(plan):
    lib = plan.library[1]
    assert lib.role == "ring" and lib.lumen_diameter_mm == 3.0
    cl = lib.centreline_mm
    seg = np.linalg.norm(np.diff(cl, axis=0), axis=1)
    arc_from_tip = np.concatenate([[0], np.cumsum(seg[::-1])])[::-1]
    ring_part = cl[arc_from_tip <= 55.0]  # the distal 55 mm: on the circle (runs 60 mm)
    a, b, c = ring_part[0], ring_part[len(ring_part) // 2], ring_part[-1]
    centre, normal, radius = _circumcircle(a, b, c)
    assert radius == pytest.approx(13.0, abs=0.05)
    r = np.linalg.norm(ring_part - centre, axis=1)
    assert np.all(np.abs(r - 13.0) < 0.05)
    assert np.all(np.abs((ring_part - centre) @ normal) < 0.05)  # planar
    # proximal -> distal: the last point is the lumen tip, 5 mm beyond the first marker
    assert np.linalg.norm(cl[-1] - lib.marker_mm) == pytest.approx(5.0, abs=0.05)


def test_measured_path_matches_ring_dwells(plan):
    lib = plan.library[1]
    path = lib.measured_path_mm
    assert path.shape == (30, 3) and lib.measured_step_mm == 2.5
    assert lib.measured_path_name == "VCC_RingCTMR_26x60_192-Ir-mxDR-v2 v1.1"
    ring = plan.channel(1)
    idx = np.rint(ring.relative_position_mm / 2.5).astype(int)
    np.testing.assert_allclose(path[idx], ring.positions_mm, atol=0.05)


def test_tandem_dwells_lie_on_the_tube_centreline(plan):
    """Tandem dwell 0 (relative position 0) is the first marker; all dwells on the centreline."""
    lib, tandem = plan.library[2], plan.channel(2)
    assert lib.role == "tandem" and lib.lumen_diameter_mm == 2.5 and lib.measured_path_mm is None
    np.testing.assert_allclose(lib.marker_mm, tandem.positions_mm[0], atol=0.05)
    # distance to the polyline (1 mm chords on a straight tube: exact)
    cl = lib.centreline_mm
    a, b = cl[:-1], cl[1:]
    for x in tandem.positions_mm:
        t = np.clip(np.einsum("ij,ij->i", x - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
        assert np.min(np.linalg.norm(a + t[:, None] * (b - a) - x, axis=1)) < 0.05


def test_no_warnings_on_the_oncentra_plan(plan):
    assert plan.warnings == ()
    assert plan.applicator_name == "Interstitial Ring CT/MR d=26mm, 60°"
