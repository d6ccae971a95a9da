"""The modelled stem: how much straight channel before the first bend a simulation carries.

An applicator's channel can run a long straight shaft (the Oncentra ring's library channel: about
195 mm) before its first bend. Under friction, a cable pushed through a long straight shaft buckles
into a helix against the wall ("snaking"); the quasi-static solution then branches, and the dwells
in the ring pick up differences of a few tenths of a millimetre that depend on the discretisation,
not on the physics. The ring's dwells are set by the ring and the last few centimetres before it:
the cable in the shaft only passes the push force on. The paper (Straathof et al. 2024, section
2.2) modelled the applicator's plastic tube insert with its short straight stem in the same spirit.

:func:`trim_to_stem` keeps ``stem_m`` of straight channel before the first bend and drops the rest
proximally; the measured path (positions in space) and the relative positions do not change, only
the arc lengths shift (``s_ref_m`` minus the dropped length). How much the choice moves the dwells
is measured in ``benchmarks/bench_commission_numerics.py`` and shown in docs/commissioning.md, and
every commissioning run that cuts measures it again: its numerical check also runs the whole
channel and adds what the cut moves to each dwell's error
(:class:`ringqa.pipeline.simulate.StemCheck`). On the Oncentra example the cut is not harmless:
the cable buckles in the 193 mm shaft under friction, and the whole channel's runs put the dwells
0.3-0.6 mm from the cut runs and from each other.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ringqa.geometry.applicator import Channel
from ringqa.geometry.centreline import Centreline, GeometryError
from ringqa.geometry.lumen import Lumen

#: Curvature (1/m) above which the channel counts as bent: a 200 mm radius. The rings bend at
#: 1/13-1/17 mm; a machined straight shaft stays below 1/m.
BEND_KAPPA_PER_M = 5.0

#: Straight channel kept before the first bend by default (m): the shipped rings' stem.
DEFAULT_STEM_M = 0.060

#: Point spacing of the trimmed centreline (m): the centreline table's own spacing.
_RESAMPLE_M = 0.25e-3
#: Less than this (m) is not worth dropping (the bend's detected start wanders by a fraction of a
#: millimetre with the curvature threshold; the centreline is not refitted for that).
MIN_DROP_M = 1.0e-3


@dataclass(frozen=True, eq=False)
class TrimmedChannel:
    """A channel whose proximal straight part was shortened.

    Attributes
    ----------
    channel : Channel
        The trimmed channel (the original when nothing was dropped).
    dropped_m : float
        Straight length removed at the entry (m); 0 when the stem was already short enough.
    stem_m : float
        Straight channel left before the first bend (m).
    first_bend_m : float
        Arc length of the first bend in the ORIGINAL channel (m).
    """

    channel: Channel
    dropped_m: float
    stem_m: float
    first_bend_m: float


def first_bend_m(channel: Channel, kappa_per_m: float = BEND_KAPPA_PER_M) -> float:
    """Arc length (m) of the first centreline point curved more than ``kappa_per_m`` (1/m).

    Returns the channel length when the channel is straight everywhere.
    """
    tab = channel.centreline.table
    bent = np.flatnonzero(tab.kappa > float(kappa_per_m))
    return float(tab.s[bent[0]]) if bent.size else float(channel.length_m)


def trim_to_stem(channel: Channel, stem_m: float | None = DEFAULT_STEM_M) -> TrimmedChannel:
    """Keep ``stem_m`` of straight channel before the first bend; drop the rest proximally.

    Parameters
    ----------
    channel : Channel
    stem_m : float or None
        Straight length to keep before the first bend (m), > 0; None keeps the whole channel.

    Returns
    -------
    TrimmedChannel

    Raises
    ------
    GeometryError
        ``stem_m`` not a positive length.
    """
    s_bend = first_bend_m(channel)
    if stem_m is None:
        return TrimmedChannel(channel, 0.0, s_bend, s_bend)
    stem = float(stem_m)
    if not np.isfinite(stem) or stem <= 0.0:
        raise GeometryError(
            f"stem: {stem_m!r} m is not a positive length; give the straight channel to keep "
            "before the first bend, e.g. 60 mm (or none to keep the whole channel)"
        )
    s0 = s_bend - stem
    if s0 < MIN_DROP_M:  # nothing (worth) dropping
        return TrimmedChannel(channel, 0.0, s_bend, s_bend)
    length = channel.length_m
    s = np.arange(s0, length, _RESAMPLE_M)
    s = np.append(s[s < length - 0.5 * _RESAMPLE_M], length)
    centreline = Centreline.from_points(channel.centreline.position(s))
    lumen = channel.lumen
    seg_s = lumen.seg_s - s0  # +-inf stay infinite
    trimmed_lumen = Lumen(
        seg_s, lumen.seg_rb, lumen.seg_ra, lumen.seg_flat, lumen.flat_side, lumen.source
    )
    trimmed = replace(
        channel, centreline=centreline, lumen=trimmed_lumen, s_ref_m=channel.s_ref_m - s0
    )
    return TrimmedChannel(trimmed, s0, stem, s_bend)
