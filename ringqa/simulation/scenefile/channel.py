"""Build a scene's channel (centreline and lumen, in SI) from its ``[channel]`` table.

Analytic centrelines (straight, arc, helix, s-curve), inline centreline points and applicator
channels, each with a circular, U-shaped or stepped lumen.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import RingQAError, SceneError
from ringqa.simulation.scenefile.check import Checker
from ringqa.units import deg_to_rad, m_to_mm, mm_to_m

ANALYTIC_TIP_GAP_MM = 5.0  # analytic channels: s_ref = length - 5 mm (as the 1st ring marker)
POINT_SPACING_MM = 0.25  # sampling of analytic centrelines handed to Centreline.from_points


def arc_points(start, tangent, normal, radius, angle, n):
    """Points of a planar arc from ``start`` with unit ``tangent``, bending towards ``normal``."""
    phi = np.linspace(0.0, angle, n)
    centre = start + radius * normal
    pts = centre - radius * np.outer(np.cos(phi), normal) + radius * np.outer(np.sin(phi), tangent)
    end_t = np.cos(angle) * tangent + np.sin(angle) * normal
    end_n = np.cos(angle) * normal - np.sin(angle) * tangent
    return pts, end_t, end_n


def line_points(start, tangent, length, n):
    return start + np.outer(np.linspace(0.0, length, n), tangent)


def point_count(length_mm: float) -> int:
    return max(3, math.ceil(length_mm / POINT_SPACING_MM) + 1)


def analytic_centreline_mm(spec: Mapping[str, Any]) -> np.ndarray:
    """Centreline points (mm), proximal -> distal, for an analytic channel spec.

    Shapes (all start at the origin heading along +x; the bends lie in the x-y plane, the helix
    axis is +z):

    - ``straight``: ``length_mm``.
    - ``arc``: ``straight_mm`` approach, then an arc of ``radius_mm`` over ``angle_deg``
      (default 180), then ``exit_mm`` straight.
    - ``helix``: ``straight_mm`` approach, then a helix of ``radius_mm`` and ``pitch_mm`` (rise
      per turn) over ``angle_deg`` (default 360).
    - ``s-curve``: ``straight_mm``, an arc of ``radius_mm`` over ``angle_deg`` (default 90)
      bending left, the same arc bending right, then ``exit_mm``.
    """
    kind = spec["kind"]
    x, y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    o = np.zeros(3)
    if kind == "straight":
        return line_points(o, x, spec["length_mm"], point_count(spec["length_mm"]))
    r = spec["radius_mm"]
    straight = spec.get("straight_mm", 0.0)
    parts = [line_points(o, x, straight, point_count(straight))] if straight > 0 else [o[None, :]]
    start = parts[-1][-1]
    if kind == "arc":
        ang = deg_to_rad(spec.get("angle_deg") or 180.0)
        pts, t, _ = arc_points(start, x, y, r, ang, point_count(r * ang))
        parts.append(pts[1:])
        exit_mm = spec.get("exit_mm", 0.0)
        if exit_mm > 0:
            parts.append(line_points(pts[-1], t, exit_mm, point_count(exit_mm))[1:])
    elif kind == "s-curve":
        ang = deg_to_rad(spec.get("angle_deg") or 90.0)
        pts, t, nrm = arc_points(start, x, y, r, ang, point_count(r * ang))
        parts.append(pts[1:])
        pts2, t2, _ = arc_points(pts[-1], t, -nrm, r, ang, point_count(r * ang))
        parts.append(pts2[1:])
        exit_mm = spec.get("exit_mm", 0.0)
        if exit_mm > 0:
            parts.append(line_points(pts2[-1], t2, exit_mm, point_count(exit_mm))[1:])
    elif kind == "helix":
        ang = deg_to_rad(spec.get("angle_deg") or 360.0)
        pitch = spec.get("pitch_mm", 0.0)
        c = pitch / (2.0 * math.pi)
        # helix tangent at phi = 0 is (r, 0, c)/sqrt(r^2+c^2): tilt the approach to match it
        n = point_count(math.hypot(r, c) * ang)
        phi = np.linspace(0.0, ang, n)
        helix = np.column_stack([r * np.sin(phi), r * (1.0 - np.cos(phi)), c * phi])
        t0 = np.array([r, 0.0, c]) / math.hypot(r, c)
        if straight > 0:
            approach = line_points(o, t0, straight, point_count(straight))
            parts = [approach, approach[-1] + helix[1:]]
        else:
            parts = [helix]
    else:  # pragma: no cover - guarded by the schema
        raise ValueError(kind)
    return np.vstack(parts)


#: the [channel] keys that describe the lumen (the spec's ``kind`` is ``lumen``, its ``source``
#: ``lumen_source``)
LUMEN_TABLE_KEYS = ("r_b_mm", "r_a_mm", "flat_mm", "flat_towards", "u_start_mm", "u_end_mm",
                    "s_breaks_mm", "lumen_source")  # fmt: skip


def read_lumen(ck: Checker, sec: dict, required: bool, ring_frame=None):
    """The lumen the ``[channel]`` table describes (None: none given and none ``required``), read
    with the one lumen vocabulary (:mod:`ringqa.geometry.lumen_spec`) that applicator files use.

    ``ring_frame`` (centre (3,) m, normal (3,)) orients a flat fixed in the applicator's frame.
    """
    from ringqa.geometry.lumen_spec import lumen_from_spec

    kind = ck.value("channel", "lumen", sec=sec)
    if kind is None:
        if not required and not any(k in sec for k in LUMEN_TABLE_KEYS):
            return None
        kind = "circular"
    if "r_b_mm" not in sec:
        raise ck.fail("channel.r_b_mm", "missing", "give the lumen radius, e.g. r_b_mm = 1.5")
    spec = {"kind": kind}
    for key in LUMEN_TABLE_KEYS:
        if key in sec:
            spec["source" if key == "lumen_source" else key] = sec[key]
    try:
        return lumen_from_spec(spec, "channel", ring_frame)
    except RingQAError as exc:
        msg = str(exc).replace("channel.kind", "channel.lumen")
        msg = msg.replace("channel.source", "channel.lumen_source")
        raise SceneError(ck.origin + msg) from None


def build_channel(ck: Checker):
    """The :class:`ringqa.geometry.Channel` a scene's ``[channel]`` table describes."""
    sec = ck.section("channel")
    if not sec:
        raise ck.fail(
            "channel",
            "missing",
            "add a [channel] table with applicator = 'ring26x60' or an analytic kind = 'arc'",
        )
    for key in sec:
        ck.value("channel", key, sec=sec)  # type/range check every key given
    kind = sec.get("kind", "applicator" if "applicator" in sec else None)
    if kind is None:
        raise ck.fail(
            "channel.applicator",
            "missing",
            "give applicator = 'ring26x60' (or a file) or an analytic kind = 'arc'",
        )
    if kind == "applicator":
        return applicator_channel(ck, sec)
    from ringqa.geometry import Centreline, Channel

    if kind == "points":
        if "centreline_mm" not in sec:
            raise ck.fail("channel.centreline_mm", "missing", "give [[x, y, z], ...] in mm")
        pts_mm = ck.numbers("channel.centreline_mm", sec["centreline_mm"], ndim=2)
    else:
        need = {"straight": ("length_mm",), "arc": ("radius_mm",), "s-curve": ("radius_mm",)}
        need["helix"] = ("radius_mm", "pitch_mm")
        for key in need[kind]:
            if key not in sec:
                raise ck.fail(f"channel.{key}", f"missing for kind = {kind!r}", "give it in mm")
        pts_mm = analytic_centreline_mm(sec)
    try:
        cl = Centreline.from_points(mm_to_m(pts_mm))
    except RingQAError as exc:
        raise ck.fail(
            "channel", f"cannot build the centreline: {exc}", "check its parameters"
        ) from None
    lumen = read_lumen(ck, sec, required=True, ring_frame=_analytic_ring_frame(sec))
    length_mm = m_to_mm(cl.length_m)
    s_ref_mm = sec.get("s_ref_mm", max(length_mm - ANALYTIC_TIP_GAP_MM, 0.5 * length_mm))
    if not 0 <= s_ref_mm <= length_mm:
        raise ck.fail(
            "channel.s_ref_mm",
            f"{s_ref_mm} mm is outside the channel (length {length_mm:.2f} mm)",
            "choose an arc length inside the channel",
        )
    measured = None
    if "measured_path_mm" in sec:
        measured = mm_to_m(ck.numbers("channel.measured_path_mm", sec["measured_path_mm"], ndim=2))
        if "measured_step_mm" not in sec:
            raise ck.fail("channel.measured_step_mm", "missing", "give the measured path's step")
    channel = Channel(
        name=str(sec.get("channel", kind)),
        centreline=cl,
        lumen=lumen,
        s_ref_m=mm_to_m(s_ref_mm),
        measured_path_m=measured,
        measured_step_m=None if measured is None else mm_to_m(sec["measured_step_mm"]),
    )
    from ringqa.geometry.shape_checks import check_channel_shape

    try:
        check_channel_shape(channel, "channel")
    except RingQAError as exc:
        raise SceneError(ck.origin + str(exc)) from None
    return channel


