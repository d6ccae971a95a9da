"""Applicator files: shipped rings (must-show 4), round trip, folders, malformed files."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from ringqa.geometry import Applicator, Channel, ring_applicator
from ringqa.io.applicator_file import (
    ApplicatorFileError,
    applicator_to_dict,
    load_applicator,
    save_applicator,
    shipped_applicators,
)
from ringqa.io.points import write_points

SHIPPED = ("ring26x45", "ring26x60", "ring30x45", "ring30x60", "ring34x45", "ring34x60")


def test_six_rings_are_shipped():
    """The six Elekta-like rings are shipped by name."""
    assert set(SHIPPED) <= set(shipped_applicators())


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_ring_has_its_diameter_and_angle(name):
    """Must-show 4: ring<D>x<A> loads; its centreline radius about the ring centre is D/2 within
    0.05 mm over the circle part (and in the ring plane within 0.05 mm), the stem's angle to the
    ring plane (line fitted to the first 50 mm) is A within 0.5 deg; ring + tandem channels."""
    d, a = (float(v) for v in name[4:].split("x"))
    app = load_applicator(name)
    assert isinstance(app, Applicator) and app.name == name
    assert app.channel_names == ("ring", "tandem")
    ring = app.channel("ring")
    info = app.metadata["construction"]
    s0 = (info["stem_mm"] + info["transition_mm"]) * 1e-3
    p = ring.centreline.position(np.linspace(s0, ring.length_m, 400)) - app.ring_centre_m
    h = p @ app.ring_normal
    radial = np.linalg.norm(p - h[:, None] * app.ring_normal, axis=1) * 1e3
    assert np.abs(radial - d / 2).max() < 0.05
    assert np.abs(h).max() * 1e3 < 0.05
    stem = ring.centreline.position(np.linspace(0.0, 0.05, 101))
    _, _, vt = np.linalg.svd(stem - stem.mean(axis=0))
    angle = np.rad2deg(np.arcsin(abs(vt[0] @ app.ring_normal)))
    assert abs(angle - a) < 0.5
    assert ring.s_ref_m == pytest.approx(ring.length_m - 5e-3, abs=1e-8)


def test_shipped_files_match_the_generator(repo_root):
    """tools/make_applicators.py --check: the committed files equal a fresh rebuild."""
    sys.path.insert(0, str(repo_root / "tools"))
    try:
        import make_applicators
    finally:
        sys.path.pop(0)
    assert make_applicators.main(["--check", "--out", str(repo_root / "data" / "applicators")]) == 0
    # the comparison forgives one rounding unit (1e-6 mm) and nothing more
    tree = {"centreline_mm": [[1.000001, 2.0, 3.0]], "name": "x"}
    assert make_applicators.same(tree, {"centreline_mm": [[1.000000, 2.0, 3.0]], "name": "x"})
    assert not make_applicators.same(tree, {"centreline_mm": [[1.00001, 2.0, 3.0]], "name": "x"})
    assert not make_applicators.same(tree, {"centreline_mm": [[1.000001, 2.0, 3.0]], "name": "y"})


def _same(a: Applicator, b: Applicator) -> None:
    assert a.name == b.name and a.channel_names == b.channel_names
    assert np.allclose(a.ring_centre_m, b.ring_centre_m, atol=1e-12)
    assert np.allclose(a.ring_normal, b.ring_normal) and np.allclose(a.ring_lateral, b.ring_lateral)
    for ca, cb in zip(a.channels, b.channels, strict=True):
        s = np.linspace(0, ca.length_m, 97)
        assert np.abs(ca.centreline.position(s) - cb.centreline.position(s)).max() < 1e-12
        assert ca.s_ref_m == pytest.approx(cb.s_ref_m, abs=1e-12)
        for x, y in zip(ca.lumen.kernel_arrays(), cb.lumen.kernel_arrays(), strict=True):
            assert np.array_equal(x, y)
        if ca.measured_path_m is None:
            assert cb.measured_path_m is None
        else:
            assert np.allclose(ca.measured_path_m, cb.measured_path_m, atol=1e-12)
        assert ca.measured_step_m == cb.measured_step_m


def test_round_trip_is_exact(tmp_path):
    """save_applicator at full precision then load_applicator gives the same applicator (same
    points -> same spline), including a measured path and step."""
    app = ring_applicator(30, 45)
    ring = app.channel("ring")
    path = ring.centreline.position(ring.s_ref_m - np.arange(0, 0.03, 0.0025))
    ring2 = Channel("ring", ring.centreline, ring.lumen, ring.s_ref_m, path, 0.0025)
    app2 = Applicator(
        app.name,
        (ring2, app.channel("tandem")),
        app.ring_centre_m,
        app.ring_normal,
        app.ring_lateral,
        app.ring_radius_m,
        app.metadata,
    )
    f = save_applicator(app2, tmp_path / "a.json")
    back = load_applicator(f)
    _same(app2, back)
    assert json.loads(f.read_text())["format_version"] == 1
    # and again: the saved form is stable (up to mm <-> m rounding, 1e-12 mm)
    f2 = save_applicator(back, tmp_path / "b.json")
    c1 = json.loads(f.read_text())["channels"][0]["centreline_mm"]
    c2 = json.loads(f2.read_text())["channels"][0]["centreline_mm"]
    assert np.abs(np.array(c1) - np.array(c2)).max() < 1e-12


def _ring_folder(tmp_path, rel_m, spec_extra, with_rel_column=False):
    """A folder with the ring26x60 centreline, a path on it at s_ref - rel, applicator.json."""
    ring = ring_applicator(26, 60).channel("ring")
    write_points(tmp_path / "centreline.csv", ring.centreline.points_m)
    path = ring.centreline.position(ring.s_ref_m - rel_m)
    write_points(
        tmp_path / "measured_path.csv", path,
        relative_position_mm=rel_m * 1e3 if with_rel_column else None,
    )  # fmt: skip
    spec = {"name": "my ring", "lumen": {"kind": "circular", "r_b_mm": 1.5, "r_a_mm": 1.4},
            **spec_extra}  # fmt: skip
    (tmp_path / "applicator.json").write_text(json.dumps(spec))
    return ring


def test_folder_with_csv_files(tmp_path):
    """A folder: centreline.csv + measured_path.csv + applicator.json (lumen, step, s_ref asked
    for from the path; no ring frame): s_ref is the arc length of the path's first point, the
    frame a circle fit (radius 13 mm, normal +z because the stem comes from below); the path's
    provenance is the user's file."""
    rel = np.arange(0.0, 0.0301, 0.0025)
    ring = _ring_folder(tmp_path, rel, {"measured_step_mm": 2.5, "s_ref_mm": "from_measured_path"})
    got = load_applicator(tmp_path)
    ch = got.channel("ring")
    assert ch.s_ref_m == pytest.approx(ring.s_ref_m, abs=1e-6)
    assert ch.measured_path_m.shape == (13, 3) and ch.measured_step_m == pytest.approx(0.0025)
    assert ch.measured_source == "user file measured_path.csv"
    assert got.ring_radius_m == pytest.approx(0.013, abs=1e-6)
    assert np.allclose(got.ring_normal, [0, 0, 1], atol=1e-6)
    assert np.allclose(got.ring_centre_m, 0, atol=1e-6)
    assert np.allclose(got.ring_lateral, [1, 0, 0], atol=1e-6)


