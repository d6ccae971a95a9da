"""Channel shape checks (issue 18): curvature vs lumen, self-intersection, bends the capsule
cannot pass; and the unique batch labels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringqa.geometry import Centreline, Channel, Lumen
from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.shape_checks import (
    capsule_pass_radius_m,
    check_channel_shape,
    self_intersection,
    sharpest_bend,
    tight_bend_warning,
)
from ringqa.pipeline.batch import unique_label


def _helix(radius_mm: float, pitch_mm: float, turns: float, straight_mm: float = 20.0):
    """A straight approach along +x, then a helix about +z (points in m)."""
    c = pitch_mm / (2 * math.pi)
    phi = np.linspace(0.0, 2 * math.pi * turns, int(400 * turns) + 2)
    helix = np.column_stack([radius_mm * np.sin(phi), radius_mm * (1 - np.cos(phi)), c * phi])
    t0 = np.array([radius_mm, 0.0, c]) / math.hypot(radius_mm, c)
    if straight_mm <= 0:
        return helix * 1e-3
    approach = np.outer(np.linspace(-straight_mm, 0.0, 41), t0)
    return np.vstack([approach, helix[1:]]) * 1e-3


def _channel(points_m, r_b_mm: float = 1.5) -> Channel:
    cl = Centreline.from_points(points_m)
    lumen = Lumen.circular(r_b_mm * 1e-3, (r_b_mm - 0.1) * 1e-3)
    return Channel("ring", cl, lumen, s_ref_m=cl.length_m - 5e-3)


def test_sharpest_bend_of_a_circle_is_its_radius():
    """Three quarters of a circle of radius 13 mm: the smallest radius of curvature is 13 mm
    (the spline fit within 1 %). After a straight approach the curvature jumps from 0 to 1/R,
    and the fitted spline overshoots there (radius ~12.2 mm: within 10 %, on the circle)."""
    bend = sharpest_bend(Centreline.from_points(_helix(13.0, 0.0, 0.75, straight_mm=0.0)))
    assert bend.radius_m == pytest.approx(13e-3, rel=0.01)
    bend = sharpest_bend(Centreline.from_points(_helix(13.0, 0.0, 0.75)))
    assert bend.radius_m == pytest.approx(13e-3, rel=0.1)
    assert bend.s_m > 20e-3


@pytest.mark.parametrize(("pitch_mm", "hit"), [(2.0, True), (0.0, True), (4.0, False)])
def test_self_intersection_of_a_helix(pitch_mm, hit):
    """Two turns of a 13 mm helix in a 3 mm lumen: turns `pitch` apart overlap when the pitch is
    below the 3 mm diameter (the closest pair is one turn, 2 pi 13 = 81.7 mm, apart along s and
    `pitch` apart in space); a 4 mm pitch leaves the tube clear of itself."""
    found = self_intersection(Centreline.from_points(_helix(13.0, pitch_mm, 2.0)), 3e-3)
    assert (found is not None) == hit
    if hit:
        s1, s2, d = found
        assert d <= pitch_mm * 1e-3 + 0.1e-3
        assert abs(s2 - s1) >= math.pi * 3e-3


def test_a_bend_tighter_than_the_lumen_radius_is_refused():
    """A half turn of radius 1.0 mm in a 1.5 mm-radius lumen: channel.curvature, naming the
    radius."""
    with pytest.raises(GeometryError, match=r"\[channel.curvature\].* 1\.0\d mm"):
        check_channel_shape(_channel(_helix(1.0, 0.0, 0.5)), "test")


def test_a_helix_of_pitch_zero_is_refused_as_self_intersecting():
    with pytest.raises(GeometryError, match=r"\[channel.self_intersection\]"):
        check_channel_shape(_channel(_helix(13.0, 0.0, 1.5)), "test")


def test_capsule_pass_radius():
    """Flexitron capsule (4.6 mm long, radius 0.425 mm) in a 2.5 mm tandem lumen: clearance
    c = 1.25 - 0.425 = 0.825 mm, R >= 4.6^2 / (16 x 0.825) = 1.603 mm; no clearance: inf."""
    assert capsule_pass_radius_m(4.6e-3, 0.425e-3, 1.25e-3) == pytest.approx(1.6030e-3, rel=1e-4)
    assert capsule_pass_radius_m(4.6e-3, 0.425e-3, 0.4e-3) == math.inf


def test_tight_bend_warning_only_below_the_capsule_radius():
    """Radius 1.5 mm in a 1.25 mm lumen (limit 1.60 mm): a warning naming both radii; radius
    13 mm: none."""
    tight = _channel(_helix(1.5, 0.0, 0.25), r_b_mm=1.25)
    text = tight_bend_warning(tight, 4.6e-3, 0.425e-3, "tandem")
    assert "1.60 mm or more" in text and "radius of 1.5" in text
    assert tight_bend_warning(_channel(_helix(13.0, 0.0, 0.75)), 4.6e-3, 0.425e-3, "ring") == ""


def test_unique_labels():
    """Repeated names get -2, -3 (case-insensitively, as on macOS/Windows file systems); unsafe
    characters become '_'."""
    taken: set[str] = set()
    got = [unique_label(n, taken) for n in ("same", "same", "Same", "a/b", "", "same-2")]
    assert got == ["same", "same-2", "Same-3", "a_b", "applicator", "same-2-2"]


def test_close_far_pairs_match_a_kd_tree():
    """The numpy close-pair search (which replaced scipy's cKDTree on the commissioning path)
    finds exactly the pairs cKDTree.query_pairs finds, after the same along-the-channel filter,
    on random clouds dense enough that hundreds of pairs are within r."""
    import math

    from scipy.spatial import cKDTree

    from ringqa.geometry.shape_checks import _close_far_pairs

    rng = np.random.default_rng(3)
    for n in (2, 300, 700):
        s = np.sort(rng.uniform(0.0, 0.3, n))
        pts = rng.uniform(0.0, 0.01, (n, 3))
        r = 1e-3
        gap = math.pi * r
        ref = cKDTree(pts).query_pairs(r, output_type="ndarray").reshape(-1, 2)
        ref = ref[np.abs(s[ref[:, 0]] - s[ref[:, 1]]) >= gap]
        want = {tuple(sorted(p)) for p in ref.tolist()}
        got = {tuple(p) for p in _close_far_pairs(pts, s, r, gap).tolist()}
        assert got == want
        assert n < 300 or len(want) > 100


@pytest.mark.parametrize("strict", [False, True])
def test_close_pairs_match_brute_force(strict):
    """The sorted sweep finds exactly the pairs the all-pairs distance matrix finds (sorted by i
    then j, distances equal to 1e-18 m), with <= and with < (a pair exactly r apart on a grid:
    spacing r in x, found only without strict), on a random cloud and on a ring lying in the
    plane x = 0 (the sort axis is then y or z, never the degenerate x)."""
    from ringqa.geometry.shape_checks import close_pairs

    rng = np.random.default_rng(5)
    r = 2.0**-10  # ~1 mm, exact in binary: the grid's neighbours are exactly r apart
    grid = np.c_[np.arange(20) * r, np.zeros(20), np.zeros(20)]
    phi = np.linspace(0.0, 4 * np.pi, 400)  # two turns: every point has a twin
    ring = np.c_[np.zeros(400), 0.013 * np.cos(phi), 0.013 * np.sin(phi)]
    for pts in (rng.uniform(0.0, 0.01, (500, 3)), grid, ring):
        d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
        hit = d < r if strict else d <= r
        want = np.argwhere(np.triu(hit, 1))
        i, j, dist = close_pairs(pts, r, strict=strict)
        np.testing.assert_array_equal(np.c_[i, j], want)
        np.testing.assert_allclose(dist, d[want[:, 0], want[:, 1]], rtol=0, atol=1e-18)
    assert close_pairs(grid, r, strict=False)[0].size == 19
    assert close_pairs(grid, r, strict=True)[0].size == 0


def test_duplicate_positions_far_apart_in_a_dense_path_are_found():
    """20 000 measured positions (the issue's case that took 21.6 GB as all pairwise
    differences): positions 17 and 19 000 coincide (0.5 um apart, closer than the 1 um
    tolerance) and are named; the check's memory is O(n) (close_pairs)."""
    from ringqa.geometry import ring_applicator
    from ringqa.geometry.registration import RegistrationError, reference_positions

    ch = ring_applicator(26, 60).channel("ring")
    s = np.linspace(ch.s_ref_m, ch.s_ref_m - 0.1, 20_000)
    pts = ch.centreline.position(s)
    pts[19_000] = pts[17] + [0.5e-6, 0.0, 0.0]
    with pytest.raises(RegistrationError, match=r"positions 17 and 19000 coincide \(0\.500 um"):
        reference_positions(pts, ch, step_m=0.1 / 19_999)
