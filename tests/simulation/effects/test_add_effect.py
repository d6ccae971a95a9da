"""Adding an effect touches its own module, its registration and its tests: this module is such
an effect (a uniform distributed load), written against the public effect API only, and checked
against a closed-form result (docs/architecture.md, "How to add an effect")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
import pytest
from numba import njit

from ringqa.simulation import simulate
from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects import EFFECTS, register_effect, unregister_effect
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels
from ringqa.simulation.scene import Effects, Motion, SolverSettings
from tests.simulation.builders import rod, scene

EI = 5e-4


# -- the effect: args, kernel, registration, unit ---------------------------------------------
class UniformLoadArgs(NamedTuple):
    """Force on every node (N+1,) (N) along a unit direction (3,)."""

    f_node: np.ndarray
    direction: np.ndarray


@njit
def add_uniform_load(p, q, st, sw, r, B, jac):
    """A constant external force: ``r -= f`` (no stiffness); returns its potential -f.x (J)."""
    energy = 0.0
    for i in range(st.n_nodes):
        for a in range(3):
            f = p.f_node[i] * p.direction[a]
            r[st.nd * i + a] -= f
            energy -= f * q[st.nd * i + a]
    return energy


register_kernels(UniformLoadArgs, add=add_uniform_load)


@dataclass(frozen=True)
class UniformLoad(Effect):
    """A load of ``w`` N/m along ``direction``, lumped to the nodes by half links."""

    name = "uniform_load"
    energy = "stored"
    load: ClassVar[tuple | None] = None  # (w (N/m), direction): what "the scene" asks for here

    f_node: np.ndarray
    direction: np.ndarray

    @classmethod
    def build(cls, ctx: BuildContext) -> UniformLoad | None:
        if cls.load is None:
            return None
        w, direction = cls.load
        half = 0.5 * w * ctx.chain.link_len
        f = np.zeros(ctx.chain.n_nodes)
        f[:-1] += half
        f[1:] += half
        return cls(f, np.asarray(direction, dtype=float))

    def args(self) -> UniformLoadArgs:
        return UniformLoadArgs(self.f_node, self.direction)


# -- the tests ------------------------------------------------------------------------------
@pytest.fixture
def uniform_load():
    """The effect registered (and removed again afterwards)."""
    register_effect(UniformLoad)
    yield UniformLoad
    UniformLoad.load = None
    unregister_effect(UniformLoad)


def _cantilever(length=0.1, n_links=50):
    """A clamped rod of free length 0.1 m along +x in a huge straight lumen (no contact), held
    at its final advance: the run's initial equilibrium is the static solution."""
    ch = arc_channel(radius_m=1.0, angle_rad=0.01, entry_m=0.5, r_b_m=0.2, r_a_m=0.19)
    u = length - 1e-3
    return scene(
        ch,
        rod(ei=EI, element=length / n_links, length=1.0, r_o=1e-3),
        effects=Effects(friction="none", contact=False),
        solver=SolverSettings(approach_m=1e-3, axial_stiffness_n=1e8),
        motion=Motion(start_m=u, advances_m=(u,)),
    ), u


def test_registered_effect_is_assembled_before_the_tether(uniform_load):
    """register_effect puts the unit into the assembly order just before the solver's tether."""
    names = [cls.name for cls in EFFECTS]
    assert names[-2:] == ["uniform_load", "tether"]


def test_uniform_load_bends_a_cantilever_by_w_l4_over_8_ei(uniform_load):
    """A clamped rod under a uniform load w per length deflects w L^4 / (8 EI) at the tip
    (small deflection): w = 0.05 N/m, L = 0.1 m, EI = 5e-4 N m^2 -> w L^3 / EI = 0.01,
    deflection 0.125 mm (the large-deflection correction is ~1e-5 relative); 50 links, within 1 %.
    The effect is switched on only while registered and asked for."""
    sc, u = _cantilever()
    free = simulate(sc, [u * 1e3])
    uniform_load.load = (0.05, (0.0, -1.0, 0.0))
    loaded = simulate(sc, [u * 1e3])
    assert loaded.success and "uniform_load" in loaded.settings["effects_assembled"]
    assert "uniform_load" not in free.settings["effects_assembled"]
    x = loaded.nodes_m[0]
    L = 0.1
    assert -(x[0, 1] - x[-2, 1]) == pytest.approx(0.05 * L**4 / (8 * EI), rel=0.01)
    assert np.max(np.abs(free.nodes_m[0][:, 1])) < 1e-12


def test_uniform_load_equals_gravity_on_the_same_weight(uniform_load):
    """The same load as gravity on 0.04 kg/m at 1.25 m/s^2 (w = 0.05 N/m): identical chains to
    round-off (the lumping differs only in the order of the multiplications)."""
    sc, u = _cantilever()
    uniform_load.load = (0.04 * 1.25, (0.0, -1.0, 0.0))
    a = simulate(sc, [u * 1e3])
    uniform_load.load = None
    g = sc.replace(effects=Effects(friction="none", contact=False, gravity_m_s2=(0.0, -1.25, 0.0)))
    b = simulate(g, [u * 1e3])
    np.testing.assert_allclose(a.nodes_m, b.nodes_m, rtol=0, atol=1e-12)
