"""What a simulation is asked to do: the scene (channel, instrument, effects, motion, solver).

These frozen dataclasses are the engine's whole input, in SI units. They validate themselves in
``__post_init__`` against the scene keys (:mod:`ringqa.simulation.scene_keys`: defaults, ranges
and the names errors use are described there once), so a scene built in Python is checked
exactly like one read from a TOML file by :mod:`ringqa.simulation.scenefile` (which converts
mm/deg/s to SI). They know nothing of the file format. The engine assembles exactly the effects
switched on here and nothing else.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ringqa.errors import SceneError
from ringqa.simulation.scene_keys import (
    FORMULATIONS,
    FRICTION_LAWS,
    INTEGRATORS,
    MOTION_KINDS,
    SOLVER_KINDS,
    check_fields,
    default_si,
)

if TYPE_CHECKING:  # pragma: no cover
    from ringqa.geometry import Channel

__all__ = [
    "FORMULATIONS",
    "FRICTION_LAWS",
    "INTEGRATORS",
    "MOTION_KINDS",
    "SOLVER_KINDS",
    "CableSection",
    "ChannelSpec",
    "ContactParams",
    "Effects",
    "Instrument",
    "ModelSettings",
    "Motion",
    "Outputs",
    "Scene",
    "SolverSettings",
]


def _d(section: str, name: str):
    """A field's default, from its scene key (in SI)."""
    return field(default=default_si(section, name))


@dataclass(frozen=True)
class CableSection:
    """One uniform section of the instrument, counted from the tip backwards.

    Attributes
    ----------
    name : str
        Section label (``"capsule"``, ``"thin"``, ``"thick"``).
    length_m : float
        Section length (m).
    r_o_m : float
        Outer radius (m).
    ei_nm2 : float
        Bending stiffness EI (N m^2).
    gj_nm2 : float
        Torsional stiffness GJ (N m^2).
    mass_per_length_kg_m : float
        Mass per unit length (kg/m).
    element_length_m : float
        Link length used to discretise this section (m). A rigid section (the source capsule) is
        one link whatever this says.
    rigid : bool
        True for the rigid source capsule.
    """

    name: str
    length_m: float
    r_o_m: float
    ei_nm2: float
    gj_nm2: float
    mass_per_length_kg_m: float
    element_length_m: float
    rigid: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise SceneError(f"instrument section name: expected a non-empty string, got "
                             f"{self.name!r}")  # fmt: skip
        try:
            check_fields("section", self)
        except SceneError as exc:
            raise SceneError(f"instrument section {self.name!r}: "
                             f"{str(exc).replace('section.', '')}") from None  # fmt: skip


@dataclass(frozen=True)
class Instrument:
    """A source cable (or catheter): sections from the tip back.

    Attributes
    ----------
    name : str
        Preset or user name.
    sections : tuple of CableSection
        From the distal tip backwards; the first is the source capsule for a source cable.
    centre_from_tip_m : float
        Distance from the distal tip to the source's centre of activity (m) (Flexitron 2.4 mm).
    afterloader : str
        Which afterloader the cable data belong to (``"flexitron"``), for the report.
    """

    name: str
    sections: tuple[CableSection, ...]
    centre_from_tip_m: float
    afterloader: str = ""

    def __post_init__(self) -> None:
        secs = tuple(self.sections)
        if not secs or not all(isinstance(s, CableSection) for s in secs):
            raise SceneError("instrument.sections: give at least one CableSection, tip first")
        object.__setattr__(self, "sections", secs)
        check_fields("instrument", self)

    @property
    def length_m(self) -> float:
        """Total modelled length (m)."""
        return float(sum(s.length_m for s in self.sections))


@dataclass(frozen=True)
class Effects:
    """Which physical effects the engine assembles (bending is always on).

    ``gravity_m_s2`` is the gravity vector (m/s^2) in the channel's frame, or None for off.
    """

    torsion: bool = _d("effects", "torsion")
    contact: bool = _d("effects", "contact")
    friction: str = _d("effects", "friction")  # one of FRICTION_LAWS
    wall_damping: bool = _d("effects", "wall_damping")
    inertia: bool = _d("effects", "inertia")
    gravity_m_s2: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        check_fields("effects", self)
        g = self.gravity_m_s2
        if g is not None:
            try:
                vec = tuple(float(x) for x in g)
            except (TypeError, ValueError):
                vec = ()
            if len(vec) != 3 or not all(math.isfinite(x) for x in vec):
                raise SceneError(
                    f"effects.gravity_m_s2: expected three finite numbers (m/s^2), got {g!r} "
                    "(e.g. [0, -9.81, 0])"
                )
            object.__setattr__(self, "gravity_m_s2", vec)


