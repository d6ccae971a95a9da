"""Oncentra's applicator library on a synthetic plan: the mapping worked out by hand.

The library below has a straight ring-like part "R" at joint "@" (centre curve along +z, tip
first: (0,0,50) ... (0,0,0), marker1 (0,0,45)), transform M(@) = translation (10, 20, 30); and a
tube "IU" at "@.IU" with M(@.IU) = diag(1, -1, -1) + translation (0, -15, 100). Library -> patient
is (X, Y, Z) -> (X, -Z, Y). Hence

- R: part p = (0, 0, z) -> library (10, 20, 30 + z) -> patient (10, -30 - z, 20): proximal end
  (10, -30, 20), tip (10, -80, 20), marker (10, -75, 20);
- IU: (0, 0, z) -> M(@) M(@.IU) p = (10, 5, 130 - z) -> patient (10, z - 130, 5): proximal
  (10, -130, 5), tip (10, -120, 5);
- the source path's connector RO has axis (0,1,0), reference (0,0,1); the part's RO connector has
  axis (1,0,0), reference (0,0,1), centre (0,0,40). The rotation takes path y -> part x, path z ->
  part z, path x (= y cross z) -> part -y (= x cross z). Positions (listed out of order) index 1
  (0,2,0), 2 (0,1,0), 3 (1,0,0) -> part (2,0,40), (1,0,40), (0,-1,40) -> patient (12,-70,20),
  (11,-70,20), (10,-70,19).
"""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from ringqa.io.rtplan import read_rtplan


def _pts(zs):
    return "\n".join(f'<point x="0" y="0" z="{z}" />' for z in zs)


def _part(pid, kind, zs, marker_z, diameter, connectors=""):
    return f"""<part id="{pid}"><![CDATA[<?xml version="1.0" encoding="utf-16"?>
<part revision="1">
  <information partid="{pid}" type="Tube"><description>
    <longDescription>{kind} d={{0}}mm</longDescription><parameter>26</parameter>
  </description></information>
  <centerCurve tipLength="6">{_pts(zs)}<marker1 x="0" y="0" z="{marker_z}" /></centerCurve>
  <lumen diameter="{diameter}" />
  <connectors>{connectors}</connectors>
</part>]]></part>"""


LIBRARY = f"""<?xml version="1.0" encoding="utf-16"?>
<dataset id="x"><build datasetid="x">
<assembly id="a"><![CDATA[<?xml version="1.0" encoding="utf-16"?>
<configuration partset="1" label="Synthetic ring">
  <assembly part="P-R" label="R"><connection name="IU"><assembly part="P-IU" label="IU" />
  </connection></assembly>
</configuration>]]></assembly>
{
    _part(
        "P-R",
        "Ring Tube",
        range(50, -1, -1),
        45,
        3,
        '''<connector name="RO">
  <centerPoint x="0" y="0" z="40" /><axisDirection x="1" y="0" z="0" />
  <referenceDirection x="0" y="0" z="1" /></connector>''',
    )
}
{_part("P-IU", "Intrauterine tube", range(10, -1, -1), 5, 2.5)}
<sourcePath id="measured v1"><![CDATA[<?xml version="1.0" encoding="utf-16"?>
<sourcePath label="measured" stepsize="2.5"><sourcePositions>
  <connector name="RO"><centerPoint x="0" y="0" z="0" /><axisDirection x="0" y="1" z="0" />
    <referenceDirection x="0" y="0" z="1" /></connector>
  <sourcePosition x="1" y="0" z="0" index="3" />
  <sourcePosition x="0" y="2" z="0" index="1" />
  <sourcePosition x="0" y="1" z="0" index="2" />
</sourcePositions>
<partConnections><partConnection partid="P-R" connector="RO" /></partConnections>
</sourcePath>]]></sourcePath>
</build>
<transforms datasetid="x">
  <transform jointAddress="@" matrix="1 0 0 10 0 1 0 20 0 0 1 30 0 0 0 1" />
  <transform jointAddress="@.IU" matrix="1 0 0 0 0 -1 0 -15 0 0 -1 100 0 0 0 1" />
</transforms></dataset>"""

