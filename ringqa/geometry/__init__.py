"""Geometry layer: channel centrelines, lumen cross-sections, channels, applicators (SI)."""

from ringqa.geometry.applicator import Applicator, Channel
from ringqa.geometry.centreline import Centreline, CentrelineTable, GeometryError
from ringqa.geometry.families.ring_frame import RingFrame, fit_ring_frame
from ringqa.geometry.frame import fit_circle
from ringqa.geometry.lumen import Lumen
from ringqa.geometry.parametric import ring_applicator, ring_channel, tandem_channel
from ringqa.geometry.registration import (
    REGISTER_MODES,
    ReferencePathCheck,
    ReferencePositions,
    Registration,
    RegistrationError,
    check_reference_path,
    reference_positions,
    register_reference,
)
from ringqa.geometry.s_channel import SChannelLayout, s_channel, s_channel_layout
from ringqa.geometry.splice import (
    SplicedCentreline,
    SpliceError,
    splice_applicator,
    splice_centreline,
    splice_channel,
)

__all__ = [
    "REGISTER_MODES",
    "Applicator",
    "Centreline",
    "CentrelineTable",
    "Channel",
    "GeometryError",
    "Lumen",
    "ReferencePathCheck",
    "ReferencePositions",
    "Registration",
    "RegistrationError",
    "RingFrame",
    "SChannelLayout",
    "SpliceError",
    "SplicedCentreline",
    "check_reference_path",
    "fit_circle",
    "fit_ring_frame",
    "reference_positions",
    "register_reference",
    "ring_applicator",
    "ring_channel",
    "s_channel",
    "s_channel_layout",
    "splice_applicator",
    "splice_centreline",
    "splice_channel",
    "tandem_channel",
]
