"""What every effect unit provides: validation from the scene and its slot in the kernel arrays."""

from __future__ import annotations

import numpy as np

from ringqa.errors import SceneError

#: index of each effect's switch in the ``flags`` array of the solver kernels
FLAG = {
    "contact": 0,
    "friction": 1,
    "wall_damping": 2,
    "inertia": 3,
    "gravity": 4,
    "torsion": 5,
    "stabilisation": 6,
}
#: index of each parameter in the ``cpar`` array of the solver kernels
CPAR = {
    "k_wall": 0,
    "transition": 1,
    "transition_max_fraction": 2,
    "c_w": 3,
    "mu_s": 4,
    "mu_k": 5,
    "v_brk": 6,
    "v_reg": 7,
    "stabilisation": 8,
    "k_axial": 9,
    "slip_min": 10,
}
N_FLAGS = 7
N_CPAR = 11


def positive(key: str, value, allow_zero: bool = False) -> float:
    """``value`` as a finite float > 0 (>= 0 with ``allow_zero``); SceneError names ``key``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{key}: expected a number, got {value!r}") from None
    ok = np.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if not ok:
        raise SceneError(f"{key}: must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return v
