"""One vocabulary for a lumen in files: read and write it for applicator JSON and scene TOML alike.

A lumen spec is a mapping of these keys (user units, mm):

``kind``
    ``"circular"``, ``"u"`` (a flat side over an arc-length range) or ``"stepped"`` (segments
    whose radius, and optionally flat, change at ``s_breaks_mm``). Older applicator files'
    ``"u_shaped"`` and ``"segments"`` are read too.
``r_b_mm``, ``r_a_mm``
    Wall radius and contact-transition radius (``r_a`` default ``r_b - 0.1``); lists (one per
    segment) for ``"stepped"``.
``flat_mm``
    ``"u"``: the flat side's distance from the centreline (at or beyond ``r_b`` it does not cut
    the circle); ``"stepped"``: a list, 0 or null = no flat.
``flat_towards``
    Which way the flat faces (:data:`~ringqa.geometry.lumen.FLAT_TOWARDS`): ``"bend_outside"``
    (default), or fixed in the applicator's frame: ``"ring_outside"``, ``"cranial"``,
    ``"caudal"`` (these need the applicator frame's centre and normal).
``u_start_mm``, ``u_end_mm``
    ``"u"``: the arc-length range of the flat (default: everywhere).
``s_breaks_mm``
    ``"stepped"``: the arc lengths where the cross-section changes.
``source``
    Where the dimensions come from (a citation or measurement), or ``"assumed"``.

Errors name the key (``where.key``) and the fix; an unknown key is refused with the nearest known
one suggested.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.lumen import FLAT_TOWARDS, FlatSide, Lumen
from ringqa.units import m_to_mm, mm_to_m

#: the lumen spec's keys
LUMEN_SPEC_KEYS = ("kind", "r_b_mm", "r_a_mm", "flat_mm", "flat_towards", "u_start_mm",
                   "u_end_mm", "s_breaks_mm", "source")  # fmt: skip
#: kinds written; "u_shaped" and "segments" (older applicator files) are read as well
LUMEN_KINDS = ("circular", "u", "stepped")
_OLD_KINDS = ("u_shaped", "segments")
#: keys of older applicator files, still read
_OLD_KEYS = ("s_bounds_mm", "s_start_mm", "s_end_mm")
#: r_a = r_b minus this when a spec gives no r_a (mm)
R_A_BELOW_R_B_MM = 0.1


def _fail(where: str, key: str, problem: str, fix: str) -> GeometryError:
    return GeometryError(f"{where}.{key}: {problem} ({fix})")


def _number(spec: Mapping, key: str, where: str, positive: bool = True) -> float:
    v = spec.get(key)
    if isinstance(v, list):
        raise _fail(where, key, f"got a list {v!r}", "lists (one per segment) need a stepped lumen")
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise _fail(where, key, f"expected a number (mm), got {v!r}", "give a finite number")
    if positive and not v > 0:
        raise _fail(where, key, f"must be > 0, got {v!r}", "give a positive size in mm")
    return float(v)


def _numbers(spec: Mapping, key: str, where: str, allow_null: bool = False) -> np.ndarray:
    v = spec.get(key)
    if isinstance(v, int | float) and not isinstance(v, bool):
        v = [v]
    if not isinstance(v, list | tuple) or not v:
        raise _fail(where, key, f"expected a list of numbers (mm), got {v!r}", "write [a, b, ...]")
    out = []
    for i, x in enumerate(v):
        if x is None and allow_null:
            out.append(math.nan)
        elif isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
            raise _fail(where, f"{key}[{i}]", f"expected a finite number, got {x!r}", "fix it")
        else:
            out.append(float(x))
    return np.array(out)


def lumen_from_spec(
    spec: Mapping[str, Any],
    where: str = "lumen",
    frame: tuple[np.ndarray, np.ndarray] | None = None,
) -> Lumen:
    """A :class:`Lumen` from a spec in the one vocabulary (see the module docstring).

    Parameters
    ----------
    spec : mapping
        The lumen's keys (mm).
    where : str
        Prefix of error messages (``"channels[0].lumen"``, ``"channel"``).
    frame : (centre_m (3,), normal (3,)), optional
        The applicator frame's origin (m) and cranial normal, for a flat fixed in that frame.

    Returns
    -------
    Lumen

    Raises
    ------
    GeometryError
        Unknown key (the nearest known one suggested), missing or out-of-range value, or a
        fixed flat orientation without a frame; the message names ``where.key``.
    """
    if not isinstance(spec, Mapping):
        raise GeometryError(f"{where}: expected a table of lumen keys, got {spec!r}")
    known = (*LUMEN_SPEC_KEYS, *_OLD_KEYS)
    for key in spec:
        if key not in known:
            near = difflib.get_close_matches(str(key), LUMEN_SPEC_KEYS, n=1)
            hint = f"did you mean {near[0]!r}? " if near else ""
            raise _fail(where, str(key), "unknown lumen key", f"{hint}keys: {', '.join(known)}")
    kind = spec.get("kind", "circular")
    if kind not in (*LUMEN_KINDS, *_OLD_KINDS):
        raise _fail(where, "kind", f"got {kind!r}", f"choose one of {', '.join(LUMEN_KINDS)}")
    towards = spec.get("flat_towards", "bend_outside")
    if towards not in FLAT_TOWARDS:
        raise _fail(where, "flat_towards", f"got {towards!r}",
                    f"choose one of {', '.join(FLAT_TOWARDS)}")  # fmt: skip
    if towards != "bend_outside" and frame is None:
        raise _fail(where, "flat_towards", f"{towards!r} is fixed in the applicator's frame",
                    "this channel has no applicator frame: use 'bend_outside'")  # fmt: skip
    centre, normal = frame if frame is not None else (None, None)
    side = FlatSide(towards, centre, normal) if towards != "bend_outside" else FlatSide()
    source = spec.get("source", "")
    if not isinstance(source, str):
        raise _fail(where, "source", f"got {source!r}", "a citation, a measurement or 'assumed'")
    try:
        return _build(spec, kind, where, side, source)
    except GeometryError as exc:
        msg = str(exc)
        raise GeometryError(msg if msg.startswith(where) else f"{where}: {msg}") from None


def _build(spec: Mapping, kind: str, where: str, side: FlatSide, source: str) -> Lumen:
    if kind in ("circular", "u", "u_shaped"):
        r_b = _number(spec, "r_b_mm", where)
        r_a = _number(spec, "r_a_mm", where) if "r_a_mm" in spec else r_b - R_A_BELOW_R_B_MM
        if not 0 < r_a < r_b:
            raise _fail(where, "r_a_mm", f"got {r_a}", f"must be in (0, r_b_mm = {r_b})")
        if kind == "circular":
            lum = Lumen.circular(mm_to_m(r_b), mm_to_m(r_a))
            return Lumen(lum.seg_s, lum.seg_rb, lum.seg_ra, lum.seg_flat, side, source)
        if "flat_mm" not in spec:
            raise _fail(where, "flat_mm", "missing for a U-shaped lumen",
                        "give the flat side's distance from the centreline, e.g. 1.5")  # fmt: skip
        flat = _number(spec, "flat_mm", where)
        start = spec.get("u_start_mm", spec.get("s_start_mm"))
        end = spec.get("u_end_mm", spec.get("s_end_mm"))
        return Lumen.u_shaped(
            mm_to_m(r_b), mm_to_m(r_a), mm_to_m(flat),
            -np.inf if start is None else mm_to_m(_number({"u_start_mm": start}, "u_start_mm",
                                                          where, positive=False)),
            np.inf if end is None else mm_to_m(_number({"u_end_mm": end}, "u_end_mm", where,
                                                       positive=False)),
            side, source,
        )  # fmt: skip
    if kind == "segments":
        bounds = _numbers(spec, "s_bounds_mm", where, allow_null=True)
        if np.isnan(bounds[1:-1]).any():
            raise _fail(where, "s_bounds_mm", "only the first and last may be null", "fix it")
        bounds[0] = -np.inf if np.isnan(bounds[0]) else bounds[0]
        bounds[-1] = np.inf if np.isnan(bounds[-1]) else bounds[-1]
    else:  # stepped
        if "s_breaks_mm" not in spec:
            raise _fail(where, "s_breaks_mm", "missing for a stepped lumen",
                        "give the arc lengths (mm) where the cross-section changes")  # fmt: skip
        breaks = _numbers(spec, "s_breaks_mm", where)
        bad = np.flatnonzero(np.diff(breaks) <= 0)
        if bad.size:
            k = int(bad[0])
            raise _fail(where, "s_breaks_mm",
                        f"{breaks[k]:g} then {breaks[k + 1]:g} mm: the breaks do not increase",
                        "list the arc lengths from the channel entry, increasing, each once, "
                        "with r_b_mm (and r_a_mm, flat_mm) in the same order")  # fmt: skip
        bounds = np.concatenate([[-np.inf], breaks, [np.inf]])
    rb = _numbers(spec, "r_b_mm", where)
    ra = _numbers(spec, "r_a_mm", where) if "r_a_mm" in spec else rb - R_A_BELOW_R_B_MM
    k = bounds.size - 1
    if rb.size != k or ra.size != k:
        raise _fail(where, "r_b_mm", f"{rb.size} radii and {ra.size} r_a for {k} segments",
                    "one r_b_mm and r_a_mm per segment: one more than s_breaks_mm")  # fmt: skip
    if "flat_mm" in spec:
        flat = _numbers(spec, "flat_mm", where, allow_null=True)
        if flat.size != k:
            raise _fail(where, "flat_mm", f"{flat.size} values for {k} segments",
                        "one per segment (0 or null = no flat)")  # fmt: skip
        flat = np.where(np.isnan(flat) | (flat == 0), np.inf, flat)
    else:
        flat = np.full(k, np.inf)
    return Lumen(mm_to_m(bounds), mm_to_m(rb), mm_to_m(ra), mm_to_m(flat), side, source)


def lumen_to_spec(lumen: Lumen) -> dict[str, Any]:
    """A :class:`Lumen` as a spec in the one vocabulary (mm): ``circular``, ``u`` or ``stepped``.

    :func:`lumen_from_spec` reads it back to the same cross-sections (the frame of a fixed flat
    orientation comes from the applicator, not from the spec).
    """
    seg_s, seg_rb, seg_ra, seg_flat = (np.asarray(a, dtype=float) for a in lumen.kernel_arrays())
    radii = {"r_b_mm": float(m_to_mm(seg_rb[0])), "r_a_mm": float(m_to_mm(seg_ra[0]))}
    same_r = bool(np.all(seg_rb == seg_rb[0]) and np.all(seg_ra == seg_ra[0]))
    finite = np.isfinite(seg_flat)
    if same_r and not finite.any():
        spec: dict[str, Any] = {"kind": "circular", **radii}
    elif same_r and finite.sum() == 1 and len(seg_flat) <= 3:
        i = int(np.flatnonzero(finite)[0])
        spec = {"kind": "u", **radii, "flat_mm": float(m_to_mm(seg_flat[i])),
                "flat_towards": _towards(lumen)}  # fmt: skip
        if np.isfinite(seg_s[i]):
            spec["u_start_mm"] = float(m_to_mm(seg_s[i]))
        if np.isfinite(seg_s[i + 1]):
            spec["u_end_mm"] = float(m_to_mm(seg_s[i + 1]))
    else:
        spec = {
            "kind": "stepped",
            "s_breaks_mm": [float(v) for v in m_to_mm(seg_s[1:-1])],
            "r_b_mm": [float(v) for v in m_to_mm(seg_rb)],
            "r_a_mm": [float(v) for v in m_to_mm(seg_ra)],
        }
        if finite.any():
            spec["flat_mm"] = [float(m_to_mm(f)) if np.isfinite(f) else 0.0 for f in seg_flat]
            spec["flat_towards"] = _towards(lumen)
    if getattr(lumen, "source", ""):
        spec["source"] = lumen.source
    return spec


def _towards(lumen) -> str:
    side = getattr(lumen, "flat_side", None)
    return "bend_outside" if side is None else side.towards