def test_missing_s_ref_is_refused_not_guessed(tmp_path):
    """Without s_ref_mm / tip_to_first_dwell_mm the folder is refused, naming the field and the
    explicit way to estimate it (s_ref shifts every along-channel deviation)."""
    _ring_folder(tmp_path, np.arange(0.0, 0.0301, 0.0025), {"measured_step_mm": 2.5})
    with pytest.raises(ApplicatorFileError, match=r"s_ref_mm: missing.*from_measured_path"):
        load_applicator(tmp_path)


def test_uneven_user_path_keeps_its_relative_positions(tmp_path):
    """A path CSV with a relative_position_mm column 0, 2.5, 6, 7, 12.5 mm (uneven): the channel
    keeps exactly these (no renumbering to a nominal step) and has no step."""
    rel = np.array([0.0, 2.5, 6.0, 7.0, 12.5]) * 1e-3
    _ring_folder(tmp_path, rel, {"s_ref_mm": 94.9}, with_rel_column=True)
    ch = load_applicator(tmp_path).channel("ring")
    np.testing.assert_allclose(ch.measured_relative_m, rel, atol=1e-12)
    np.testing.assert_allclose(ch.measured_relative_positions_m, rel, atol=1e-12)
    assert ch.measured_step_m is None


@pytest.mark.parametrize(
    ("extra", "with_rel", "fragment"),
    [
        ({"s_ref_mm": 94.9}, False, r"measured_step_mm: missing"),
        ({"s_ref_mm": 94.9, "measured_step_mm": 2.0}, True, r"contradicts the relative"),
    ],
)
def test_path_spacing_must_be_known_and_consistent(tmp_path, extra, with_rel, fragment):
    """A path needs its relative positions or a step; a step that contradicts the relative
    positions given (2.5 mm apart) is refused."""
    _ring_folder(tmp_path, np.arange(0.0, 0.0101, 0.0025), extra, with_rel_column=with_rel)
    with pytest.raises(ApplicatorFileError, match=fragment):
        load_applicator(tmp_path)


def _valid_doc():
    return applicator_to_dict(ring_applicator(26, 60), decimals=6)