@dataclass(frozen=True)
class ContactParams:
    """Wall contact and friction parameters (the paper's Table 1 by default).

    Attributes
    ----------
    stiffness_n_m : float
        Wall stiffness k (N/m).
    damping_ns_m : float
        Wall damping c_w (N s/m), used only when ``Effects.wall_damping``.
    mu_s, mu_k : float
        Static (Stribeck peak) and kinetic friction coefficients (``mu_k <= mu_s``).
    v_brk_m_s : float
        Breakaway velocity (m/s).
    transition_m : float or None
        Width of the contact transition zone r_b - r_a (m); None = take r_a from the lumen.
        The engine shrinks it where the clearance is smaller (and says so in warnings).
    transition_max_fraction : float
        The transition zone is at most this fraction of the clearance r_b - r_o (engine).
    friction_v_reg_m_s : float or None
        Regularisation velocity of the tanh in the friction law (m/s); None = v_brk / 10 (paper).
    friction_slip_min_m : float
        The regularisation never acts over less slip per (load or time) step than this (m), i.e.
        v_reg >= friction_slip_min_m / dt. With dt = increment / speed the tanh would
        otherwise sharpen without bound as a step is cut (0.2 um at 1 mm steps, 0.4 nm cut 256
        times) and Newton stall. 0.1 um: a micro-slip well below anything reported.
    stiffness_per_length : bool
        False (the paper): ``stiffness_n_m`` and ``damping_ns_m`` act at every contact sample.
        True: they are per 3 mm of cable (the paper's element), each sample getting its share, so
        the wall is a stiffness per unit length and refining the links does not stiffen it (for
        convergence studies; tight bends then sink deeper into the wall with the paper's k).
    """

    stiffness_n_m: float = _d("contact", "stiffness_n_m")
    damping_ns_m: float = _d("contact", "damping_ns_m")
    mu_s: float = _d("contact", "mu_s")
    mu_k: float = _d("contact", "mu_k")
    v_brk_m_s: float = _d("contact", "v_brk_m_s")
    transition_m: float | None = None
    transition_max_fraction: float = _d("contact", "transition_max_fraction")
    friction_v_reg_m_s: float | None = None
    friction_slip_min_m: float = _d("contact", "friction_slip_min_m")
    stiffness_per_length: bool = _d("contact", "stiffness_per_length")

    def __post_init__(self) -> None:
        check_fields("contact", self)
        if self.mu_k > self.mu_s:
            raise SceneError(
                f"contact.mu_k: {self.mu_k:g} exceeds mu_s = {self.mu_s:g} (the kinetic "
                "coefficient must not exceed the static (Stribeck peak) one)"
            )


@dataclass(frozen=True)
class Motion:
    """Input motion at the proximal end (axial only; rotation and lateral motion fixed).

    Attributes
    ----------
    kind : str
        ``"constant"`` (constant speed to the last advance), ``"stepwise"`` (advance one step,
        dwell, advance; forward or backward), ``"retract"`` (pull back from the first advance).
    advances_m : tuple of float
        Cable advances at which results are reported (m): the centreline arc length where the source
        centre WOULD sit if the cable followed the centreline.
    speed_m_s : float
        Input speed (m/s) during motion.
    start_m : float or None
        Advance at which the simulation starts (m); None = the instrument tip at the channel entry.
    dwell_s : float
        Pause at each advance for ``"stepwise"`` motion (s).
    backward : bool
        Stepwise motion from the most distal advance backwards (backward-stepping afterloaders).
    """

    kind: str = _d("motion", "kind")
    advances_m: tuple[float, ...] = ()
    speed_m_s: float = 0.5
    start_m: float | None = None
    dwell_s: float = _d("motion", "dwell_s")
    backward: bool = _d("motion", "backward")

    def __post_init__(self) -> None:
        check_fields("motion", self)
        adv = tuple(float(a) for a in self.advances_m)
        if not all(math.isfinite(a) for a in adv):
            raise SceneError("motion.advances_mm: every advance must be a finite number (mm)")
        object.__setattr__(self, "advances_m", adv)
        if self.start_m is not None and not math.isfinite(float(self.start_m)):
            raise SceneError("motion.start_mm: must be a finite number (mm)")


