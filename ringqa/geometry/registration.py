"""Reference source paths: checks against the channel, and registration to the channel (SI).

A *reference path* is the measured (vendor or clinic) list of source-centre positions a
commissioning run compares the simulation and the centreline with, MOST DISTAL FIRST. Before
trusting it, three questions are asked (:func:`check_reference_path`):

1. **Can each position be in the lumen?** The source centre of a capsule of radius ``r_c`` in a
   lumen of wall radius ``r_b`` is at most ``r_b - r_c`` from the channel centreline. A position
   farther than that plus :data:`FEASIBLE_TOL_M` is flagged ``"infeasible"``. The bound uses the
   CIRCULAR wall ``r_b`` also where the lumen is U-shaped: the flat side's distance is an
   assumption in the shipped models, and ``r_b - r_c`` is the largest offset in any direction, so
   a flagged position is certainly outside the lumen (a position that is not flagged may still be
   too close to a flat side, or to the outer wall in a bend, where the rigid capsule's ends reach
   farther out than its centre). Tolerance 0.05 mm: the library centrelines reproduce their
   design circles to about 0.03 mm (``ringqa.geometry.parametric``), and coordinates are stored to
   0.01 mm; an excess below 0.05 mm is not evidence.
2. **Is each position along the channel?** A position whose closest centreline point is beyond an
   end (``s < 0``: proximal of the entry; ``s > length``: past the lumen tip, on the straight
   extensions of :class:`~ringqa.geometry.Centreline`) or farther than
   :data:`OUTSIDE_DISTANCE_M` (5 mm) from it is flagged ``"outside_channel"``. 5 mm is more than
   three lumen radii (1.5 mm) and twice the worst offset of the Oncentra example (2.4 mm): such a
   position is not a source slightly off-centre but a position of another part, or of a wrong
   frame, and its closest centreline point (the stem of a ring passes 7-11 mm from its distal
   part) need not be the channel point it belongs to. The flag takes precedence over
   ``"infeasible"``.
3. **Was it measured in 3D?** A plane is fitted (SVD, total least squares). The path is
   ``planar`` when its RMS distance from that plane is below :data:`PLANAR_TOL_M` (0.01 mm): a
   measurement in 3D (CT, radiographs, a camera) carries at least tens of micrometres of noise,
   so positions within 10 um of one plane over tens of millimetres were stored as a 2D path. The
   heights above the RING CHANNEL'S PLANE (the circle of the ring channel; positive along the
   ring normal, cranially) are reported per position; ``constant_height`` when they all lie
   within :data:`PLANAR_TOL_M` of their mean (the path's plane is then parallel to the ring
   plane).

Registration (:func:`register_reference`, modes :data:`REGISTER_MODES`) moves the reference onto
the CHANNEL, never onto a simulation: ``"none"`` (identity), ``"plane-height"`` (a planar,
constant-height path translated along the ring normal into the ring channel's plane) and
``"rigid"`` (the rotation and translation minimising the squared distances of the positions to
the centreline, keeping their mean position ALONG the channel; see :func:`register_reference`
for why, and for its weakness).

Relative positions (:func:`reference_positions`) are kept AS GIVEN (uneven spacing kept);
duplicated positions are refused.

Everything is in metres; millimetres appear only in messages and summaries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from ringqa.geometry.applicator import Channel
from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.families.ring_frame import fit_ring_frame
from ringqa.geometry.frame import Frame
from ringqa.geometry.shape_checks import close_pairs
from ringqa.units import m_to_mm, rad_to_deg

__all__ = [
    "DUPLICATE_TOL_M",
    "FEASIBLE_TOL_M",
    "FLAG_INFEASIBLE",
    "FLAG_OK",
    "FLAG_OUTSIDE",
    "MIN_POSITIONS",
    "OUTSIDE_DISTANCE_M",
    "PLANAR_TOL_M",
    "REGISTER_MODES",
    "PathPlacement",
    "ReferencePathCheck",
    "ReferencePositions",
    "Registration",
    "RegistrationError",
    "check_reference_path",
    "path_placement",
    "reference_positions",
    "register_reference",
]

#: Registration modes, in the order of the command-line choice ``--register``.
REGISTER_MODES = ("none", "plane-height", "rigid")
RegisterMode = Literal["none", "plane-height", "rigid"]

#: Flag of a position that can lie in the lumen.
FLAG_OK = ""
#: Flag of a position farther from the centreline than the source centre can get.
FLAG_INFEASIBLE = "infeasible"
#: Flag of a position not along the channel (beyond an end, or far from it).
FLAG_OUTSIDE = "outside_channel"

#: Allowed excess of the offset over ``r_b - capsule radius`` (m): the centreline's fit.
FEASIBLE_TOL_M = 0.05e-3
#: A position farther than this from the centreline is not along the channel (m).
OUTSIDE_DISTANCE_M = 5.0e-3
#: RMS distance from the best plane below which a path is planar, i.e. stored 2D (m).
PLANAR_TOL_M = 0.01e-3
#: Two positions (or relative positions) closer than this are duplicates (m).
DUPLICATE_TOL_M = 1.0e-6
#: A reference path needs at least this many positions on the channel.
MIN_POSITIONS = 3
#: Without a frame given, the ring family's circle is fitted to this much of the channel's distal
#: end (m), as for an applicator file without one (``ringqa.io.applicator_file``).
RING_FIT_LENGTH_M = 40.0e-3
#: ... and accepted when the centreline lies within this RMS of the fitted circle (m).
RING_FIT_RMS_M = 0.05e-3
#: Rigid fit: stop when the RMS distance changes by less than this between iterations (m) ...
RIGID_RMS_CHANGE_M = 1.0e-9
#: ... and the last update moved no position by more than this (m).
RIGID_STEP_M = 1.0e-9
#: Rigid fit: at most this many Gauss-Newton iterations.
RIGID_MAX_ITER = 100
#: Rigid fit: largest update per iteration (m at the positions' RMS radius), so that the closest
#: centreline points move continuously.
RIGID_MAX_STEP_M = 0.5e-3
#: Rigid fit: closest-point search window around the previous answer (m): stays on its branch.
RIGID_WINDOW_M = 10.0e-3
#: Rigid fit: singular values below this fraction of the largest are directions the channel's
#: shape does not determine (e.g. a rotation about the axis of a circular arc); left unchanged.
RIGID_RCOND = 1.0e-6


class RegistrationError(GeometryError):
    """A reference path cannot be checked or registered as asked (names the argument/mode and
    the fix)."""


# --------------------------------------------------------------------------------------------
# results


def rotvec_to_matrix(rotvec) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula).

    Parameters
    ----------
    rotvec : (3,) array_like
        Rotation axis times angle (rad).

    Returns
    -------
    (3, 3) ndarray
        ``R = I + a K + b K^2`` with ``K`` the cross-product matrix of ``rotvec``,
        ``a = sin(theta)/theta`` and ``b = (1 - cos(theta))/theta^2 = 2 sin^2(theta/2)/theta^2``
        (the half-angle form has no cancellation); below ``theta = 1e-3`` their Taylor series to
        ``theta^4`` (truncation below 1e-21), which also covers ``theta = 0``. Equals scipy's
        ``Rotation.from_rotvec(v).as_matrix()`` to round-off.
    """
    v = np.asarray(rotvec, dtype=float)
    theta = float(np.sqrt(v @ v))
    if theta < 1e-3:
        t2 = theta * theta
        a = 1.0 - t2 / 6.0 + t2 * t2 / 120.0
        b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0
    else:
        a = np.sin(theta) / theta
        b = 2.0 * (np.sin(0.5 * theta) / theta) ** 2
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + a * k + b * (k @ k)


