"""Compiled (numba) kernels of :mod:`planners.series` and of the series linear solve of :mod:`planners.newton`.

The same recurrences as the pure-numpy reference kernels of :mod:`planners.series`
(Cauchy product, quotient, exp, sin/cos, powers, tan), written as explicit loops
and compiled by numba (``cache=True``: compiled once per machine, the machine
code is kept in ``__pycache__``).  They work on float64 or complex128,
C-contiguous, coefficient-first arrays; every kernel writes into an output
array allocated by its caller, so one compiled version serves each dtype.

Binary kernels take three-dimensional operands ``(m, R, S)`` whose middle axis
is either ``R`` or 1 (broadcast), which covers the batch broadcasting the
planner does (a series of batch ``(nodes,)`` times a complex-step batch
``(n + 1, nodes)``) without materialising the broadcast.

The numpy kernels stay the reference; the property tests of
``tests/planners/test_series_backends.py`` check that both agree to 1e-12.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

_JIT = dict(cache=True, nogil=True, error_model="numpy")


def _arr(dtype, ndim: int, readonly: bool = False):
    return types.Array(dtype, ndim, "C", readonly=readonly)


# Explicit signatures: inputs typed read-only (series storage is read-only; writable arrays convert),
# outputs writable, so that one compiled version per dtype serves every call -- compiled once, on import
# of this module, then loaded from numba's cache.
_F, _C = types.float64, types.complex128


def _binary(ndim: int):
    return [types.void(_arr(t, ndim, True), _arr(t, ndim, True), _arr(t, ndim)) for t in (_F, _C)]


def _unary_out(ndim: int = 2):
    return [types.void(_arr(t, ndim, True), _arr(t, ndim)) for t in (_F, _C)]


@njit(_binary(3), **_JIT)
def mul3(a, b, out):
    """Truncated Cauchy product ``out_k = sum_{j+l=k} a_j b_l`` on ``(m, R|1, S)`` operands, out ``(m, R, S)``."""
    m, R, S = out.shape
    ra_step = 1 if a.shape[1] > 1 else 0
    rb_step = 1 if b.shape[1] > 1 else 0
    out[:] = 0
    for r in range(R):
        ra = r * ra_step
        rb = r * rb_step
        for j in range(m):
            for l in range(m - j):
                k = j + l
                for i in range(S):
                    out[k, r, i] += a[j, ra, i] * b[l, rb, i]


@njit(_binary(3), **_JIT)
def div3(a, b, out):
    """Quotient ``a / b``: ``q_k = (a_k - sum_{j>=1} b_j q_{k-j}) / b_0`` on ``(m, R|1, S)`` operands."""
    m, R, S = out.shape
    ra_step = 1 if a.shape[1] > 1 else 0
    rb_step = 1 if b.shape[1] > 1 else 0
    inv = np.empty(S, out.dtype)
    for r in range(R):
        ra = r * ra_step
        rb = r * rb_step
        for i in range(S):
            inv[i] = 1.0 / b[0, rb, i]
        for k in range(m):
            for i in range(S):
                out[k, r, i] = a[k, ra, i]
            for j in range(1, k + 1):
                for i in range(S):
                    out[k, r, i] -= b[j, rb, i] * out[k - j, r, i]
            for i in range(S):
                out[k, r, i] *= inv[i]


@njit(_unary_out(), **_JIT)
def exp2(u, out):
    """``exp(u)`` given ``out[0]``: ``k e_k = sum_{j=1}^{k} j u_j e_{k-j}``; ``(m, N)`` arrays."""
    m, n = u.shape
    for k in range(1, m):
        for i in range(n):
            out[k, i] = 0
        for j in range(1, k + 1):
            w = j / k
            for i in range(n):
                out[k, i] += w * u[j, i] * out[k - j, i]


@njit([types.void(_arr(t, 2, True), _arr(t, 2), _arr(t, 2), _F) for t in (_F, _C)], **_JIT)
def sincos2(u, s, c, sign):
    """Coupled recurrence, ``s[0], c[0]`` given: ``k s_k = sum j u_j c_{k-j}``, ``k c_k = sign sum j u_j s_{k-j}``.

    ``sign = -1`` for (sin, cos), ``+1`` for (sinh, cosh).
    """
    m, n = u.shape
    for k in range(1, m):
        for i in range(n):
            s[k, i] = 0
            c[k, i] = 0
        for j in range(1, k + 1):
            for i in range(n):
                v = j * u[j, i]
                s[k, i] += v * c[k - j, i]
                c[k, i] += v * s[k - j, i]
        ik = 1.0 / k
        for i in range(n):
            s[k, i] *= ik
            c[k, i] *= sign * ik


@njit([types.void(_arr(_F, 2, True), _F, _arr(_F, 2)), types.void(_arr(_C, 2, True), _C, _arr(_C, 2))], **_JIT)
def pow2(u, p, out):
    """``u ** p`` for a scalar ``p`` given ``out[0]``: ``c_k = sum_{j=1}^{k} ((p + 1) j / k - 1) (u_j / u_0) c_{k-j}``."""
    m, n = u.shape
    ut = np.empty((m, n), out.dtype)
    for i in range(n):
        i0 = 1.0 / u[0, i]
        for j in range(1, m):
            ut[j, i] = u[j, i] * i0
    p1 = p + 1
    for k in range(1, m):
        for i in range(n):
            out[k, i] = 0
        for j in range(1, k + 1):
            w = p1 * (j / k) - 1.0
            for i in range(n):
                out[k, i] += w * ut[j, i] * out[k - j, i]


@njit([types.void(_arr(t, 2, True), _arr(t, 1, True), _arr(t, 2)) for t in (_F, _C)], **_JIT)
def pow_array2(u, p, out):
    """``u ** p`` with one exponent per batch element (``p`` of shape ``(N,)``), given ``out[0]``."""
    m, n = u.shape
    ut = np.empty((m, n), out.dtype)
    for i in range(n):
        i0 = 1.0 / u[0, i]
        for j in range(1, m):
            ut[j, i] = u[j, i] * i0
    for k in range(1, m):
        for i in range(n):
            out[k, i] = 0
        for j in range(1, k + 1):
            for i in range(n):
                out[k, i] += ((p[i] + 1) * (j / k) - 1.0) * ut[j, i] * out[k - j, i]


@njit([types.void(_arr(t, 2, True), _arr(t, 2), _F) for t in (_F, _C)], **_JIT)
def tan2(u, t, sign):
    """``tan u`` (``sign = +1``) or ``tanh u`` (``sign = -1``) given ``t[0]``: ``t' = (1 + sign t^2) u'``."""
    m, n = u.shape
    w = np.empty((m, n), t.dtype)
    for i in range(n):
        w[0, i] = 1.0 + sign * t[0, i] * t[0, i]
    for k in range(1, m):
        for i in range(n):
            t[k, i] = 0
        for j in range(1, k + 1):
            wj = j / k
            for i in range(n):
                t[k, i] += wj * u[j, i] * w[k - j, i]
        if k < m - 1:
            for i in range(n):
                w[k, i] = 0
            for j in range(k + 1):
                for i in range(n):
                    w[k, i] += t[j, i] * t[k - j, i]
            for i in range(n):
                w[k, i] *= sign


@njit([types.void(_arr(_F, 4, True), _arr(_F, 3, True), _arr(_F, 3, True), _arr(_F, 3))], **_JIT)
def series_solve(J, J0inv, G, D):
    """Order by order ``D_m = J_0^{-1} (G_m - sum_{l=1..m} J_l D_{m-l})`` for every batch element.

    ``J`` (B, n, n, K), ``J0inv`` (B, n, n), ``G`` and ``D`` (B, n, K).
    """
    B, n, _, K = J.shape
    rhs = np.empty(n, D.dtype)
    for b in range(B):
        for mth in range(K):
            for i in range(n):
                acc = G[b, i, mth]
                for l in range(1, mth + 1):
                    for j in range(n):
                        acc -= J[b, i, j, l] * D[b, j, mth - l]
                rhs[i] = acc
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += J0inv[b, i, j] * rhs[j]
                D[b, i, mth] = acc
