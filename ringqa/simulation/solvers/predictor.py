"""The load-step predictor kernel: the previous chain slid along the channel, the driven end put
at the new input advance, the link lengths restored; and the rule that says whether a load step
continues the previous one (:func:`continuation_scale`: the extrapolation of
:meth:`ringqa.simulation.model.Model.predict` and :func:`~.march.march`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ringqa.simulation._kernels import curve_eval, restore_lengths, slide_points


@njit(cache=True, error_model="numpy")
def predict(q, slide, du, u_new, nd, n_nodes, link_len, chan, samp_s, cum, cft, node_sample):
    """Load-step predictor in place on ``q``.

    With ``slide`` every free node is slid ``du`` along the channel keeping its offset
    (``slide_points``; node hints from the samples at the nodes, ``samp_s`` advanced by ``du``);
    then the two driven proximal nodes are put on the approach axis for input advance ``u_new``
    (twist 0) and the free nodes' link lengths are restored.

    Parameters
    ----------
    q : (n_all,) float
        State, changed in place (m; twist in rad).
    slide : bool
        Slide the free nodes along the channel first.
    du, u_new : float
        Advance of this step and the input advance at its end (m).
    nd, n_nodes : int
        Coordinates per node, nodes.
    link_len : (N,) float
        Link lengths (m).
    chan : ChannelArgs
        The channel table.
    samp_s : (P,) float
        The contact samples' closest arc lengths (m), advanced by ``du`` in place with ``slide``.
    cum : (N+1,) float
        Arc length of each node from the tip along the undeformed cable (m).
    cft : float
        Source centre's distance behind the tip (m).
    node_sample : (N,) int64
        The sample that sits on each node 0..N-1 (alpha = 0).
    """
    h, pos, tan = chan.h, chan.pos, chan.tan
    if slide:
        x = np.empty((n_nodes, 3))
        for k in range(n_nodes):
            for a in range(3):
                x[k, a] = q[nd * k + a]
        hints = np.empty(n_nodes)
        for k in range(n_nodes - 1):
            hints[k] = samp_s[node_sample[k]]
        hints[n_nodes - 1] = hints[n_nodes - 2] - link_len[n_nodes - 2]
        out = np.empty((n_nodes, 3))
        s_out = np.empty(n_nodes)
        slide_points(h, pos, tan, x, hints, du, out, s_out)
        for k in range(n_nodes - 2):
            for a in range(3):
                q[nd * k + a] = out[k, a]
        for i in range(samp_s.shape[0]):
            samp_s[i] += du
    c = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    for k in range(n_nodes - 2, n_nodes):
        curve_eval(h, pos, tan, u_new + cft - cum[k], c, d1, d2)
        for a in range(3):
            q[nd * k + a] = c[a]
        if nd == 4:
            q[nd * k + 3] = 0.0
    restore_lengths(q, nd, n_nodes, link_len)


@njit(cache=True, error_model="numpy")
def continuation_scale(du, u_new, pred_du, pred_u, rtol, scale_max):
    """How much of the previous step's Newton correction a forward load step may extrapolate:
    the factor on :data:`~ringqa.simulation.model.EXTRAPOLATE_FRACTION` (0: none, the plain
    slide). The one rule of both load-step loops (the Python one calls ``py_func``).

    The step continues the previous one when it starts where that one ended
    (``|pred_u + du - u_new| <= 1e-9 |du|``) and is as long: ``|du - pred_du| <= rtol |du|``
    (factor 1; ``rtol`` = 0 is exact equality). The step ``du = min(target - u, inc)`` with ``u``
    accumulated by ``u + du`` falls a few ulp short of ``inc`` (1e-19-1e-17 m) at random
    wherever it is ``target - u``, e.g. on a step into a dwell one increment away; such a step
    continues the one before it. A step of another length
    gets ``du / pred_du`` where that is at most ``scale_max`` (0: never).

    Parameters
    ----------
    du, u_new : float
        This step's advance and the input advance at its end (m); ``du > 0``.
    pred_du, pred_u : float
        The previous predicted step's advance and end (m; NaN: the previous step was hard or
        failed, or there was none).
    rtol : float
        Relative tolerance on ``du`` (:data:`~ringqa.simulation.model.EXTRAPOLATE_RTOL`).
    scale_max : float
        Largest ``du / pred_du`` extrapolated for a step of another length
        (:data:`~ringqa.simulation.model.EXTRAPOLATE_SCALE_MAX`).
    """
    if not abs(pred_u + du - u_new) <= 1e-9 * abs(du):
        return 0.0
    if abs(du - pred_du) <= rtol * abs(du):
        return 1.0
    ratio = du / pred_du
    if 0.0 < ratio <= scale_max:
        return ratio
    return 0.0
