"""Applicator families: one module per family, a registry, and which family a channel is.

Shipped: :mod:`~.ring` (Elekta/Varian rings), :mod:`~.tandem`, :mod:`~.ovoid` (Fletcher-type and
lunar) and :mod:`~.free_form` (any centreline + lumen). What a family provides:
:class:`~ringqa.geometry.families.base.ApplicatorFamily`. A new family is one module that
defines a class with those members and calls :func:`register_family` (docs/architecture.md, "How
to add an applicator family").
"""

from __future__ import annotations

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.families.base import (
    KINK_SCALE_M,
    ApplicatorFamily,
    FamilyPoint,
    FamilyWords,
)
from ringqa.geometry.families.free_form import FREE_FORM
from ringqa.geometry.families.ovoid import OVOID
from ringqa.geometry.families.ring import RING, ring_arc_mm
from ringqa.geometry.families.tandem import TANDEM, tandem_frame

__all__ = [
    "FAMILIES",
    "KINK_SCALE_M",
    "ApplicatorFamily",
    "FamilyPoint",
    "FamilyWords",
    "family_name_of",
    "family_named",
    "family_of",
    "register_family",
    "ring_arc_mm",
    "tandem_frame",
]

#: The registered families by name (the shipped ones; :func:`register_family` adds more).
FAMILIES: dict[str, ApplicatorFamily] = {f.name: f for f in (RING, TANDEM, OVOID, FREE_FORM)}

#: Channel names that say their family (lower case, before any side or number).
_BY_NAME = {"ring": "ring", "tandem": "tandem", "ovoid": "ovoid", "lunar": "ovoid"}


def register_family(family: ApplicatorFamily) -> ApplicatorFamily:
    """Add ``family`` to :data:`FAMILIES` (replacing one of the same name); returns it.

    Raises
    ------
    GeometryError
        ``family`` lacks a member of :class:`~ringqa.geometry.families.base.ApplicatorFamily`.
    """
    if not isinstance(family, ApplicatorFamily) or not isinstance(family.name, str):
        raise GeometryError(
            f"register_family: {family!r} does not provide name, words, gynae, span_mm, points, "
            "curvature_scale_m and checks (ringqa.geometry.families.base.ApplicatorFamily)"
        )
    FAMILIES[family.name] = family
    return family


def family_named(name: str) -> ApplicatorFamily:
    """The family called ``name``.

    Raises
    ------
    GeometryError
        No such family (the message lists the registered ones).
    """
    try:
        return FAMILIES[name]
    except KeyError:
        raise GeometryError(
            f"no applicator family {name!r}; known: {', '.join(sorted(FAMILIES))}"
        ) from None


def family_name_of(app, channel) -> str:
    """The family name of ``channel``: its own ``family``, else what its name says (``"tandem"``,
    ``"left ovoid"``, ``"lunar ovoid R"``), else the applicator's ``family``."""
    own = getattr(channel, "family", "") or ""
    if own:
        return own
    words = str(channel.name).lower().replace("_", " ").replace("-", " ").split()
    for word in words:
        if word in _BY_NAME:
            return _BY_NAME[word]
    return getattr(app, "family", "ring") or "ring"


def family_of(app, channel) -> ApplicatorFamily:
    """The family of ``channel`` of ``app`` (:func:`family_name_of`, then :func:`family_named`)."""
    return family_named(family_name_of(app, channel))
