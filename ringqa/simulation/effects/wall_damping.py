"""Wall damping: ``c_w (3 - 2z) z^2 v_n`` in the transition zone, ``c_w v_n`` beyond (Khatait).

The total normal force (elastic + damping) is clamped at zero: the wall never pulls (the paper's
MATLAB code does not clamp, which makes a "sticky" wall). v_n is the change of the sample's
centre distance over the step divided by the step time (against the step's history, so BDF2
gets its second-order velocity); the work is taken over the step's actual change of distance.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class WallDampingArgs(NamedTuple):
    """Kernel parameters: damping coefficient c_w (N s/m) per sample of weight 1; ``active``
    False suspends it (the initial static equilibrium)."""

    c_w: float
    active: bool


@njit(cache=True, inline="always", error_model="numpy")
def prepare_wall_damping(p, q, st, sw):
    """The effect's uniform signature: call :func:`wall_damping_kernel` (if active)."""
    if not p.active:
        return 0.0
    return wall_damping_kernel(
        sw.d, st.d_hist, st.d_start, sw.z, sw.w, sw.wt, p.c_w, st.dt, sw.F, sw.dF
    )


@njit(cache=True, error_model="numpy")
def wall_damping_kernel(samp_d, d_hist, d_start, samp_z, samp_w, samp_wt, c_w, dt, samp_F, samp_dF):
    """Add the damping force to the samples' normal forces (after :mod:`.contact` computed the
    elastic ones), then clamp the total at zero; returns the damping work over the step (J)."""
    work = 0.0
    for i in range(samp_d.shape[0]):
        z = samp_z[i]
        if z <= 0.0:
            continue
        vn = (samp_d[i] - d_hist[i]) / dt
        if z <= 1.0:
            sh = (3.0 - 2.0 * z) * z * z
            dsh = (6.0 * z - 6.0 * z * z) / samp_w[i]
        else:
            sh = 1.0
            dsh = 0.0
        cw = c_w * samp_wt[i]
        fd = cw * sh * vn
        samp_F[i] += fd
        samp_dF[i] += cw * (dsh * vn + sh / dt)
        work += fd * (samp_d[i] - d_start[i])
    # the wall never pulls: a negative total normal force is clamped to zero
    for i in range(samp_F.shape[0]):
        if samp_F[i] < 0.0:
            samp_F[i] = 0.0
            samp_dF[i] = 0.0
    return work


@njit(cache=True, inline="always", error_model="numpy")
def add_wall_damping(p, q, st, sw, r, B, jac):
    """Nothing to add itself: the damping force acts through the contact's normal force."""
    return 0.0


register_kernels(WallDampingArgs, add=add_wall_damping, prepare=prepare_wall_damping)


@dataclass(frozen=True)
class WallDamping(Effect):
    """Wall damping coefficient c_w (N s/m)."""

    name = "wall_damping"
    energy = "dissipated"
    history = True

    c_w: float

    @classmethod
    def build(cls, ctx: BuildContext) -> WallDamping | None:
        """On with ``effects.wall_damping`` (needs contact); reads ``contact.damping_ns_m``."""
        eff = ctx.scene.effects
        if not (eff.contact and eff.wall_damping):
            return None
        return cls(float(ctx.scene.contact.damping_ns_m))

    def args(self) -> WallDampingArgs:
        return WallDampingArgs(self.c_w, True)

    def suspended_args(self) -> WallDampingArgs:
        return WallDampingArgs(self.c_w, False)
