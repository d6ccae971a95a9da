"""The engine scene for one needle insertion: a catheter pushed into a channel from rest.

The settings (instrument, contact, friction, solver numerics) come from a scene file, by default
the shipped ``needle-paper`` scene (``data/scenes/needle-paper.toml``); the channel is either that
scene's own (a centreline file) or the paper's S channel from :func:`ringqa.geometry.s_channel`.

Depth and the engine's advance
------------------------------
The catheter starts straight with its tip at the start of the channel (s = 0, the end of the
straight guide it lies in; the engine continues the centreline straight before s = 0 with the
entry lumen, so the guide is the entry lumen). The engine's advance of a scene whose instrument
has no source offset (``centre_from_tip`` = 0) is the centreline arc length where the TIP would
be if the catheter followed the centreline, and ``motion.start_mm = 0`` starts it there, so

    depth (mm) = advance (mm) = how far the driven end has moved from its start position.

The driven end is the clamp: the engine prescribes the two proximal nodes on the approach axis, so
the free length (Table 1: 120 mm) is the instrument's length and the scene built here adds one
link of the last section behind it (the clamped link). ``solver.approach_mm`` then plays no role:
the modelled length is the whole catheter (free length + clamped link) because it is shorter than
the deepest tip position plus the approach. Results are reported at every increment of depth from
0 to the insertion depth (default 120 mm, the paper's; at most the free length and the channel's
length).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry import Channel, GeometryError, s_channel
from ringqa.geometry.s_channel import NOMINAL_DIAMETER_MM, max_radius_mm
from ringqa.simulation import Scene, load_scene
from ringqa.simulation.scenefile import scene_for_channel, scene_to_dict, scene_with_overrides
from ringqa.units import m_to_mm

#: The shipped scene with the needle study's settings (data/scenes/needle-paper.toml).
DEFAULT_SCENE = "needle-paper"
#: Insertion depth (mm): the catheter is pushed 120 mm (the authors' code; its free length).
INSERTION_MM = 120.0
#: The paper's channel when only some of radius / torsion / diameter are given.
DEFAULT_RADIUS_MM = 35.0
DEFAULT_TORSION_RAD = 0.0
DEFAULT_DIAMETER_MM = NOMINAL_DIAMETER_MM


class NeedleError(RingQAError):
    """Bad input to the needle study (names the argument and the fix)."""


@dataclass(frozen=True)
class ChannelSpec:
    """The paper's S channel asked for: radius (mm), torsion (rad) and diameter (mm)."""

    radius_mm: float = DEFAULT_RADIUS_MM
    torsion_rad: float = DEFAULT_TORSION_RAD
    diameter_mm: float = DEFAULT_DIAMETER_MM


def load_settings(scene: str | Scene | None = None, overrides: Mapping[str, Any] | None = None):
    """The settings scene: a scene file or shipped name (default ``needle-paper``) with overrides.

    Parameters
    ----------
    scene : str, Path, Scene or None
        Scene file, shipped scene name, an already loaded scene, or None for ``needle-paper``.
    overrides : mapping of dotted key -> value, optional
        ``{"solver.increment_mm": 0.5}`` (user units), applied to the file's settings.

    Returns
    -------
    Scene
    """
    if isinstance(scene, Scene):
        return scene_with_overrides(scene, overrides) if overrides else scene
    return load_scene(DEFAULT_SCENE if scene is None else scene, overrides)


def _free_length_mm(settings: Scene) -> float:
    return m_to_mm(sum(s.length_m for s in settings.instrument.sections))


def n_links(scene: Scene) -> int:
    """Links of the scene's whole instrument (each section in equal links no longer than its
    element length, a rigid section one link), as the engine cuts it when it models it all."""
    return sum(
        1 if s.rigid else max(1, math.ceil(s.length_m / s.element_length_m - 1e-9))
        for s in scene.instrument.sections
    )