def matrix_to_rotvec(matrix) -> np.ndarray:
    """Rotation vector (axis times angle, rad, angle in [0, pi]) of a rotation matrix.

    Parameters
    ----------
    matrix : (3, 3) array_like
        A rotation matrix (orthonormal to round-off).

    Returns
    -------
    (3,) ndarray

    Notes
    -----
    Through the unit quaternion, found by Markley's method (the largest of the trace and the
    diagonal entries picks the formula, so no component is computed from a small difference: the
    angle near 0 and near pi are both exact to round-off), then ``angle = 2 atan2(|q_xyz|, q_w)``
    with ``q_w >= 0`` and ``rotvec = q_xyz angle / sin(angle/2)`` (its series below 1e-3 rad). The
    steps are those of scipy's ``Rotation.from_matrix(m).as_rotvec()``.
    """
    m = np.asarray(matrix, dtype=float)
    decision = (m[0, 0], m[1, 1], m[2, 2], m[0, 0] + m[1, 1] + m[2, 2])
    choice = int(np.argmax(decision))
    q = np.empty(4)
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1.0 - decision[3] + 2.0 * m[i, i]
        q[j] = m[j, i] + m[i, j]
        q[k] = m[k, i] + m[i, k]
        q[3] = m[k, j] - m[j, k]
    else:
        q[0] = m[2, 1] - m[1, 2]
        q[1] = m[0, 2] - m[2, 0]
        q[2] = m[1, 0] - m[0, 1]
        q[3] = 1.0 + decision[3]
    q /= np.sqrt(q @ q)
    if q[3] < 0.0:
        q = -q
    xyz = q[:3]
    angle = 2.0 * float(np.arctan2(np.sqrt(xyz @ xyz), q[3]))
    if angle <= 1e-3:
        a2 = angle * angle
        scale = 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0
    else:
        scale = angle / np.sin(0.5 * angle)
    return scale * xyz


def _freeze(obj) -> None:
    """Make every ndarray field of a frozen dataclass read-only (a copy, so inputs stay
    writeable)."""
    for name, value in vars(obj).items():
        if isinstance(value, np.ndarray):
            arr = np.array(value)
            arr.setflags(write=False)
            object.__setattr__(obj, name, arr)


@dataclass(frozen=True, eq=False)
class ReferencePathCheck:
    """What a reference path looks like against its channel (see the module docstring).

    Attributes
    ----------
    s_m : (n,) ndarray
        Arc length of each position's closest centreline point (m); < 0 or > the channel length
        on the straight extensions beyond the ends.
    offset_m : (n,) ndarray
        Distance of each position from the centreline (m).
    max_offset_m : (n,) ndarray
        Largest offset the source centre can have at ``s_m``: ``r_b(s) - capsule_radius_m`` (m).
    flags : tuple of str, length n
        Per position: :data:`FLAG_OK` (``""``), :data:`FLAG_INFEASIBLE` or :data:`FLAG_OUTSIDE`.
    capsule_radius_m : float
        Source capsule radius used (m).
    plane_rms_m : float
        RMS distance of the positions from their best-fitting plane (m).
    plane_normal : (3,) ndarray or None
        Unit normal of that plane, on the ring normal's side; None for collinear positions.
    collinear : bool
        The positions lie on a straight line (RMS distance from the best line < ``PLANAR_TOL_M``):
        no plane is defined.
    planar : bool
        Not collinear and ``plane_rms_m < PLANAR_TOL_M``: the path was stored 2D.
    plane_tilt_deg : float or None
        Angle between the path's plane and the ring plane (deg, 0-90); None when collinear.
    heights_m : (n,) ndarray
        Signed height of each position above the ring channel's plane, along the ring normal
        (cranial positive), m.
    height_m : float
        Mean of ``heights_m`` (m): for a planar path parallel to the ring plane, the height of
        its plane.
    constant_height : bool
        All heights within ``PLANAR_TOL_M`` of ``height_m``.
    ring_centre_m : (3,) ndarray
        Centre of the applicator frame used (m; the name is results.json's).
    ring_normal : (3,) ndarray
        Unit normal (cranial) of the applicator frame used.
    frame_source : str
        ``"given"`` or how it was fitted.
    summary : tuple of str
        Plain-language findings, one sentence each, for the report.
    """

    s_m: np.ndarray
    offset_m: np.ndarray
    max_offset_m: np.ndarray
    flags: tuple[str, ...]
    capsule_radius_m: float
    plane_rms_m: float
    plane_normal: np.ndarray | None
    collinear: bool
    planar: bool
    plane_tilt_deg: float | None
    heights_m: np.ndarray
    height_m: float
    constant_height: bool
    ring_centre_m: np.ndarray
    ring_normal: np.ndarray
    frame_source: str
    summary: tuple[str, ...]

    def __post_init__(self) -> None:
        _freeze(self)

    @property
    def n_positions(self) -> int:
        """Number of positions checked."""
        return int(self.s_m.size)

    @property
    def infeasible(self) -> np.ndarray:
        """(n,) bool: positions flagged ``"infeasible"``."""
        return np.array([f == FLAG_INFEASIBLE for f in self.flags], dtype=bool)

    @property
    def outside(self) -> np.ndarray:
        """(n,) bool: positions flagged ``"outside_channel"``."""
        return np.array([f == FLAG_OUTSIDE for f in self.flags], dtype=bool)

    @property
    def on_channel(self) -> np.ndarray:
        """(n,) bool: positions NOT flagged ``"outside_channel"`` (feasible or not)."""
        return ~self.outside

    @property
    def ok(self) -> bool:
        """No position flagged."""
        return all(f == FLAG_OK for f in self.flags)