@dataclass(frozen=True)
class SolverSettings:
    """Numerical settings (what the accuracy study varies).

    Attributes
    ----------
    kind : str
        ``"quasistatic"`` or ``"dynamic"``.
    increment_m : float
        Input increment per quasi-static load step (m).
    time_step_s : float
        Time step of the dynamic solver (s).
    tol : float
        Newton convergence tolerance (relative residual).
    max_iter : int
        Newton iterations per step before the step is cut.
    stabilisation : float
        Small artificial viscosity (N s/m per node) that carries the quasi-static solver through
        snap-through on every step; 0: only as the fallback of a step that fails.
    jam_force_n : float
        Push force above which the run is reported as jammed (N).
    jam_length_m : float
        Input length without source progress after which the run is reported as jammed (m).
    axial_stiffness_n : float
        EA of the stiff axial penalty that keeps the links inextensible (N); the link strain is
        push force / EA (1e-6 at 1 N).
    approach_m : float
        Straight cable modelled in front of the channel entry at the deepest advance (m).
    contact_bow_fraction : float
        Extra contact samples per link so that a link's bow between samples across the tightest
        bend is at most this fraction of the clearance.
    integrator : str
        Time integrator of the dynamic solver: ``"backward_euler"`` (first order in the time
        step) or ``"bdf2"`` (second order: the two-step backward differentiation formula, a
        backward-Euler step for the first step and whenever the time step grows by more than
        ``BDF2_MAX_RATIO``; see :mod:`ringqa.simulation.solvers.integrators`).
        Quasi-static runs ignore it (their load steps have no time derivative to integrate).
    """

    kind: str = _d("solver", "kind")
    increment_m: float = _d("solver", "increment_m")
    time_step_s: float = _d("solver", "time_step_s")
    tol: float = _d("solver", "tol")
    max_iter: int = _d("solver", "max_iter")
    stabilisation: float = _d("solver", "stabilisation")
    jam_force_n: float = _d("solver", "jam_force_n")
    jam_length_m: float = _d("solver", "jam_length_m")
    axial_stiffness_n: float = _d("solver", "axial_stiffness_n")
    approach_m: float = _d("solver", "approach_m")
    contact_bow_fraction: float = _d("solver", "contact_bow_fraction")
    integrator: str = _d("solver", "integrator")

    def __post_init__(self) -> None:
        check_fields("solver", self)
        if int(self.max_iter) != self.max_iter:
            raise SceneError(f"solver.max_iter: must be an integer, got {self.max_iter!r}")
        object.__setattr__(self, "max_iter", int(self.max_iter))


@dataclass(frozen=True)
class Outputs:
    """What to keep besides the dwell table."""

    trajectory: bool = _d("outputs", "trajectory")

    def __post_init__(self) -> None:
        check_fields("outputs", self)


@dataclass(frozen=True)
class ModelSettings:
    """How the engine discretises the instrument.

    Attributes
    ----------
    formulation : str
        ``"rigid"`` (default: rigid links joined by hinge springs EI/l, the paper's rigid
        multibody model) or ``"flexible"`` (cubic Hermite beam elements with nodal positions and
        tangents, bending from the elements' curvature: :mod:`ringqa.simulation.flexible`).
    """

    formulation: str = _d("model", "formulation")

    def __post_init__(self) -> None:
        check_fields("model", self)


@dataclass(frozen=True, eq=False)
class ChannelSpec:
    """How a scene file described its channel (user units), tied to the channel it built.

    A :class:`Scene` keeps it only while its ``channel`` is that very channel: replace the
    channel and the description is dropped (the writer then writes the channel inline).
    """

    spec: Mapping[str, Any]
    channel: Any


@dataclass(frozen=True)
class Scene:
    """Everything one simulation needs, in SI units.

    Attributes
    ----------
    name : str
        Scene name (file stem or given).
    channel : ringqa.geometry.Channel
        The channel the instrument is pushed into (centreline, lumen, s_ref).
    instrument : Instrument
    effects : Effects
    contact : ContactParams
    motion : Motion
    solver : SolverSettings
    outputs : Outputs
    description : str
        Free text.
    channel_spec : ChannelSpec or None
        How a scene file described the channel (an applicator name, an analytic shape); None for
        a channel given as an object, or once the channel is replaced.
    model : ModelSettings
        The discretisation (``model.formulation``: rigid or flexible).
    """

    name: str
    channel: Channel
    instrument: Instrument
    effects: Effects = field(default_factory=Effects)
    contact: ContactParams = field(default_factory=ContactParams)
    motion: Motion = field(default_factory=Motion)
    solver: SolverSettings = field(default_factory=SolverSettings)
    outputs: Outputs = field(default_factory=Outputs)
    description: str = ""
    channel_spec: ChannelSpec | None = None
    model: ModelSettings = field(default_factory=ModelSettings)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise SceneError(f"name: expected a string, got {self.name!r}")
        for attr, cls in (("instrument", Instrument), ("effects", Effects),
                          ("contact", ContactParams), ("motion", Motion),
                          ("solver", SolverSettings), ("outputs", Outputs),
                          ("model", ModelSettings)):  # fmt: skip
            if not isinstance(getattr(self, attr), cls):
                raise SceneError(f"scene.{attr}: expected a {cls.__name__}")
        if getattr(self.channel, "centreline", None) is None or not hasattr(self.channel, "lumen"):
            raise SceneError(
                "scene.channel: needs a centreline and a lumen (use ringqa.geometry.Channel)"
            )
        if self.channel_spec is not None and self.channel_spec.channel is not self.channel:
            object.__setattr__(self, "channel_spec", None)

    def replace(self, **changes) -> Scene:
        """A copy with some fields replaced (dataclasses.replace; validated again)."""
        return replace(self, **changes)
