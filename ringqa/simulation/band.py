"""The banded Jacobian: its storage, the kernels that add to it and the banded LU solve.

Band storage (row-wise): ``B[i, kl + j - i]`` holds ``A[i, j]`` for ``-kl <= j - i <= 2 kl``;
the effects write only ``|j - i| <= kl`` (``kl = 3 nd - 1``: a link couples a node's ``nd``
coordinates with its neighbours'), the extra ``kl`` columns take the fill-in of pivoting.
Everything here sees arrays and scalars only.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always", error_model="numpy")
def badd(B, kl, i, j, v):
    """``A[i, j] += v``."""
    B[i, kl + j - i] += v


@njit(cache=True, error_model="numpy")
def add_block(B, kl, nd, ni, nj, w, K):
    """Add ``w * K`` (3x3) to the position block (node ``ni``, node ``nj``)."""
    bi = nd * ni
    bj = nd * nj
    for a in range(3):
        for b in range(3):
            B[bi + a, kl + bj + b - bi - a] += w * K[a, b]


@njit(cache=True, inline="always", error_model="numpy")
def add_block_flat(Bf, W, kl, nd, ni, nj, w, K):
    """:func:`add_block` through a flat view ``Bf = B.reshape(-1)`` (``W = B.shape[1]``).

    ``B[i, kl + j - i]`` is ``Bf[i (W - 1) + kl + j]``; unsigned offsets skip numba's
    negative-index wraparound test on every entry. Same additions in the same order.
    """
    step = np.uint64(W - 1)
    base = np.uint64(nd * ni) * step + np.uint64(kl + nd * nj)
    for a in range(3):
        ra = base + np.uint64(a) * step
        for b in range(3):
            Bf[ra + np.uint64(b)] += w * K[a, b]


@njit(cache=True, error_model="numpy")
def band_solve(B, kl, rhs, n):
    """Solve ``A x = rhs`` for the leading ``n x n`` block of a banded matrix (in place).

    Gaussian elimination with partial pivoting (as LAPACK gbsv) on the row-wise band storage
    described in the module docstring; O(n kl^2). ``B`` and ``rhs`` are overwritten, the
    solution is returned in ``rhs[:n]``.

    Each row's last possibly non-zero column is tracked (``last``: from the assembled entries,
    carried along by row swaps and eliminations), and the row operations stop there: the
    skipped terms are exact zeros (``x - f * 0 = x``), so the result is the same, bit for bit,
    as running every row out to the full fill-in width ``2 kl``; without row swaps a row's fill
    stays within ``kl`` and the work halves.

    Returns
    -------
    ok : bool
        False when a pivot is exactly zero (singular matrix).
    """
    ku = 2 * kl
    W = B.shape[1]
    Bf = B.reshape(-1)  # flat view: row operations index it with unsigned offsets (no wraparound)
    last = np.empty(n, dtype=np.int64)
    for i in range(n):
        jl = min(n - 1, i + kl)
        while jl > i and B[i, kl + jl - i] == 0.0:
            jl -= 1
        last[i] = jl
    for k in range(n):
        # pivot search in column k, rows k .. k + kl
        imax = min(n - 1, k + kl)
        p = k
        vmax = abs(B[k, kl])
        for i in range(k + 1, imax + 1):
            v = abs(B[i, kl + k - i])
            if v > vmax:
                vmax = v
                p = i
        if vmax == 0.0:
            return False
        if p != k:
            jmax = max(last[k], last[p])
            for j in range(k, jmax + 1):
                a = B[k, kl + j - k]
                B[k, kl + j - k] = B[p, kl + j - p]
                B[p, kl + j - p] = a
            a = rhs[k]
            rhs[k] = rhs[p]
            rhs[p] = a
            jl = last[k]
            last[k] = last[p]
            last[p] = jl
        piv = B[k, kl]
        jmax = min(n - 1, k + ku, last[k])
        bk = np.uint64(k * W + kl - k)  # B[k, kl + j - k] == Bf[bk + j]
        for i in range(k + 1, imax + 1):
            f = B[i, kl + k - i] / piv
            if f != 0.0:
                B[i, kl + k - i] = 0.0
                bi = np.uint64(i * W + kl - i)
                for j in range(np.uint64(k + 1), np.uint64(jmax + 1)):
                    Bf[bi + j] -= f * Bf[bk + j]
                rhs[i] -= f * rhs[k]
                if jmax > last[i]:
                    last[i] = jmax
    for k in range(n - 1, -1, -1):
        acc = rhs[k]
        jmax = min(n - 1, k + ku, last[k])
        bk = np.uint64(k * W + kl - k)
        for j in range(np.uint64(k + 1), np.uint64(jmax + 1)):
            acc -= Bf[bk + j] * rhs[j]
        rhs[k] = acc / B[k, kl]
    return True
