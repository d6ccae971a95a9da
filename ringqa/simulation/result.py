"""What a simulation returns (after scipy's OdeResult: status, message, counts, never partial
silently)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ringqa.units import m_to_mm

#: contract columns of ``dwells.csv`` (issue 4), in order
DWELL_COLUMNS = (
    "advance_mm",
    "x_mm",
    "y_mm",
    "z_mm",
    "dir_x",
    "dir_y",
    "dir_z",
    "push_force_n",
    "s_mm",
    "offset_mm",
)

STATUS_SUCCESS = 0
STATUS_JAMMED = 1
STATUS_FAILED = -1


@dataclass(frozen=True)
class SolverStats:
    """What a run's solver did (after scipy's ``OdeResult`` counters ``nfev``, ``njev``, ``nlu``).

    Attributes
    ----------
    n_steps : int
        Accepted load or time steps.
    n_newton_iters : int
        Newton iterations, failed attempts included.
    n_residuals : int
        Residual assemblies (line-search trials included).
    n_jacobians : int
        Jacobian assemblies.
    n_solves : int
        Banded linear solves.
    n_halvings : int
        Line-search halvings.
    n_failed_attempts : int
        Attempts at a step that did not converge (then cut or stabilised).
    n_cut_steps : int
        Accepted steps that needed sub-steps.
    n_stabilised_steps : int
        Accepted steps that needed the fallback stabilisation.
    """

    n_steps: int = 0
    n_newton_iters: int = 0
    n_residuals: int = 0
    n_jacobians: int = 0
    n_solves: int = 0
    n_halvings: int = 0
    n_failed_attempts: int = 0
    n_cut_steps: int = 0
    n_stabilised_steps: int = 0


@dataclass(frozen=True)
class SimResult:
    """The outcome of :func:`ringqa.simulation.simulate`, one row per requested advance.

    Attributes
    ----------
    status : int
        0 success, 1 jammed (push force above ``solver.jam_force_n`` or no source progress over
        ``solver.jam_length_m`` of input), -1 failed (Newton did not converge even with the
        smallest increment). Rows not reached are NaN and ``message`` says which.
    message : str
        Human-readable outcome.
    advances_mm : (n,) float64
        Requested cable advances (mm), in the order requested.
    source_pos_m : (n, 3) float64
        Source centre of activity (m).
    source_dir : (n, 3) float64
        Unit source axis, pointing to the tip.
    tip_pos_m : (n, 3) float64
        Distal tip (m).
    push_force_n : (n,) float64
        Axial force applied by the driver (N, > 0 pushing).
    contact_force_n : (n, n_nodes) float64
        Magnitude of the wall's normal force lumped to each node (N).
    newton_iters : (n,) int64
        Newton iterations spent since the previous reported advance.
    s_m : (n,) float64
        Arc length of the centreline point closest to the source centre (m).
    offset_m : (n,) float64
        Distance of the source centre from the centreline (m).
    n_elements : int
        Number of links.
    solve_time_s : float
        Wall time of the solve (s), JIT compilation excluded.
    settings : dict
        Settings used (solver, effects, discretisation, derived quantities).
    warnings : tuple of str
    work : dict
        ``input``, ``elastic`` (change of stored energy), ``friction``, ``damping``,
        ``stabilisation``, ``kinetic`` (J) and ``balance_error`` (relative).
    nodes_m : (n, n_nodes, 3) float64
        The whole chain at each reported advance (m).
    trajectory : dict or None
        With ``outputs.trajectory``: ``advance_m`` (k,), ``time_s`` (k,),
        ``nodes_m`` (k, n_nodes, 3), ``push_force_n`` (k,) for every load/time step.
    provenance : ringqa.provenance.Provenance or None
    max_penetration_m : float
        Largest penetration of the instrument's surface beyond the lumen wall r_b over the whole
        run (m; 0 if it never reached the wall), over all contact sample points.
    stats : SolverStats
        The solver's counters.
    """

    status: int
    message: str
    advances_mm: np.ndarray
    source_pos_m: np.ndarray
    source_dir: np.ndarray
    tip_pos_m: np.ndarray
    push_force_n: np.ndarray
    contact_force_n: np.ndarray
    newton_iters: np.ndarray
    s_m: np.ndarray
    offset_m: np.ndarray
    n_elements: int
    solve_time_s: float
    settings: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    work: dict[str, float] = field(default_factory=dict)
    nodes_m: np.ndarray | None = None
    trajectory: dict[str, np.ndarray] | None = None
    provenance: Any = None
    max_penetration_m: float = 0.0
    stats: SolverStats = field(default_factory=SolverStats)

    @property
    def success(self) -> bool:
        """True when every requested advance was reached (status 0)."""
        return self.status == STATUS_SUCCESS

    def dwell_table(self):
        """The dwell table (pandas DataFrame) with the contract columns of issue 4 first.

        Columns: ``advance_mm, x_mm, y_mm, z_mm, dir_x, dir_y, dir_z, push_force_n, s_mm,
        offset_mm`` then ``tip_x_mm, tip_y_mm, tip_z_mm, newton_iters``.
        """
        import pandas as pd

        pos = m_to_mm(np.asarray(self.source_pos_m).reshape(-1, 3))
        tip = m_to_mm(np.asarray(self.tip_pos_m).reshape(-1, 3))
        d = np.asarray(self.source_dir).reshape(-1, 3)
        return pd.DataFrame(
            {
                "advance_mm": np.asarray(self.advances_mm, dtype=float),
                "x_mm": pos[:, 0],
                "y_mm": pos[:, 1],
                "z_mm": pos[:, 2],
                "dir_x": d[:, 0],
                "dir_y": d[:, 1],
                "dir_z": d[:, 2],
                "push_force_n": np.asarray(self.push_force_n, dtype=float),
                "s_mm": m_to_mm(np.asarray(self.s_m, dtype=float)),
                "offset_mm": m_to_mm(np.asarray(self.offset_m, dtype=float)),
                "tip_x_mm": tip[:, 0],
                "tip_y_mm": tip[:, 1],
                "tip_z_mm": tip[:, 2],
                "newton_iters": np.asarray(self.newton_iters, dtype=np.int64),
            }
        )

    def __repr__(self) -> str:  # compact, like OdeResult
        return (
            f"SimResult(status={self.status}, message={self.message!r}, "
            f"n_advances={len(self.advances_mm)}, n_elements={self.n_elements}, "
            f"solve_time_s={self.solve_time_s:.4g}, newton_iters={int(np.sum(self.newton_iters))})"
        )
