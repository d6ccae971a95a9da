"""Standard plans: equal dwell times on 5 mm dwells, scaled to the prescription at Point A.

The paper's dosimetric comparison (Straathof et al. 2024, section 2.4): a standard plan on the
measured dwell positions spaced 5 mm apart, prescribed to 100 % at Point A; the same dwell times
are then transferred unchanged to the simulated and the centreline positions, and the doses at
the dose points are compared. Positions are in mm (the TG-43 interface), times in s.

Source orientation at a measured dwell (a measured path has positions only): the unit tangent of
the path by central finite differences (one-sided at the ends), pointing DISTALLY (towards
relative position 0, the source tip direction).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ringqa.errors import RingQAError

#: Default dwell spacing of the standard plan, mm.
PLAN_STEP_MM = 5.0
#: Default prescription to Point A, Gy (4 x 7 Gy GEC-ESTRO schedule).
PRESCRIPTION_GY = 7.0
#: Default air-kerma strength, U (the Oncentra example's source; doses do not depend on it
#: because dwell times are scaled to the prescription).
SK_U = 40820.0


def _xyz(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise RingQAError(f"{name}: expected an (n, 3) array of positions, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise RingQAError(f"{name}: contains NaN or infinite coordinates")
    return arr


def path_directions(path_mm) -> np.ndarray:
    """Unit source directions along a measured path (most distal position FIRST).

    Central differences inside, one-sided at the ends; each direction points distally, i.e.
    from position i+1 towards position i-1.

    Parameters
    ----------
    path_mm : array_like, shape (n, 3)
        Positions ordered most distal first (relative positions 0, step, 2 step, ...), n >= 2.

    Returns
    -------
    ndarray, shape (n, 3)
        Unit vectors.

    Raises
    ------
    RingQAError
        Fewer than two positions, or two consecutive positions that coincide.
    """
    p = _xyz(path_mm, "measured path")
    if p.shape[0] < 2:
        raise RingQAError("measured path: needs at least 2 positions to define orientations")
    d = -np.gradient(p, axis=0)  # gradient runs proximally (increasing relative position)
    norm = np.linalg.norm(d, axis=1)
    if np.any(norm < 1e-9):
        i = int(np.argmin(norm))
        raise RingQAError(
            f"measured path: positions around index {i} coincide, orientation undefined "
            "(remove duplicate positions)"
        )
    return d / norm[:, None]


def resample_path(path_mm, step_mm: float, plan_step_mm: float = PLAN_STEP_MM):
    """Positions of a path at relative positions 0, plan_step, 2 plan_step, ... (mm).

    The path's positions sit at relative positions ``i * step_mm``; plan positions that fall
    between two of them are interpolated linearly (exact where they coincide).

    Returns
    -------
    rel_mm : ndarray, shape (k,)
        Relative positions of the plan's dwells, mm (0 = most distal).
    positions_mm : ndarray, shape (k, 3)
    directions : ndarray, shape (k, 3)
        Unit tangents of the path pointing distally (interpolated, renormalised).
    """
    p = _xyz(path_mm, "measured path")
    if not (np.isfinite(step_mm) and step_mm > 0):
        raise RingQAError(f"measured path: step {step_mm!r} mm must be > 0")
    if not (np.isfinite(plan_step_mm) and plan_step_mm > 0):
        raise RingQAError(f"plan step {plan_step_mm!r} mm must be > 0")
    dirs = path_directions(p)
    rel_path = np.arange(p.shape[0]) * float(step_mm)
    n_plan = int(np.floor(rel_path[-1] / plan_step_mm + 1e-9)) + 1
    rel = np.arange(n_plan) * float(plan_step_mm)
    pos = np.column_stack([np.interp(rel, rel_path, p[:, k]) for k in range(3)])
    dd = np.column_stack([np.interp(rel, rel_path, dirs[:, k]) for k in range(3)])
    dd /= np.linalg.norm(dd, axis=1)[:, None]
    return rel, pos, dd


@dataclass(frozen=True, eq=False)
class Plan:
    """A set of dwells with times (a plan as TG-43 sees it).

    Attributes
    ----------
    name : str
        ``"measured"``, ``"simulated"``, ``"centreline"`` or a user label.
    channels : tuple of str, length n
        Channel name of each dwell (``"ring"``, ``"tandem"``).
    relative_position_mm : ndarray, shape (n,)
        Relative position of each dwell in its channel, mm (0 = most distal).
    positions_mm : ndarray, shape (n, 3)
        Source centres, mm.
    directions : ndarray, shape (n, 3)
        Unit source directions (towards the source tip).
    times_s : ndarray, shape (n,)
        Dwell times, s.
    source : tg43.Source
        TG-43 source.
    sk_U : float
        Air-kerma strength, U.
    """

    name: str
    channels: tuple[str, ...]
    relative_position_mm: np.ndarray
    positions_mm: np.ndarray
    directions: np.ndarray
    times_s: np.ndarray
    source: object
    sk_U: float = SK_U

    def __post_init__(self) -> None:
        n = len(self.channels)
        pos = _xyz(self.positions_mm, f"plan {self.name}: positions")
        dirs = _xyz(self.directions, f"plan {self.name}: directions")
        times = np.asarray(self.times_s, dtype=float).reshape(-1)
        rel = np.asarray(self.relative_position_mm, dtype=float).reshape(-1)
        if not (pos.shape[0] == dirs.shape[0] == times.shape[0] == rel.shape[0] == n):
            raise RingQAError(
                f"plan {self.name}: channels ({n}), relative positions ({rel.shape[0]}), "
                f"positions ({pos.shape[0]}), directions ({dirs.shape[0]}) and times "
                f"({times.shape[0]}) must have the same length"
            )
        norm = np.linalg.norm(dirs, axis=1)
        if np.any(norm < 1e-9):
            raise RingQAError(f"plan {self.name}: a source direction is zero")
        if np.any(times < 0) or not np.all(np.isfinite(times)):
            raise RingQAError(f"plan {self.name}: dwell times must be finite and >= 0")
        object.__setattr__(self, "positions_mm", pos)
        object.__setattr__(self, "directions", dirs / norm[:, None])
        object.__setattr__(self, "times_s", times)
        object.__setattr__(self, "relative_position_mm", rel)
        object.__setattr__(self, "channels", tuple(str(c) for c in self.channels))

    @property
    def n_dwells(self) -> int:
        """Number of dwells."""
        return len(self.channels)

    @property
    def total_time_s(self) -> float:
        """Sum of the dwell times, s."""
        return float(self.times_s.sum())

    def transfer(self, positions_mm, directions, name: str) -> Plan:
        """The same dwell times on other positions/orientations (same order, same channels)."""
        return replace(self, name=name, positions_mm=positions_mm, directions=directions)

    def dose_gy(self, points_mm) -> np.ndarray:
        """TG-43 dose of this plan at points (n_points, 3) mm -> (n_points,) Gy."""
        import tg43

        return tg43.plan_dose_gy(
            self.source, self.positions_mm, self.directions, self.times_s, self.sk_U, points_mm
        )


@dataclass(frozen=True)
class DwellSet:
    """Dwell positions of one channel, before times are assigned.

    Attributes
    ----------
    channel : str
        Channel name.
    relative_position_mm : ndarray, shape (n,)
    positions_mm : ndarray, shape (n, 3)
    directions : ndarray, shape (n, 3)
    """

    channel: str
    relative_position_mm: np.ndarray
    positions_mm: np.ndarray
    directions: np.ndarray


def standard_plan(
    dwell_sets: Sequence[DwellSet],
    point_a_mm,
    source,
    *,
    prescription_gy: float = PRESCRIPTION_GY,
    sk_U: float = SK_U,
    name: str = "measured",
) -> Plan:
    """Equal dwell times on all dwells, scaled so the MEAN dose of the Point A's = prescription.

    Parameters
    ----------
    dwell_sets : sequence of DwellSet
        The channels' dwells (e.g. ring from the measured path, tandem).
    point_a_mm : array_like, shape (k, 3)
        Point A left and right (or any points whose mean dose is prescribed), mm.
    source : tg43.Source
    prescription_gy : float
        Mean dose at ``point_a_mm``, Gy (> 0).
    sk_U : float
        Air-kerma strength, U (> 0).

    Returns
    -------
    Plan
        With ``t = prescription / mean_k(D_k(1 s each))`` at every dwell.
    """
    if not (np.isfinite(prescription_gy) and prescription_gy > 0):
        raise RingQAError(f"prescription {prescription_gy!r} Gy must be > 0")
    if not dwell_sets:
        raise RingQAError("standard plan: no dwells (the applicator has no dwell positions)")
    channels: list[str] = []
    for ds in dwell_sets:
        channels += [ds.channel] * len(ds.relative_position_mm)
    unit = Plan(
        name=name,
        channels=tuple(channels),
        relative_position_mm=np.concatenate([ds.relative_position_mm for ds in dwell_sets]),
        positions_mm=np.concatenate([ds.positions_mm for ds in dwell_sets]),
        directions=np.concatenate([ds.directions for ds in dwell_sets]),
        times_s=np.ones(len(channels)),
        source=source,
        sk_U=float(sk_U),
    )
    per_second = float(np.mean(unit.dose_gy(point_a_mm)))
    if not per_second > 0:
        raise RingQAError("standard plan: Point A receives no dose (check the dose points)")
    return replace(unit, times_s=np.full(len(channels), prescription_gy / per_second))


def relative_difference_pct(dose_gy, reference_gy) -> np.ndarray:
    """``100 (dose / reference - 1)``, %, elementwise."""
    d = np.asarray(dose_gy, dtype=float)
    ref = np.asarray(reference_gy, dtype=float)
    return 100.0 * (d / ref - 1.0)
