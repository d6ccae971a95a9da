"""What an applicator family provides (the protocol), and the data it hands over.

A family is the rules of one kind of applicator channel: a ring, a tandem, an ovoid, a freely
curved (3-D printed) channel. The pipeline, the dose points and the report ask a channel's family
(:func:`ringqa.geometry.families.family_of`) instead of reading one kind's fields:

=====================  =======================================================================
``name``               the family's name in files and on the command line (``"ring"``)
``words``              :class:`FamilyWords`: how the report names the channel and its parts
``gynae``              True: its plans get Point A left/right (from the applicator's frame)
``span_mm(...)``       the part of the channel to simulate when no measured path is given: the
                       largest relative position (mm) of the reference dwells
``points(...)``        the family's own dose points beside Point A (:class:`FamilyPoint`)
``curvature_scale_m``  the length (m) a sharp bend is judged against (the kink check)
``checks(...)``        the family's checks of one channel: report notes (refusals raise)
=====================  =======================================================================

A channel's lumen and centreline are the channel's own (:class:`~ringqa.geometry.Channel`): a
family does not change them. The frame is the applicator's (:attr:`Applicator.frame
<ringqa.geometry.Applicator.frame>`, :func:`~ringqa.geometry.frame.frame_of`: given by its file
or reader, else :func:`~ringqa.geometry.frame.fit_frame`); a family module may offer the fit
its readers use (the ring family's circle fit; the tandem's
:func:`~ringqa.geometry.families.tandem.tandem_frame`). Everything here is in the geometry
layer: points are plain positions in mm (the plan layer makes them dose points), ``spec`` is
read by attribute (a :class:`ringqa.plan.DosePointSpec` or anything with the same attributes).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.frame import frame_of
from ringqa.units import m_to_mm, mm_to_m

__all__ = [
    "KINK_SCALE_M",
    "ApplicatorFamily",
    "FamilyPoint",
    "FamilyWords",
    "channel_points_mm",
    "channel_tip_mm",
    "lateral_side",
    "radial_outward",
    "span_on_grid_mm",
]

#: The curvature scale (m) of families without their own: the 26 mm ring's radius, so that a
#: kink is judged the same way on every channel.
KINK_SCALE_M = 0.013


@dataclass(frozen=True)
class FamilyWords:
    """How the report names a family's channel.

    Attributes
    ----------
    title : str
        The applicator kind ("ring applicator", "tandem", "ovoid", "free-form channel").
    channel : str
        The channel ("ring channel").
    span : str
        The part simulated without a measured path ("the circular part of the ring").
    plane : str
        The plane across the applicator frame's cranial axis, in which positions are projected
        and the radial deviation lies (default "transverse plane"; a ring names its own).
    axis : str
        The frame's cranial axis through its origin (Point A is lateral of it).
    origin : str
        What the frame's origin lies in (Point A's height is above it: "ring channel plane").
    """

    title: str
    channel: str
    span: str
    plane: str = "transverse plane"
    axis: str = "applicator axis"
    origin: str = "frame origin"


@dataclass(frozen=True, eq=False)
class FamilyPoint:
    """A family's dose point (mm; the plan layer turns it into a :class:`ringqa.plan
    .DosePoint`).

    Attributes
    ----------
    name : str
    kind : str
        ``"surface"``, ``"depth5"``, ``"ovoid_surface"``, ``"user"``, ...
    position_mm : (3,) ndarray
    """

    name: str
    kind: str
    position_mm: np.ndarray


@runtime_checkable
class ApplicatorFamily(Protocol):
    """What a family provides (see the module docstring)."""

    name: str
    words: FamilyWords
    gynae: bool

    def span_mm(self, app: Any, channel: Any, step_mm: float) -> float:
        """Largest relative position (mm) of the reference dwells without a measured path."""
        ...

    def points(self, app: Any, channel: Any, spec: Any) -> tuple[FamilyPoint, ...]:
        """The family's dose points for ``channel`` (mm)."""
        ...

    def curvature_scale_m(self, app: Any, channel: Any) -> float:
        """The length (m) a kink's curvature excess is measured in."""
        ...

    def checks(self, app: Any, channel: Any) -> tuple[str, ...]:
        """Report notes on ``channel`` (raise GeometryError to refuse it)."""
        ...


def span_on_grid_mm(channel, span_mm: float, step_mm: float) -> float:
    """``span_mm`` cut to the channel (relative positions up to ``s_ref``) and down to a multiple
    of ``step_mm``, mm (0 when not even one step fits)."""
    if step_mm <= 0:
        raise GeometryError(f"span_on_grid_mm: step_mm = {step_mm!r} must be > 0")
    span = min(float(span_mm), m_to_mm(float(channel.s_ref_m)))
    return float(np.floor(span / step_mm + 1e-9) * step_mm) if span > 0 else 0.0


def lateral_side(app, position_mm) -> str:
    """``"left"`` or ``"right"``: the side of the applicator frame's axis ``position_mm`` lies
    on (along the frame's lateral axis, patient left positive)."""
    frame = frame_of(app)
    c = m_to_mm(np.asarray(frame.centre_m, dtype=float))
    d = np.asarray(position_mm, dtype=float) - c
    return "left" if float(d @ np.asarray(frame.lateral, dtype=float)) >= 0.0 else "right"


def radial_outward(app, position_mm) -> np.ndarray:
    """Unit vector from the applicator frame's axis (through its centre along its normal)
    towards ``position_mm``, perpendicular to the axis; the frame's lateral axis (signed by the
    side) when the point lies on the axis. (3,)"""
    frame = frame_of(app)
    c = m_to_mm(np.asarray(frame.centre_m, dtype=float))
    n = np.asarray(frame.normal, dtype=float)
    d = np.asarray(position_mm, dtype=float) - c
    d = d - float(d @ n) * n
    norm = float(np.linalg.norm(d))
    if norm < 1e-9:
        lat = np.asarray(frame.lateral, dtype=float)
        return lat if lateral_side(app, position_mm) == "left" else -lat
    return d / norm


def channel_tip_mm(channel) -> np.ndarray:
    """Position (mm) of relative position 0 (the source centre's most distal dwell), (3,)."""
    return m_to_mm(np.asarray(channel.centreline.position(channel.s_ref_m), dtype=float))


def channel_points_mm(channel, rel_mm) -> np.ndarray:
    """Centreline positions (mm) at relative positions ``rel_mm`` (arc length s_ref - p), (n, 3)."""
    s = channel.s_ref_m - mm_to_m(np.asarray(rel_mm, dtype=float))
    return m_to_mm(np.asarray(channel.centreline.position(s), dtype=float).reshape(-1, 3))