@dataclass(frozen=True, eq=False)
class Registration:
    """A reference path moved onto its channel by one rigid transform.

    The registered positions are ``points_m = (p - rotation_centre_m) @ rotation.T +
    rotation_centre_m + translation_m`` for the input positions ``p`` (m): a rotation about
    ``rotation_centre_m`` followed by a translation, so ``translation_m`` is the displacement of
    the rotation centre and reads as a plain shift (:meth:`matrix` gives the 4x4 form).

    Attributes
    ----------
    mode : str
        One of :data:`REGISTER_MODES`.
    points_m : (n, 3) ndarray
        Registered positions (m), in the input order.
    rotation : (3, 3) ndarray
        Proper rotation matrix.
    translation_m : (3,) ndarray
        Translation after the rotation (m).
    rotation_centre_m : (3,) ndarray
        Point the rotation is about (m): the centroid of the positions used.
    rotation_deg : float
        Rotation angle (deg).
    rotation_axis : (3,) ndarray
        Unit rotation axis (zero vector for no rotation).
    used : (n,) ndarray of bool
        Positions on the channel (not ``"outside_channel"`` before registration): those the
        rigid fit used, and those the RMS and maximum distances below are taken over.
    rms_before_m, max_before_m : float
        RMS and largest distance of the used positions from the centreline before (m).
    rms_after_m, max_after_m : float
        The same after registration (m).
    iterations : int
        Gauss-Newton iterations of the rigid fit (0 for the other modes).
    converged : bool
        The rigid fit met its stopping rule (always True for the other modes).
    undetermined : int
        Directions of rigid motion the channel's shape does not determine for these positions
        (e.g. 1 for positions all on one circular arc: the rotation about its axis), left
        unchanged by the rigid fit (0 for the other modes).
    description : str
        One line: what was done, in mm and degrees.
    before : ReferencePathCheck
        The check of the input positions.
    after : ReferencePathCheck
        The check of the registered positions.
    """

    mode: str
    points_m: np.ndarray
    rotation: np.ndarray
    translation_m: np.ndarray
    rotation_centre_m: np.ndarray
    rotation_deg: float
    rotation_axis: np.ndarray
    used: np.ndarray
    rms_before_m: float
    max_before_m: float
    rms_after_m: float
    max_after_m: float
    iterations: int
    converged: bool
    undetermined: int
    description: str
    before: ReferencePathCheck
    after: ReferencePathCheck

    def __post_init__(self) -> None:
        _freeze(self)

    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous transform ``M`` with ``[p', 1] = M [p, 1]`` (metres)."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = (
            self.rotation_centre_m + self.translation_m - self.rotation @ (self.rotation_centre_m)
        )
        return m

    def apply(self, points_m) -> np.ndarray:
        """Apply the transform to other points ``(k, 3)`` or ``(3,)`` (m)."""
        p = np.asarray(points_m, dtype=float)
        out = (np.atleast_2d(p) - self.rotation_centre_m) @ self.rotation.T
        out = out + self.rotation_centre_m + self.translation_m
        return out[0] if p.ndim == 1 else out


@dataclass(frozen=True, eq=False)
class ReferencePositions:
    """A reference path with its relative positions, as given.

    Attributes
    ----------
    points_m : (n, 3) ndarray
        Source-centre positions (m), most distal first.
    relative_m : (n,) ndarray
        Relative position of each (m): 0 = the most distal dwell, increasing proximally; as given
        (uneven spacing kept), or ``k * step`` when only a step was given.
    s_nominal_m : (n,) ndarray
        The channel arc length of each relative position, ``s_ref_m - relative_m`` (m): the cable
        advance the afterloader uses for it.
    in_range : (n,) ndarray of bool
        ``0 <= s_nominal_m <= channel length`` (within 1 nm): the relative position is on the
        channel (a simulation can place the source there).
    step_m : float or None
        The common spacing (m) when the spacing is even within ``DUPLICATE_TOL_M``, else None.
    relative_from : str
        ``"given"`` (relative positions given), ``"step"`` (``k * step_m`` from the argument) or
        ``"channel step"`` (``k * channel.measured_step_m``).
    """

    points_m: np.ndarray
    relative_m: np.ndarray
    s_nominal_m: np.ndarray
    in_range: np.ndarray
    step_m: float | None
    relative_from: str

    def __post_init__(self) -> None:
        _freeze(self)

    @property
    def uneven(self) -> bool:
        """The relative positions are not evenly spaced."""
        return self.step_m is None

    @property
    def n_in_range(self) -> int:
        """Number of positions whose relative position is on the channel."""
        return int(np.count_nonzero(self.in_range))


# --------------------------------------------------------------------------------------------
# helpers


def _points(points_m, name: str = "points_m") -> np.ndarray:
    try:
        p = np.array(points_m, dtype=float)
    except (TypeError, ValueError):
        raise RegistrationError(
            f"{name}: cannot be read as numbers; give an (n, 3) array of positions in metres"
        ) from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise RegistrationError(
            f"{name}: expected an (n, 3) array of x, y, z in metres, got shape {p.shape}"
        )
    if p.shape[0] < MIN_POSITIONS:
        raise RegistrationError(
            f"{name}: {p.shape[0]} position(s); a reference path needs at least {MIN_POSITIONS} "
            "(give more measured positions)"
        )
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        raise RegistrationError(
            f"{name}: position {int(np.argmax(bad))} is not finite (NaN or inf); remove or "
            "correct it"
        )
    if float(np.ptp(p, axis=0).max()) > 10.0:
        raise RegistrationError(
            f"{name}: the positions span more than 10 m; give them in metres "
            "(convert millimetres with ringqa.units.mm_to_m)"
        )
    return p


def _channel(channel) -> Channel:
    if not isinstance(channel, Channel):
        raise RegistrationError(
            f"channel: expected a ringqa.geometry.Channel, got {type(channel).__name__}"
        )
    return channel