def _catheter(settings: Scene) -> tuple[float, float]:
    """(outer radius (m), smallest bending stiffness (N m^2)) of the flexible sections."""
    secs = [s for s in settings.instrument.sections if not s.rigid]
    if not secs:
        raise NeedleError("instrument: the needle study needs a flexible instrument section")
    return max(s.r_o_m for s in secs), min(s.ei_nm2 for s in secs)


def min_passable_radius_mm(settings: Scene, diameter_mm: float) -> float:
    """Smallest bend radius (mm) the catheter can be pushed through without jamming.

    A catheter pushed round a bend whose path radius is rho needs at least the frictionless
    insertion force ``EI / (2 rho^2)`` (``shared/reference/mechanics.md`` item 1; friction only
    adds to it); with the catheter against the outer wall, ``rho = r + c``, ``c = D/2 - r_o``.
    Above ``solver.jam_force_n`` the engine reports a jam, so the smallest radius is
    ``sqrt(EI / (2 F_jam)) - c`` (10.6 mm for the paper's catheter, EI = 1.2e-2 N m^2, 50 N,
    2.6 mm), and never below the lumen radius (the inner wall would fold).
    """
    r_o, ei = _catheter(settings)
    c_mm = diameter_mm / 2.0 - m_to_mm(r_o)
    rho_mm = m_to_mm(math.sqrt(ei / (2.0 * settings.solver.jam_force_n)))
    return max(rho_mm - c_mm, diameter_mm / 2.0)


def check_spec(spec: ChannelSpec, settings: Scene) -> None:
    """Reject a channel the catheter cannot be simulated in, before anything runs.

    Raises
    ------
    NeedleError
        Torsion outside 0..pi, a diameter not larger than the catheter's, a bend radius too small
        for the catheter to pass (:func:`min_passable_radius_mm`) or too large for the S
        (:func:`ringqa.geometry.s_channel.max_radius_mm`).
    """
    vals = {}
    for name, v in (
        ("--radius-mm", spec.radius_mm),
        ("--torsion-rad", spec.torsion_rad),
        ("--diameter-mm", spec.diameter_mm),
    ):
        try:
            vals[name] = float(v)
        except (TypeError, ValueError):
            raise NeedleError(f"{name} {v!r}: expected a number") from None
        if not math.isfinite(vals[name]):
            raise NeedleError(f"{name} {v}: expected a finite number")
    r, tau, dia = vals.values()
    if not 0.0 <= tau <= math.pi:
        raise NeedleError(
            f"--torsion-rad {tau:g}: the torsion must lie in 0..pi (0 = planar S, "
            f"pi = {math.pi:.4f} = both bends in one plane turning the same way)"
        )
    r_o, _ = _catheter(settings)
    cat_mm = 2.0 * m_to_mm(r_o)
    if dia <= cat_mm:
        raise NeedleError(
            f"--diameter-mm {dia:g}: the channel must be wider than the catheter "
            f"({cat_mm:.2f} mm); the paper's channels are 2.6-3.0 mm"
        )
    if not r > 0.0:
        raise NeedleError(f"--radius-mm {r:g}: the bend radius must be > 0 mm")
    r_min = min_passable_radius_mm(settings, dia)
    if r < r_min:
        _, ei = _catheter(settings)
        rho = (r + dia / 2.0 - m_to_mm(r_o)) * 1e-3
        raise NeedleError(
            f"--radius-mm {r:g}: too tight for the catheter to pass: bending it round a "
            f"{m_to_mm(rho):.2f} mm path alone takes EI/(2 rho^2) = {ei / (2 * rho**2):.0f} N, "
            f"above solver.jam_force_n = {settings.solver.jam_force_n:g} N (smallest radius "
            f"{math.ceil(r_min * 10) / 10:.1f} mm)"
        )
    r_max = max_radius_mm()
    if r > r_max:
        raise NeedleError(
            f"--radius-mm {r:g}: no S channel 30 mm wide and 120 mm high has bends that wide "
            f"(largest radius {math.floor(r_max * 10) / 10:.1f} mm)"
        )


