"""Geometry layer: channel centrelines, lumen cross-sections, channels, applicators (SI)."""

from ringqa.geometry.centreline import Centreline, CentrelineTable, GeometryError
from ringqa.geometry.lumen import Lumen

__all__ = ["Centreline", "CentrelineTable", "GeometryError", "Lumen"]
