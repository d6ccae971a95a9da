"""Channels and applicators (frozen data; SI units).

A :class:`Channel` is a centreline, a lumen and the dwell convention: ``s_ref_m`` is the arc length
at which the SOURCE CENTRE sits at relative position 0 (the most distal dwell); relative position
``p`` (m) is at arc length ``s_ref_m - p``. An :class:`Applicator` groups channels with the
applicator's frame used for dose points and plots.

Families: an applicator and each of its channels belong to a family (``"ring"``, ``"tandem"``,
``"ovoid"``, ``"free-form"``, ...; :mod:`ringqa.geometry.families` holds each family's rules). A
channel's ``family`` may be left empty: then its name says it (a channel called ``"tandem"`` is a
tandem) or else the applicator's family does. The frame fields keep the ring's names
(``ring_centre_m``, ``ring_normal``, ``ring_lateral``, ``ring_radius_m``) for every family: for a
ring they are the fitted ring; for another family they are its frame (given, or fitted by
:func:`ringqa.geometry.frame.fit_frame` when left out), and :attr:`Applicator.frame` reads them
under family-neutral names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ringqa.geometry.centreline import Centreline, GeometryError
from ringqa.geometry.frame import Frame, fit_frame
from ringqa.geometry.lumen import Lumen

#: The family of an applicator that does not name one.
DEFAULT_FAMILY = "ring"


def _unit_vector(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise GeometryError(f"{name}: expected a finite 3-vector, got {v!r}")
    n = float(np.linalg.norm(a))
    if abs(n - 1.0) > 1e-6:
        raise GeometryError(f"{name}: must be a unit vector (length {n:.6g}); normalise it")
    return a / n


@dataclass(frozen=True, eq=False)
class Channel:
    """One applicator channel.

    Attributes
    ----------
    name : str
        Channel name ("ring", "tandem", ...).
    centreline : Centreline
        The channel centreline, s from the proximal entry (0) to the lumen tip (length).
    lumen : Lumen
        Cross-section along s.
    s_ref_m : float
        Arc length (m) of the source centre at relative position 0 (most distal dwell).
    measured_path_m : (n, 3) ndarray or None
        Measured (reference) source-centre positions (m), most distal first.
    measured_step_m : float or None
        Spacing of the measured path in relative position (m), when it is evenly spaced.
    measured_relative_m : (n,) ndarray or None
        The measured positions' relative positions (m) as the source gave them, increasing
        (uneven spacing kept); None: ``0, step, 2 step, ...``.
    measured_source : str
        Where the measured path comes from (a library path's name, version and date, or the
        user's file); ``""`` when unknown.
    family : str
        The channel's family (``"ring"``, ``"tandem"``, ``"ovoid"``, ``"free-form"``, ...);
        ``""``: said by its name, else the applicator's (:func:`ringqa.geometry.families
        .family_of`).
    label : str
        How the plan and the report number the channel (an RT Plan's channel number, ``"1"``);
        ``""``: the channel's name.
    """

    name: str
    centreline: Centreline
    lumen: Lumen
    s_ref_m: float
    measured_path_m: np.ndarray | None = None
    measured_step_m: float | None = None
    measured_relative_m: np.ndarray | None = None
    measured_source: str = ""
    family: str = ""
    label: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise GeometryError(f"Channel name: expected a non-empty string, got {self.name!r}")
        if not isinstance(self.centreline, Centreline):
            raise GeometryError(f"channel {self.name!r}: centreline must be a Centreline")
        if not isinstance(self.lumen, Lumen):
            raise GeometryError(f"channel {self.name!r}: lumen must be a Lumen")
        s_ref = float(self.s_ref_m)
        length = self.centreline.length_m
        if not np.isfinite(s_ref) or s_ref < 0.0 or s_ref > length + 1e-9:
            raise GeometryError(
                f"channel {self.name!r}: s_ref_m = {s_ref!r} m lies outside the centreline "
                f"(0 .. {length:.6g} m); give the arc length of relative position 0"
            )
        object.__setattr__(self, "s_ref_m", s_ref)
        if self.measured_path_m is not None:
            path = np.array(self.measured_path_m, dtype=float)
            if path.ndim != 2 or path.shape[1] != 3 or path.shape[0] < 1:
                raise GeometryError(
                    f"channel {self.name!r}: measured_path_m must be (n, 3) in metres, "
                    f"got shape {path.shape}"
                )
            if not np.isfinite(path).all():
                raise GeometryError(f"channel {self.name!r}: measured_path_m has NaN/inf values")
            path.setflags(write=False)
            object.__setattr__(self, "measured_path_m", path)
        if self.measured_step_m is not None:
            step = float(self.measured_step_m)
            if not np.isfinite(step) or step <= 0.0:
                raise GeometryError(
                    f"channel {self.name!r}: measured_step_m must be > 0 m, got {step!r}"
                )
            object.__setattr__(self, "measured_step_m", step)
        if self.measured_relative_m is not None:
            rel = np.array(self.measured_relative_m, dtype=float).reshape(-1)
            n_path = None if self.measured_path_m is None else len(self.measured_path_m)
            if n_path is None or rel.size != n_path:
                raise GeometryError(
                    f"channel {self.name!r}: measured_relative_m needs one relative position per "
                    f"measured position ({rel.size} given for {n_path or 0})"
                )
            if not np.isfinite(rel).all() or np.any(np.diff(rel) <= 0.0):
                raise GeometryError(
                    f"channel {self.name!r}: measured_relative_m must be finite and increase "
                    "strictly (most distal first, no duplicated relative positions)"
                )
            rel.setflags(write=False)
            object.__setattr__(self, "measured_relative_m", rel)
        if not isinstance(self.measured_source, str):
            raise GeometryError(f"channel {self.name!r}: measured_source must be a string")
        for key in ("family", "label"):
            if not isinstance(getattr(self, key), str):
                raise GeometryError(f"channel {self.name!r}: {key} must be a string")

    @property
    def measured_relative_positions_m(self) -> np.ndarray | None:
        """Relative positions (m) of the measured path: as given, else ``0, step, ...``; None
        without a measured path or when neither relative positions nor a step are known."""
        if self.measured_path_m is None:
            return None
        if self.measured_relative_m is not None:
            return self.measured_relative_m
        if self.measured_step_m is None:
            return None
        return np.arange(len(self.measured_path_m)) * self.measured_step_m

    @property
    def length_m(self) -> float:
        """Centreline length (m)."""
        return self.centreline.length_m

    def s_of_relative(self, relative_position_m):
        """Arc length (m) of relative position(s) ``p`` (m): ``s_ref_m - p``."""
        return self.s_ref_m - np.asarray(relative_position_m, dtype=float)


@dataclass(frozen=True, eq=False)
class Applicator:
    """An applicator: channels plus its frame (see the module docstring for the families).

    Attributes
    ----------
    name : str
    channels : tuple of Channel
    ring_centre_m : (3,) ndarray
        The frame's origin (m): a ring's centre (of the ring channel's circle).
    ring_normal : (3,) ndarray
        Unit cranial axis (towards the tandem tip / Point A): a ring's plane normal.
    ring_lateral : (3,) ndarray
        Unit axis towards the patient's left, perpendicular to ``ring_normal``.
    ring_radius_m : float
        The frame's length scale (m): the radius of a ring's channel centreline.
    metadata : dict
        ``diameter_mm``, ``angle_deg``, sources/citations and assumptions.
    family : str
        The applicator's family (default ``"ring"``, which needs the four frame fields; the
        others are fitted to the channels when left out).
    """

    name: str
    channels: tuple[Channel, ...]
    ring_centre_m: np.ndarray | None = None
    ring_normal: np.ndarray | None = None
    ring_lateral: np.ndarray | None = None
    ring_radius_m: float | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    family: str = DEFAULT_FAMILY

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise GeometryError(f"Applicator name: expected a non-empty string, got {self.name!r}")
        chans = tuple(self.channels)
        if not chans or not all(isinstance(c, Channel) for c in chans):
            raise GeometryError(f"applicator {self.name!r}: channels must be Channel objects")
        names = [c.name for c in chans]
        if len(set(names)) != len(names):
            raise GeometryError(f"applicator {self.name!r}: duplicated channel names {names}")
        object.__setattr__(self, "channels", chans)
        if not isinstance(self.family, str) or not self.family.strip():
            raise GeometryError(f"applicator {self.name!r}: family must be a non-empty string")
        frame_keys = ("ring_centre_m", "ring_normal", "ring_lateral", "ring_radius_m")
        missing = [k for k in frame_keys if getattr(self, k) is None]
        if missing and self.family == DEFAULT_FAMILY:
            raise GeometryError(
                f"applicator {self.name!r}: a ring needs its frame; give {', '.join(missing)}"
            )
        if missing:
            fit = fit_frame(c.centreline for c in chans)
            for key, val in zip(frame_keys, (fit.centre_m, fit.normal, fit.lateral, fit.scale_m),
                                strict=True):  # fmt: skip
                if getattr(self, key) is None:
                    object.__setattr__(self, key, val)
        centre = np.asarray(self.ring_centre_m, dtype=float)
        if centre.shape != (3,) or not np.isfinite(centre).all():
            raise GeometryError(
                f"applicator {self.name!r}: ring_centre_m must be a finite 3-vector"
            )
        normal = _unit_vector("ring_normal", self.ring_normal)
        lateral = _unit_vector("ring_lateral", self.ring_lateral)
        if abs(float(normal @ lateral)) > 1e-6:
            raise GeometryError(
                f"applicator {self.name!r}: ring_lateral must lie in the ring plane "
                f"(perpendicular to ring_normal; dot = {float(normal @ lateral):.3g})"
            )
        radius = float(self.ring_radius_m)
        if not np.isfinite(radius) or radius <= 0.0 or radius > 0.1:
            raise GeometryError(
                f"applicator {self.name!r}: ring_radius_m = {radius!r} must be a positive radius "
                "in metres (e.g. 0.013 for the 26 mm ring)"
            )
        for key, val in (("ring_centre_m", centre), ("ring_normal", normal),
                         ("ring_lateral", lateral)):  # fmt: skip
            val = val.copy()
            val.setflags(write=False)
            object.__setattr__(self, key, val)
        object.__setattr__(self, "ring_radius_m", radius)
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def frame(self) -> Frame:
        """The applicator's frame under family-neutral names (:class:`ringqa.geometry.frame
        .Frame`)."""
        return Frame(self.ring_centre_m, self.ring_normal, self.ring_lateral, self.ring_radius_m)

    @property
    def channel_names(self) -> tuple[str, ...]:
        """Names of the channels, in order."""
        return tuple(c.name for c in self.channels)

    @property
    def ring_anterior(self) -> np.ndarray:
        """Unit vector in the ring plane towards the patient's anterior (``lateral x normal``:
        with lateral = patient left (+x) and normal = cranial (+z) this is -y, i.e. anterior in
        DICOM patient coordinates, where +y is posterior)."""
        return np.cross(self.ring_lateral, self.ring_normal)

    def channel(self, name: str) -> Channel:
        """The channel called ``name``; raises GeometryError listing the available names."""
        for c in self.channels:
            if c.name == name:
                return c
        raise GeometryError(
            f"applicator {self.name!r} has no channel {name!r}; available: "
            + ", ".join(self.channel_names)
        )