@pytest.mark.parametrize(
    ("mutate", "fragment"),
    [
        (lambda d: d.pop("channels"), "channels: missing"),
        (lambda d: d.update(units="m"), "millimetres"),
        (lambda d: d.update(format_version=7), "format_version"),
        (lambda d: d["channels"][0].pop("lumen"), "channels[0] (ring).lumen: missing"),
        (lambda d: d["channels"][0]["lumen"].update(kind="oval"), "lumen.kind: got 'oval'"),
        (lambda d: d["channels"][0]["lumen"].update(lumen_diameter_mm=3.0), "unknown lumen key"),
        (lambda d: d["channels"][0].update(s_ref_mm=900.0), "s_ref_m"),
        (lambda d: d["channels"][0]["centreline_mm"].__setitem__(3, [1, 2]), "centreline_mm[3]"),
        (lambda d: d["channels"][0]["centreline_mm"].__setitem__(4, "x"), "centreline_mm[4]"),
        (lambda d: d["channels"][1].update(name="ring"), "duplicated"),
        (lambda d: d["ring_frame"].update(normal=[0, 0, 0]), "ring_frame.normal"),
        (lambda d: d["channels"][0]["lumen"].update(r_b_mm=-1), "r_b_mm: must be > 0"),
    ],
)
def test_malformed_files_name_the_field(tmp_path, mutate, fragment):
    """Each broken file raises ApplicatorFileError naming the file and the field."""
    doc = _valid_doc()
    mutate(doc)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(ApplicatorFileError) as err:
        load_applicator(f)
    assert str(f) in str(err.value)
    assert fragment in str(err.value)


def test_unreadable_inputs(tmp_path):
    """Not JSON, unknown name, folder without applicator.json: clear errors."""
    f = tmp_path / "x.json"
    f.write_text("{not json")
    with pytest.raises(ApplicatorFileError, match="invalid JSON at line 1"):
        load_applicator(f)
    with pytest.raises(ApplicatorFileError, match="ring26x60"):
        load_applicator("ring99x99")
    with pytest.raises(ApplicatorFileError, match=r"no applicator\.json"):
        load_applicator(tmp_path)
    with pytest.raises(ApplicatorFileError, match=r"\.json"):
        save_applicator(ring_applicator(26, 60), tmp_path / "a.txt")


def test_saved_file_is_plain_readable_json(tmp_path):
    """The file is readable without ringqa: points in mm proximal -> distal (first point caudal,
    last point on the 13 mm circle), s_ref_mm = length - 5 mm."""
    f = save_applicator(ring_applicator(26, 60), tmp_path / "r.json", decimals=6)
    doc = json.loads(Path(f).read_text())
    ring = doc["channels"][0]
    pts = np.array(ring["centreline_mm"])
    assert pts[0, 2] < -50 and abs(np.hypot(*pts[-1, :2]) - 13.0) < 1e-5
    assert ring["s_ref_mm"] == pytest.approx(ring["length_mm"] - 5.0, abs=1e-6)


def test_parametric_26x60_reproduces_the_oncentra_library(repo_root):
    """Independent check of the parametric model: the Oncentra 4.3 library centreline of the real
    26/60 ring (the example plan) in its ring frame (circle fit to its distal 55 mm, normal towards
    the tandem tip, lateral = DICOM +x projected) against ring26x60, point by point at equal
    distance b from the lumen tip: circle part (b <= 60 mm) within 0.1 mm, transition (60-90 mm)
    within 1.2 mm, first 30 mm of stem within 1.5 mm (measured 0.03 / 1.0 / 1.1 mm)."""
    from ringqa.geometry import Centreline, fit_circle
    from ringqa.io.rtplan import read_rtplan

    dcm = repo_root / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
    assert dcm.is_file(), f"{dcm}: the shipped example plan is missing"
    plan = read_rtplan(dcm)
    lib_ring = Centreline.from_points(np.asarray(plan.library[1].centreline_mm) * 1e-3)
    tandem_tip = np.asarray(plan.library[2].centreline_mm)[-1] * 1e-3
    length = lib_ring.length_m
    c, n, r, _ = fit_circle(lib_ring.position(np.linspace(length - 0.055, length, 100)))
    assert r == pytest.approx(0.013, abs=0.05e-3)
    n = n if (tandem_tip - c) @ n > 0 else -n
    lat = np.array([1.0, 0.0, 0.0]) - n[0] * n
    lat /= np.linalg.norm(lat)
    rot = np.vstack([lat, np.cross(n, lat), n])
    par = load_applicator("ring26x60").channel("ring").centreline
    b = np.arange(0.0, 0.120, 0.001)
    lib_pts = (lib_ring.position(length - b) - c) @ rot.T
    par_pts = par.position(par.length_m - b)
    dev_mm = np.linalg.norm(lib_pts - par_pts, axis=1) * 1e3
    assert dev_mm[b <= 0.060].max() < 0.1
    assert dev_mm[(b > 0.060) & (b <= 0.090)].max() < 1.2
    assert dev_mm[b > 0.090].max() < 1.5
