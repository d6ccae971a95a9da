"""Stand-ins for the geometry and the engine, so the pipeline is tested on its own (shared by
tests/pipeline, tests/report and tests/cli through ``tests.pipeline.fakes``).

The engine is an :class:`ringqa.pipeline.Engine`: :func:`fake_engine` (fake scenes and a fake
simulator) for the stand-in applicators, :func:`stand_in_engine` (ringqa's real scenes with a
stand-in simulator) for real applicators.

The ring: a straight stem along +y (x = 13 mm, 40 mm long) joining, tangentially, a circle of
radius R = 13 mm around the origin in the z = 0 plane, run counter-clockwise for 264 degrees
(59.9 mm) to the lumen tip; s_ref = tip - 5 mm. Cranial = +z, patient's left = +x. SI units, as
the geometry API.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np

from ringqa.geometry import Applicator, Centreline, Channel, Lumen
from ringqa.pipeline import Engine, default_engine

R = 0.013
STEM = 0.040
ARC = R * np.deg2rad(264.0)
LENGTH = STEM + ARC
S_REF = LENGTH - 0.005


class FakeCentreline(Centreline):
    """Stem + circle, evaluated analytically (a real :class:`Centreline` underneath, so the
    geometry API's type checks and tables work; positions, tangents and closest points are
    exact)."""

    def __init__(self):
        s = np.linspace(0.0, LENGTH, int(LENGTH / 0.25e-3) + 1)
        base = Centreline.from_points(self.position(s))
        super().__init__(base._spl, base._points, LENGTH, base.table)

    @staticmethod
    def position(s):
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = np.clip(s - STEM, 0, None) / R
        on_arc = s > STEM
        x = np.where(on_arc, R * np.cos(phi), R)
        y = np.where(on_arc, R * np.sin(phi), s - STEM)
        out = np.column_stack([x, y, np.zeros_like(s)])
        return out if out.shape[0] > 1 else out[0]

    @staticmethod
    def tangent(s):
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = np.clip(s - STEM, 0, None) / R
        out = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros_like(s)])
        return out if out.shape[0] > 1 else out[0]

    def closest(self, points, s_hint_m=None, window_m=None):
        """Exact closest points: on the stem (and its extension before the entry), on the arc,
        or on the straight extension beyond the tip."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        s_stem = np.minimum(p[:, 1] + STEM, STEM)
        phi = np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * np.pi)
        s_arc = STEM + R * np.clip(phi, 0.0, ARC / R)
        tip, t_tip = self.position(LENGTH), self.tangent(LENGTH)
        s_tip = LENGTH + np.maximum((p - tip) @ t_tip, 0.0)
        cands = np.column_stack([s_stem, s_arc, s_tip])
        pos = np.where(cands[..., None] > LENGTH, tip + (cands[..., None] - LENGTH) * t_tip,
                       self.position(cands.ravel()).reshape(-1, 3, 3))  # fmt: skip
        d = np.linalg.norm(p[:, None, :] - pos, axis=2)
        k = np.argmin(d, axis=1)
        rows = np.arange(p.shape[0])
        return cands[rows, k], d[rows, k]


def outward(pos):
    """In-plane unit vectors from the ring centre (origin) to positions (k, 3)."""
    v = pos.copy()
    v[:, 2] = 0
    return v / np.linalg.norm(v, axis=1)[:, None]


def make_applicator(*, measured_offset_m=0.5e-3, n_measured=30, step=2.5e-3, tandem=False,
                    r_b=1.5e-3, name="fake26", relative_m=None, measured_z_m=0.0,
                    moved=None):  # fmt: skip
    """The stand-in ring (a real :class:`Applicator`): measured path ``measured_offset_m``
    outside the centreline and ``measured_z_m`` above the ring plane, at relative positions
    ``relative_m`` (default 0, step, ...); ``moved`` maps path indices to extra displacements
    (m, (3,))."""
    cl = FakeCentreline()
    path = None
    if n_measured:
        rel = np.arange(n_measured) * step if relative_m is None else np.asarray(relative_m)
        pos = np.atleast_2d(cl.position(S_REF - rel))
        path = pos + measured_offset_m * outward(pos)
        path[:, 2] += measured_z_m
        for k, d in (moved or {}).items():
            path[k] += np.asarray(d, dtype=float)
    ring = Channel(
        "ring", cl, Lumen.circular(r_b, r_b - 1e-4), S_REF, measured_path_m=path,
        measured_step_m=step if n_measured and relative_m is None else None,
        measured_relative_m=relative_m if n_measured else None,
        measured_source="stand-in path" if n_measured else "",
    )  # fmt: skip
    channels = [ring]
    if tandem:
        z = np.linspace(0.005, 0.065, 61)
        tcl = Centreline.from_points(np.column_stack([np.zeros_like(z), np.zeros_like(z), z]))
        channels.append(Channel("tandem", tcl, Lumen.circular(1.25e-3, 1.15e-3), 0.055))
    return Applicator(
        name=name, channels=tuple(channels), ring_centre_m=np.zeros(3),
        ring_normal=np.array([0.0, 0, 1]), ring_lateral=np.array([1.0, 0, 0]), ring_radius_m=R,
    )  # fmt: skip


