"""The ring frame from a centreline (circle fit) and the applicator built from an RT Plan.

Circle fit: on an analytic ring (a circle of radius R through 264 degrees, joined tangentially by
a straight stem) the fit must return R, the centre and the plane normal to 1e-9 mm / 1e-9, and
count exactly the points on the circular arc (the stem's points are off the circle).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.io.plan_applicator import fit_ring_circle, stem_end_mm
from ringqa.io.rtplan import read_rtplan

EXAMPLE = ("data", "examples", "oncentra_ring26x60", "RP_ring26x60_oncentra43.dcm")


def _analytic_ring(radius, centre, rot, arc_deg=264.0, stem_mm=40.0, step=1.0):
    """Stem (straight, tangent at the arc start) then the arc; proximal -> distal (mm)."""
    phi = np.arange(0.0, np.radians(arc_deg) * radius + 1e-9, step) / radius
    arc = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), np.zeros_like(phi)])
    t0 = np.array([0.0, 1.0, 0.0])  # tangent at phi = 0
    stem = arc[0] - np.outer(np.arange(stem_mm, 0, -step), t0)
    pts = np.vstack([stem, arc])
    return pts @ rot.T + centre, len(arc)


def _rotation(a, b, c):
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    return rz @ ry @ rx


@given(
    radius=st.sampled_from([13.0, 15.0, 17.0]),
    centre=st.lists(st.floats(-200, 200), min_size=3, max_size=3),
    angles=st.lists(st.floats(0, 2 * np.pi), min_size=3, max_size=3),
)
def test_fit_recovers_an_analytic_ring(radius, centre, angles):
    rot = _rotation(*angles)
    pts, n_arc = _analytic_ring(radius, np.array(centre), rot)
    c = fit_ring_circle(pts)
    assert c.radius_mm == pytest.approx(radius, abs=1e-9)
    np.testing.assert_allclose(c.centre_mm, centre, atol=1e-8)
    assert abs(abs(c.normal @ rot[:, 2]) - 1.0) < 1e-12
    assert c.n_points == n_arc
    assert stem_end_mm(pts) == pytest.approx(40.0, abs=1e-9)  # the stem is 40 x 1 mm


@pytest.fixture(scope="module")
def example_app(request):
    from ringqa.io.rtplan import applicator_from_rtplan

    root = request.config.rootpath
    plan = read_rtplan(root.joinpath(*EXAMPLE))
    return plan, applicator_from_rtplan(plan)


def test_applicator_channels_and_ring_frame(example_app):
    """Oncentra 26/60: ring radius 13.0 mm, stem 60 degrees to the ring plane (domain.md),
    normal towards the tandem tip, lateral = patient left (+x) in the ring plane."""
    plan, app = example_app
    assert [c.name for c in app.channels] == ["ring", "tandem"]
    assert app.ring_radius_m == pytest.approx(13.0e-3, abs=0.05e-3)
    assert app.metadata["angle_deg"] == pytest.approx(60.0, abs=0.5)
    n, lat = np.asarray(app.ring_normal), np.asarray(app.ring_lateral)
    assert n @ lat == pytest.approx(0.0, abs=1e-12) and lat[0] > 0.9
    tip = plan.library[2].centreline_mm[-1] * 1e-3
    assert (tip - np.asarray(app.ring_centre_m)) @ n > 0.05  # tandem tip 64 mm cranial


def test_applicator_s_ref_and_measured_path(example_app):
    """s_ref = arc length of the first marker = SourceApplicatorLength (277.571 / 280.499 mm)
    to 0.05 mm; the tandem's dwell at relative position p sits at arc length s_ref - p."""
    plan, app = example_app
    ring, tandem = app.channel("ring"), app.channel("tandem")
    assert ring.s_ref_m * 1e3 == pytest.approx(plan.channel(1).applicator_length_mm, abs=0.05)
    assert tandem.s_ref_m * 1e3 == pytest.approx(plan.channel(2).applicator_length_mm, abs=0.05)
    ch = plan.channel(2)
    pos = tandem.centreline.position(tandem.s_ref_m - ch.relative_position_mm * 1e-3)
    np.testing.assert_allclose(pos * 1e3, ch.positions_mm, atol=0.05)
    assert ring.measured_path_m.shape == (30, 3) and ring.measured_step_m == pytest.approx(2.5e-3)
    assert tandem.measured_path_m is None


