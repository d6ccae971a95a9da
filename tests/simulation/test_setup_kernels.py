"""The run's set-up and checks outside the load steps, compiled (issue 29, simulate()'s time
outside the solve): the initial chain on the centreline, the contact samples' closest-point
hints, the outside-the-lumen test's tip distances, and the entry-point binding a marched run
skips. Each compiled path must give the Python one's numbers to the last digit: the same
evaluations (``curve_eval``, ``closest_point``) in the same order, the sample points as
``(1 - a) x_j + a x_{j+1}`` (a product and a sum per coordinate, no fused multiply-add in
either), the distance as ``sqrt(e . e)``, so any difference at all is a wrong index or order.
"""

from __future__ import annotations

import numpy as np

from ringqa.simulation import _kernels as K
from ringqa.simulation import simulate
from ringqa.simulation.model import Model
from ringqa.simulation.plausibility import outside_lumen
from ringqa.simulation.scenefile import load_scene
from ringqa.simulation.solvers import driver


def _ring26(repo_root):
    return load_scene(repo_root / "data" / "scenes" / "ring26-flexitron.toml")


def _python_initial_state(m: Model, u: float) -> tuple[np.ndarray, np.ndarray]:
    """The loops Model.initial_state and Model.set_hints ran in Python before they were
    compiled (the reference)."""
    q = np.zeros(m.n_all)
    for k in range(m.n_nodes):
        q[m.nd * k : m.nd * k + 3] = m.table.point(u + m.cft - m.chain.cum[k])
    work = np.empty(9)
    s = np.empty(m.samples.link.size)
    for i in range(s.size):
        j, a = m.samples.link[i], m.samples.alpha[i]
        p = (1 - a) * q[m.nd * j : m.nd * j + 3] + a * q[m.nd * (j + 1) : m.nd * (j + 1) + 3]
        s[i] = K.closest_point(
            m.table.h, m.table.pos, m.table.tan, np.ascontiguousarray(p), 0.0, -1.0, work
        )
    return q, s


def test_initial_state_and_hints_are_the_python_loops_bit_for_bit(repo_root):
    """At the run's start (the chain on the straight approach and inside the ring) and deep in
    the ring: the nodes and every sample's hint identical to the Python loops'."""
    sc = _ring26(repo_root)
    m = Model(sc, np.array([0.14]))
    for u in (m.u_start, 0.05, 0.12):
        q = m.initial_state(u)
        q_ref, s_ref = _python_initial_state(m, u)
        np.testing.assert_array_equal(q, q_ref)
        np.testing.assert_array_equal(m.samples.s, s_ref)
        assert np.ptp(s_ref) > 0.05  # the samples spread along the channel: a real test


def test_tip_distances_are_channel_table_closest_bit_for_bit(repo_root):
    """outside_lumen's compiled tip search gives ChannelTable.closest's arc length and
    distance for each finite tip (NaN rows skipped, the rows' order kept): a tip pushed
    0.4 mm beyond the lumen wall at the second row is found there, with that distance."""
    sc = _ring26(repo_root)
    m = Model(sc, np.array([0.14]))
    tb = m.table
    s_tab = np.array([0.03, 0.06, 0.09])
    tips = np.array([tb.point(s) for s in s_tab])
    n = np.cross(tb.tangent(0.06), [0.0, 0.0, 1.0])
    n /= np.linalg.norm(n)
    r_b = float(tb.seg_rb[0])
    tips[1] += (r_b + 4e-4) * n
    tips = np.vstack([tips, [np.nan] * 3])
    ts, td = np.empty(3), np.empty(3)
    K.closest_rows(tb.h, tb.pos, tb.tan, np.ascontiguousarray(tips[:3]), ts, td)
    for k in range(3):
        s_ref, d_ref = tb.closest(tips[k])
        assert ts[k] == s_ref and td[k] == d_ref
    nan = np.full(4, np.nan)
    out = outside_lumen(tb, nan, nan, tips, np.array([1.0, 2.0, 3.0, 4.0]))
    assert out is not None and out.what == "cable tip" and out.advance_mm == 2.0
    assert out.offset_m == td[1]
    assert abs(out.beyond_m - 4e-4) < 1e-6


def test_a_marched_run_does_not_bind_entry_points_the_python_loop_does(repo_root, monkeypatch):
    """Binding Newton's and the predictor's compiled entry points costs ~0.5 ms of type
    lookups a run; only the Python loop, which calls them every load step, binds them. The
    two runs give the same dwells to the last digit (test_march compares the loops fully)."""
    sc = _ring26(repo_root)
    bound = []
    orig = Model.bind_compiled_newton
    monkeypatch.setattr(
        Model, "bind_compiled_newton", lambda self, q: (bound.append(1), orig(self, q))
    )
    marched = simulate(sc)
    assert bound == []
    monkeypatch.setattr(driver, "USE_MARCH", False)
    looped = simulate(sc)
    assert bound == [1]
    np.testing.assert_array_equal(marched.source_pos_m, looped.source_pos_m)
