"""The engine against the AAPM/ESTRO consensus along-away QA tables (independent published data).

The consensus spreadsheets tabulate the 2D TG-43 dose rate per unit S_K on a z (along the axis,
+z = tip) x y (away) grid. Every point of each table is recomputed through the public API
``tg43.dose_rate_per_sk`` (source at the origin pointing along +z, point at (y, 0, z)), except the
(0, 0) placeholder (the source centre). Tolerances are those asked of the engine (0.15 %,
Flexisource 0.12 %); with the consensus interpolation rules the tables are in fact met to better
than 0.05 % (the residual is the GammaMed sheet's near-field grid).
"""

from __future__ import annotations

import numpy as np
import pytest

import tg43

TOLERANCE_PCT = {"flexisource": 0.12, "gammamed-plus": 0.15, "vs2000": 0.15, "m-19": 0.15}


def _table_points(source):
    zz, yy = np.meshgrid(source.qa_z_cm, source.qa_y_cm, indexing="ij")
    keep = ~((zz == 0) & (yy == 0))
    pts_mm = np.column_stack([yy[keep], np.zeros(keep.sum()), zz[keep]]) * 10.0
    return pts_mm, source.qa_dose_rate[keep], zz[keep], yy[keep]


@pytest.mark.parametrize("name", sorted(TOLERANCE_PCT))
def test_reproduces_every_qa_table_point(name):
    """max |D_engine / D_consensus - 1| over the whole table below the tolerance.

    Calling dose_rate_per_sk (not along_away_table) also proves that the inside-source radius
    r_min rejects none of the table's points except (0, 0).
    """
    source = tg43.load_source(name)
    assert source.has_qa_table
    pts, expected, zz, yy = _table_points(source)
    assert expected.size == source.qa_dose_rate.size - 1
    got = tg43.dose_rate_per_sk(source, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], pts)[:, 0]
    err_pct = np.abs(got / expected - 1.0) * 100.0
    k = int(np.argmax(err_pct))
    print(f"{name}: max deviation {err_pct[k]:.4f} % at z={zz[k]} cm, y={yy[k]} cm")
    assert err_pct[k] < TOLERANCE_PCT[name], (
        f"{name}: max deviation {err_pct[k]:.4f} % at z={zz[k]} cm, y={yy[k]} cm "
        f"(engine {got[k]:.6g}, consensus {expected[k]:.6g} cGy/h/U), "
        f"tolerance {TOLERANCE_PCT[name]} %"
    )


@pytest.mark.parametrize("name", sorted(TOLERANCE_PCT))
def test_qa_table_tip_and_cable_sides_differ(name):
    """The tables are not symmetric in z: a sign error in theta would swap F(theta) and
    F(180 - theta). At z = +-1 cm on the axis the consensus values differ by > 5 %, and the
    engine puts the larger one on the same side as the table."""
    source = tg43.load_source(name)
    iz_tip = int(np.argmin(np.abs(source.qa_z_cm - 1.0)))
    iz_cable = int(np.argmin(np.abs(source.qa_z_cm + 1.0)))
    tip, cable = source.qa_dose_rate[iz_tip, 0], source.qa_dose_rate[iz_cable, 0]
    assert abs(tip / cable - 1) > 0.05
    got = tg43.dose_rate_per_sk(
        source, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [[0.0, 0.0, 10.0], [0.0, 0.0, -10.0]]
    )[:, 0]
    assert (got[0] > got[1]) == (tip > cable)
    np.testing.assert_allclose(got, [tip, cable], rtol=1.5e-3)


def test_along_away_table_matches_public_api():
    """along_away_table (used by the demo) is the same computation laid out as a grid."""
    source = tg43.load_source("vs2000")
    table = tg43.along_away_table(source, source.qa_z_cm, source.qa_y_cm)
    pts, _, zz, yy = _table_points(source)
    got = tg43.dose_rate_per_sk(source, [[0, 0, 0]], [[0, 0, 1]], pts)[:, 0]
    zi = {z: i for i, z in enumerate(source.qa_z_cm)}
    yi = {y: i for i, y in enumerate(source.qa_y_cm)}
    grid = np.array([table[zi[z], yi[y]] for z, y in zip(zz, yy, strict=True)])
    np.testing.assert_array_equal(grid, got)
    assert np.isnan(table[zi[0.0], yi[0.0]])