CHANNELS = (
    {"number": 1, "dwells": [(0.0, (12.0, -70.0, 20.0), 10.0)], "joint": "@"},
    {"number": 2, "dwells": [(0.0, (10.0, -125.0, 5.0), 10.0)], "joint": "@.IU"},
)


def _with_library(payload: bytes, joints=True):
    def edit(ds):
        setup = ds.ApplicationSetupSequence[0]
        block = setup.private_block(0x300B, "NUCLETRON", create=True)
        block.add_new(0x0D, "OB", payload)
        block.add_new(0x10, "LO", "Synthetic ring")
        if joints:
            for ch, spec in zip(setup.ChannelSequence, CHANNELS, strict=True):
                ch.private_block(0x300B, "NUCLETRON", create=True).add_new(
                    0x13, "LO", spec["joint"]
                )

    return edit


@pytest.fixture
def synthetic_plan(rtplan_factory):
    data = gzip.compress(LIBRARY.encode("utf-16"))
    return read_rtplan(rtplan_factory(CHANNELS, edit=_with_library(data)))


def test_part_mapping_and_order(synthetic_plan):
    ring, tube = synthetic_plan.library[1], synthetic_plan.library[2]
    assert ring.role == "ring" and tube.role == "tandem"
    np.testing.assert_allclose(ring.centreline_mm[0], [10, -30, 20], atol=1e-12)
    np.testing.assert_allclose(ring.centreline_mm[-1], [10, -80, 20], atol=1e-12)
    np.testing.assert_allclose(ring.marker_mm, [10, -75, 20], atol=1e-12)
    np.testing.assert_allclose(tube.centreline_mm[0], [10, -130, 5], atol=1e-12)
    np.testing.assert_allclose(tube.centreline_mm[-1], [10, -120, 5], atol=1e-12)
    assert ring.lumen_diameter_mm == 3 and tube.lumen_diameter_mm == 2.5
    assert synthetic_plan.applicator_name == "Synthetic ring"


def test_measured_path_through_the_connector_frames(synthetic_plan):
    ring, tube = synthetic_plan.library[1], synthetic_plan.library[2]
    np.testing.assert_allclose(
        ring.measured_path_mm, [[12, -70, 20], [11, -70, 20], [10, -70, 19]], atol=1e-12
    )
    assert ring.measured_step_mm == 2.5 and ring.measured_path_name == "measured v1"
    assert tube.measured_path_mm is None


def test_library_that_cannot_be_decoded_is_a_notice(rtplan_factory):
    plan = read_rtplan(rtplan_factory(CHANNELS, edit=_with_library(b"not gzip at all")))
    assert plan.library is None
    assert any("(300B,100D) not readable (not gzip" in w for w in plan.warnings)
    assert plan.channel(1).times_s[0] == pytest.approx(10.0)  # the standard tags still read


def test_channels_without_joint_address_get_no_library(rtplan_factory):
    data = gzip.compress(LIBRARY.encode("utf-16"))
    plan = read_rtplan(rtplan_factory(CHANNELS, edit=_with_library(data, joints=False)))
    assert plan.library is None
    assert any("no joint address (300B,1013)" in w for w in plan.warnings)


def test_library_not_matching_the_dwells_is_flagged(rtplan_factory):
    """A dwell 30 mm away from the channel's measured path: the library may be another plan's."""
    far = ({**CHANNELS[0], "dwells": [(0.0, (42.0, -70.0, 20.0), 10.0)]}, CHANNELS[1])
    data = gzip.compress(LIBRARY.encode("utf-16"))
    plan = read_rtplan(rtplan_factory(far, edit=_with_library(data)))
    assert any("channel 1: dwells lie up to 30.00 mm" in w for w in plan.warnings)
