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


# --------------------------------------------------------------------------------------------
# plausibility (issue 18: nothing wrong passes silently). Bad inputs are built from the shipped
# ring26x60 (data/applicators) one change at a time; every refusal names the file, the field,
# the value and the fix.


def _shipped_doc(repo_root, name="ring26x60"):
    return json.loads((repo_root / "data" / "applicators" / f"{name}.json").read_text())


def _write(tmp_path, doc, name="bad.json"):
    p = tmp_path / name
    p.write_text(json.dumps(doc))
    return p


def _refused(path, *words):
    """Load ``path`` (a file, or a folder: its applicator.json is named), expect an
    ApplicatorFileError naming the file and every word."""
    with pytest.raises(ApplicatorFileError) as info:
        load_applicator(path)
    msg = str(info.value)
    name = "applicator.json" if Path(path).is_dir() else Path(path).name
    for w in (name, *words):
        assert w in msg, (w, msg)
    return msg


@pytest.mark.parametrize(
    ("mutate", "field", "suggestion"),
    [
        (lambda d: d["channels"][0].update(sref_mm=d["channels"][0].pop("s_ref_mm")),
         "channels[0].sref_mm", "did you mean 's_ref_mm'"),
        (lambda d: d["channels"][1].update(lumen_diameter_mm=2.5),
         "channels[1].lumen_diameter_mm", "r_b_mm = diameter / 2"),
        (lambda d: d["ring_frame"].update(radius=13.0), "ring_frame.radius",
         "did you mean 'radius_mm'"),
        (lambda d: d.update(chanels=[]), "chanels", "did you mean 'channels'"),
        (lambda d: d["channels"][0]["lumen"].update(rb_mm=1.5), "lumen.rb_mm",
         "did you mean 'r_b_mm'"),
    ],
)  # fmt: skip
def test_unknown_or_misspelt_key_is_refused_with_the_nearest_key(
    tmp_path, repo_root, mutate, field, suggestion
):
    doc = _shipped_doc(repo_root)
    mutate(doc)
    msg = _refused(_write(tmp_path, doc), field, "unknown", suggestion)
    assert "keys" in msg  # the known keys are listed


def test_unknown_key_in_a_folder_applicator_json(tmp_path):
    """The folder form's top level (lumen, s_ref_mm, ... beside centreline.csv) is checked too."""
    rel = np.arange(0.0, 0.0301, 0.0025)
    _ring_folder(tmp_path, rel, {"measured_step_mm": 2.5, "sref_mm": 142.9})
    _refused(tmp_path, "sref_mm", "unknown", "did you mean 's_ref_mm'")


def test_centreline_csv_with_a_latin1_comment_is_read_with_a_note(tmp_path):
    """A centreline.csv saved by a German Excel (Latin-1 comment) loads; the applicator's notes
    say it was read as Latin-1."""
    rel = np.arange(0.0, 0.0301, 0.0025)
    _ring_folder(tmp_path, rel, {"measured_step_mm": 2.5, "s_ref_mm": "from_measured_path"})
    cl = tmp_path / "centreline.csv"
    cl.write_bytes("# Länge gemessen, Ø 26 mm, Bögen geprüft\n".encode("latin-1") + cl.read_bytes())
    app = load_applicator(tmp_path)
    notes = app.metadata["notes"]
    assert any("centreline.csv" in n and "Latin-1" in n for n in notes), notes


def test_coordinates_in_centimetres_inline_are_refused(tmp_path, repo_root):
    """The ring centreline divided by 10 (cm): 28 mm long in 'mm' is plausible, so the tandem (12
    mm in cm) names the unit; the ring frame's radius in cm too."""
    doc = _shipped_doc(repo_root)
    doc["channels"][1]["centreline_mm"] = [
        [v / 10 for v in p] for p in doc["channels"][1]["centreline_mm"]
    ]
    _refused(_write(tmp_path, doc), "channels[1] (tandem).centreline_mm", "centimetres",
             "multiply by 10")  # fmt: skip
    doc = _shipped_doc(repo_root)
    doc["ring_frame"]["radius_mm"] = 1.3
    _refused(_write(tmp_path, doc), "ring_frame.radius_mm", "1.3 mm", "implausible",
             "multiply by 10")  # fmt: skip