def check_channel(channel: Channel, settings: Scene) -> None:
    """Refuse a given channel (a free-form applicator's, ``--applicator``) whose lumen is no
    wider than the catheter, before anything runs.

    Raises
    ------
    NeedleError
        The narrowest lumen diameter is at most the catheter's outer diameter.
    """
    r_o, _ = _catheter(settings)
    rb = np.asarray(channel.lumen.kernel_arrays()[1], dtype=float)
    if rb.size and float(rb.min()) <= r_o:
        raise NeedleError(
            f"channel {channel.name}: its lumen ({2 * m_to_mm(float(rb.min())):.2f} mm) is no "
            f"wider than the catheter ({2 * m_to_mm(r_o):.2f} mm): it cannot pass; widen the "
            "channel or choose a thinner catheter (--set instrument.preset=...)"
        )


def paper_channel(spec: ChannelSpec, settings: Scene) -> Channel:
    """The paper's S channel for ``spec`` after :func:`check_spec`."""
    check_spec(spec, settings)
    try:
        return s_channel(spec.radius_mm, spec.torsion_rad, spec.diameter_mm)
    except GeometryError as exc:  # pragma: no cover - check_spec catches these first
        raise NeedleError(str(exc)) from None


def depth_grid_mm(settings: Scene, channel: Channel, depth_mm: float | None = None) -> np.ndarray:
    """Depths (mm) at which the force is reported: 0, one increment, ... the insertion depth.

    The insertion depth is ``depth_mm`` (default 120 mm), at most the catheter's free length and
    the channel's length; the grid spacing is ``solver.increment_mm`` (shortened so the last
    depth is the insertion depth).
    """
    total = INSERTION_MM if depth_mm is None else float(depth_mm)
    if not (math.isfinite(total) and total > 0):
        raise NeedleError(f"depth_mm = {depth_mm}: must be a positive number of mm")
    total = min(total, _free_length_mm(settings), m_to_mm(channel.length_m))
    inc = m_to_mm(settings.solver.increment_m)
    n = max(1, math.ceil(total / inc - 1e-9))
    return np.linspace(0.0, total, n + 1)


def needle_scene(
    channel: Channel, settings: Scene, depth_mm: float | None = None, name: str | None = None
) -> Scene:
    """The engine scene: the settings' catheter pushed from rest into ``channel``.

    Parameters
    ----------
    channel : Channel
        The channel (s = 0 where the catheter's tip starts).
    settings : Scene
        Instrument, effects, contact, motion speed and solver settings (its channel and motion
        advances are not used).
    depth_mm : float, optional
        Insertion depth (default 120 mm; see :func:`depth_grid_mm`).
    name : str, optional
        Scene name (default ``<settings name>:<channel name>``).

    Returns
    -------
    Scene
        Every flexible section cut into equal links no longer than its element length (so the free
        length is a whole number of links), one clamped link added behind the free length,
        ``motion.start_mm = 0`` and the advances = :func:`depth_grid_mm` (module docstring).
    """
    data = scene_to_dict(settings)
    inst = copy.deepcopy(data["instrument"])
    preset = str(inst.get("preset", "catheter"))
    sections = inst["sections"]
    for sec in sections:
        if not sec.get("rigid", False):
            n = max(1, math.ceil(sec["length_mm"] / sec["element_length_mm"] - 1e-9))
            sec["element_length_mm"] = sec["length_mm"] / n
    sections[-1]["length_mm"] += sections[-1]["element_length_mm"]  # the clamped link
    depths = depth_grid_mm(settings, channel, depth_mm)
    motion = {
        "kind": "constant",
        "advances_mm": [float(d) for d in depths],
        "speed_mm_s": data["motion"]["speed_mm_s"],
        "start_mm": 0.0,
    }
    tables = {k: data[k] for k in ("effects", "contact", "solver", "outputs") if k in data}
    scene = scene_for_channel(
        channel,
        preset,
        instrument={"preset": preset, "centre_from_tip_mm": 0.0, "sections": sections},
        motion=motion,
        **tables,
    )
    return replace(scene, name=name or f"{settings.name}:{channel.name}")