def _capsule_radius(capsule_radius_m, channel: Channel) -> float:
    try:
        r = float(capsule_radius_m)
    except (TypeError, ValueError):
        raise RegistrationError(
            f"capsule_radius_m: expected a number in metres, got {capsule_radius_m!r}"
        ) from None
    if not np.isfinite(r) or r <= 0.0:
        raise RegistrationError(
            f"capsule_radius_m: must be a positive radius in metres (e.g. 0.45e-3 for the "
            f"0.90 mm mHDR-v2 capsule), got {capsule_radius_m!r}"
        )
    rb_min = float(np.min(channel.lumen.seg_rb))
    if r >= rb_min:
        raise RegistrationError(
            f"capsule_radius_m: {m_to_mm(r):.3g} mm is not smaller than the lumen radius of "
            f"channel {channel.name!r} ({m_to_mm(rb_min):.3g} mm); give the capsule RADIUS in "
            "metres (half its outer diameter)"
        )
    return r


def _frame_or_ring_fit(frame, channel: Channel) -> tuple[np.ndarray, np.ndarray, str]:
    """(centre, unit normal, source text) from the argument or fitted to the channel."""
    if frame is None:
        cl = channel.centreline
        s = np.linspace(max(0.0, cl.length_m - RING_FIT_LENGTH_M), cl.length_m, 81)
        try:
            frame = fit_ring_frame(cl.position(s), caudal_point_m=cl.position(0.0))
        except GeometryError:
            frame = None
        if frame is None or not (frame.rms_m < RING_FIT_RMS_M and frame.radius_m < 0.1):
            raise RegistrationError(
                f"frame: not given, and the distal {m_to_mm(RING_FIT_LENGTH_M):.0f} mm of "
                f"channel {channel.name!r} is not a circular arc; give frame=(centre_m, "
                "normal), e.g. (applicator.frame.centre_m, applicator.frame.normal)"
            )
        return (
            frame.centre_m,
            frame.normal,
            f"fitted to the distal {m_to_mm(RING_FIT_LENGTH_M):.0f} mm of channel "
            f"{channel.name!r} (radius {m_to_mm(frame.radius_m):.2f} mm)",
        )
    if hasattr(frame, "centre_m") and hasattr(frame, "normal"):  # a Frame, the ring's fit
        centre, normal = frame.centre_m, frame.normal
    else:
        try:
            centre, normal = frame
        except (TypeError, ValueError):
            raise RegistrationError(
                "frame: expected a Frame (centre_m, normal) or a pair (centre_m, normal)"
            ) from None
    c = np.asarray(centre, dtype=float)
    n = np.asarray(normal, dtype=float)
    if c.shape != (3,) or n.shape != (3,) or not (np.isfinite(c).all() and np.isfinite(n).all()):
        raise RegistrationError("frame: centre_m and normal must be finite 3-vectors")
    norm = float(np.linalg.norm(n))
    if abs(norm - 1.0) > 1e-6:
        raise RegistrationError(
            f"frame: the normal must be a unit vector (length {norm:.6g}); normalise it"
        )
    return c.copy(), n / norm, "given"


def _index_ranges(idx) -> str:
    """``[0, 1, 2, 5, 7, 8]`` -> ``"0-2, 5, 7-8"``."""
    idx = [int(i) for i in idx]
    if not idx:
        return "none"
    parts = []
    start = prev = idx[0]
    for i in [*idx[1:], None]:
        if i is not None and i == prev + 1:
            prev = i
            continue
        parts.append(f"{start}" if start == prev else f"{start}-{prev}")
        if i is not None:
            start = prev = i
    return ", ".join(parts)


def _which(idx, relative_m: np.ndarray | None) -> str:
    """Names positions for a message: indices, and relative positions in mm when known."""
    idx = np.asarray(idx, dtype=int)
    text = f"position{'s' if idx.size != 1 else ''} {_index_ranges(idx)}"
    if relative_m is not None and idx.size:
        rel = ", ".join(f"{m_to_mm(float(relative_m[i])):g}" for i in idx)
        text += f" (relative {rel} mm)"
    return text


