"""Stand-ins for the geometry and the engine, so the pipeline is tested on its own (shared by
tests/pipeline, tests/report and tests/cli through ``tests.pipeline.fakes``).

The ring: a straight stem along +y (x = 13 mm, 40 mm long) joining, tangentially, a circle of
radius R = 13 mm around the origin in the z = 0 plane, run counter-clockwise for 264 degrees
(59.9 mm) to the lumen tip; s_ref = tip - 5 mm. Cranial = +z, patient's left = +x. SI units, as
the geometry API.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

R = 0.013
STEM = 0.040
ARC = R * np.deg2rad(264.0)
LENGTH = STEM + ARC
S_REF = LENGTH - 0.005


class FakeCentreline:
    """Stem + circle, analytic."""

    length_m = LENGTH

    def position(self, s):
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = np.clip(s - STEM, 0, None) / R
        on_arc = s > STEM
        x = np.where(on_arc, R * np.cos(phi), R)
        y = np.where(on_arc, R * np.sin(phi), s - STEM)
        out = np.column_stack([x, y, np.zeros_like(s)])
        return out if out.shape[0] > 1 else out[0]

    def tangent(self, s):
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = np.clip(s - STEM, 0, None) / R
        out = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros_like(s)])
        return out if out.shape[0] > 1 else out[0]

    def closest(self, points, s_hint_m=None, window_m=None):
        s = np.linspace(0, LENGTH, 20001)
        pos = self.position(s)
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        d = np.linalg.norm(p[:, None, :] - pos[None, :, :], axis=2)
        k = np.argmin(d, axis=1)
        return s[k], d[np.arange(len(k)), k]


class FakeLumen:
    def __init__(self, r_b=1.5e-3):
        self.r_b = r_b

    def kernel_arrays(self):
        return (np.array([0.0, LENGTH]), np.array([self.r_b]), np.array([self.r_b - 1e-4]),
                np.array([np.inf]))  # fmt: skip


def outward(pos):
    """In-plane unit vectors from the ring centre (origin) to positions (k, 3)."""
    v = pos.copy()
    v[:, 2] = 0
    return v / np.linalg.norm(v, axis=1)[:, None]


def make_applicator(*, measured_offset_m=0.5e-3, n_measured=30, step=2.5e-3, tandem=False,
                    r_b=1.5e-3, name="fake26"):  # fmt: skip
    cl = FakeCentreline()
    path = None
    if n_measured:
        s = S_REF - np.arange(n_measured) * step
        pos = cl.position(s)
        path = pos + measured_offset_m * outward(pos)
    ring = SimpleNamespace(
        name="ring",
        centreline=cl,
        lumen=FakeLumen(r_b),
        s_ref_m=S_REF,
        measured_path_m=path,
        measured_step_m=step if n_measured else None,
    )
    channels = [ring]
    if tandem:
        tcl = SimpleNamespace(
            length_m=0.06,
            position=lambda s: np.column_stack(
                [np.zeros(np.size(s)), np.zeros(np.size(s)), 0.005 + np.atleast_1d(s)]
            ).squeeze(),
            tangent=lambda s: np.tile([0.0, 0.0, 1.0], (np.size(s), 1)).squeeze(),
            closest=None,
        )
        channels.append(SimpleNamespace(name="tandem", centreline=tcl, lumen=FakeLumen(1.25e-3),
                                        s_ref_m=0.055, measured_path_m=None,
                                        measured_step_m=None))  # fmt: skip
    by_name = {c.name: c for c in channels}
    return SimpleNamespace(
        name=name, channels=tuple(channels), channel=by_name.__getitem__,
        ring_centre_m=np.zeros(3), ring_normal=np.array([0.0, 0, 1]),
        ring_lateral=np.array([1.0, 0, 0]), ring_radius_m=R, metadata={},
    )  # fmt: skip


def fake_scene_factory(r_o=0.45e-3):
    def factory(channel, cable):
        scene = SimpleNamespace(
            channel=channel,
            instrument=SimpleNamespace(sections=[SimpleNamespace(r_o_m=r_o)],
                                       afterloader="flexitron"),
            overrides={},
        )  # fmt: skip
        scene.with_overrides = lambda d: (scene.overrides.update(d), scene)[1]
        scene.to_dict = lambda: {"instrument": {"preset": cable}, **scene.overrides}
        return scene

    return factory


def fake_simulator(offset_m=0.3e-3, z_m=0.0, jam_after=None, along_m=0.0, exact=None, warnings=()):
    """Source centre = centreline point at the advance (+ along_m further), offset_m outward
    in the ring plane and z_m cranially; direction = centreline tangent. ``exact`` = (positions
    (n, 3) m, directions (n, 3)) in advance order replaces them."""
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
        status, msg = 0, "ok"
        if jam_after is not None:
            pos, dirs, status, msg = pos[:jam_after], dirs[:jam_after], 1, "push force above 50 N"
        return SimpleNamespace(status=status, message=msg, advances_mm=adv, source_pos_m=pos,
                               source_dir=dirs, warnings=warnings, solve_time_s=0.01, n_elements=12,
                               settings={"fake": True})  # fmt: skip

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
        return SimpleNamespace(
            status=0,
            message="",
            advances_mm=adv,
            source_pos_m=pos,
            source_dir=np.atleast_2d(cl.tangent(s)),
            warnings=(),
            solve_time_s=0.0,
            n_elements=0,
            settings={"stand_in": True},
        )

    return simulate


def real_engine():
    """ringqa.simulation.simulate when the engine has landed, else None."""
    import ringqa.simulation as simulation

    return getattr(simulation, "simulate", None)
