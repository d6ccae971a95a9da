"""Tick locators of the report's figures that give only the ticks a draw shows.

matplotlib's default locator (``AutoLocator``, a ``MaxNLocator``) returns tick places that
cover the view: its first place is at or below the lower limit and its last at or above the
upper one, so most axes get a place just outside the view at each end. The draw makes a
``Tick`` for every place (three ``Line2D`` and two ``Text``, the costliest objects of a
figure: about a fifth of the report figures' CPU goes to making ticks), formats its label and
then leaves the ticks outside the view out (``Axis._update_ticks``: ``ticks_to_draw``). In the
report's three figures 28 of the 131 major ticks are never drawn.

:class:`InView` wraps such a locator and drops the places outside the view (with a margin
10 000 times matplotlib's own, so every tick the draw would show is kept). What is drawn is the
same: the ticks shown and their places, and their labels, because ``ScalarFormatter`` (the
default formatter of a linear axis) takes its offset and order of magnitude from the places in
view only, and its number of decimals from all places: it drops decimals while the places
differ from their rounded values by less than a thousandth of the spread's power of ten. The
places of a ``MaxNLocator`` are multiples of one step of 1, 2, 2.5 or 5 times a power of ten,
at least two of them in view: rounded to the step's own decimals they are exact, rounded to one
decimal fewer one of any two neighbours moves by at least a fifth of the step, far above that
threshold with or without the outer places (their spread is at most about twelve steps): so
the same decimals.

:func:`ticks_in_view` installs it on the linear axes of a figure whose major locator is
matplotlib's ``AutoLocator`` or ``MaxNLocator`` and formatter its ``ScalarFormatter``; the axis
keeps counting its locator as the default one (a later ``set_xscale("log")`` replaces it, as it
would replace the default). tests/report/test_ticks.py compares the ticks drawn, their labels,
the offset texts and the pixels with and without it over many views, autoscaled and with ticks
on the view's edges.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import AutoLocator, Locator, MaxNLocator, ScalarFormatter

#: the margin, relative to the view's length, within which a place outside the view is kept
#: (matplotlib draws a tick within 1e-10 of the view's length: ``_interval_contains_close``)
MARGIN = 1e-6


class InView(Locator):
    """``locator``'s tick places in the axis' view (see the module's description); every
    other question (``tick_values``, ``nonsingular``, ``view_limits``, ``set_params``) is
    ``locator``'s."""

    def __init__(self, locator: Locator) -> None:
        self.locator = locator

    def set_axis(self, axis) -> None:
        super().set_axis(axis)
        self.locator.set_axis(axis)

    def __call__(self):
        locs = np.asarray(self.locator())
        low, high = sorted(self.axis.get_view_interval())
        margin = MARGIN * (high - low)
        return locs[(locs >= low - margin) & (locs <= high + margin)]

    def tick_values(self, vmin, vmax):
        return self.locator.tick_values(vmin, vmax)

    def nonsingular(self, v0, v1):
        return self.locator.nonsingular(v0, v1)

    def view_limits(self, vmin, vmax):
        return self.locator.view_limits(vmin, vmax)

    def set_params(self, **kwargs):
        self.locator.set_params(**kwargs)


def ticks_in_view(fig) -> int:
    """Wrap the major locator of each linear axis of ``fig`` whose locator is matplotlib's
    ``AutoLocator`` or ``MaxNLocator`` and formatter its ``ScalarFormatter`` in
    :class:`InView` (once: axes sharing an axis share its locator); how many it wrapped."""
    wrapped = 0
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            locator = axis.get_major_locator()
            if axis.get_scale() != "linear" or type(locator) not in (AutoLocator, MaxNLocator):
                continue  # another locator (or one wrapped already: a shared axis)
            if type(axis.get_major_formatter()) is not ScalarFormatter:
                continue
            default = axis.isDefault_majloc
            axis.set_major_locator(InView(locator))
            axis.isDefault_majloc = default  # still the scale's own (set_*scale replaces it)
            wrapped += 1
    return wrapped