def test_huge_coordinates_are_refused(tmp_path, repo_root):
    doc = _shipped_doc(repo_root)
    doc["channels"][0]["centreline_mm"][3][0] = 2.5e6
    _refused(_write(tmp_path, doc), "channels[0] (ring).centreline_mm[3]", "2.5e+06 mm",
             "micrometres")  # fmt: skip


def test_tip_first_centreline_is_named(tmp_path, repo_root):
    """The ring centreline listed tip first: with the ring frame given and without it (where the
    frame fit used to say 'not a circle'), the message names the order and the fix."""
    doc = _shipped_doc(repo_root)
    doc["channels"][0]["centreline_mm"].reverse()
    _refused(_write(tmp_path, doc), "channels[0] (ring).centreline", "tip to the entry",
             "reverse the rows")  # fmt: skip
    del doc["ring_frame"]
    _refused(_write(tmp_path, doc), "channels[0] (ring).centreline", "tip to the entry",
             "reverse the rows")  # fmt: skip


def test_decreasing_s_breaks_and_negative_radius_are_named(tmp_path, repo_root):
    doc = _shipped_doc(repo_root)
    doc["channels"][0]["lumen"] = {"kind": "stepped", "s_breaks_mm": [100.0, 60.0],
                                   "r_b_mm": [1.5, 1.6, 1.5]}  # fmt: skip
    _refused(_write(tmp_path, doc), "lumen.s_breaks_mm", "100 then 60 mm", "do not increase",
             "increasing")  # fmt: skip
    doc = _shipped_doc(repo_root)
    doc["channels"][1]["lumen"]["r_b_mm"] = -1.25
    _refused(_write(tmp_path, doc), "lumen.r_b_mm", "-1.25", "positive")


def _with_path(repo_root, path_mm, step_mm=2.5):
    doc = _shipped_doc(repo_root)
    doc["channels"][0]["measured_path_mm"] = np.asarray(path_mm).tolist()
    doc["channels"][0]["measured_step_mm"] = step_mm
    return doc


def _ring_path_mm(n=20, step=2.5e-3):
    ring = ring_applicator(26, 60).channel("ring")
    return ring.centreline.position(ring.s_ref_m - np.arange(n) * step) * 1e3


def test_measured_path_on_the_channel_is_accepted(tmp_path, repo_root):
    app = load_applicator(_write(tmp_path, _with_path(repo_root, _ring_path_mm())))
    assert app.channel("ring").measured_path_m.shape == (20, 3)


def test_reversed_measured_path_is_refused_with_the_fix(tmp_path, repo_root):
    """Proximal first (inline and as measured_path.csv in a folder): 'reverse the rows'."""
    doc = _with_path(repo_root, _ring_path_mm()[::-1])
    _refused(_write(tmp_path, doc), "channels[0] (ring).measured_path", "MOST DISTAL FIRST",
             "reverse the order of the rows")  # fmt: skip
    folder = tmp_path / "folder"
    folder.mkdir()
    rel = np.arange(0.0, 0.0301, 0.0025)
    _ring_folder(folder, rel, {"measured_step_mm": 2.5, "s_ref_mm": 142.9})
    mp = folder / "measured_path.csv"
    lines = mp.read_text().splitlines()
    mp.write_text("\n".join([lines[0], *lines[:0:-1]]) + "\n")
    _refused(folder, "measured_path", "reverse the order of the rows")


def test_shifted_measured_path_is_refused_naming_the_distance(tmp_path, repo_root):
    """The path moved 20 mm along the ring normal: every position is 20 mm off the channel."""
    doc = _with_path(repo_root, _ring_path_mm() + np.array([0.0, 0.0, 20.0]))
    _refused(_write(tmp_path, doc), "channels[0] (ring).measured_path", "median 20.0 mm",
             "same coordinates as the centreline")  # fmt: skip


def test_declared_step_unlike_the_spacing_is_refused(tmp_path, repo_root):
    """measured_step_mm 5 for positions 2.5 mm apart (the hole beside the existing refusal of a
    step that contradicts relative positions)."""
    doc = _with_path(repo_root, _ring_path_mm(), step_mm=5.0)
    _refused(_write(tmp_path, doc), "channels[0] (ring).measured_path", "2.5 mm apart",
             "measured_step_mm says 5 mm", "correct measured_step_mm")  # fmt: skip
