"""What every physical effect provides, and how the assembler reaches its kernels.

An effect is one module with three parts:

1. ``<Name>Args``, a ``typing.NamedTuple`` of the kernel's parameters (arrays and scalars, SI,
   named fields: the kernel reads ``p.hinge_k``, never ``cpar[5]``);
2. its numba kernels with ONE signature for every effect::

       prepare(p, q, st, sw) -> float                  # optional: before any effect adds
       add(p, q, st, sw, r, B, jac) -> float           # its residual (and Jacobian) terms

   ``p`` its args, ``q`` the state (n_all,), ``st`` the :class:`Step` (history, step size and
   layout), ``sw`` the :class:`Samples` (contact sample points and their per-sample results),
   ``r`` (n_all,) the residual ``dU/dq - f_ext`` (N; twist N m) to add to, ``B`` the banded
   Jacobian ``dr/dq`` (:mod:`ringqa.simulation.band`) to add to when ``jac``; the returned float
   is the energy it stores (J) or the work it dissipated over the step (J), see ``ENERGY``;
3. a public frozen-dataclass unit (subclass of :class:`Effect`) that validates the scene's
   values (errors name the scene key and the fix), knows whether the scene calls for it
   (:meth:`Effect.build` returns None otherwise) and packs the args.

``register_kernels(Args, add=..., prepare=...)`` ties the kernels to the args type; the assembler
(:func:`ringqa.simulation.solvers.assemble.assemble`) loops over a tuple of args with numba's
``literal_unroll`` and calls :func:`effect_prepare` / :func:`effect_add`, which numba resolves to
the registered kernel of each args type at compile time. So the assembler never names an effect,
and an effect that a scene does not call for is neither called nor compiled.

numba's disk cache keeps one index per cached function, holding every specialisation's type
signature; an args type defined outside this package (a notebook, a test) may not be importable
in the next process, and one such entry would make the whole index unreadable. So models whose
effects are all defined in ``ringqa`` run the cached assembler and Newton, and any other model
runs uncached twins of them (compiled once per process: :func:`is_cacheable`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numba.extending import overload


class Step(NamedTuple):
    """What a kernel knows about the step it is solving (layout and history), SI.

    Backward Euler: ``q_hist = q_start`` and ``d_hist = d_start`` (the same arrays),
    ``floor_scale = 1``. BDF2 takes a backward-Euler step against a modified history (see
    :mod:`ringqa.simulation.solvers.integrators`).

    Attributes
    ----------
    nd : int
        Coordinates per node: 3 (x, y, z in m) or 4 (plus the twist angle in rad).
    n_nodes : int
        Nodes of the chain (links + 1); node 0 is the distal tip.
    kl : int
        Half-bandwidth of the Jacobian (``3 nd - 1``).
    q_hist : (n_all,) float64
        State the velocities are taken against: ``v = (q - q_hist) / dt`` (m; rad).
    v_hist : (n_all,) float64
        Velocity history of the inertia term ``M (q - q_hist - dt v_hist) / dt^2`` (m/s; rad/s).
    q_start : (n_all,) float64
        State at the start of the step: a force's work over the step is taken over
        ``q - q_start`` (m; rad).
    q_ref : (n_all,) float64
        Anchor of the stabilisation tether (the step's predictor) (m; rad).
    d_hist : (P,) float64
        Contact sample distances the wall-damping velocity is taken against (m).
    d_start : (P,) float64
        Contact sample distances at the start of the step (m).
    dt : float
        The kernel's step (s): the time step, or ``increment / speed`` quasi-statically.
    floor_scale : float
        ``dt`` of the kernel over the actual step (1 for backward Euler; BDF2's ``h_eff / h``):
        per-step floors (the friction slip floor, the tether) keep the actual step's value.
    """

    nd: int
    n_nodes: int
    kl: int
    q_hist: np.ndarray
    v_hist: np.ndarray
    q_start: np.ndarray
    q_ref: np.ndarray
    d_hist: np.ndarray
    d_start: np.ndarray
    dt: float
    floor_scale: float


class Samples(NamedTuple):
    """The contact sample points along the links (P of them) and their last results (SI).

    Attributes
    ----------
    link : (P,) int64
        The link of each sample.
    alpha : (P,) float64
        Its fraction along the link (0 at node ``link``).
    ro : (P,) float64
        The instrument's outer radius there (m).
    wt : (P,) float64
        Its wall-stiffness weight (1: the scene's k and c_w act at this sample).
    s : (P,) float64
        Closest centreline arc length (m); the closest-point hint, updated in place.
    p : (P, 3) float64
        Sample positions (m).
    d : (P,) float64
        Effective centre distances (m).
    n : (P, 3) float64
        Wall normals ``grad d`` (unit; zero for a sample out of contact).
    H : (P, 3, 3) float64
        Hessians of ``d`` (1/m; zero out of contact).
    z : (P,) float64
        Contact depths ``(d - a) / w`` (-).
    w : (P,) float64
        Transition widths (m).
    F : (P,) float64
        Normal force magnitudes (N).
    dF : (P,) float64
        Their derivatives ``dF / dd`` (N/m).
    """

    link: np.ndarray
    alpha: np.ndarray
    ro: np.ndarray
    wt: np.ndarray
    s: np.ndarray
    p: np.ndarray
    d: np.ndarray
    n: np.ndarray
    H: np.ndarray
    z: np.ndarray
    w: np.ndarray
    F: np.ndarray
    dF: np.ndarray

    @classmethod
    def empty(cls, link, alpha, ro, wt) -> Samples:
        """Samples at the given places with zeroed results."""
        P = int(np.asarray(link).size)
        return cls(
            np.ascontiguousarray(link, dtype=np.int64),
            np.ascontiguousarray(alpha, dtype=np.float64),
            np.ascontiguousarray(ro, dtype=np.float64),
            np.ascontiguousarray(wt, dtype=np.float64),
            np.zeros(P),
            np.zeros((P, 3)),
            np.zeros(P),
            np.zeros((P, 3)),
            np.zeros((P, 3, 3)),
            np.zeros(P),
            np.zeros(P),
            np.zeros(P),
            np.zeros(P),
        )


#: what an effect's kernels return: energy it stores, work it dissipates over a step, or nothing
ENERGY = ("stored", "dissipated", "none")


@dataclass
class BuildContext:
    """What :meth:`Effect.build` may look at (the model under construction).

    Attributes
    ----------
    scene : ringqa.simulation.scene.Scene
    chain : ringqa.simulation.chain.Chain
    table : ringqa.simulation.channel.ChannelTable
    dynamic : bool
        The dynamic solver (inertia on).
    nd : int
        Coordinates per node (4 with torsion).
    clearance_m : float
        Smallest clearance r_b - r_o of the channel (m).
    warnings : list of str
        Append what the user should know (an effect switched on or off implicitly, ...).
    """

    scene: Any
    chain: Any
    table: Any
    dynamic: bool
    nd: int
    clearance_m: float
    warnings: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class Effect:
    """Base of the effect units (subclasses are frozen dataclasses holding validated values).

    Class attributes
    ----------------
    name : str
        The effect's name (a key of ``SimResult.settings['effects_assembled']``).
    energy : str
        One of :data:`ENERGY`: what the kernels' return value means.
    history : bool
        The effect acts through the step's history (velocities): it is suspended in the initial
        static equilibrium (:meth:`suspended_args`).
    """

    name: ClassVar[str] = ""
    energy: ClassVar[str] = "none"
    history: ClassVar[bool] = False

    @classmethod
    def build(cls, ctx: BuildContext) -> Effect | None:  # pragma: no cover - abstract
        """The unit for this model, or None when the scene does not call for the effect."""
        raise NotImplementedError

    def args(self) -> tuple:  # pragma: no cover - abstract
        """The kernel's args (the ``<Name>Args`` named tuple)."""
        raise NotImplementedError

    def suspended_args(self) -> tuple:
        """Args with the effect inactive (history effects) or unchanged (the others)."""
        return self.args()


# ------------------------------------------------------------------------------------------
# dispatch: args type -> kernels, resolved by numba at compile time

_PREPARE: dict[type, Any] = {}
_ADD: dict[type, Any] = {}


def register_kernels(args_type: type, *, add, prepare=None) -> None:
    """Tie an effect's kernels to its args type (each effect module does this once).

    Parameters
    ----------
    args_type : type
        The effect's ``typing.NamedTuple`` of kernel parameters.
    add : numba dispatcher
        ``add(p, q, st, sw, r, B, jac) -> float``.
    prepare : numba dispatcher, optional
        ``prepare(p, q, st, sw) -> float``, run for every effect before any ``add``.
    """
    _ADD[args_type] = add
    if prepare is not None:
        _PREPARE[args_type] = prepare
    else:
        _PREPARE.pop(args_type, None)


def effect_prepare(p, q, st, sw):  # pragma: no cover - replaced by numba
    """Run the prepare kernel registered for ``type(p)`` (numba resolves it; 0.0 if none)."""
    raise NotImplementedError("effect_prepare is called from numba kernels only")


def effect_add(p, q, st, sw, r, B, jac):  # pragma: no cover - replaced by numba
    """Run the add kernel registered for ``type(p)`` (numba resolves it)."""
    raise NotImplementedError("effect_add is called from numba kernels only")


@overload(effect_prepare, inline="always")
def _ol_effect_prepare(p, q, st, sw):
    cls = getattr(p, "instance_class", None)
    if cls not in _ADD:
        return None
    fn = _PREPARE.get(cls)
    if fn is None:

        def no_prepare(p, q, st, sw):
            return 0.0

        return no_prepare

    def call_prepare(p, q, st, sw):
        return fn(p, q, st, sw)

    return call_prepare


@overload(effect_add, inline="always")
def _ol_effect_add(p, q, st, sw, r, B, jac):
    cls = getattr(p, "instance_class", None)
    fn = _ADD.get(cls)
    if fn is None:
        return None

    def call_add(p, q, st, sw, r, B, jac):
        return fn(p, q, st, sw, r, B, jac)

    return call_add


def is_cacheable(effects: tuple) -> bool:
    """True when every args type in ``effects`` is defined in the ringqa package (so numba's
    disk cache can hold the specialisation: the module docstring says why)."""
    return all(type(a).__module__.startswith("ringqa.") for a in effects)