def test_ring_lumen_is_u_shaped_after_the_stem(example_app):
    """Ring: r_b 1.5 mm, r_a 1.4 mm; circular on the stem, the paper's U beyond it (flat at the
    1.5 mm circle, facing the outside of the ring; the stem ends about 282.5 - 60 (circle) - 28
    (transition) = 194 mm from the entry); every lumen says where its dimensions come from."""
    _, app = example_app
    seg_s, rb, ra, flat = app.channel("ring").lumen.kernel_arrays()
    np.testing.assert_allclose(rb * 1e3, 1.5)
    np.testing.assert_allclose(ra * 1e3, 1.4)
    assert seg_s[1] * 1e3 == pytest.approx(194.0, abs=1.5)
    assert np.isinf(flat[0]) and flat[-1] * 1e3 == pytest.approx(1.5)
    ring = app.channel("ring").lumen
    assert ring.flat_side.towards == "ring_outside" and "Oncentra library" in ring.source
    seg_s, rb, ra, flat = app.channel("tandem").lumen.kernel_arrays()
    assert np.all(np.isinf(flat)) and rb[0] * 1e3 == pytest.approx(1.25)


def test_plan_without_library_cannot_give_an_applicator(rtplan_factory):
    from ringqa.errors import RingQAError
    from ringqa.io.rtplan import applicator_from_rtplan

    plan = read_rtplan(rtplan_factory())
    with pytest.raises(RingQAError, match="no embedded applicator library"):
        applicator_from_rtplan(plan)


# --------------------------------------------------------------------------------------------
# plausibility of the embedded library (issue 18): the shipped example with one thing broken in
# its library XML, written to a new plan.


def _broken_example(root, tmp_path, old: str, new: str):
    """The example plan with ``old`` replaced by ``new`` (once) in its library XML."""
    import gzip

    import pydicom

    from ringqa.io import oncentra

    ds = pydicom.dcmread(root.joinpath(*EXAMPLE))
    el = ds.ApplicationSetupSequence[0][oncentra.LIBRARY_TAG]
    text = oncentra.decode_library(el.value)
    assert text.count(old) == 1
    el.value = gzip.compress(text.replace(old, new).encode("utf-16"))
    out = tmp_path / "RP_broken.dcm"
    ds.save_as(out)
    return out


@pytest.mark.parametrize(
    ("address", "old"),
    [("@", 'matrix="-0.9944154088620123 '), ("@.IU", 'matrix="1.0000000000000007 ')],
)
def test_nan_in_a_library_transform_is_refused_naming_it(request, tmp_path, address, old):
    """A NaN in a joint's transform used to give NaN centrelines: now the plan reads (dwells,
    with a notice) and the applicator is refused naming the joint address."""
    from ringqa.errors import InputFileError
    from ringqa.io.rtplan import applicator_from_rtplan

    path = _broken_example(request.config.rootpath, tmp_path, old, 'matrix="NaN ')
    plan = read_rtplan(path)
    assert any(f"joint address {address!r}" in w for w in plan.warnings), plan.warnings
    with pytest.raises(InputFileError) as info:
        applicator_from_rtplan(plan)
    msg = str(info.value)
    for w in ("RP_broken.dcm", f"joint address {address!r}", "non-finite", "nan",
              "export the plan again"):  # fmt: skip
        assert w in msg, (w, msg)


def test_negative_lumen_diameter_is_refused_naming_the_part(request, tmp_path):
    from ringqa.errors import InputFileError
    from ringqa.io.rtplan import applicator_from_rtplan

    path = _broken_example(request.config.rootpath, tmp_path, '<lumen diameter="3" />',
                           '<lumen diameter="-3" />')  # fmt: skip
    with pytest.raises(InputFileError) as info:
        applicator_from_rtplan(read_rtplan(path))
    msg = str(info.value)
    for w in ("RP_broken.dcm", "library part", "(channel 1)", "<lumen diameter> is -3 mm",
              "export the plan again"):  # fmt: skip
        assert w in msg, (w, msg)


def test_reversed_library_source_path_is_refused(request, tmp_path, monkeypatch):
    """The library's measured path numbered proximal first (indices reversed): refused with the
    fix, naming the source path."""
    from ringqa.errors import InputFileError
    from ringqa.io import oncentra
    from ringqa.io.rtplan import applicator_from_rtplan

    plan = read_rtplan(request.config.rootpath.joinpath(*EXAMPLE))
    ring = plan.library[1]
    flipped = dict(plan.library)
    reversed_path = ring.measured_path_mm[::-1]
    flipped[1] = oncentra.LibraryChannel(**{**vars(ring), "measured_path_mm": reversed_path})
    object.__setattr__(plan, "library", flipped)
    with pytest.raises(InputFileError) as info:
        applicator_from_rtplan(plan)
    msg = str(info.value)
    for w in ("RP_ring26x60_oncentra43.dcm", "library source path", "MOST DISTAL FIRST",
              "reverse the order of the positions"):  # fmt: skip
        assert w in msg, (w, msg)