def sim_result(status, message, advances_mm, source_pos_m, source_dir=None, **fields):
    """A REAL :class:`ringqa.simulation.SimResult` of a stand-in engine: the given rows, the
    per-advance arrays it does not model NaN (tip, forces, arc length, offset) and
    ``fields`` (``warnings``, ``solve_time_s``, ``n_elements``, ``settings``, ...) as given."""
    from ringqa.simulation.result import SimResult

    adv = np.asarray(advances_mm, dtype=float).reshape(-1)
    pos = np.asarray(source_pos_m, dtype=float).reshape(-1, 3)
    n = pos.shape[0]
    dirs = np.full((n, 3), np.nan) if source_dir is None else np.asarray(source_dir, float)
    nan = np.full(n, np.nan)
    base = {"n_elements": 0, "solve_time_s": 0.0}
    return SimResult(
        status=int(status), message=str(message), advances_mm=adv, source_pos_m=pos,
        source_dir=dirs.reshape(-1, 3), tip_pos_m=np.full((n, 3), np.nan), push_force_n=nan,
        contact_force_n=np.zeros((n, 0)), newton_iters=np.zeros(n, dtype=np.int64), s_m=nan,
        offset_m=nan, **{**base, **fields},
    )  # fmt: skip


def fake_scene_factory(r_o=0.45e-3):
    """``scene_for_channel`` of the fake engine: a scene of one cable section of radius r_o."""

    def factory(channel, cable):
        return SimpleNamespace(
            channel=channel,
            cable=cable,
            instrument=SimpleNamespace(sections=[SimpleNamespace(r_o_m=r_o)],
                                       afterloader="flexitron"),
            overrides={},
        )  # fmt: skip

    return factory


def fake_with_overrides(scene, overrides):
    """``scene_with_overrides`` of the fake engine: records the overrides in the scene."""
    scene.overrides.update(overrides)
    return scene


def fake_scene_to_dict(scene):
    """``scene_to_dict`` of the fake engine: the preset and the overrides."""
    return {"instrument": {"preset": scene.cable}, **scene.overrides}


def fake_refine(scene, factor):
    """``refine`` of the fake engine: a copy of the scene that records the refinement factor."""
    new = SimpleNamespace(**vars(scene))
    new.overrides = {**scene.overrides, "refined": factor}
    return new


def fake_engine(simulator=None, scene_factory=None) -> Engine:
    """The fake engine: fake scenes (:func:`fake_scene_factory`) and a fake simulator."""
    return Engine(
        simulate=simulator or fake_simulator(),
        scene_for_channel=scene_factory or fake_scene_factory(),
        scene_with_overrides=fake_with_overrides,
        scene_to_dict=fake_scene_to_dict,
        refine=fake_refine,
    )


def stand_in_engine(simulator) -> Engine:
    """ringqa's engine with ``simulator`` instead of ``ringqa.simulation.simulate`` (real scenes
    and applicators, no mechanics)."""
    return dataclasses.replace(default_engine(), simulate=simulator)


def fake_simulator(offset_m=0.3e-3, z_m=0.0, jam_after=None, along_m=0.0, exact=None, warnings=(),
                   coarse_z_m=0.0):  # fmt: skip
    """Source centre = centreline point at the advance (+ along_m further), offset_m outward
    in the ring plane and z_m cranially; direction = centreline tangent. ``exact`` = (positions
    (n, 3) m, directions (n, 3)) in advance order replaces them. A scene that was not refined
    (the commissioning run before the refined one) puts the source ``coarse_z_m`` further
    cranially: the numerical error is then ``coarse_z_m``."""
    cl = FakeCentreline()
    calls = []

    def simulate(scene, advances_mm=None, progress=False):
        adv = np.asarray(advances_mm, dtype=float)
        calls.append(adv)
        s = adv * 1e-3 + along_m
        pos = np.atleast_2d(cl.position(s))
        pos = pos + offset_m * outward(pos)
        pos[:, 2] += z_m
        dirs = np.atleast_2d(cl.tangent(s))
        if exact is not None:
            pos, dirs = exact[0].copy(), exact[1].copy()
        if "refined" not in getattr(scene, "overrides", {"refined": True}):
            pos = pos.copy()
            pos[:, 2] += coarse_z_m
        status, msg = 0, "ok"
        if jam_after is not None:
            pos, dirs, status, msg = pos[:jam_after], dirs[:jam_after], 1, "push force above 50 N"
        return sim_result(status, msg, adv, pos, dirs, warnings=tuple(warnings), solve_time_s=0.01,
                          n_elements=12, settings={"fake": True})  # fmt: skip

    simulate.calls = calls
    return simulate


def centreline_simulator(offset_m=0.0):
    """A stand-in engine for REAL channels: the source centre on the centreline at the advance,
    moved ``offset_m`` along the channel's normal; direction = tangent."""

    def simulate(scene, advances_mm=None, progress=False):
        cl = scene.channel.centreline
        adv = np.asarray(advances_mm, dtype=float)
        s = adv * 1e-3
        pos = np.atleast_2d(cl.position(s)) + offset_m * np.atleast_2d(cl.normal(s))
        return sim_result(
            0, "", adv, pos, np.atleast_2d(cl.tangent(s)), settings={"stand_in": True}
        )

    return simulate
