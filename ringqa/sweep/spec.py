"""The sweep specification (TOML): what to vary, how, and for which commissioning input.

A spec is read and checked completely before anything runs or is written
(:func:`load_spec`); every refusal is a :class:`SweepSpecError` whose one-line message names the
file, the key, the value and the fix. The format is documented in ``docs/sweeps.md``.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ringqa.errors import RingQAError
from ringqa.pipeline.settings import SETTINGS
from ringqa.pipeline.uncertainty import PERTURBATION_KEYS
from ringqa.textio import read_toml

__all__ = [
    "DISTRIBUTIONS",
    "METHODS",
    "Correlation",
    "Parameter",
    "SweepSpec",
    "SweepSpecError",
    "apply_spec_sets",
    "load_spec",
    "spec_from_dict",
]

#: distribution -> its required fields
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "normal": ("mean", "sd"),
    "uniform": ("low", "high"),
    "lognormal": ("median", "sigma"),
    "grid": ("values",),
}
#: sampling methods: independent random draws (numpy), or SALib's Sobol/Saltelli design
METHODS = ("random", "sobol")
#: ``numerics``: ``calibrated`` (one engine run per sample, the numerical check measured once per
#: sweep on ``calibration_samples`` samples: ringqa.sweep.fast) or ``full`` (every sample a full
#: commissioning run with its own numerical check)
NUMERICS = ("calibrated", "full")
#: default number of calibration samples of a calibrated sweep
CALIBRATION_SAMPLES = 6
#: The commissioning settings (CommissionSettings fields) a spec's [settings] table may set:
#: the rows of the settings table marked ``sweep``.
SWEEP_SETTING_FIELDS = tuple(dict.fromkeys(s.field for s in SETTINGS if s.sweep))
#: Their names in a spec's [settings] table: the configuration keys' names (the settings table,
#: :data:`ringqa.pipeline.settings.SETTINGS`: ``sk_u``), and ``centreline_reference`` (the
#: option --centreline-reference, which has no configuration key).
SETTINGS_KEYS = (
    *(s.key.split(".")[-1] for s in SETTINGS if s.field in SWEEP_SETTING_FIELDS
      and s.kind != "flag"),
    "centreline_reference",
)  # fmt: skip
TOP_KEYS = (
    "description",
    "input",
    "samples",
    "seed",
    "method",
    "batch_size",
    "numerics",
    "calibration_samples",
    "sample_budget_s",
    "settings",
    "set",
    "parameters",
    "correlation",
)
PARAM_FIELDS = ("distribution", "mean", "sd", "low", "high", "median", "sigma", "values", "source")
#: largest number of samples a spec may ask for
MAX_SAMPLES = 1_000_000


class SweepSpecError(RingQAError):
    """A sweep spec that cannot be run (names the file, key and value, says the fix)."""


@dataclass(frozen=True)
class Parameter:
    """One varied input.

    Attributes
    ----------
    key : str
        A numeric scene key (``contact.mu_k``), a perturbation key
        (:data:`ringqa.pipeline.uncertainty.PERTURBATION_KEYS`) or a boolean scene key (grid
        only, e.g. ``motion.backward``).
    distribution : str
        ``normal``, ``uniform``, ``lognormal`` or ``grid``.
    args : dict
        The distribution's fields (user units): normal ``mean, sd``; uniform ``low, high``;
        lognormal ``median, sigma`` (sigma of the natural logarithm); grid ``values``.
    source : str
        Where the numbers come from.
    """

    key: str
    distribution: str
    args: Mapping[str, Any]
    source: str = ""

    @property
    def nominal(self) -> Any:
        """The value of the nominal run: mean, midpoint, median or the first grid value."""
        a = self.args
        return {
            "normal": lambda: a["mean"],
            "uniform": lambda: 0.5 * (a["low"] + a["high"]),
            "lognormal": lambda: a["median"],
            "grid": lambda: a["values"][0],
        }[self.distribution]()


@dataclass(frozen=True)
class Correlation:
    """Correlated normal parameters (the spec's ``[correlation]`` table): the named keys are
    drawn from ONE multivariate normal with their means and sds and this correlation matrix,
    e.g. the covariance of a fit (``ringqa calibrate``'s ``calibration_sweep.toml``).

    Attributes
    ----------
    keys : tuple of str
        Varied parameters with ``distribution = "normal"``, at least two.
    matrix : tuple of tuple of float
        (k, k) correlation matrix: symmetric, unit diagonal, positive semi-definite.
    """

    keys: tuple[str, ...]
    matrix: tuple[tuple[float, ...], ...]

    def factor(self):
        """(k, k) ``L`` with ``L L^T`` = the matrix: ``L z`` of independent standard normals
        ``z`` has this correlation (Cholesky; a singular matrix, |r| = 1, through its
        eigen-decomposition)."""
        import numpy as np

        r = np.asarray(self.matrix, dtype=float)
        try:
            return np.linalg.cholesky(r)
        except np.linalg.LinAlgError:
            w, v = np.linalg.eigh(r)
            return v * np.sqrt(np.clip(w, 0.0, None))


@dataclass(frozen=True)
class SweepSpec:
    """A checked sweep specification.

    Attributes
    ----------
    path : str
        The spec file (for messages).
    input : str
        Commissioning input: shipped applicator name, folder, applicator JSON or RT Plan.
    samples : int
        Random: the number of samples; sobol: the base number N (N (D + 2) runs for D
        parameters).
    seed : int
        Seed of the whole study (sample i's numbers depend on (seed, i) only).
    method : str
        ``random`` or ``sobol``.
    batch_size : int
        Samples per Dask task (0: ``"auto"``, sized from the measured time of a sample).
    numerics : str
        ``calibrated`` or ``full`` (:data:`NUMERICS`).
    calibration_samples : int
        Samples of a calibrated sweep run both ways to measure the numerical error.
    sample_budget_s : float or None
        Wall-clock budget of one sample's engine run, s (None: set from the calibration).
    settings : dict
        CommissionSettings fields (``stem_mm``, ``cable``, ...).
    fixed : dict
        Scene keys held at a value in every sample (``--set`` of ``ringqa commission``).
    parameters : tuple of Parameter
    description : str
    raw : dict
        The spec as read (after ``--set``), for sweep.json.
    """

    path: str
    input: str
    samples: int
    seed: int
    method: str
    batch_size: int
    settings: Mapping[str, Any]
    fixed: Mapping[str, Any]
    parameters: tuple[Parameter, ...]
    description: str = ""
    raw: Mapping[str, Any] = field(default_factory=dict)
    numerics: str = "calibrated"
    calibration_samples: int = CALIBRATION_SAMPLES
    sample_budget_s: float | None = None
    correlation: Correlation | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The parameters' keys, in spec order."""
        return tuple(p.key for p in self.parameters)

    def digest(self) -> str:
        """A checksum of everything that decides each sample's numbers: a resumed sweep must
        have the same. Not ``batch_size`` or ``description``, nor (random method) ``samples``:
        sample i depends on (seed, i) only, so a finished sweep can be extended with more."""
        skip = ("batch_size", "description", "sample_budget_s") + (
            ("samples",) if self.method == "random" else ()
        )
        d = {k: v for k, v in self.raw.items() if k not in skip}
        if self.numerics == "calibrated":  # one engine run per sample: other numbers
            d["numerics"] = self.numerics
            d["calibration_samples"] = self.calibration_samples
        return hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()


def _num(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


def _scene_keys() -> dict[str, Any]:
    from ringqa.simulation.scene_keys import KEYS

    return {k.dotted: k for k in KEYS}


def load_spec(path: str | Path, sets: Mapping[str, Any] | None = None) -> SweepSpec:
    """Read and check a sweep spec; ``sets`` (``--set KEY=VALUE``) override its keys first.

    Raises
    ------
    SweepSpecError
        Unreadable file, unknown key, bad value or impossible distribution.
    """
    p = Path(path)
    if not p.exists():
        raise SweepSpecError(f"{p}: no such sweep spec (give the path of a .toml file)")
    data = read_toml(
        p, error=lambda path, problem, fix: SweepSpecError(f"{path}: {problem} ({fix})")
    )
    data = apply_spec_sets(data, sets or {}, str(p))
    base = p.parent
    inp = data.get("input")
    if isinstance(inp, str) and ("/" in inp or inp.endswith((".dcm", ".json"))):
        candidate = (base / inp).resolve()
        if not Path(inp).is_absolute() and candidate.exists():
            data["input"] = str(candidate)
        elif not Path(inp).exists() and not candidate.exists():
            raise SweepSpecError(
                f"{p}: input = {inp!r}: no such file or folder (give a shipped applicator name, "
                "or a path relative to the spec file)"
            )
    return spec_from_dict(data, str(p))


def apply_spec_sets(data: Mapping, sets: Mapping[str, Any], origin: str) -> dict:
    """``data`` with ``--set`` values: ``samples=24``, ``seed=1``, ``set.<scene key>=v``,
    ``settings.<field>=v`` or ``parameters.<key>.<field>=v`` (``parameters.contact.mu_k.sd``)."""
    out = copy.deepcopy(dict(data))
    for key, value in sets.items():
        if key.startswith("parameters."):
            rest = key[len("parameters.") :]
            pkey, _, fld = rest.rpartition(".")
            params = out.setdefault("parameters", {})
            if not pkey or pkey not in params:
                raise SweepSpecError(
                    f"{origin}: --set {key}: no parameter {pkey or rest!r} in the spec (known: "
                    f"{', '.join(params) or 'none'}; write parameters.<key>.<field>=value)"
                )
            params[pkey][fld] = value
        elif key.startswith(("set.", "settings.")):
            table, _, sub = key.partition(".")
            out.setdefault(table, {})[sub] = value
        else:
            out[key] = value
    return out


def _unknown(origin: str, where: str, key: str, known) -> SweepSpecError:
    import difflib

    close = difflib.get_close_matches(key, list(known), n=1)
    hint = f"did you mean {close[0]!r}? " if close else ""
    return SweepSpecError(
        f"{origin}: {where}{key}: unknown key ({hint}known keys here: {', '.join(known)})"
    )


def spec_from_dict(data: Mapping, origin: str = "<spec>") -> SweepSpec:
    """Check a spec given as a dict (see :func:`load_spec`)."""
    for k in data:
        if k not in TOP_KEYS:
            raise _unknown(origin, "", k, TOP_KEYS)
    inp = data.get("input")
    if not (isinstance(inp, str) and inp.strip()):
        raise SweepSpecError(
            f"{origin}: input = {inp!r}: give the commissioning input (a shipped applicator name "
            "such as 'ring26x60', an applicator folder or JSON, or an RT Plan .dcm)"
        )
    samples = data.get("samples")
    if not (
        isinstance(samples, int) and not isinstance(samples, bool) and 1 <= samples <= MAX_SAMPLES
    ):
        raise SweepSpecError(
            f"{origin}: samples = {samples!r}: give a whole number of samples, 1 to {MAX_SAMPLES}"
        )
    seed = data.get("seed")
    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        raise SweepSpecError(
            f"{origin}: seed = {seed!r}: give a whole number >= 0 (the study's seed: the same "
            "seed gives the same samples)"
        )
    method = data.get("method", "random")
    if method not in METHODS:
        raise SweepSpecError(
            f"{origin}: method = {method!r}: choose one of {', '.join(METHODS)} (random: "
            "independent draws; sobol: SALib's Sobol design, for Sobol indices)"
        )
    batch = data.get("batch_size", "auto")
    if batch == "auto":
        batch = 0
    elif not (isinstance(batch, int) and not isinstance(batch, bool) and 1 <= batch <= 10_000):
        raise SweepSpecError(
            f"{origin}: batch_size = {batch!r}: give a whole number of samples per task >= 1 "
            '(e.g. 4), or "auto" (sized from the measured time of a sample)'
        )
    numerics = data.get("numerics", "calibrated")
    if numerics not in NUMERICS:
        raise SweepSpecError(
            f"{origin}: numerics = {numerics!r}: choose one of {', '.join(NUMERICS)} "
            "(calibrated: one engine run per sample, the numerical error measured once per "
            "sweep; full: every sample a full commissioning run)"
        )
    n_cal = data.get("calibration_samples", CALIBRATION_SAMPLES)
    if not (isinstance(n_cal, int) and not isinstance(n_cal, bool) and 1 <= n_cal <= 1000):
        raise SweepSpecError(
            f"{origin}: calibration_samples = {n_cal!r}: give a whole number, 1 to 1000 (the "
            f"samples run both ways to measure the numerical error; default {CALIBRATION_SAMPLES})"
        )
    budget = data.get("sample_budget_s")
    if budget is not None and not (_num(budget) and budget > 0):
        raise SweepSpecError(
            f"{origin}: sample_budget_s = {budget!r}: give a number of seconds > 0 (the wall "
            "time one sample may take), or leave it out (set from the calibration)"
        )
    settings = data.get("settings", {})
    if not isinstance(settings, Mapping):
        raise SweepSpecError(f"{origin}: settings: must be a table ([settings])")
    for k in settings:
        if k not in SETTINGS_KEYS:
            raise _unknown(origin, "settings.", k, SETTINGS_KEYS)
    fixed = data.get("set", {})
    if not isinstance(fixed, Mapping):
        raise SweepSpecError(f"{origin}: set: must be a table of scene keys ([set])")
    keys = _scene_keys()
    for k in fixed:
        if k not in keys:
            raise _unknown(origin, "set.", k, sorted(keys))
    params_in = data.get("parameters", {})
    if not isinstance(params_in, Mapping) or not params_in:
        raise SweepSpecError(
            f"{origin}: parameters: give at least one varied parameter, e.g. "
            '[parameters."contact.mu_k"] distribution = "normal", mean = 0.2, sd = 0.02'
        )
    params = tuple(_parameter(origin, k, v, keys) for k, v in params_in.items())
    for p in params:
        if p.key in fixed:
            raise SweepSpecError(
                f"{origin}: {p.key}: both varied ([parameters]) and fixed ([set]); keep one"
            )
    if method == "sobol":
        grid = [p.key for p in params if p.distribution == "grid"]
        if grid:
            raise SweepSpecError(
                f"{origin}: parameters.{grid[0]}: a grid cannot be part of a Sobol design (use "
                'method = "random", or a continuous distribution)'
            )
    correlation = _correlation(origin, data.get("correlation"), params, method)
    return SweepSpec(
        path=origin,
        input=inp,
        samples=int(samples),
        seed=int(seed),
        method=method,
        batch_size=int(batch),
        settings=dict(settings),
        fixed=dict(fixed),
        parameters=params,
        description=str(data.get("description", "")),
        raw=json.loads(json.dumps(data, default=str)),
        numerics=str(numerics),
        calibration_samples=int(n_cal),
        sample_budget_s=None if budget is None else float(budget),
        correlation=correlation,
    )


#: tolerance of the correlation matrix's symmetry, unit diagonal and semi-definiteness
CORRELATION_TOL = 1.0e-6


def _correlation(origin: str, spec: Any, params, method: str) -> Correlation | None:
    """The ``[correlation]`` table, checked (:class:`Correlation`)."""
    if spec is None:
        return None
    where = f"{origin}: correlation"
    example = ('[correlation] keys = ["contact.mu_k", "instrument.ei_scale"], '
               "matrix = [[1, -0.3], [-0.3, 1]]")  # fmt: skip
    if not isinstance(spec, Mapping):
        raise SweepSpecError(f"{where}: must be a table, e.g. {example}")
    for f in spec:
        if f not in ("keys", "matrix", "source"):
            raise _unknown(origin, "correlation.", f, ("keys", "matrix", "source"))
    keys = spec.get("keys")
    normal = {p.key for p in params if p.distribution == "normal"}
    if not (isinstance(keys, list) and len(keys) >= 2 and all(isinstance(k, str) for k in keys)
            and len(set(keys)) == len(keys)):  # fmt: skip
        raise SweepSpecError(f"{where}.keys = {keys!r}: give two or more different varied keys, "
                             f"e.g. {example}")  # fmt: skip
    for k in keys:
        if k not in normal:
            raise SweepSpecError(
                f'{where}.keys: {k} is not a varied parameter with distribution = "normal" '
                "(only normal parameters can be correlated: give it a [parameters] table with "
                "mean and sd)"
            )
    if method != "random":
        raise SweepSpecError(
            f'{where}: correlated parameters need method = "random" (a Sobol design draws '
            "the parameters independently)"
        )
    matrix = spec.get("matrix")
    n = len(keys)
    rows = matrix if isinstance(matrix, list) else []
    if not (len(rows) == n and all(isinstance(r, list) and len(r) == n and all(_num(x) for x in r)
                                   for r in rows)):  # fmt: skip
        raise SweepSpecError(f"{where}.matrix: give a {n} x {n} table of numbers (one row per "
                             f"key, in the order of keys), e.g. {example}")  # fmt: skip
    import numpy as np

    r = np.asarray(rows, dtype=float)
    if not np.allclose(np.diag(r), 1.0, rtol=0.0, atol=CORRELATION_TOL):
        raise SweepSpecError(f"{where}.matrix: its diagonal must be 1 (a correlation matrix)")
    if not np.allclose(r, r.T, rtol=0.0, atol=CORRELATION_TOL):
        i, j = np.unravel_index(int(np.argmax(np.abs(r - r.T))), r.shape)
        raise SweepSpecError(
            f"{where}.matrix: not symmetric (row {i + 1}, column {j + 1}: {r[i, j]:g} vs "
            f"{r[j, i]:g}); give the same correlation both ways"
        )
    if np.any(np.abs(r) > 1.0 + CORRELATION_TOL) or np.linalg.eigvalsh(r).min() < -CORRELATION_TOL:
        raise SweepSpecError(
            f"{where}.matrix: not a correlation matrix (not positive semi-definite, or |r| > 1): "
            "take it from a fit's covariance (ringqa calibrate's calibration.json)"
        )
    return Correlation(tuple(keys), tuple(tuple(float(x) for x in row) for row in rows))


def _parameter(origin: str, key: str, spec: Any, keys: Mapping[str, Any]) -> Parameter:
    where = f"{origin}: parameters.{key}"
    known = sorted([*PERTURBATION_KEYS, *(k for k, v in keys.items() if _numeric_key(v))])
    boolean = key in keys and bool in keys[key].types and not _numeric_key(keys[key])
    if key not in PERTURBATION_KEYS and not (key in keys and (_numeric_key(keys[key]) or boolean)):
        if key in keys:
            raise SweepSpecError(
                f"{where}: {key} is not a number or a flag and cannot be varied (varied keys: "
                f"{', '.join(known)})"
            )
        raise _unknown(origin, "parameters.", key, known)
    if not isinstance(spec, Mapping):
        raise SweepSpecError(f"{where}: must be a table with distribution = ... and its fields")
    for f in spec:
        if f not in PARAM_FIELDS:
            raise _unknown(origin, f"parameters.{key}.", f, PARAM_FIELDS)
    dist = spec.get("distribution")
    if dist not in DISTRIBUTIONS:
        raise SweepSpecError(
            f"{where}.distribution = {dist!r}: choose one of {', '.join(DISTRIBUTIONS)}"
        )
    need = DISTRIBUTIONS[dist]
    extra = [f for f in spec if f not in (*need, "distribution", "source")]
    if extra:
        raise SweepSpecError(
            f"{where}.{extra[0]}: not a field of a {dist} distribution (it takes {', '.join(need)})"
        )
    missing = [f for f in need if f not in spec]
    if missing:
        raise SweepSpecError(
            f"{where}: a {dist} distribution needs {', '.join(need)}; {missing[0]} is missing"
        )
    args = {f: spec[f] for f in need}
    if boolean and dist != "grid":
        raise SweepSpecError(
            f'{where}: {key} is a flag: vary it with distribution = "grid", values = [false, true]'
        )
    lo, hi = _bounds(key, keys)
    if dist == "grid":
        vals = args["values"]
        ok_type = (lambda v: isinstance(v, bool)) if boolean else _num
        if not (isinstance(vals, list) and vals and all(ok_type(v) for v in vals)):
            raise SweepSpecError(
                f"{where}.values = {vals!r}: give a non-empty list of "
                + ("true/false" if boolean else "numbers")
            )
        if not boolean:
            bad = [v for v in vals if not _inside(v, lo, hi)]
            if bad:
                raise SweepSpecError(
                    f"{where}.values: {bad[0]!r} is outside the key's range {_range(lo, hi)}"
                )
        return Parameter(key, dist, {"values": list(vals)}, str(spec.get("source", "")))
    for f in need:
        if not _num(args[f]):
            raise SweepSpecError(f"{where}.{f} = {args[f]!r}: must be a finite number")
        args[f] = float(args[f])
    if dist == "normal":
        if args["sd"] <= 0:
            raise SweepSpecError(
                f"{where}.sd = {args['sd']:g}: a standard deviation must be > 0 (to hold the "
                "parameter fixed, put it in [set])"
            )
        if not _inside(args["mean"], lo, hi):
            raise SweepSpecError(
                f"{where}.mean = {args['mean']:g}: outside the key's range {_range(lo, hi)}"
            )
    elif dist == "uniform":
        if not args["low"] < args["high"]:
            raise SweepSpecError(
                f"{where}: low = {args['low']:g} >= high = {args['high']:g}: an impossible "
                "uniform distribution (give low < high)"
            )
        if not (_inside(args["low"], lo, hi, closed=True) and _inside(args["high"], lo, hi)):
            raise SweepSpecError(
                f"{where}: [{args['low']:g}, {args['high']:g}] reaches outside the key's range "
                f"{_range(lo, hi)}"
            )
    else:  # lognormal
        if args["median"] <= 0 or args["sigma"] <= 0:
            raise SweepSpecError(
                f"{where}: median = {args['median']:g}, sigma = {args['sigma']:g}: a lognormal "
                "distribution needs median > 0 and sigma > 0 (sigma of the natural log)"
            )
        if hi is not None and hi <= 0:
            raise SweepSpecError(
                f"{where}: a lognormal cannot give the key's range {_range(lo, hi)}"
            )
    return Parameter(key, dist, args, str(spec.get("source", "")))


def _numeric_key(k) -> bool:
    return any(t in (int, float) for t in k.types) and bool not in k.types and k.unit != ""


def _bounds(key: str, keys: Mapping[str, Any]) -> tuple[float | None, float | None]:
    """(lower, upper) of a key's allowed values (lower exclusive for 'positive')."""
    if key in PERTURBATION_KEYS:
        return PERTURBATION_KEYS[key][1], None
    check = keys[key].check
    if check == "positive":
        return 0.0, None
    if check == "nonneg":
        return -0.0, None
    if check == "fraction":
        return 0.0, 1.0
    return None, None


def _inside(v: float, lo, hi, closed: bool = False) -> bool:
    if lo is not None:
        if lo == 0.0 and math.copysign(1.0, lo) < 0:  # nonneg: >= 0
            if v < 0:
                return False
        elif v < lo or (v == lo and not closed):
            return False
    return hi is None or v <= hi


def _range(lo, hi) -> str:
    if lo is None and hi is None:
        return "(any number)"
    if lo is not None and math.copysign(1.0, lo) < 0 and lo == 0:
        left = ">= 0"
    elif lo is not None:
        left = f"> {lo:g}"
    else:
        left = ""
    right = f"<= {hi:g}" if hi is not None else ""
    return "(" + " and ".join(x for x in (left, right) if x) + ")"