def _analytic_ring_frame(sec: dict):
    """The ring frame of an analytic ``arc`` (its circle's centre and normal, m), else None."""
    if sec.get("kind") != "arc" or "radius_mm" not in sec:
        return None
    centre = mm_to_m(np.array([float(sec.get("straight_mm", 0.0)), float(sec["radius_mm"]), 0.0]))
    return centre, np.array([0.0, 0.0, 1.0])


def applicator_channel(ck: Checker, sec: dict):
    from ringqa.io.applicator_file import load_applicator

    name = sec.get("applicator")
    if name is None:
        raise ck.fail("channel.applicator", "missing", "give a shipped name such as 'ring26x60'")
    ref = str(name)
    if ck.origin and not Path(ref).is_absolute() and ("/" in ref or ref.endswith(".json")):
        base = Path(ck.origin.rstrip(": ")).parent  # relative paths: relative to the scene file
        if (base / ref).exists():
            ref = str(base / ref)
    try:
        app = load_applicator(ref)
    except SceneError:
        raise
    except Exception as exc:  # RingQAError from io, or a missing file
        raise ck.fail(
            "channel.applicator",
            f"cannot load {name!r}: {exc}",
            "use a shipped name (ringqa.io.applicator_file.shipped_applicators()) or a file path",
        ) from None
    chan_name = sec.get("channel", "ring")
    try:
        channel = app.channel(chan_name)
    except Exception:
        names = ", ".join(c.name for c in app.channels)
        raise ck.fail(
            "channel.channel", f"{name!r} has no channel {chan_name!r}", f"choose one of {names}"
        ) from None
    lumen = read_lumen(
        ck,
        sec,
        required=False,
        ring_frame=(np.asarray(app.ring_centre_m), np.asarray(app.ring_normal)),
    )
    if lumen is not None:
        channel = replace(channel, lumen=lumen)
    if "s_ref_mm" in sec:
        channel = replace(channel, s_ref_m=mm_to_m(sec["s_ref_mm"]))
    return channel