def _closest(channel: Channel, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s, d = channel.centreline.closest(points)
    return np.asarray(s, dtype=float), np.asarray(d, dtype=float)


@dataclass(frozen=True)
class PathPlacement:
    """Where a path lies along its channel, in gross terms (:func:`path_placement`).

    Attributes
    ----------
    median_offset_m : float
        Median distance of the positions from the centreline (m).
    n_off : int
        Positions farther than :data:`OUTSIDE_DISTANCE_M` from the centreline.
    n_along : int
        Positions along the channel (closest point within ``[0, length]`` and not farther than
        :data:`OUTSIDE_DISTANCE_M`): the only ones whose arc length means anything.
    direction : int
        -1: arc length falls along the list (most distal first, as a reference path must be);
        +1: it rises (proximal first, i.e. reversed); 0: fewer than 2 positions along the
        channel, or no clear trend.
    median_step_m : float
        Median change of arc length between consecutive positions along the channel (m,
        signed; nan when undetermined).
    """

    median_offset_m: float
    n_off: int
    n_along: int
    direction: int
    median_step_m: float


def path_placement(points_m, channel: Channel) -> PathPlacement:
    """The gross placement of a path (m, in list order) along ``channel``: how far it lies from
    the centreline and which way its positions run. Readers use it to refuse a path shifted off
    its channel or listed proximal first before anything else is computed from it; the
    per-position flags are :func:`check_reference_path`'s."""
    ch = _channel(channel)
    p = np.asarray(points_m, dtype=float).reshape(-1, 3)
    s, d = _closest(ch, p)
    along = (s >= 0.0) & (s <= ch.length_m) & (d <= OUTSIDE_DISTANCE_M)
    ds = np.diff(s[along])
    direction = 0
    step = float("nan")
    if ds.size:
        step = float(np.median(ds))
        rising, falling = int(np.count_nonzero(ds > 0)), int(np.count_nonzero(ds < 0))
        if rising > 2 * falling and step > 0:
            direction = 1
        elif falling > 2 * rising and step < 0:
            direction = -1
    return PathPlacement(
        float(np.median(d)),
        int(np.count_nonzero(d > OUTSIDE_DISTANCE_M)),
        int(np.count_nonzero(along)),
        direction,
        step,
    )


# --------------------------------------------------------------------------------------------
# the check


def check_reference_path(
    points_m,
    channel: Channel,
    capsule_radius_m: float,
    frame: Frame | tuple | None = None,
    *,
    relative_m=None,
) -> ReferencePathCheck:
    """Check a reference source path against its channel (see the module docstring).

    Parameters
    ----------
    points_m : (n, 3) array_like
        Source-centre positions (m), most distal first, n >= 3.
    channel : Channel
        The channel the path belongs to (centreline and lumen).
    capsule_radius_m : float
        Source capsule radius (m): 0.45e-3 for the microSelectron mHDR-v2 (0.90 mm outer
        diameter), 0.425e-3 for the Flexisource/Flexitron (0.85 mm).
    frame : Frame or (centre_m (3,), normal (3,)), optional
        The applicator frame's origin and cranial unit normal (a ring's: its channel's plane;
        :func:`ringqa.geometry.frame.frame_of`). Default: the ring family's frame fitted to the
        distal 40 mm of ``channel`` (a circle, normal pointing away from the channel entry).
    relative_m : (n,) array_like, optional
        Relative positions (m), used only to name positions in the summary.

    Returns
    -------
    ReferencePathCheck

    Raises
    ------
    RegistrationError
        Fewer than 3 positions, non-finite values, a capsule not narrower than the lumen, or no
        frame given for a channel without a circular distal end.

    Examples
    --------
    The Oncentra 26/60 example's library path (mHDR-v2, capsule 0.90 mm) is planar, 0.89 mm
    above the ring channel's plane; 13 of its 30 positions are farther from the centreline than
    1.05 mm + 0.05 mm, and the 2 most proximal lie past the lumen tip::

        check = check_reference_path(ring.measured_path_m, ring, 0.45e-3,
                                     (app.ring_centre_m, app.ring_normal))
        print("\\n".join(check.summary))
    """
    ch = _channel(channel)
    p = _points(points_m)
    n = p.shape[0]
    rc = _capsule_radius(capsule_radius_m, ch)
    rel = None
    if relative_m is not None:
        rel = np.asarray(relative_m, dtype=float).reshape(-1)
        if rel.shape != (n,):
            raise RegistrationError(
                f"relative_m: expected {n} relative positions (one per position), got {rel.size}"
            )
    centre, normal, frame_source = _frame_or_ring_fit(frame, ch)

    # per position: closest centreline point, offset, bound, flag
    s, d = _closest(ch, p)
    length = ch.length_m
    rb = np.array([ch.lumen.radii_at(float(si))[0] for si in s])
    max_off = rb - rc
    outside = (s < 0.0) | (s > length) | (d > OUTSIDE_DISTANCE_M)
    infeasible = ~outside & (d > max_off + FEASIBLE_TOL_M)
    flags = tuple(
        FLAG_OUTSIDE if o else (FLAG_INFEASIBLE if f else FLAG_OK)
        for o, f in zip(outside, infeasible, strict=True)
    )

    # planarity (SVD of the centred positions)
    centred = p - p.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    plane_rms = float(sv[2] / np.sqrt(n)) if sv.size > 2 else 0.0
    line_rms = float(np.sqrt((sv[1:] ** 2).sum() / n))
    collinear = line_rms < PLANAR_TOL_M
    if collinear:
        plane_normal = None
        tilt = None
    else:
        plane_normal = vt[2] if float(vt[2] @ normal) >= 0.0 else -vt[2]
        tilt = float(
            rad_to_deg(
                np.arctan2(np.linalg.norm(np.cross(plane_normal, normal)), plane_normal @ normal)
            )
        )
    planar = (not collinear) and plane_rms < PLANAR_TOL_M
    heights = (p - centre) @ normal
    height = float(heights.mean())
    constant_height = bool(np.max(np.abs(heights - height)) <= PLANAR_TOL_M)

    summary = _summary(
        n=n,
        rel=rel,
        d=d,
        max_off=max_off,
        rb=rb,
        rc=rc,
        s=s,
        length=length,
        outside=outside,
        infeasible=infeasible,
        plane_rms=plane_rms,
        collinear=collinear,
        planar=planar,
        tilt=tilt,
        heights=heights,
        height=height,
        constant_height=constant_height,
        frame_source=frame_source,
        channel_name=ch.name,
    )
    return ReferencePathCheck(
        s_m=s,
        offset_m=d,
        max_offset_m=max_off,
        flags=flags,
        capsule_radius_m=rc,
        plane_rms_m=plane_rms,
        plane_normal=plane_normal,
        collinear=bool(collinear),
        planar=bool(planar),
        plane_tilt_deg=tilt,
        heights_m=heights,
        height_m=height,
        constant_height=constant_height,
        ring_centre_m=np.asarray(centre, dtype=float),
        ring_normal=np.asarray(normal, dtype=float),
        frame_source=frame_source,
        summary=summary,
    )


def _summary(
    *,
    n,
    rel,
    d,
    max_off,
    rb,
    rc,
    s,
    length,
    outside,
    infeasible,
    plane_rms,
    collinear,
    planar,
    tilt,
    heights,
    height,
    constant_height,
    frame_source,
    channel_name,
) -> tuple[str, ...]:
    """The check's findings in plain words (mm, degrees)."""
    mm = m_to_mm
    out = []
    where = (
        "in"
        if abs(height) < 0.5e-5
        else f"{mm(abs(height)):.2f} mm {'above' if height > 0.0 else 'below'}"
    )
    plane_words = (
        "the ring channel's plane"
        if frame_source == "given"
        else f"the ring channel's plane ({frame_source})"
    )
    if collinear:
        out.append(
            f"The {n} reference positions lie on a straight line: they define no plane (heights "
            f"above {plane_words} {mm(heights.min()):.2f} to {mm(heights.max()):.2f} mm)."
        )
    elif planar and constant_height:
        out.append(
            f"The reference path is planar (all {n} positions within "
            f"{mm(np.max(np.abs(heights - height))):.3f} mm of one plane, "
            f"{where} {plane_words} and parallel to it): "
            "it was stored 2D, not measured in 3D."
        )
    elif planar:
        out.append(
            f"The reference path is planar (RMS {mm(plane_rms):.3f} mm from one plane): it was "
            f"stored 2D. Its plane is tilted {tilt:.2f} deg from {plane_words} (heights "
            f"{mm(heights.min()):.2f} to {mm(heights.max()):.2f} mm)."
        )
    else:
        out.append(
            f"The reference path is three-dimensional (RMS {mm(plane_rms):.3f} mm from its best "
            f"plane; heights above {plane_words} {mm(heights.min()):.2f} to "
            f"{mm(heights.max()):.2f} mm)."
        )
    on = ~outside
    n_inf = int(np.count_nonzero(infeasible))
    bound = (
        f"{mm(float(max_off[on].min())):.2f} mm = lumen radius "
        f"{mm(float(rb[on].min())):.2f} mm - capsule radius {mm(rc):.3f} mm"
        if on.any()
        else ""
    )
    if n_inf:
        idx = np.flatnonzero(infeasible)
        out.append(
            f"{n_inf} of {n} positions lie farther from the channel centreline than the source "
            f"centre can get (up to {mm(float(d[idx].max())):.2f} mm vs {bound}): "
            f"{_which(idx, rel)}."
        )
    elif on.any():
        out.append(
            f"All {int(np.count_nonzero(on))} positions along the channel can lie in the lumen "
            f"(largest distance from the centreline {mm(float(d[on].max())):.2f} mm; the source "
            f"centre can reach {bound})."
        )
    if outside.any():
        idx = np.flatnonzero(outside)
        why = []
        if np.any(s[idx] < 0.0):
            why.append("before the channel entry")
        if np.any(s[idx] > length):
            why.append("past the lumen tip")
        if np.any(d[idx] > OUTSIDE_DISTANCE_M):
            why.append(f"more than {mm(OUTSIDE_DISTANCE_M):.0f} mm from the centreline")
        out.append(
            f"{idx.size} of {n} positions are not along channel {channel_name!r} (closest "
            f"centreline point {' or '.join(why)}): {_which(idx, rel)}."
        )
    return tuple(out)


# --------------------------------------------------------------------------------------------
# registration


def _skew(v: np.ndarray) -> np.ndarray:
    """(k, 3) -> (k, 3, 3) cross-product matrices, ``skew(v) @ w = v x w``."""
    out = np.zeros((v.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


def _rigid_fit(p: np.ndarray, s0: np.ndarray, channel: Channel, slide: bool):
    """Gauss-Newton fit of a rotation (about the centroid) and a translation minimising the sum
    of squared distances of ``p (k, 3)`` from the (extended) centreline; without ``slide``,
    subject to the mean closest-point arc length staying ``mean(s0)``.

    Each update is a Gauss-Newton step (truncated SVD: directions below ``RIGID_RCOND`` are left
    alone), capped at ``RIGID_MAX_STEP_M`` and halved until the RMS distance does not grow (a
    backtracking line search: the distance to a curved centreline is a large-residual problem
    where full Gauss-Newton steps can oscillate).

    Returns (R, t, centre, iterations, converged, undetermined).
    """
    cl = channel.centreline
    centre = p.mean(axis=0)
    arm0 = p - centre
    scale = max(float(np.sqrt(np.mean(np.sum(arm0**2, axis=1)))), 1e-6)
    s_mean0 = float(np.mean(s0))
    eye = np.eye(3)

    def moved(rot, t, x):
        return rotvec_to_matrix(x[:3] / scale) @ rot, t + x[3:]

    def evaluate(rot, t, s_hint):
        q = arm0 @ rot.T + centre + t
        s, d = cl.closest(q, s_hint_m=s_hint, window_m=RIGID_WINDOW_M)
        return q, s, float(np.sqrt(np.mean(d**2)))

    rot = np.eye(3)
    t = np.zeros(3)
    q, s, rms = evaluate(rot, t, s0)
    undetermined = 0
    for it in range(1, RIGID_MAX_ITER + 1):
        tau = cl.tangent(s)
        proj = eye[None, :, :] - tau[:, :, None] * tau[:, None, :]  # (k, 3, 3)
        res = np.einsum("kij,kj->ki", proj, q - cl.position(s)).reshape(-1)
        # d(q_i) = omega x arm_i + delta = [-skew(arm_i) | I] (omega, delta); unknowns are
        # x = (scale * omega, delta), both in metres
        ident = np.broadcast_to(eye, proj.shape)
        motion = np.concatenate([-_skew(q - (centre + t)) / scale, ident], axis=2)  # (k, 3, 6)
        jac = (proj @ motion).reshape(-1, 6)
        if slide:
            x_p = np.zeros(6)
            basis = np.eye(6)
        else:
            # mean along-channel motion = mean(s0) - mean(s): a Newton step on the constraint
            row = np.einsum("ki,kij->j", tau, motion) / tau.shape[0]
            x_p = row * (s_mean0 - float(np.mean(s))) / float(row @ row)
            basis = np.linalg.svd(row[None, :])[2][1:].T  # (6, 5): the motions keeping it
        u, sv, vt = np.linalg.svd(jac @ basis, full_matrices=False)
        keep = sv > RIGID_RCOND * sv[0]
        undetermined = int(np.count_nonzero(~keep))
        dx = basis @ (vt[keep].T @ ((u[:, keep].T @ -(res + jac @ x_p)) / sv[keep]))
        base_rot, base_t = moved(rot, t, x_p)
        _, _, rms_base = evaluate(base_rot, base_t, s)
        x = x_p
        for _ in range(60):
            trial = x_p + dx
            norm = float(np.linalg.norm(trial))
            if norm > RIGID_MAX_STEP_M:
                trial = trial * (RIGID_MAX_STEP_M / norm)
            new_rot, new_t = moved(rot, t, trial)
            _, _, rms_new = evaluate(new_rot, new_t, s)
            if rms_new <= rms_base:
                x = trial
                break
            dx = 0.5 * dx
        step = float(np.linalg.norm(x))
        rot, t = moved(rot, t, x)
        q, s, rms_new = evaluate(rot, t, s)
        change = abs(rms - rms_new)
        rms = rms_new
        if change < RIGID_RMS_CHANGE_M and step < RIGID_STEP_M:
            return rot, t, centre, it, True, undetermined
    return rot, t, centre, RIGID_MAX_ITER, False, undetermined


def _rms_max(d: np.ndarray) -> tuple[float, float]:
    if d.size == 0:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(d**2))), float(d.max())


def register_reference(
    points_m,
    channel: Channel,
    mode: str,
    capsule_radius_m: float,
    frame: Frame | tuple | None = None,
    *,
    relative_m=None,
    slide: bool = False,
) -> Registration:
    """Register a reference path to its CHANNEL (never to a simulation).

    Modes
    -----
    ``"none"``
        Identity: the path as given.
    ``"plane-height"``
        For a planar path at ONE constant height above the ring channel's plane (a path stored
        2D, :class:`ReferencePathCheck` ``planar`` and ``constant_height``): translate it by
        ``-height`` along the ring normal, into the ring channel's own plane on its circular
        part. It undoes exactly one number (the stored height) and leaves the positions' places
        in the plane alone. Refused for any other path.
    ``"rigid"``
        The rotation (about the centroid of the positions on the channel) and translation, no
        scaling, minimising the sum of squared distances of those positions from the centreline
        (Gauss-Newton on the point-to-curve distance: an iterative-closest-point fit whose
        correspondence is each position's closest centreline point, searched within 10 mm of the
        previous one; it stops when the RMS distance changes by less than 1e-9 m and the last
        update moved the positions by less than 1e-9 m). The centreline is the one target every
        channel has and it is exact; the lumen wall would need the capsule's contact, which is
        what the simulation computes and the reference must not borrow. Positions flagged
        ``"outside_channel"`` are carried along but not fitted; at least 3 must be on the
        channel.

        By default (``slide=False``) the fit keeps the MEAN ARC LENGTH of the positions' closest
        centreline points: it corrects where the path lies ACROSS the channel, never where it
        lies ALONG it. Where the source stops along the channel is the quantity under test, and
        no fit to a centreline can tell a frame error along a circular ring (a rotation about its
        axis) from a source that stops short; without the constraint that rotation is fixed only
        by the few positions off the circle, and on the Oncentra example it slides the whole
        path 23 deg (5.1 mm) round the ring to fit the library path's proximal artefact.
        ``slide=True`` drops the constraint (all six degrees of freedom); directions the
        channel's shape then does not fix (the rotation about the axis of a circular arc, for
        positions all on the circle) are left unchanged and counted in ``undetermined``.

        WEAKNESS: the centreline is where the source is NOT: a source runs off-centre (against
        the outer wall in a bend), so a rigid fit to the centreline pulls a truly off-centre path
        towards it and turns real deviations into a transform (on the Oncentra example it takes
        out about 0.4 mm of the path's outward offset in the ring plane). Read the transform: a
        shift or rotation larger than a plausible frame error means the fit absorbed physics.

    Parameters
    ----------
    points_m : (n, 3) array_like
        Source-centre positions (m), most distal first, n >= 3.
    channel : Channel
        The channel (centreline and lumen).
    mode : {"none", "plane-height", "rigid"}
        See above.
    capsule_radius_m : float
        Source capsule radius (m), for the feasibility check before and after.
    frame : Frame or (centre_m, normal), optional
        The applicator frame's origin and cranial normal; default the ring's fitted to the
        channel (see :func:`check_reference_path`).
    relative_m : (n,) array_like, optional
        Relative positions (m), used only to name positions in the checks' summaries.
    slide : bool
        ``"rigid"`` only: let the fit move the positions along the channel (default False).

    Returns
    -------
    Registration

    Raises
    ------
    RegistrationError
        An unknown mode; ``"plane-height"`` for a path that is not planar at a constant height;
        ``"rigid"`` with fewer than 3 positions on the channel; bad input (see
        :func:`check_reference_path`).

    Examples
    --------
    On the Oncentra 26/60 example ``register_reference(path, ring, "plane-height", 0.45e-3,
    frame).description`` is ``"translated 0.89 mm caudally along the ring normal (onto the
    ring channel's plane)"``.
    """
    if mode not in REGISTER_MODES:
        raise RegistrationError(
            f"mode: {mode!r} is not a registration mode; choose one of "
            + ", ".join(repr(m) for m in REGISTER_MODES)
        )
    if slide and mode != "rigid":
        raise RegistrationError(
            f"slide: only mode 'rigid' can slide the path along the channel (mode {mode!r})"
        )
    p = _points(points_m)
    before = check_reference_path(p, channel, capsule_radius_m, frame, relative_m=relative_m)
    frame = (before.ring_centre_m, before.ring_normal)
    used = before.on_channel
    rot = np.eye(3)
    t = np.zeros(3)
    centre = p[used].mean(axis=0) if used.any() else p.mean(axis=0)
    iterations, converged, undetermined = 0, True, 0
    mm = m_to_mm
    if mode == "none":
        description = "not registered (the reference path as given)"
    elif mode == "plane-height":
        if not (before.planar and before.constant_height):
            why = (
                "its positions lie on a straight line"
                if before.collinear
                else f"it is not planar (RMS {mm(before.plane_rms_m):.3f} mm from its best plane)"
                if not before.planar
                else f"its plane is tilted {before.plane_tilt_deg:.2f} deg from the ring plane "
                f"(heights {mm(before.heights_m.min()):.2f} to "
                f"{mm(before.heights_m.max()):.2f} mm)"
            )
            raise RegistrationError(
                f"mode 'plane-height': the reference path is not a planar path at one height "
                f"above the ring plane ({why}); this mode only undoes the height of a path "
                "stored 2D: use mode 'none' or 'rigid'"
            )
        t = -before.height_m * before.ring_normal
        direction = "caudally" if before.height_m >= 0.0 else "cranially"
        description = (
            f"translated {mm(abs(before.height_m)):.2f} mm {direction} along the ring normal "
            "(onto the ring channel's plane)"
        )
    else:
        k = int(np.count_nonzero(used))
        if k < MIN_POSITIONS:
            raise RegistrationError(
                f"mode 'rigid': only {k} of {p.shape[0]} positions lie along channel "
                f"{channel.name!r} (the others are beyond its ends or more than "
                f"{mm(OUTSIDE_DISTANCE_M):.0f} mm from it); a rigid fit needs at least "
                f"{MIN_POSITIONS}: check the path's frame, or use mode 'none'"
            )
        rot, t, centre, iterations, converged, undetermined = _rigid_fit(
            p[used], before.s_m[used], channel, bool(slide)
        )
    # no rotation: a plain shift, so "none" returns the input bit for bit
    registered = p + t if mode != "rigid" else (p - centre) @ rot.T + centre + t
    after = check_reference_path(
        registered, channel, capsule_radius_m, frame, relative_m=relative_m
    )
    rotvec = matrix_to_rotvec(rot)
    angle = float(np.linalg.norm(rotvec))
    axis = rotvec / angle if angle > 0.0 else np.zeros(3)
    if mode == "rigid":
        along = float(t @ before.ring_normal)
        description = (
            f"rotated {float(rad_to_deg(angle)):.2f} deg about the centroid of the "
            f"{int(np.count_nonzero(used))} positions on the channel and translated "
            f"({mm(t[0]):.2f}, {mm(t[1]):.2f}, {mm(t[2]):.2f}) mm ({mm(along):+.2f} mm along "
            "the ring normal), "
            + (
                "free to slide along the channel"
                if slide
                else "mean position along the channel kept"
            )
        )
        if undetermined:
            description += (
                f"; {undetermined} direction(s) not fixed by the channel's shape left unchanged"
            )
        if not converged:
            description += f"; NOT converged in {RIGID_MAX_ITER} iterations"
    rms_b, max_b = _rms_max(before.offset_m[used])
    rms_a, max_a = _rms_max(after.offset_m[used])
    return Registration(
        mode=mode,
        points_m=registered,
        rotation=rot,
        translation_m=np.asarray(t, dtype=float),
        rotation_centre_m=np.asarray(centre, dtype=float),
        rotation_deg=float(rad_to_deg(angle)),
        rotation_axis=axis,
        used=used,
        rms_before_m=rms_b,
        max_before_m=max_b,
        rms_after_m=rms_a,
        max_after_m=max_a,
        iterations=int(iterations),
        converged=bool(converged),
        undetermined=int(undetermined),
        description=description,
        before=before,
        after=after,
    )


# --------------------------------------------------------------------------------------------
# relative positions


def reference_positions(
    points_m,
    channel: Channel,
    *,
    relative_m=None,
    step_m: float | None = None,
) -> ReferencePositions:
    """A reference path's relative positions, AS GIVEN, checked against the channel.

    Parameters
    ----------
    points_m : (n, 3) array_like
        Source-centre positions (m), most distal first, n >= 3.
    channel : Channel
        Gives ``s_ref_m`` (arc length of relative position 0) and the length.
    relative_m : (n,) array_like, optional
        The user's relative positions (m), increasing (most distal first): kept exactly, uneven
        spacing included.
    step_m : float, optional
        Without ``relative_m``: relative positions ``0, step, 2 step, ...`` (m). Without either,
        ``channel.measured_step_m`` is used.

    Returns
    -------
    ReferencePositions

    Raises
    ------
    RegistrationError
        Both or neither of ``relative_m``/``step_m`` (and no channel step); a relative position
        repeated or out of order (names the indices); two positions closer than 1 um (names the
        indices); fewer than 3 positions, or fewer than 3 whose relative position lies on the
        channel (names the count).

    Examples
    --------
    Relative positions 0, 2.5, 5, 10 mm stay 0, 2.5, 5, 10 mm (``step_m`` None, ``uneven``
    True); given only ``step_m=2.5e-3`` they are 0, 2.5, 5, 7.5 mm.
    """
    ch = _channel(channel)
    p = _points(points_m)
    n = p.shape[0]
    mm = m_to_mm
    if relative_m is not None and step_m is not None:
        raise RegistrationError(
            "relative_m, step_m: give the relative positions OR a step, not both"
        )
    if relative_m is not None:
        try:
            rel = np.array(relative_m, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise RegistrationError(
                "relative_m: cannot be read as numbers; give one relative position (m) per position"
            ) from None
        if rel.shape != (n,):
            raise RegistrationError(
                f"relative_m: {rel.size} relative positions for {n} positions; give one per "
                "position"
            )
        if not np.isfinite(rel).all():
            k = int(np.argmax(~np.isfinite(rel)))
            raise RegistrationError(f"relative_m: relative position {k} is not finite")
        order = np.argsort(rel, kind="stable")
        gaps = np.diff(rel[order])
        dup = np.flatnonzero(gaps < DUPLICATE_TOL_M)
        if dup.size:
            i, j = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
            raise RegistrationError(
                f"relative_m: positions {i} and {j} have the same relative position "
                f"({mm(rel[i]):g} mm); remove the duplicated position"
            )
        back = np.flatnonzero(np.diff(rel) <= 0.0)
        if back.size:
            k = int(back[0]) + 1
            raise RegistrationError(
                f"relative_m: position {k} ({mm(rel[k]):g} mm) is not proximal of position "
                f"{k - 1} ({mm(rel[k - 1]):g} mm); list the positions most distal first "
                "(increasing relative position)"
            )
        source = "given"
    else:
        source = "step"
        if step_m is None:
            step_m = ch.measured_step_m
            source = "channel step"
        if step_m is None:
            raise RegistrationError(
                f"relative_m, step_m: neither given and channel {ch.name!r} has no "
                "measured_step_m; give the relative positions or their step"
            )
        step = float(step_m)
        if not np.isfinite(step) or step <= 0.0:
            raise RegistrationError(f"step_m: must be a positive step in metres, got {step_m!r}")
        rel = np.arange(n) * step
    # duplicated positions (any two, not only neighbours)
    ci, cj, cd = close_pairs(p, DUPLICATE_TOL_M, strict=True)  # O(n) memory (issue 25)
    if ci.size:
        i, j = int(ci[0]), int(cj[0])
        raise RegistrationError(
            f"points_m: positions {i} and {j} coincide ({mm(cd[0]) * 1e3:.3f} um apart, "
            f"closer than {DUPLICATE_TOL_M * 1e6:g} um); remove the duplicated position"
        )
    s_nom = ch.s_ref_m - rel
    tol = 1e-9
    in_range = (s_nom >= -tol) & (s_nom <= ch.length_m + tol)
    k = int(np.count_nonzero(in_range))
    if k < MIN_POSITIONS:
        raise RegistrationError(
            f"relative positions: only {k} of {n} lie on channel {ch.name!r} (arc length "
            f"s_ref - p within 0 .. {mm(ch.length_m):.1f} mm, i.e. relative positions "
            f"{mm(ch.s_ref_m - ch.length_m):.1f} .. {mm(ch.s_ref_m):.1f} mm); at least "
            f"{MIN_POSITIONS} are needed: check s_ref and the relative positions"
        )
    gaps = np.diff(rel)
    even = bool(np.max(np.abs(gaps - gaps.mean())) <= DUPLICATE_TOL_M)
    common = float(step_m) if source != "given" else float(gaps.mean()) if even else None
    return ReferencePositions(
        points_m=p,
        relative_m=rel,
        s_nominal_m=s_nom,
        in_range=in_range,
        step_m=common,
        relative_from=source,
    )
