"""Must-show 2 and 3 on the whole paper sweep (34 rows, 28 channels, default settings): every
point finishes with finite forces, and the paper's trends (section 3.2, Figure 9) hold.

The sweep runs once per session (tests/needle/conftest.py, ~10 s on two processes); the numbers
quoted in the docstrings are the ones docs/needle.md reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringqa.needle.scene import NeedleError
from ringqa.needle.sweep import paper_points, parse_families

pytestmark = pytest.mark.slow

#: the issue-14 contract columns of DIR/peaks.csv, written out here
CONTRACT = ("family", "radius_mm", "torsion_rad", "diameter_mm", "nominal_diameter_mm", "peak1_n",
            "plateau_n", "peak2_n", "status")  # fmt: skip
LANDMARKS = ("peak1_n", "plateau_n", "peak2_n")


def _family(table, fam, nominal=True):
    t = table[table["family"] == fam]
    same = np.isclose(t["diameter_mm"], t["nominal_diameter_mm"])
    return t[same if nominal else ~same]


def test_the_study_has_34_rows_from_28_channels(paper_sweep, paper_peaks):
    """radius 9 x 2 + torsion 5 x 2 + diameter 3 x 2 = 34 rows; the r = 35 mm, tau = 0 channel at
    2.6 and 2.8 mm recurs in every family (and 2.8 mm as 2.6 + 0.2), so 28 distinct runs."""
    assert list(paper_peaks.columns[:5]) == list(CONTRACT[:5])
    assert set(CONTRACT) <= set(paper_peaks.columns)
    assert paper_peaks["family"].value_counts().to_dict() == {
        "radius": 18, "torsion": 10, "diameter": 6}  # fmt: skip
    assert len(paper_sweep.runs) == 28
    assert sorted(paper_peaks.loc[paper_peaks["family"] == "diameter", "diameter_mm"]) == (
        pytest.approx([2.6, 2.8, 2.8, 3.0, 3.0, 3.2])
    )
    forces = paper_sweep.force_table()
    assert len(forces) == 34 * 481


def test_every_point_finishes_with_finite_forces(paper_sweep, paper_peaks):
    """Must-show 3: status 0 and a finite force at every depth for all 34 rows, including the
    hardest channel (r = 20 mm, 2.6 mm: 1st peak 15.2 N, 2nd 20.7 N, below the 50 N jam force);
    every landmark found."""
    assert (paper_peaks["status"] == 0).all(), paper_peaks.loc[paper_peaks["status"] != 0]
    for p in paper_sweep.points:
        assert paper_sweep.run(p).finite
    assert np.isfinite(paper_peaks[list(LANDMARKS)].to_numpy()).all()
    hard = paper_peaks[(paper_peaks["radius_mm"] == 20.0) & (paper_peaks["diameter_mm"] == 2.6)]
    assert len(hard) == 1 and 10.0 < float(hard["peak2_n"].iloc[0]) < 50.0


@pytest.mark.parametrize("nominal", [True, False], ids=["2.6mm", "2.8mm"])
def test_peak_and_plateau_fall_as_the_radius_grows(paper_peaks, nominal):
    """'With increasing radius of curvature, peak and plateau insertion forces asymptotically
    decrease': the 1st peak and the plateau fall strictly from r = 20 to 60 mm at both
    diameters (2.6 mm: 15.2 -> 4.68 N and 6.06 -> 2.15 N), the 2nd peak from 20 to 55 mm
    (20.7 -> 6.36 N). At r = 60 mm the 2nd peak rises again (6.59 N at 2.6 mm, 5.99 N at 2.8
    mm): the S of w = 30 mm, h = 120 mm has its largest bend angle there (36.9 deg) and only a
    10 mm middle straight, so the catheter pushes through both bends at once (docs/needle.md);
    not asserted."""
    t = _family(paper_peaks, "radius", nominal).sort_values("radius_mm")
    for col in ("peak1_n", "plateau_n"):
        assert np.all(np.diff(t[col].to_numpy()) < 0), (col, t[col].tolist())
    p2 = t.loc[t["radius_mm"] <= 55.0, "peak2_n"].to_numpy()
    assert np.all(np.diff(p2) < 0)


def test_peak_and_plateau_fall_as_the_diameter_grows(paper_peaks):
    """'With increasing channel diameter ... peak and plateau forces decrease': every landmark
    falls from 2.6 to 2.8 to 3.0 mm (r = 35 mm, tau = 0; 1st peak 9.94 / 7.82 / 6.28 N), and in
    every row of every family the +0.2 mm run needs less than the nominal one (the band's
    sign)."""
    t = _family(paper_peaks, "diameter").sort_values("nominal_diameter_mm")
    for col in LANDMARKS:
        assert np.all(np.diff(t[col].to_numpy()) < 0), (col, t[col].tolist())
    for fam in ("radius", "torsion", "diameter"):
        nom = _family(paper_peaks, fam, True).reset_index(drop=True)
        wide = _family(paper_peaks, fam, False).reset_index(drop=True)
        for col in LANDMARKS:
            assert np.all(wide[col] < nom[col]), (fam, col)


def test_second_peak_adds_to_the_plateau(paper_peaks):
    """'Peak forces in successive curves seem to be additive, that is, the peak forces generated
    in the second curve are the same as that in the first curve.' The force bend 2 adds on top of
    the plateau, peak2 - plateau, equals the 1st peak within 15 % where the two bends act
    separately: where the middle straight d2 is at least the catheter's bending length
    sqrt(EI / plateau) (r = 20..35 mm at 2.6 mm: d2 = 70..56 mm vs 44..55 mm; observed
    -3.7 / -4.8 / -6.3 / -8.4 %). For every one of the 34 rows bend 2 adds something and at
    most what bend 1 needed: peak1 < peak2 <= peak1 + plateau. The second peak itself is 9-41 %
    above the first (friction carries bend 2's force through bend 1): 'as large as the first'
    holds for the rise, not the peak (docs/needle.md)."""
    t = paper_peaks
    assert np.all(t["peak2_n"] > t["peak1_n"])
    assert np.all(t["peak2_n"] <= t["peak1_n"] + t["plateau_n"])
    rad = _family(t, "radius")
    from ringqa.geometry.s_channel import bend_angle

    ei = 1.2e-2  # N m^2
    separated = []
    for _, row in rad.iterrows():
        d2_mm = bend_angle(row["radius_mm"])[1]
        bending_length_mm = 1e3 * math.sqrt(ei / row["plateau_n"])
        if d2_mm >= bending_length_mm:
            separated.append(row["radius_mm"])
            rise = row["peak2_n"] - row["plateau_n"]
            assert rise == pytest.approx(row["peak1_n"], rel=0.15), row["radius_mm"]
    assert {20.0, 25.0, 30.0} <= set(separated)  # not vacuous (observed: 20..35 mm)


def test_torsion_moves_the_forces_less_than_the_diameter_band(paper_peaks):
    """'For the developed templates, cumulative torsion is of small impact on the magnitude of
    peak and plateau forces': over tau = 0..pi (r = 35 mm) every landmark changes by less than
    the +0.2 mm band at tau = 0 does, at both diameters (2nd peak 13.02..13.50 N, a 0.48 N
    range, against a 3.68 N band; the 1st peak and the plateau come before bend 2 and do not
    change: < 0.01 N)."""
    nom = _family(paper_peaks, "torsion", True)
    wide = _family(paper_peaks, "torsion", False)
    zero_nom = nom[nom["torsion_rad"] == 0.0].iloc[0]
    zero_wide = wide[wide["torsion_rad"] == 0.0].iloc[0]
    for col in LANDMARKS:
        band = zero_nom[col] - zero_wide[col]
        assert band > 0
        for part in (nom, wide):
            spread = part[col].max() - part[col].min()
            assert spread < band, (col, spread, band)
    assert nom["peak2_n"].max() - nom["peak2_n"].min() > 0.1  # torsion does act on bend 2


@pytest.mark.parametrize(
    ("text", "expected"),
    [("paper", ("radius", "torsion", "diameter")), ("diameter,radius", ("radius", "diameter"))],
)
def test_family_names(text, expected):
    assert parse_families(text) == expected


def test_unknown_family_name():
    with pytest.raises(NeedleError, match=r"--sweep curvature: unknown family 'curvature'"):
        paper_points(["curvature"])
