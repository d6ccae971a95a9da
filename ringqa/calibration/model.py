"""The forward model of a calibration: scene parameters -> simulated source positions.

One evaluation simulates each measured applicator's cable once, to the advances ``s_ref - p``
of its measured relative positions ``p`` (the simulated path evaluated at the same relative
position as each measured point, not at the nearest point), at the settings whose positions
``ringqa commission`` reports: the commissioning settings refined once
(:func:`ringqa.pipeline.simulate.commission_scene`, times
:data:`~ringqa.pipeline.simulate.REFINE_FACTOR`), on the channel trimmed to its modelled
stem as the commissioning trims it. Nothing else is computed (no plan, no dose, no report).

The fitted keys are ordinary scene keys; the fit works in unconstrained-looking coordinates
``theta`` that keep every parameter in its physical range by construction:

- ``contact.mu_k = exp(theta_k)``;
- ``contact.mu_s = mu_k (1 + exp(theta_s))`` (so mu_s > mu_k whatever theta is);
- ``instrument.ei_scale = exp(theta_e)`` (EI > 0);
- ``lumen.diameter_delta_mm = theta_d`` (bounded so that the lumen stays wider than the cable).

With two or more applicators the cable keys are shared and each applicator has its own lumen
diameter change, ``lumen.diameter_delta_mm@LABEL`` (:func:`expand_keys`; the lumen belongs to
the applicator, the friction and stiffness to the cable).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.calibration.measured import CalibrationError, MeasuredApplicator
from ringqa.geometry import Channel
from ringqa.geometry.stem import trim_to_stem
from ringqa.pipeline.simulate import (
    REFINE_FACTOR,
    Engine,
    commission_scene,
    default_engine,
    refine_scene,
)
from ringqa.units import m_to_mm, mm_to_m

__all__ = [
    "APPLICATOR_SEP",
    "DEFAULT_KEYS",
    "FITTABLE_KEYS",
    "PER_APPLICATOR_KEYS",
    "ForwardModel",
    "Parametrisation",
    "applicator_of",
    "base_key",
    "expand_keys",
    "values_for",
]

#: Keys a multi-applicator fit gives each applicator its own value of (``KEY@LABEL``): the
#: lumen is a property of each applicator, the cable's friction and stiffness are shared.
PER_APPLICATOR_KEYS = ("lumen.diameter_delta_mm",)
#: Separates a per-applicator key from its applicator's label.
APPLICATOR_SEP = "@"


def base_key(key: str) -> str:
    """The scene key of a fitted key (``lumen.diameter_delta_mm@ring30x60`` ->
    ``lumen.diameter_delta_mm``)."""
    return key.split(APPLICATOR_SEP, 1)[0]


def applicator_of(key: str) -> str:
    """The applicator label of a per-applicator key (``""``: a shared key)."""
    return key.split(APPLICATOR_SEP, 1)[1] if APPLICATOR_SEP in key else ""


def expand_keys(keys: Sequence[str], labels: Sequence[str]) -> tuple[str, ...]:
    """The fitted parameters of ``keys`` for the applicators ``labels``: with two or more, each
    :data:`PER_APPLICATOR_KEYS` key becomes one ``KEY@LABEL`` per applicator."""
    out: list[str] = []
    for k in keys:
        if k in PER_APPLICATOR_KEYS and len(labels) > 1:
            out += [f"{k}{APPLICATOR_SEP}{label}" for label in labels]
        else:
            out.append(k)
    return tuple(out)


def values_for(values: Mapping[str, float], label: str) -> dict[str, float]:
    """The scene values of applicator ``label``: the shared keys and its own ``KEY@LABEL``."""
    out = {k: v for k, v in values.items() if APPLICATOR_SEP not in k}
    for k, v in values.items():
        if APPLICATOR_SEP in k and applicator_of(k) == label:
            out[base_key(k)] = v
    return out


#: Keys fitted by default (issue 26): the cable's friction and bending stiffness.
DEFAULT_KEYS = ("contact.mu_k", "contact.mu_s", "instrument.ei_scale")
#: Every key ``--fit`` accepts.
FITTABLE_KEYS = (*DEFAULT_KEYS, "lumen.diameter_delta_mm")
#: Physical ranges searched: mu_k, mu_s / mu_k - 1, EI factor, lumen diameter change (mm; its
#: lower end is raised so that the lumen stays wider than the cable).
RANGES = {
    "contact.mu_k": (0.01, 1.0),
    "contact.mu_s": (1.0e-3, 4.0),  # of mu_s / mu_k - 1
    "instrument.ei_scale": (0.1, 10.0),
    "lumen.diameter_delta_mm": (-0.5, 1.0),
}
#: Smallest clearance (mm) a narrowed lumen keeps around the cable.
MIN_CLEARANCE_MM = 0.02


@dataclass(frozen=True)
class Parametrisation:
    """Fitted keys <-> ``theta`` (see the module docstring).

    Attributes
    ----------
    keys : tuple of str
        The fitted scene keys, in fit order.
    fixed : dict
        Values of the other keys the transform needs (``contact.mu_k`` when only mu_s is fitted).
    lower, upper : (n,) ndarray
        Bounds of theta.
    """

    keys: tuple[str, ...]
    fixed: Mapping[str, float]
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def build(cls, keys: Sequence[str], start: Mapping[str, float], min_delta_mm: float):
        """The parametrisation of ``keys`` around the ``start`` values (every key of
        :data:`FITTABLE_KEYS`); ``min_delta_mm``: the smallest lumen diameter change that keeps
        :data:`MIN_CLEARANCE_MM` around the cable."""
        lo, hi = [], []
        for k in keys:
            a, b = RANGES[base_key(k)]
            if base_key(k) == "lumen.diameter_delta_mm":
                lo.append(max(a, min_delta_mm))
                hi.append(b)
            elif k == "contact.mu_k" and "contact.mu_s" not in keys:
                lo.append(math.log(a))
                hi.append(math.log(min(b, start["contact.mu_s"])))
            else:
                lo.append(math.log(a))
                hi.append(math.log(b))
        fixed = {"contact.mu_k": start["contact.mu_k"], "contact.mu_s": start["contact.mu_s"]}
        return cls(tuple(keys), fixed, np.array(lo), np.array(hi))

    def values(self, theta: np.ndarray) -> dict[str, float]:
        """The physical values (scene keys, user units) of ``theta``."""
        t = dict(zip(self.keys, (float(x) for x in theta), strict=True))
        out: dict[str, float] = {}
        mu_k = math.exp(t["contact.mu_k"]) if "contact.mu_k" in t else self.fixed["contact.mu_k"]
        if "contact.mu_k" in t:
            out["contact.mu_k"] = mu_k
        if "contact.mu_s" in t:
            out["contact.mu_s"] = mu_k * (1.0 + math.exp(t["contact.mu_s"]))
        elif "contact.mu_k" in t:
            out["contact.mu_s"] = max(self.fixed["contact.mu_s"], mu_k)
        if "instrument.ei_scale" in t:
            out["instrument.ei_scale"] = math.exp(t["instrument.ei_scale"])
        for k, v in t.items():
            if base_key(k) == "lumen.diameter_delta_mm":
                out[k] = v
        return out

    def theta(self, values: Mapping[str, float]) -> np.ndarray:
        """``theta`` of physical values (clipped into the bounds)."""
        mu_k = values.get("contact.mu_k", self.fixed["contact.mu_k"])
        out = []
        for k in self.keys:
            v = float(values[k])
            if k == "contact.mu_s":
                out.append(math.log(max(v / mu_k - 1.0, RANGES[k][0])))
            elif base_key(k) == "lumen.diameter_delta_mm":
                out.append(v)
            else:
                out.append(math.log(v))
        return np.clip(np.array(out), self.lower, self.upper)

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        """(n, n) d(value_i)/d(theta_j) (the fitted keys' values by theta)."""
        vals = self.values(theta)
        idx = {k: i for i, k in enumerate(self.keys)}
        g = np.zeros((len(self.keys), len(self.keys)))
        for k, i in idx.items():
            if k in ("contact.mu_k", "instrument.ei_scale"):
                g[i, i] = vals[k]
            elif base_key(k) == "lumen.diameter_delta_mm":
                g[i, i] = 1.0
            elif k == "contact.mu_s":
                mu_k = vals.get("contact.mu_k", self.fixed["contact.mu_k"])
                g[i, i] = mu_k * math.exp(float(theta[i]))
                if "contact.mu_k" in idx:
                    g[i, idx["contact.mu_k"]] = vals["contact.mu_s"]
        return g


@dataclass(frozen=True, eq=False)
class _Target:
    """One applicator as the forward model simulates it."""

    channel: Any
    advances_mm: np.ndarray  # ascending, unique
    rows: np.ndarray  # row of each measured point in advances_mm


@dataclass(frozen=True, eq=False)
class ForwardModel:
    """Simulated source positions (mm) at every measured point, for given scene values.

    Attributes
    ----------
    measured : tuple of MeasuredApplicator
    cable : str
        The cable preset (shared by every applicator).
    overrides : dict
        The user's scene overrides (``--config``'s ``[scene]``), under the fitted values.
    stem_mm : float or None
        Straight channel kept before the first bend (the commissioning's ``stem_mm``).
    engine : Engine or None
        Default :func:`~ringqa.pipeline.simulate.default_engine`.
    """

    measured: tuple[MeasuredApplicator, ...]
    cable: str
    overrides: Mapping[str, Any]
    stem_mm: float | None
    engine: Engine | None = None

    def _targets(self) -> list[_Target]:
        cached = self.__dict__.get("_cached_targets")
        if cached is not None:
            return cached
        out = []
        for m in self.measured:
            ch = m.channel
            if self.stem_mm is not None and isinstance(ch, Channel):
                stem = trim_to_stem(ch, mm_to_m(self.stem_mm))
                if stem.dropped_m > 0:
                    ch = stem.channel
            wanted = m_to_mm(ch.s_ref_m) - np.asarray(m.relative_position_mm, dtype=float)
            adv = np.unique(np.round(wanted, 9))
            rows = np.searchsorted(adv, np.round(wanted, 9))
            out.append(_Target(ch, adv, rows))
        object.__setattr__(self, "_cached_targets", out)
        return out

    def scene(self, index: int, values: Mapping[str, float]):
        """The scene simulated for applicator ``index`` with the fitted ``values``."""
        engine = self.engine or default_engine()
        target = self._targets()[index]
        scene = commission_scene(
            engine, target.channel, self.cable, {**dict(self.overrides), **dict(values)}
        )
        return (engine.refine or refine_scene)(scene, REFINE_FACTOR)

    def base_values(self) -> dict[str, float]:
        """Every fittable key's value in the scene without fitted values (the preset's, or
        the user's overrides)."""
        scene = self.scene(0, {})
        out = {
            "contact.mu_k": float(scene.contact.mu_k),
            "contact.mu_s": float(scene.contact.mu_s),
            "instrument.ei_scale": float(getattr(scene.instrument, "ei_scale", 1.0)),
            "lumen.diameter_delta_mm": m_to_mm(float(scene.lumen.diameter_delta_m))
            if hasattr(scene, "lumen") else 0.0,
        }  # fmt: skip
        for k in PER_APPLICATOR_KEYS:  # each applicator's own value starts at the shared one
            for m in self.measured:
                out[f"{k}{APPLICATOR_SEP}{m.label}"] = out[k]
        return out

    def min_delta_mm(self) -> float:
        """The smallest lumen diameter change that keeps :data:`MIN_CLEARANCE_MM` around the
        cable in every applicator, mm."""
        worst = math.inf
        for i, t in enumerate(self._targets()):
            scene = self.scene(i, {})
            r_cable = max(float(s.r_o_m) for s in scene.instrument.sections)
            r_b = float(np.min(t.channel.lumen.seg_rb))
            worst = min(worst, m_to_mm(r_b - r_cable))
        return -2.0 * (worst - MIN_CLEARANCE_MM)

    def positions(self, values: Mapping[str, float]) -> list[np.ndarray]:
        """Per applicator, the simulated source centres (m, 3) at its measured points, mm.

        Raises
        ------
        CalibrationError
            The cable jammed or the engine failed at these values (even with half the
            increment).
        """
        engine = self.engine or default_engine()
        out = []
        for i, t in enumerate(self._targets()):
            scene = self.scene(i, values_for(values, self.measured[i].label))
            res = engine.simulate(scene, advances_mm=t.advances_mm, progress=False)
            if int(getattr(res, "status", 0)) == -1:
                inc = m_to_mm(float(scene.solver.increment_m)) * 0.5
                scene = engine.scene_with_overrides(scene, {"solver.increment_mm": inc})
                res = engine.simulate(scene, advances_mm=t.advances_mm, progress=False)
            pos = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
            status = int(getattr(res, "status", 0))
            if status != 0 or pos.shape[0] < t.advances_mm.size or not np.all(np.isfinite(pos)):
                shown = ", ".join(f"{k} = {v:.4g}" for k, v in values.items())
                raise CalibrationError(
                    f"applicator {self.measured[i].label}: the simulated cable "
                    f"{'jammed' if status == 1 else 'failed'} at {shown or 'the start values'}: "
                    f"{getattr(res, 'message', '')} (narrow the fitted keys with --fit, or fix "
                    "the scene with --config)"
                )
            out.append(m_to_mm(pos[t.rows]))
        return out
