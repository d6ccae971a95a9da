"""The engine keeps the channel table of the channels it simulated last
(:func:`ringqa.simulation.model.channel_table`): the same channel object gives the same table,
another channel (even an equal one) its own, and a run with a cached table gives the same
positions to the last digit as one that sampled the channel afresh."""

from __future__ import annotations

import dataclasses

import numpy as np

from ringqa.simulation import model as model_mod
from ringqa.simulation import simulate
from ringqa.simulation.channel import ChannelTable
from tests.simulation.builders import ring_channel, rod, scene


def test_same_channel_object_same_table_other_object_its_own():
    ch = ring_channel()
    a = model_mod.channel_table(ch)
    assert model_mod.channel_table(ch) is a
    other = dataclasses.replace(ch)  # equal fields, another object
    b = model_mod.channel_table(other)
    assert b is not a
    np.testing.assert_array_equal(b.pos, a.pos)
    fresh = ChannelTable.from_channel(ch)
    for name in ("pos", "tan", "nor", "kappa", "seg_rb"):
        np.testing.assert_array_equal(getattr(a, name), getattr(fresh, name))


def test_only_the_last_channels_are_kept():
    first = ring_channel()
    model_mod.channel_table(first)
    for _ in range(model_mod.TABLES_KEPT):
        model_mod.channel_table(ring_channel())
    assert id(first) not in model_mod._TABLES or model_mod._TABLES[id(first)][0] is not first
    assert len(model_mod._TABLES) <= model_mod.TABLES_KEPT


def test_a_run_with_the_cached_table_is_the_same_run():
    """Three runs of one scene: the first samples the channel, the next two reuse its table;
    with the cache emptied before each, the positions are the same to the last digit."""
    sc = scene(ring_channel(), rod(element=5e-3))
    adv = np.array([20.0, 40.0])
    cached = [simulate(sc, advances_mm=adv).source_pos_m for _ in range(2)]
    model_mod._TABLES.clear()
    fresh = simulate(sc, advances_mm=adv).source_pos_m
    for c in cached:
        np.testing.assert_array_equal(c, fresh)
