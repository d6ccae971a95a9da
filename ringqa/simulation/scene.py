"""What a simulation is asked to do: the scene (channel, instrument, effects, motion, solver).

These frozen dataclasses are the engine's whole input, in SI units. They are built from a TOML
scene file by :mod:`ringqa.simulation.scenefile` (which validates keys and converts mm/deg/s to SI),
or programmatically (``Scene.for_channel``). The engine assembles exactly the effects switched on
here and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from ringqa.geometry import Channel

FRICTION_LAWS = ("none", "coulomb", "stribeck")
SOLVER_KINDS = ("quasistatic", "dynamic")
INTEGRATORS = ("backward_euler", "bdf2")
MOTION_KINDS = ("constant", "stepwise", "retract")


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

    @property
    def length_m(self) -> float:
        """Total modelled length (m)."""
        return float(sum(s.length_m for s in self.sections))


@dataclass(frozen=True)
class Effects:
    """Which physical effects the engine assembles (bending is always on).

    ``gravity_m_s2`` is the gravity vector (m/s^2) in the channel's frame, or None for off.
    """

    torsion: bool = False
    contact: bool = True
    friction: str = "stribeck"  # one of FRICTION_LAWS
    wall_damping: bool = False
    inertia: bool = False
    gravity_m_s2: tuple[float, float, float] | None = None


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
        Static (Stribeck peak) and kinetic friction coefficients.
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

    stiffness_n_m: float = 1.0e5
    damping_ns_m: float = 10.0
    mu_s: float = 0.25
    mu_k: float = 0.20
    v_brk_m_s: float = 1.0e-3
    transition_m: float | None = None
    transition_max_fraction: float = 0.2
    friction_v_reg_m_s: float | None = None
    friction_slip_min_m: float = 1.0e-7
    stiffness_per_length: bool = False


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

    kind: str = "constant"
    advances_m: tuple[float, ...] = ()
    speed_m_s: float = 0.5
    start_m: float | None = None
    dwell_s: float = 0.0
    backward: bool = False


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
        Small artificial viscosity (N s/m per node, or documented unit) that carries the
        quasi-static solver through snap-through; 0 switches it off.
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
        ``BDF2_MAX_RATIO``; see :func:`ringqa.simulation.solvers.driver.bdf2_history`).
        Quasi-static runs ignore it (their load steps have no time derivative to integrate).
    """

    kind: str = "quasistatic"
    increment_m: float = 1.0e-3
    time_step_s: float = 1.0e-3
    tol: float = 1.0e-8
    max_iter: int = 50
    stabilisation: float = 0.0
    jam_force_n: float = 50.0
    jam_length_m: float = 0.02
    axial_stiffness_n: float = 1.0e6
    approach_m: float = 0.02
    contact_bow_fraction: float = 0.1
    integrator: str = "backward_euler"


@dataclass(frozen=True)
class Outputs:
    """What to keep besides the dwell table."""

    trajectory: bool = False


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
    source : dict
        The user-level (mm/deg/s) settings the scene came from, for provenance and round trips.
    """

    name: str
    channel: Channel
    instrument: Instrument
    effects: Effects = field(default_factory=Effects)
    contact: ContactParams = field(default_factory=ContactParams)
    motion: Motion = field(default_factory=Motion)
    solver: SolverSettings = field(default_factory=SolverSettings)
    outputs: Outputs = field(default_factory=Outputs)
    source: dict[str, Any] = field(default_factory=dict)

    def replace(self, **changes) -> Scene:
        """A copy with some fields replaced (dataclasses.replace)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The scene in user units (mm/deg/s), TOML-able; :func:`load_scene` reads it back."""
        from ringqa.simulation.scenefile import scene_to_dict

        return scene_to_dict(self)

    def with_overrides(self, overrides: dict[str, Any]) -> Scene:
        """A copy with dotted user-unit keys changed, e.g. ``{"solver.increment_mm": 0.5}``."""
        from ringqa.simulation.scenefile import scene_with_overrides

        return scene_with_overrides(self, overrides)

    @classmethod
    def for_channel(cls, channel: Channel, cable: str = "flexitron", **settings) -> Scene:
        """A scene for a channel with a preset cable; settings as section tables in user units
        (``solver={"increment_mm": 0.5}``) or ``solver__increment_mm=0.5``."""
        from ringqa.simulation.scenefile import scene_for_channel

        return scene_for_channel(channel, cable, **settings)
