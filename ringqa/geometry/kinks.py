"""Kinks: places where a channel centreline bends much more sharply than the channel around it.

A designed channel changes its curvature smoothly (the shipped rings' transitions: at most 0.22 of
the ring's curvature 1/R above their 10 mm running median). A library model joined from parts can
carry a kink: the Oncentra 26/60 ring of the shipped example bends at 164 1/m (radius 6.1 mm) for
about 2 mm at relative position 61 mm, against 73 1/m around it (1.19/R above the median). A stiff
cable sticks there, and the simulated dwells beyond it can settle in more than one place; the
paper corrected the library centreline from CT at the proximal ring for the same reason.
:func:`find_kinks` reports every stretch whose curvature exceeds its running median by more than
:data:`KINK_EXCESS` / R.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.applicator import Channel

#: A kink: curvature above its running median by more than this times 1/R (R: ring radius).
KINK_EXCESS = 0.5
#: Length of the running median (m).
KINK_WINDOW_M = 0.010


@dataclass(frozen=True)
class Kink:
    """One kink of a channel centreline (SI).

    Attributes
    ----------
    s_m : float
        Arc length of the sharpest point (m).
    curvature_per_m : float
        Its curvature (1/m).
    median_per_m : float
        The running median of the curvature there (1/m).
    length_m : float
        Length of the stretch above the threshold (m).
    """

    s_m: float
    curvature_per_m: float
    median_per_m: float
    length_m: float


def find_kinks(
    channel: Channel,
    ring_radius_m: float,
    excess: float = KINK_EXCESS,
    window_m: float = KINK_WINDOW_M,
) -> tuple[Kink, ...]:
    """The kinks of ``channel``'s centreline, proximal first.

    Parameters
    ----------
    channel : Channel
    ring_radius_m : float
        The ring's centreline radius R (m): the curvature scale.
    excess : float
        Threshold above the running median, in units of 1/R.
    window_m : float
        Length of the running median (m).

    Returns
    -------
    tuple of Kink
    """
    tab = channel.centreline.table
    kappa = np.asarray(tab.kappa, dtype=float)
    if kappa.size < 3:
        return ()
    h = float(tab.s[1] - tab.s[0])
    size = max(3, round(window_m / h) | 1)
    # a running median with edge replication (scipy.ndimage.median_filter(mode="nearest") for
    # an odd size, element for element; numpy here: scipy.ndimage costs ~25 ms to import)
    half = size // 2
    padded = np.pad(kappa, half, mode="edge")
    median = np.median(np.lib.stride_tricks.sliding_window_view(padded, size), axis=1)
    above = (kappa - median) * ring_radius_m > excess
    kinks = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], above.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        i = start + int(np.argmax(kappa[start:stop]))
        kinks.append(Kink(float(tab.s[i]), float(kappa[i]), float(median[i]),
                          float((stop - start) * h)))  # fmt: skip
    return tuple(kinks)
