"""What a run keeps: the outputs at the requested advances and, optionally, every step."""

from __future__ import annotations

import numpy as np
from numba import njit


class Recorder:
    """Output arrays, one row per requested advance (NaN until reached), and the trajectory.

    Parameters
    ----------
    model : ringqa.simulation.model.Model
    advances_m : (n,) float
        The requested advances (m).
    keep_trajectory : bool
        Keep the chain and push force after every accepted step.
    """

    def __init__(self, model, advances_m: np.ndarray, keep_trajectory: bool) -> None:
        self.model = model
        self.advances_m = np.asarray(advances_m, dtype=float)
        nn = model.n_nodes
        n = self.advances_m.size
        self.source_pos_m = np.full((n, 3), np.nan)
        self.source_dir = np.full((n, 3), np.nan)
        self.tip_pos_m = np.full((n, 3), np.nan)
        self.push_force_n = np.full(n, np.nan)
        self.contact_force_n = np.full((n, nn), np.nan)
        self.newton_iters = np.zeros(n, dtype=np.int64)
        self.s_m = np.full(n, np.nan)
        self.offset_m = np.full(n, np.nan)
        self.nodes_m = np.full((n, nn, 3), np.nan)
        self.keep = keep_trajectory
        self._traj = {"advance_m": [], "time_s": [], "nodes_m": [], "push_force_n": []}

    def record(self, idx: list, q: np.ndarray, u: float, push: float, iters: int) -> None:
        """The state ``q`` at input advance ``u`` for the requested advances ``idx``."""
        m = self.model
        src, d, tip = m.source(q)
        s, off = m.table.closest(src, u)
        contact = np.zeros(m.n_nodes)
        sw = m.samples
        lump_to_nodes(sw.link, sw.alpha, sw.F, contact)
        nodes = m.nodes(q)
        for i in idx:
            self.source_pos_m[i] = src
            self.source_dir[i] = d
            self.tip_pos_m[i] = tip
            self.push_force_n[i] = push
            self.contact_force_n[i] = contact
            self.newton_iters[i] = iters
            self.s_m[i] = s
            self.offset_m[i] = off
            self.nodes_m[i] = nodes

    def step(self, q: np.ndarray, u: float, time_s: float, push: float) -> None:
        """After an accepted step (trajectory only)."""
        if self.keep:
            self._traj["advance_m"].append(u)
            self._traj["time_s"].append(time_s)
            self._traj["nodes_m"].append(self.model.nodes(q))
            self._traj["push_force_n"].append(push)

    def trajectory(self) -> dict[str, np.ndarray] | None:
        """The kept trajectory (or None)."""
        if not self.keep:
            return None
        return {k: np.asarray(v) for k, v in self._traj.items()}

    @property
    def n_missing(self) -> int:
        """Requested advances not reached."""
        return int(np.sum(np.isnan(self.push_force_n)))


@njit(cache=True, error_model="numpy")
def lump_to_nodes(samp_link, samp_alpha, samp_F, out):
    """Add each sample's force to its link's nodes by fraction (in place on ``out``).

    The same order and arithmetic as ``np.add.at(out, link, (1 - alpha) F)`` followed by
    ``np.add.at(out, link + 1, alpha F)``.
    """
    for i in range(samp_link.shape[0]):
        out[samp_link[i]] += (1 - samp_alpha[i]) * samp_F[i]
    for i in range(samp_link.shape[0]):
        out[samp_link[i] + 1] += samp_alpha[i] * samp_F[i]
