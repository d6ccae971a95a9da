"""Fakes for the accuracy study: a duck-typed channel and a simulator with a known error model.

The fake simulator puts the source on a circle of radius 13 mm (the 26 mm ring) at arc length
``advance`` and adds a DETERMINISTIC discretisation error

    e(a) = (C_EL * h^2 + C_INC * inc) * (sin a', cos 2a', 0.3) / |(...)|,  a' = a / 13 mm,

with ``h`` the thin section's element length (mm) and ``inc`` the increment (mm), so the exact
answer (error 0) is known. Its "solve time" is proportional to elements x steps. Runs with an
increment above ``JAM_INC_MM`` report a jam.
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np
import pytest

from ringqa.simulation.scenefile import scene_for_channel

R_MM = 13.0
C_EL = 0.02  # mm per mm^2
C_INC = 0.05  # mm per mm
JAM_INC_MM = 3.0


class FakeCentreline:
    def __init__(self, length_m: float) -> None:
        self.length_m = length_m
        s = np.linspace(0.0, length_m, 50)
        self.points_m = np.column_stack([s, np.zeros_like(s), np.zeros_like(s)])


class FakeLumen:
    def kernel_arrays(self):
        return (np.array([-np.inf, np.inf]), np.array([1.5e-3]), np.array([1.4e-3]),
                np.array([np.inf]))  # fmt: skip


@dataclass(frozen=True)
class FakeChannel:
    name: str = "ring"
    centreline: FakeCentreline = None  # type: ignore[assignment]
    lumen: FakeLumen = None  # type: ignore[assignment]
    s_ref_m: float = 0.08
    measured_path_m: np.ndarray | None = None
    measured_step_m: float | None = None


def exact_positions_mm(adv_mm):
    a = np.asarray(adv_mm, float) / R_MM
    return np.column_stack([R_MM * np.cos(a), R_MM * np.sin(a), np.zeros_like(a)])


def exact_dirs(adv_mm):
    a = np.asarray(adv_mm, float) / R_MM
    return np.column_stack([-np.sin(a), np.cos(a), np.zeros_like(a)])


class FakeSimulator:
    """Counts calls; returns results with the error model of the module docstring."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, scene):
        self.calls += 1
        adv = np.array(scene.motion.advances_m) * 1e3
        thin = next(s for s in scene.instrument.sections if s.name == "thin")
        h = thin.element_length_m * 1e3
        inc = scene.solver.increment_m * 1e3
        n_el = sum(
            max(1, round(s.length_m / s.element_length_m)) for s in scene.instrument.sections
        )
        a = adv / R_MM
        v = np.column_stack([np.sin(a), np.cos(2 * a), np.full_like(a, 0.3)])
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        mag = C_EL * h**2 + C_INC * inc
        if scene.effects.friction == "none":
            mag += 0.5  # a model change moves the source by 0.5 mm
        pos = exact_positions_mm(adv) + mag * v
        dirs = exact_dirs(adv) + 0.01 * mag * v
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        status = 1 if inc > JAM_INC_MM else 0
        steps = max(adv) / inc
        return types.SimpleNamespace(
            status=status,
            message="jammed" if status else "ok",
            advances_mm=adv,
            source_pos_m=pos * 1e-3,
            source_dir=dirs,
            newton_iters=np.full(adv.size, 3),
            n_elements=n_el,
            solve_time_s=1e-6 * n_el * steps,
        )


@pytest.fixture
def fake_channel():
    return FakeChannel(centreline=FakeCentreline(0.1), lumen=FakeLumen())


@pytest.fixture
def fake_scene(fake_channel):
    """Flexitron in the fake channel: dwells every 5 mm from 80 mm back 40 mm, friction on."""
    return scene_for_channel(
        fake_channel,
        "flexitron",
        motion={"step_mm": 5.0, "span_mm": 40.0},
        solver={"increment_mm": 1.0},
    )


@pytest.fixture
def fake_simulator():
    return FakeSimulator()
