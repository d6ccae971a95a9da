"""The one assembler: the residual and, when asked, the banded Jacobian of the assembled effects.

``effects`` is a tuple of the effects' kernel args (:mod:`ringqa.simulation.effects.base`), in
assembly order. Every effect's ``prepare`` runs first (contact finds its samples' distances and
forces, wall damping adds to them), then every effect's ``add`` adds its terms to ``r`` (and to
``B`` with ``jac``). numba unrolls the loops over the tuple, so each model compiles an assembler
for exactly its effects.

Three uses, one code path:

- ``jac=False, fresh=True``: the residual at a trial point (Newton's line search);
- ``jac=True, fresh=True``: residual and Jacobian;
- ``jac=True, fresh=False``: the Jacobian at the point the last ``fresh`` call left, reusing its
  contact samples (``prepare`` is skipped; the residual goes to a scratch array): the line search
  evaluates trials without the Jacobian and Newton builds it only where it goes on.
"""

from __future__ import annotations

from numba import literal_unroll, njit

from ringqa.simulation.effects.base import effect_add, effect_prepare


@njit(cache=True, error_model="numpy")
def assemble(effects, q, st, sw, r, B, jac, fresh, energies):
    """Residual ``r`` (and banded Jacobian ``B`` when ``jac``) of ``effects`` at ``q``.

    Parameters
    ----------
    effects : tuple of named tuples
        The effects' kernel args, in assembly order.
    q : (n_all,) float64
        State (m; twist in rad).
    st : Step
        Layout and history of the step.
    sw : Samples
        Contact samples (their results are rewritten when ``fresh``).
    r : (n_all,) float64
        Output: residual ``dU/dq - f_ext`` (N; twist N m).
    B : (n_all, 3 kl + 1) float64
        Output (when ``jac``): banded Jacobian ``dr/dq``.
    jac, fresh : bool
        Build ``B``; run the effects' ``prepare`` (see module docstring).
    energies : (len(effects),) float64
        Output (when ``fresh``): each effect's stored energy or step work (J).
    """
    r[:] = 0.0
    if jac:
        B[:, :] = 0.0
    k = 0
    for p in literal_unroll(effects):
        if fresh:
            energies[k] = effect_prepare(p, q, st, sw)
        k += 1
    k = 0
    for p in literal_unroll(effects):
        e = effect_add(p, q, st, sw, r, B, jac)
        if fresh:
            energies[k] += e
        k += 1
