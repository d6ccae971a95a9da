"""The design: every sample's parameter values, decided in the parent before any run.

- ``method = "random"``: sample i draws its values from ``numpy.random.default_rng([seed, i])``
  in spec order (normal, uniform, lognormal); grid parameters take the combination
  ``i mod G`` of their full factorial (G combinations, first parameter slowest). Normal
  parameters named in the spec's ``[correlation]`` draw their standard normals ``z`` in the
  same order and take ``mean + sd (L z)`` with ``L L^T`` the correlation matrix
  (:meth:`~ringqa.sweep.spec.Correlation.factor`): one multivariate normal (with the identity
  matrix, the same numbers as independent draws).
- ``method = "sobol"``: SALib's Saltelli/Sobol design (``SALib.sample.sobol``, first and total
  order, seeded), N (D + 2) rows for N = ``samples`` and D parameters.

Either way a sample's numbers depend only on the spec and (seed, i), never on which worker runs
it or in what order.
"""

from __future__ import annotations

import itertools

import numpy as np

from ringqa.sweep.spec import SweepSpec

__all__ = ["design", "n_runs", "sample_values"]


def n_runs(spec: SweepSpec) -> int:
    """Number of runs of the design (random: ``samples``; sobol: ``samples (D + 2)``)."""
    if spec.method == "sobol":
        return spec.samples * (len(spec.parameters) + 2)
    return spec.samples


def _grid(spec: SweepSpec) -> list[tuple]:
    vals = [p.args["values"] for p in spec.parameters if p.distribution == "grid"]
    return list(itertools.product(*vals)) if vals else [()]


def _draw(p, rng: np.random.Generator) -> float:
    a = p.args
    if p.distribution == "normal":
        return float(rng.normal(a["mean"], a["sd"]))
    if p.distribution == "uniform":
        return float(rng.uniform(a["low"], a["high"]))
    return float(a["median"] * np.exp(a["sigma"] * rng.standard_normal()))


def sample_values(spec: SweepSpec, i: int) -> list:
    """Sample i's values (random method), in spec order (floats; grid flags stay bool)."""
    rng = np.random.default_rng([spec.seed, int(i)])
    combos = _grid(spec)
    combo = iter(combos[int(i) % len(combos)])
    corr = getattr(spec, "correlation", None)
    if corr is None:
        return [next(combo) if p.distribution == "grid" else _draw(p, rng)
                for p in spec.parameters]  # fmt: skip
    out: list = []
    z: dict[str, float] = {}
    for p in spec.parameters:
        if p.distribution == "grid":
            out.append(next(combo))
        elif p.key in corr.keys:
            z[p.key] = float(rng.standard_normal())  # the draw rng.normal would make
            out.append(None)
        else:
            out.append(_draw(p, rng))
    mixed = corr.factor() @ np.array([z[k] for k in corr.keys])
    for j, p in enumerate(spec.parameters):
        if p.key in corr.keys:
            u = float(mixed[corr.keys.index(p.key)])
            out[j] = float(p.args["mean"] + p.args["sd"] * u)
    return out


def _salib_problem(spec: SweepSpec) -> dict:
    bounds, dists = [], []
    for p in spec.parameters:
        a = p.args
        if p.distribution == "normal":
            bounds.append([a["mean"], a["sd"]])
            dists.append("norm")
        elif p.distribution == "uniform":
            bounds.append([a["low"], a["high"]])
            dists.append("unif")
        else:
            bounds.append([float(np.log(a["median"])), a["sigma"]])
            dists.append("lognorm")
    return {
        "num_vars": len(spec.parameters),
        "names": list(spec.names),
        "bounds": bounds,
        "dists": dists,
    }


def design(spec: SweepSpec) -> np.ndarray:
    """All runs' values, ``(n_runs, D)`` (object dtype when a flag is varied, else float)."""
    if spec.method == "sobol":
        from SALib.sample import sobol

        return np.asarray(
            sobol.sample(
                _salib_problem(spec), spec.samples, calc_second_order=False, seed=spec.seed
            ),
            dtype=float,
        )
    rows = [sample_values(spec, i) for i in range(spec.samples)]
    flags = any(isinstance(v, bool) for v in (rows[0] if rows else []))
    return np.array(rows, dtype=object if flags else float)


def salib_problem(spec: SweepSpec) -> dict:
    """The SALib problem dict of a Sobol spec (for :func:`SALib.analyze.sobol.analyze`)."""
    return _salib_problem(spec)
