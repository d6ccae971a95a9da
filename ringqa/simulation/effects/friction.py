"""Friction: Coulomb or Stribeck (the paper's Armstrong / Canudas de Wit form), regularised.

``mu(v) = sqrt(2e) (mu_s - mu_k) exp(-x^2) x + mu_k tanh(v / v_reg)``, x = v / (v_brk sqrt 2)
(Stribeck; Coulomb drops the first term), v_reg = v_brk / 10 unless
``contact.friction_v_reg_m_s`` is set. Quasi-statically the contact velocity is the tangential slip
over the load step divided by the step's time ``increment / motion.speed`` (an incremental slip
law: a node that slips less than ~ v_reg dt per step is sticking); dynamically it is the
integrator's velocity (backward Euler or BDF2). v_reg is floored at
``contact.friction_slip_min_m / dt`` (0.1 um of slip per step; BDF2 keeps it at the step dt, not
its kernel step 2 dt / 3) so that cutting a step does not sharpen the law without bound
(dynamically this is inactive at the default 1 ms step: 0.1 um / 1 ms = v_brk / 10).
"""

from __future__ import annotations

from dataclasses import dataclass

from ringqa.errors import SceneError
from ringqa.simulation.effects.base import CPAR, FLAG, positive

LAWS = {"none": 0, "coulomb": 1, "stribeck": 2}


@dataclass(frozen=True)
class Friction:
    """Friction law code (1 Coulomb, 2 Stribeck) and its coefficients (SI)."""

    law: int
    mu_s: float
    mu_k: float
    v_brk: float
    v_reg: float
    slip_min: float = 1.0e-7

    @classmethod
    def from_scene(cls, scene) -> Friction | None:
        """Read ``effects.friction`` and ``contact.*``; None when friction is off."""
        law = scene.effects.friction
        if law not in LAWS:
            raise SceneError(
                f"effects.friction: {law!r} is not one of {', '.join(LAWS)} (choose one)"
            )
        if LAWS[law] == 0:
            return None
        c = scene.contact
        mu_k = positive("contact.mu_k", c.mu_k, allow_zero=True)
        mu_s = positive("contact.mu_s", c.mu_s, allow_zero=True)
        if law == "stribeck" and mu_s < mu_k:
            raise SceneError("contact.mu_s: must be >= contact.mu_k for the Stribeck law")
        v_brk = positive("contact.v_brk_m_s", c.v_brk_m_s)
        v_reg = (
            v_brk / 10.0
            if c.friction_v_reg_m_s is None
            else positive("contact.friction_v_reg_m_s", c.friction_v_reg_m_s)
        )
        slip_min = positive("contact.friction_slip_min_m", c.friction_slip_min_m, allow_zero=True)
        return cls(LAWS[law], mu_s, mu_k, v_brk, v_reg, slip_min)

    def pack(self, flags, cpar) -> None:
        """Write the parameters into the kernel arrays and switch the effect on."""
        flags[FLAG["friction"]] = self.law
        cpar[CPAR["mu_s"]] = self.mu_s
        cpar[CPAR["mu_k"]] = self.mu_k
        cpar[CPAR["v_brk"]] = self.v_brk
        cpar[CPAR["v_reg"]] = self.v_reg
        cpar[CPAR["slip_min"]] = self.slip_min
