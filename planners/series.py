"""Batched truncated power series (Taylor arithmetic).

The model equations in :mod:`gna` are written once with plain arithmetic and
numpy ufuncs.  :class:`Series` lets the same code run on truncated power
series, which is how the planner obtains the Taylor expansions of states and
controls along a trajectory (paper section "Newton operator with series").

A :class:`Series` of order ``n`` holds, for every point of a *batch* of
expansion points ``t0``, the normalised Taylor coefficients ``c_0 .. c_n`` of

    f(t) = c_0 + c_1 (t - t0) + ... + c_n (t - t0)^n + O((t - t0)^(n+1)).

Design
------
* **Layout.**  The public :attr:`Series.coeffs` array has shape
  ``batch_shape + (n + 1,)``.  Internally the coefficients are stored
  *coefficient-first*, shape ``(n + 1,) + batch_shape``, so that every
  coefficient ``c_k`` of the whole batch is one contiguous row; the sequential
  recurrences below then work on contiguous vectors.  ``coeffs`` is a
  read-only transposed view of that storage.
* **Immutability.**  Series are immutable (storage is read-only), so the
  (sin, cos) pair computed by the coupled recurrence is memoised on the
  instance: ``np.sin(a)`` followed by ``np.cos(a)`` costs one recurrence.
* **Multiplication** is the truncated Cauchy product
  ``c_k = sum_j a_j b_(k-j)``, evaluated as a single ``einsum`` against a
  zero-copy strided "sliding window" (Toeplitz) view of the zero-padded second
  factor -- no Python loop.  For batch 200 and order 13 this was measured ~2x
  faster than a loop over ``k`` of vectorised dot products, ~4x faster than
  gathering a Toeplitz matrix, and much faster than outer-product + matmul.
* **Division, exp, powers, sqrt, sin/cos, tan** use the classical linear
  recurrences (the coefficient ``c_k`` is a dot product of already known
  coefficients); the only Python loop is over ``k``, each step is one or two
  batched ``einsum`` calls.
* **log, log1p, arctan, arcsin, arccos, arctan2** are obtained by integrating
  their derivative (``u'/u``, ``u'/(1+u^2)``, ``u' (1-u^2)^(-1/2)``,
  ``(x y' - y x')/(x^2 + y^2)``), the constant term being the numpy function
  of the constant term(s).
* **Complex step.**  Every operation is complex-analytic (no ``abs``, no
  ``conj``), so ``Im f(x + i h) / h`` gives exact derivatives.  For complex
  input, the constant term of ``arctan2`` is the analytic continuation of the
  real branch at the real parts of the arguments.
* **Mixed orders.**  Combining series of orders ``n1`` and ``n2`` truncates
  both to ``min(n1, n2)``: higher coefficients of the result would be wrong.
* **Mixed operands.**  Python/numpy scalars and ndarrays act as constant
  series; an ndarray is broadcast against the batch shape (numpy rules), on
  either side of an operator (``arr * s``, ``s - arr``, ``np.float64(2) * s``).
* **Backends.**  The kernels (Cauchy product, quotient, the recurrences, the
  order-by-order solve of :mod:`planners.newton`) exist twice: the numpy
  functions of this module, the reference, and numba-compiled loops
  (:mod:`planners._series_compiled`, ``pip install gflat[fast]``).  The
  environment variable ``GFLAT_SERIES_BACKEND`` (``native``, the default,
  ``numpy`` or ``compiled``) is read once, at import (:data:`BACKEND`):
  ``native`` keeps these numpy kernels and runs the planner's stages as
  compiled programs in C (:mod:`planners.program`, :mod:`planners._native`;
  the numpy path where no C compiler is found), ``compiled`` uses the numba
  kernels and runs the programs with numba.  All agree to 1e-12 relative to the
  coefficient scale (``tests/planners/test_series_backends.py``,
  ``tests/planners/test_native.py``).  A product
  of a batch ``(nodes,)`` and a batch ``(k, nodes)`` (the complex-step
  Jacobians of Newton on series) is computed without materialising the
  broadcast in the compiled kernels.
* **No truth value.**  Comparisons and ``bool(s)`` raise :class:`TypeError`:
  a truncated series cannot be ordered, and model code must not branch on it.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import numbers
import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from gna.errors import InputError

__all__ = ["BACKEND", "BACKENDS", "BACKEND_ENV", "Series"]

_NO_TRUTH_MSG = (
    "a truncated power series has no truth value and cannot be compared; "
    "compare `s.constant_term` explicitly (model code must not branch on series values)"
)


# ---------------------------------------------------------------------------
# Kernels on coefficient-first 2-D arrays of shape (m, N): m = order + 1,
# N = flattened batch size.  They never modify their inputs.
# ---------------------------------------------------------------------------


def _mul_kernel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Truncated Cauchy product of two (m, N) coefficient arrays.

    ``c_k = sum_{w} W[k, w] a_{m-1-w}`` where ``W[k, w] = bp[k + w]`` is a
    strided window over ``bp = (0, ..., 0, b_0, ..., b_{m-1})`` (``m - 1``
    leading zeros), i.e. ``W[k, w] = b_{k + w - m + 1}``.
    """
    m, n_b = a.shape
    dt = np.result_type(a, b)
    if n_b == 0:
        return np.zeros((m, 0), dt)
    if n_b >= 128 and dt.kind == "c":
        # complex einsum is slow: m row updates c_(j..) += a_j b_(..m-j) are about 2x faster here
        out = np.multiply(a[0], b, dtype=dt)
        for j in range(1, m):
            out[j:] += a[j] * b[: m - j]
        return out
    bp = np.zeros((2 * m - 1, n_b), dt)
    bp[m - 1 :] = b
    s0, s1 = bp.strides
    window = np.ndarray((m, m, n_b), dt, buffer=bp, strides=(s0, s0, s1))
    return np.einsum("kwb,wb->kb", window, a[::-1])


def _div_kernel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quotient a/b of (m, N) arrays: ``q_k = (a_k - sum_{j>=1} b_j q_{k-j}) / b_0``."""
    m, n_b = b.shape
    dt = np.result_type(a, b)
    ib0 = 1.0 / b[0]
    q = np.multiply(a, ib0, dtype=dt)
    if m > 1:
        nb = np.multiply(b[1:], -ib0, dtype=dt)
        tmp = np.empty(n_b, dt)
        for k in range(1, m):
            np.einsum("jb,jb->b", nb[:k], q[k - 1 :: -1], out=tmp)
            q[k] += tmp
    return q


def _ratio_weights(m: int, scale: complex | float = 1.0, shift: float = 0.0) -> np.ndarray:
    """Table ``w[k-1, j-1] = scale * j / k - shift`` for ``1 <= j, k <= m - 1``."""
    j = np.arange(1, m, dtype=float)
    return scale * (j[None, :] / j[:, None]) - shift


def _pow_kernel(u: np.ndarray, p: complex | float, c0: np.ndarray | None = None) -> np.ndarray:
    """``u**p`` for a scalar exponent, by the recurrence of ``u c' = p u' c``.

    ``k u_0 c_k = sum_{j=1}^{k} ((p + 1) j - k) u_j c_{k-j}``; requires ``u_0 != 0``.
    """
    m, n_b = u.shape
    dt = np.result_type(u, p)
    c = np.empty((m, n_b), dt)
    c[0] = np.power(u[0], p) if c0 is None else c0
    if m > 1:
        ut = u[1:] / u[0]
        w = _ratio_weights(m, p + 1, 1.0).astype(dt, copy=False)
        for k in range(1, m):
            np.einsum("j,jb,jb->b", w[k - 1, :k], ut[:k], c[k - 1 :: -1], out=c[k])
    return c


def _pow_array_kernel(u: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``u**p`` with one exponent per batch element (``p`` of shape (N,))."""
    m, n_b = u.shape
    dt = np.result_type(u, p)
    c = np.empty((m, n_b), dt)
    c[0] = np.power(u[0], p)
    if m > 1:
        ut = u[1:] / u[0]
        j = np.arange(1, m, dtype=dt)[:, None]
        v = np.stack([j * ut, ut], axis=1)  # (m-1, 2, N)
        p1 = p + 1
        d = np.empty((2, n_b), dt)
        for k in range(1, m):
            np.einsum("jib,jb->ib", v[:k], c[k - 1 :: -1], out=d)
            c[k] = (p1 / k) * d[0] - d[1]
    return c


def _exp_kernel(u: np.ndarray, c0: np.ndarray | None = None) -> np.ndarray:
    """``exp(u)``: ``k e_k = sum_{j=1}^{k} j u_j e_{k-j}``."""
    m, n_b = u.shape
    e = np.empty((m, n_b), u.dtype)
    e[0] = np.exp(u[0])
    if m > 1:
        w = _ratio_weights(m).astype(u.dtype, copy=False)
        for k in range(1, m):
            np.einsum("j,jb,jb->b", w[k - 1, :k], u[1 : k + 1], e[k - 1 :: -1], out=e[k])
    if c0 is not None:
        e[0] = c0
    return e


def _sincos_kernel(u: np.ndarray, hyperbolic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Coupled recurrence for (sin u, cos u) or (sinh u, cosh u).

    ``k s_k = sum_j j u_j c_{k-j}`` and ``k c_k = -+ sum_j j u_j s_{k-j}``.
    """
    m, n_b = u.shape
    pair = np.empty((2, m, n_b), u.dtype)
    if hyperbolic:
        pair[0, 0], pair[1, 0] = np.sinh(u[0]), np.cosh(u[0])
    else:
        pair[0, 0], pair[1, 0] = np.sin(u[0]), np.cos(u[0])
    if m > 1:
        v = u[1:] * np.arange(1, m, dtype=u.dtype)[:, None]
        inv_k = 1.0 / np.arange(1, m, dtype=float)
        fac = np.empty((m - 1, 2, 1), u.dtype)
        fac[:, 0, 0] = inv_k
        fac[:, 1, 0] = inv_k if hyperbolic else -inv_k
        d = np.empty((2, n_b), u.dtype)
        for k in range(1, m):
            np.einsum("jb,ijb->ib", v[:k], pair[:, k - 1 :: -1], out=d)
            np.multiply(d[::-1], fac[k - 1], out=pair[:, k])
    return pair[0], pair[1]


def _tan_kernel(u: np.ndarray, hyperbolic: bool) -> np.ndarray:
    """``tan u`` (``tanh u``): ``t' = (1 +- t^2) u'``."""
    m, n_b = u.shape
    t = np.empty((m, n_b), u.dtype)
    t[0] = np.tanh(u[0]) if hyperbolic else np.tan(u[0])
    if m > 1:
        sign = -1.0 if hyperbolic else 1.0
        w = np.empty((m - 1, n_b), u.dtype)  # w = 1 +- t^2, rows 0..m-2
        w[0] = 1.0 + sign * t[0] * t[0]
        ratio = _ratio_weights(m).astype(u.dtype, copy=False)
        signs = np.full(m, sign, u.dtype)
        for k in range(1, m):
            np.einsum("j,jb,jb->b", ratio[k - 1, :k], u[1 : k + 1], w[k - 1 :: -1], out=t[k])
            if k < m - 1:
                np.einsum("j,jb,jb->b", signs[: k + 1], t[: k + 1], t[k::-1], out=w[k])
    return t


def _diff_kernel(u: np.ndarray) -> np.ndarray:
    """Derivative: rows ``k c_k`` for ``k = 1..m-1`` (one order less)."""
    m = u.shape[0]
    return u[1:] * np.arange(1, m, dtype=np.finfo(u.dtype).dtype)[:, None]


def _int_kernel(d: np.ndarray, c0: Any) -> np.ndarray:
    """Antiderivative with constant term ``c0`` (one order more)."""
    m, n_b = d.shape
    dt = np.result_type(d, c0)
    r = np.empty((m + 1, n_b), dt)
    r[0] = c0
    np.divide(d, np.arange(1, m + 1, dtype=np.finfo(dt).dtype)[:, None], out=r[1:])
    return r


def _atan2_constant(y0: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """``arctan2`` of constant terms, analytic continuation for complex input."""
    if not (np.iscomplexobj(y0) or np.iscomplexobj(x0)):
        return np.arctan2(y0, x0)
    xr, yr = np.real(x0), np.real(y0)
    # angle of the real point + (analytic) angle between (x0, y0) and it
    return np.arctan2(yr, xr) + np.arctan((xr * y0 - yr * x0) / (xr * x0 + yr * y0))


#: Largest ``rows * inner * columns`` of one matrix product in :func:`_small_gemm`: below OpenBLAS's
#: threshold for threading a gemm (65536 * 4), so that no BLAS thread is woken.
_GEMM_CHUNK = 200_000


def _small_gemm(w: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``w @ x`` for a small ``w`` and a wide ``x``, in column blocks each below BLAS's threading threshold.

    A threaded BLAS (OpenBLAS's default: one thread per core) spins its threads after a product large
    enough to be split; on a loaded machine those threads take the cores from the planner's own
    arithmetic (measured: the roll plan 4x slower).  Blocks of columns keep every product single-threaded
    (the same sums per column, so the same result to rounding) without touching the process's BLAS
    settings.
    """
    p, q = w.shape
    n = x.shape[1]
    block = max(1, _GEMM_CHUNK // max(1, p * q))
    if n <= block:
        return w @ x
    out = np.empty((p, n), np.result_type(w, x))
    for j in range(0, n, block):
        np.matmul(w, x[:, j : j + block], out=out[:, j : j + block])
    return out


# ---------------------------------------------------------------------------
# Shape helpers for internal (coefficient-first) arrays
# ---------------------------------------------------------------------------


def _flat(c: np.ndarray) -> np.ndarray:
    """(m,)+batch -> (m, N)."""
    return c.reshape(c.shape[0], math.prod(c.shape[1:]))


def _unflat(r: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """(m', N) -> (m',)+shape."""
    return r.reshape((r.shape[0],) + shape)


def _bcast(c: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Broadcast internal array (m,)+batch to (m,)+shape (read-only view)."""
    if c.shape[1:] == shape:
        return c
    extra = len(shape) - (c.ndim - 1)
    if extra > 0:
        c = c.reshape((c.shape[0],) + (1,) * extra + c.shape[1:])
    return np.broadcast_to(c, (c.shape[0],) + shape)


def _as_constant(x: Any) -> Any:
    """Numeric constant operand, or ``None`` if ``x`` is not one."""
    if type(x) in (float, int, complex, bool):
        return x
    if isinstance(x, (numbers.Number, np.generic)):
        return x if np.asarray(x).dtype.kind in "biufc" else None
    if isinstance(x, (np.ndarray, list, tuple)):
        arr = np.asarray(x)
        return arr if arr.dtype.kind in "biufc" else None
    return None


def _coeff_axis_first(arr: np.ndarray) -> np.ndarray:
    """View of a batch-last array with the coefficient axis moved to the front."""
    nd = arr.ndim
    return arr.transpose((nd - 1,) + tuple(range(nd - 1)))


def _coeff_axis_last(c: np.ndarray) -> np.ndarray:
    """View of an internal array with the coefficient axis moved to the end."""
    nd = c.ndim
    return c.transpose(tuple(range(1, nd)) + (0,))


def _factorials(m: int) -> np.ndarray:
    """``[0!, 1!, ..., (m-1)!]`` as floats."""
    return np.array([math.factorial(k) for k in range(m)], dtype=float)


# ---------------------------------------------------------------------------
# Backends: the numpy reference kernels above, or their compiled (numba) versions
# ---------------------------------------------------------------------------


def _series_solve_kernel(J: np.ndarray, J0inv: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Order by order ``D_m = J_0^{-1} (G_m - sum_{l=1..m} J_l D_{m-l})``.

    ``J`` (B, n, n, K), ``J0inv`` (B, n, n), ``G`` (B, n, K); returns ``D`` (B, n, K).
    """
    K = G.shape[-1]
    D = np.zeros_like(G)
    D[..., 0] = np.einsum("bij,bj->bi", J0inv, G[..., 0])
    for mth in range(1, K):
        rhs = G[..., mth] - np.einsum("bijl,bjl->bi", J[..., 1 : mth + 1], D[..., mth - 1 :: -1])
        D[..., mth] = np.einsum("bij,bj->bi", J0inv, rhs)
    return D


def _full3(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """Two ``(m, R|1, S)`` operands broadcast to ``(m * ..., R * S)`` 2-D arrays (copies where broadcast)."""
    m, _, S = a.shape
    R = b.shape[1] if a.shape[1] == 1 else a.shape[1]
    if a.shape[1] != R:
        a = np.broadcast_to(a, (m, R, S))
    if b.shape[1] != R:
        b = np.broadcast_to(b, (m, R, S))
    return a.reshape(m, R * S), b.reshape(m, R * S), (m, R, S)


class _NumpyKernels:
    """The pure-numpy reference kernels (coefficient-first arrays)."""

    name = "numpy"

    @staticmethod
    def mul(a, b):
        return _mul_kernel(a, b)

    @staticmethod
    def div(a, b):
        return _div_kernel(a, b)

    @staticmethod
    def mul3(a, b):
        m, ra, n = a.shape
        r = b.shape[1] if ra == 1 else ra
        dt = np.result_type(a, b)
        if dt.kind == "c" and r * n >= 128:
            # row updates c_(j..) += x_j y_(..m-j), the operand broadcast along the middle axis as x
            # (no copy of the broadcast; a real x times a complex y costs half a complex product)
            x, y = (a, b) if ra == 1 else (b, a)
            out = np.multiply(x[0], y, dtype=dt)
            for j in range(1, m):
                out[j:] += x[j] * y[: m - j]
            return out
        af, bf, shape = _full3(a, b)
        return _mul_kernel(af, bf).reshape(shape)

    @staticmethod
    def div3(a, b):
        af, bf, shape = _full3(a, b)
        return _div_kernel(af, bf).reshape(shape)

    @staticmethod
    def exp(u, c0=None):
        return _exp_kernel(u, c0)

    @staticmethod
    def sincos(u, hyperbolic):
        return _sincos_kernel(u, hyperbolic)

    @staticmethod
    def pow(u, p, c0=None):
        return _pow_kernel(u, p, c0)

    @staticmethod
    def pow_array(u, p):
        return _pow_array_kernel(u, p)

    @staticmethod
    def tan(u, hyperbolic):
        return _tan_kernel(u, hyperbolic)

    @staticmethod
    def series_solve(J, J0inv, G):
        return _series_solve_kernel(J, J0inv, G)


_F8, _C16 = np.dtype(np.float64), np.dtype(np.complex128)


_OTHER_FLOATS = frozenset(
    np.dtype(t) for t in (np.float16, np.float32, np.longdouble, np.complex64, np.clongdouble)
) - {_F8, _C16}


def _kernel_dtype(*arrays: Any) -> np.dtype | None:
    """float64 or complex128, the dtype a compiled kernel computes in; None for other precisions
    (float32, long double: left to the numpy kernels, which keep them)."""
    dt = _F8
    for x in arrays:
        xd = x.dtype
        if xd in _OTHER_FLOATS:
            return None
        if xd.kind == "c":
            dt = _C16
    return dt


def _ready(x: np.ndarray, dt: np.dtype) -> np.ndarray:
    """``x`` as a C-contiguous array of dtype ``dt`` (no copy when it already is one)."""
    if x.dtype == dt and x.flags.c_contiguous:
        return x
    return np.ascontiguousarray(x, dtype=dt)


@functools.cache
def _sc() -> Any:
    """The module of compiled kernels, imported on first use (numba's import and the loading of the
    compiled code cost a few tenths of a second: paid by the first series operation of the compiled
    backend, not by every ``import planners``)."""
    from . import _series_compiled

    return _series_compiled


class _CompiledKernels:
    """The same kernels compiled by numba (:mod:`planners._series_compiled`), same call signatures."""

    name = "compiled"

    @staticmethod
    def mul3(a, b):
        dt = _kernel_dtype(a, b)
        if dt is None:
            return _NumpyKernels.mul3(a, b)
        rows = b.shape[1] if a.shape[1] == 1 else a.shape[1]
        if dt == _C16 and (a.dtype == _F8 or b.dtype == _F8):
            # real times complex: the real kernel on the (re, im) pairs, the real factor duplicated
            x, y = (a, b) if b.dtype == _F8 else (b, a)
            xv = _ready(x, _C16).view(np.float64)
            y2 = np.repeat(_ready(y, _F8), 2, axis=2)
            out = np.empty((a.shape[0], rows, 2 * a.shape[2]), _F8)
            _sc().mul3(xv, y2, out)
            return out.view(_C16)
        a, b = _ready(a, dt), _ready(b, dt)
        out = np.empty((a.shape[0], rows, a.shape[2]), dt)
        _sc().mul3(a, b, out)
        return out

    @staticmethod
    def div3(a, b):
        dt = _kernel_dtype(a, b)
        if dt is None:
            return _NumpyKernels.div3(a, b)
        if dt == _C16 and b.dtype == _F8:
            # complex over real: the recurrence is linear in the numerator, run on its (re, im) pairs
            av = _ready(a, _C16).view(np.float64)
            b2 = np.repeat(_ready(b, _F8), 2, axis=2)
            out = np.empty((a.shape[0], b.shape[1] if a.shape[1] == 1 else a.shape[1], 2 * a.shape[2]), _F8)
            _sc().div3(av, b2, out)
            return out.view(_C16)
        a, b = _ready(a, dt), _ready(b, dt)
        out = np.empty((a.shape[0], b.shape[1] if a.shape[1] == 1 else a.shape[1], a.shape[2]), dt)
        _sc().div3(a, b, out)
        return out

    @staticmethod
    def mul(a, b):
        return _CompiledKernels.mul3(a[:, None], b[:, None])[:, 0]

    @staticmethod
    def div(a, b):
        return _CompiledKernels.div3(a[:, None], b[:, None])[:, 0]

    @staticmethod
    def exp(u, c0=None):
        dt = _kernel_dtype(u)
        if dt is None:
            return _exp_kernel(u, c0)
        u = _ready(u, dt)
        out = np.empty_like(u)
        out[0] = np.exp(u[0])
        _sc().exp2(u, out)
        if c0 is not None:
            out[0] = c0
        return out

    @staticmethod
    def sincos(u, hyperbolic):
        dt = _kernel_dtype(u)
        if dt is None:
            return _sincos_kernel(u, hyperbolic)
        u = _ready(u, dt)
        s, c = np.empty_like(u), np.empty_like(u)
        if hyperbolic:
            s[0], c[0] = np.sinh(u[0]), np.cosh(u[0])
        else:
            s[0], c[0] = np.sin(u[0]), np.cos(u[0])
        _sc().sincos2(u, s, c, 1.0 if hyperbolic else -1.0)
        return s, c

    @staticmethod
    def pow(u, p, c0=None):
        if _kernel_dtype(u) is None:
            return _pow_kernel(u, p, c0)
        if isinstance(p, complex) or np.iscomplexobj(p):
            dt = _C16
        else:
            dt = _kernel_dtype(u)
        p = complex(p) if dt == _C16 else float(p)
        u = _ready(u, dt)
        out = np.empty_like(u)
        out[0] = np.power(u[0], p) if c0 is None else c0
        _sc().pow2(u, p, out)
        return out

    @staticmethod
    def pow_array(u, p):
        dt = _kernel_dtype(u, p)
        if dt is None:
            return _pow_array_kernel(u, p)
        u, p = _ready(u, dt), _ready(p, dt)
        out = np.empty_like(u)
        out[0] = np.power(u[0], p)
        _sc().pow_array2(u, p, out)
        return out

    @staticmethod
    def tan(u, hyperbolic):
        dt = _kernel_dtype(u)
        if dt is None:
            return _tan_kernel(u, hyperbolic)
        u = _ready(u, dt)
        t = np.empty_like(u)
        t[0] = np.tanh(u[0]) if hyperbolic else np.tan(u[0])
        _sc().tan2(u, t, -1.0 if hyperbolic else 1.0)
        return t

    @staticmethod
    def series_solve(J, J0inv, G):
        if _kernel_dtype(J, J0inv, G) != _F8:
            return _series_solve_kernel(J, J0inv, G)
        dt = _F8
        D = np.empty(G.shape, dt)
        _sc().series_solve(_ready(J, dt), _ready(J0inv, dt), _ready(G, dt), D)
        return D


#: Environment variable selecting the kernels of the series arithmetic (read once, at import).
BACKEND_ENV = "GFLAT_SERIES_BACKEND"
#: The backends: ``"numpy"`` (the reference), ``"compiled"`` (numba kernels and programs) and ``"native"``
#: (numpy kernels, the stages as compiled programs in C: the default).
BACKENDS = ("numpy", "compiled", "native")
#: The backend when :data:`BACKEND_ENV` is unset.
DEFAULT_BACKEND = "native"


def _select_backend() -> str:
    """The backend named by :data:`BACKEND_ENV`: ``"native"`` (the default), ``"numpy"`` or ``"compiled"``.

    ``native`` is the default: the stages run as compiled programs in C, compiled once per machine in about
    a second by the system's C compiler and loaded in a millisecond (:mod:`planners._native`); without a C
    compiler the planner runs on the numpy path.  numba (``compiled``) costs 0.6-1 s per process to import
    and load its compiled code, and tens of seconds to compile it once on a fresh install.
    """
    want = os.environ.get(BACKEND_ENV, "").strip().lower() or DEFAULT_BACKEND
    if want not in BACKENDS:
        raise InputError(
            f"environment variable {BACKEND_ENV}={want!r}: the series backend must be one of {', '.join(BACKENDS)}"
        )
    if want == "compiled" and importlib.util.find_spec("numba") is None:
        raise InputError(
            f"environment variable {BACKEND_ENV}=compiled needs numba (pip install numba, or the 'fast' extra)"
        )
    return want


#: The series backend in use, chosen once at import from :data:`BACKEND_ENV`.
BACKEND = _select_backend()
_K = _CompiledKernels if BACKEND == "compiled" else _NumpyKernels


# ---------------------------------------------------------------------------
# The Series class
# ---------------------------------------------------------------------------


class Series:
    """Batch of truncated power series ``sum_k c_k (t - t0)^k + O((t - t0)^(n+1))``.

    Parameters
    ----------
    coeffs : array_like
        Shape ``batch_shape + (n + 1,)``: the last axis holds the normalised
        Taylor coefficients ``c_0 .. c_n`` (``c_k = f^(k)(t0) / k!``); the
        leading axes index expansion points.  Real or complex; integer input is
        converted to float64.  The data are copied.

    Notes
    -----
    Series are immutable.  They support ``+ - * / **`` with scalars, ndarrays
    (broadcast against the batch shape) and other series, and the numpy
    ufuncs ``add subtract multiply divide power float_power negative positive
    square reciprocal sqrt exp expm1 log log1p sin cos tan arcsin arccos
    arctan arctan2 hypot sinh cosh tanh``; other ufuncs raise
    :class:`TypeError`.  Operands of different orders are truncated to the
    smaller order.  Comparisons and truth testing raise :class:`TypeError`.

    A series of order ``n`` and batch shape ``S`` stores its coefficients
    coefficient-first, an array of shape ``(n + 1,) + S``; the shapes given
    in the methods' docstrings are those of the public :attr:`coeffs`, a
    transposed view of shape ``S + (n + 1,)``.

    Examples
    --------
    >>> t = Series.variable(0.0, 4)
    >>> np.round(np.exp(t).coeffs, 4)
    array([1.    , 1.    , 0.5   , 0.1667, 0.0417])
    """

    __slots__ = ("_c", "_memo")

    def __init__(self, coeffs: Any) -> None:
        arr = np.asarray(coeffs)
        if arr.dtype.kind in "biu":
            arr = arr.astype(np.float64)
        elif arr.dtype.kind not in "fc":
            raise TypeError(f"Series coefficients must be real or complex numbers, got dtype {arr.dtype}")
        if arr.ndim == 0 or arr.shape[-1] == 0:
            raise ValueError(f"Series coefficients need a last axis of length order + 1 >= 1, got shape {arr.shape}")
        c = np.array(_coeff_axis_first(arr), order="C", copy=True)
        c.flags.writeable = False
        self._c = c
        self._memo: dict | None = None

    @classmethod
    def _wrap(cls, c: np.ndarray) -> Series:
        """Wrap an internal coefficient-first array without copying."""
        s = object.__new__(cls)
        c.flags.writeable = False
        s._c = c
        s._memo = None
        return s

    # ------------------------------------------------------------------ construction

    @classmethod
    def constant(cls, values: Any, order: int) -> Series:
        """Constant series ``values + 0 t + ...``.

        Parameters
        ----------
        values : scalar or array_like
            Constant term; its shape becomes the batch shape.
        order : int
            Truncation order ``n >= 0``.

        Returns
        -------
        Series
        """
        v = np.asarray(values)
        if v.dtype.kind not in "fc":
            v = v.astype(np.float64)
        c = np.zeros((_check_order(order) + 1,) + v.shape, v.dtype)
        c[0] = v
        return cls._wrap(c)

    @classmethod
    def variable(cls, t0: Any, order: int) -> Series:
        """The series of ``t`` itself around ``t0``: coefficients ``[t0, 1, 0, ...]``.

        Parameters
        ----------
        t0 : scalar or array_like
            Expansion point(s); the shape becomes the batch shape.
        order : int
            Truncation order ``n >= 0`` (for ``n = 0`` only ``t0`` is kept).

        Returns
        -------
        Series
        """
        s = cls.constant(t0, order)
        if order >= 1:
            c = s._c.copy()
            c[1] = 1.0
            s = cls._wrap(c)
        return s

    @classmethod
    def from_derivatives(cls, derivs: Any) -> Series:
        """Series whose k-th derivative at ``t0`` is ``derivs[..., k]``.

        Parameters
        ----------
        derivs : array_like
            Shape ``batch_shape + (n + 1,)``; ``c_k = derivs[..., k] / k!``.

        Returns
        -------
        Series
        """
        d = np.asarray(derivs)
        if d.dtype.kind not in "fc":
            d = d.astype(np.float64)
        return cls(d / _factorials(d.shape[-1]))

    def zeros_like(self) -> Series:
        """Zero series with the same order, batch shape and dtype.

        Returns
        -------
        Series
            Order ``self.order``, batch shape ``self.batch_shape``, dtype ``self.dtype``: coefficients of
            shape ``batch_shape + (order + 1,)``, all zero.
        """
        return Series._wrap(np.zeros_like(self._c))

    def ones_like(self) -> Series:
        """Constant series 1 with the same order, batch shape and dtype.

        Returns
        -------
        Series
            Order ``self.order``, batch shape ``self.batch_shape``, dtype ``self.dtype``: coefficients of
            shape ``batch_shape + (order + 1,)``, ``c_0 = 1`` and ``c_k = 0`` for ``k >= 1``.
        """
        c = np.zeros_like(self._c)
        c[0] = 1
        return Series._wrap(c)

    def astype(self, dtype: Any) -> Series:
        """Copy with coefficients cast to ``dtype`` (e.g. ``complex`` for a complex step).

        Parameters
        ----------
        dtype : data-type
            Target dtype, anything :meth:`numpy.ndarray.astype` accepts; a float or complex dtype for the
            result to take part in series arithmetic.

        Returns
        -------
        Series
            Same order and batch shape: coefficients of shape ``batch_shape + (order + 1,)`` and dtype
            ``dtype``, always a copy.  Casting complex coefficients to a real dtype drops their imaginary
            parts (numpy's ``ComplexWarning``).
        """
        return Series._wrap(self._c.astype(dtype))

    # ------------------------------------------------------------------ properties

    @property
    def order(self) -> int:
        """Truncation order ``n`` (the series is exact up to ``(t - t0)^n``)."""
        return self._c.shape[0] - 1

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Shape of the batch of expansion points."""
        return self._c.shape[1:]

    @property
    def dtype(self) -> np.dtype:
        """Coefficient dtype (float or complex)."""
        return self._c.dtype

    @property
    def coeffs(self) -> np.ndarray:
        """Read-only coefficients, shape ``batch_shape + (n + 1,)``."""
        return _coeff_axis_last(self._c)

    @property
    def constant_term(self) -> Any:
        """``c_0``: value at the expansion points (array of batch shape, read-only)."""
        return self._c[0]

    def derivatives(self) -> np.ndarray:
        """Derivatives at the expansion points, ``f^(k)(t0) = k! c_k`` for ``k = 0 .. n``.

        The inverse of :meth:`from_derivatives`.

        Returns
        -------
        numpy.ndarray
            Shape ``batch_shape + (n + 1,)``: ``[..., k]`` is the k-th derivative at each expansion point;
            real or complex like the coefficients (a new, writable array).
        """
        return self.coeffs * _factorials(self._c.shape[0])

    @property
    def real(self) -> Series:
        """Series of the real parts of the coefficients."""
        return Series._wrap(np.ascontiguousarray(self._c.real))

    @property
    def imag(self) -> Series:
        """Series of the imaginary parts of the coefficients (zeros if real)."""
        return Series._wrap(np.ascontiguousarray(self._c.imag))

    # ------------------------------------------------------------------ representation

    def __repr__(self) -> str:
        opts = dict(precision=6, threshold=8, edgeitems=2)
        if self._c.size <= 12:
            body = "coeffs=" + np.array2string(self.coeffs, separator=", ", **opts).replace("\n", "")
        else:
            body = "c0=" + np.array2string(self._c[0], separator=", ", **opts).replace("\n", "")
        return f"Series(order={self.order}, batch_shape={self.batch_shape}, dtype={self.dtype}, {body})"

    # ------------------------------------------------------------------ no truth value

    def __bool__(self) -> bool:
        raise TypeError(_NO_TRUTH_MSG)

    def _no_compare(self, other: Any) -> Any:
        raise TypeError(_NO_TRUTH_MSG)

    __lt__ = __le__ = __gt__ = __ge__ = __eq__ = __ne__ = _no_compare
    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ batch handling

    def __getitem__(self, index: Any) -> Series:
        """Index the batch axes (numpy semantics); the coefficient axis is kept."""
        if not isinstance(index, tuple):
            index = (index,)
        sub = self.coeffs[index + (slice(None),)]
        return Series._wrap(_coeff_axis_first(sub))

    def __iter__(self):
        """Iterate over the first batch axis."""
        if not self.batch_shape:
            raise TypeError("iteration over a series with a 0-d batch")
        return (self[i] for i in range(self.batch_shape[0]))

    def reshape(self, *shape: Any) -> Series:
        """Series with the batch reshaped to ``shape`` (numpy semantics, ``-1`` allowed).

        The coefficient axis is kept; only the batch axes are reshaped.

        Parameters
        ----------
        *shape : int or tuple of int
            New batch shape, as separate ints (``s.reshape(2, 3)``) or one tuple or list
            (``s.reshape((2, 3))``); its size must equal the batch size ``prod(batch_shape)``.

        Returns
        -------
        Series
            Same order and dtype, batch shape ``shape``: coefficients of shape ``shape + (order + 1,)``
            (a view of the same read-only storage when numpy can reshape without a copy).

        Raises
        ------
        ValueError
            From numpy, when the size of ``shape`` differs from the batch size.
        """
        if len(shape) == 1 and isinstance(shape[0], (tuple, list)):
            shape = tuple(shape[0])
        return Series._wrap(self._c.reshape((self._c.shape[0],) + tuple(shape)))

    def broadcast_to(self, shape: Any) -> Series:
        """Series with the batch broadcast to ``shape`` (read-only view).

        Parameters
        ----------
        shape : int or tuple of int
            Target batch shape; ``batch_shape`` is broadcast to it by numpy's rules (leading axes added,
            axes of length 1 stretched).

        Returns
        -------
        Series
            Same order and dtype, batch shape ``shape``: coefficients of shape ``shape + (order + 1,)``,
            a read-only view of ``self``'s storage (no copy).

        Raises
        ------
        ValueError
            From numpy, when ``batch_shape`` cannot be broadcast to ``shape``.
        """
        shape = (shape,) if isinstance(shape, numbers.Integral) else tuple(shape)
        return Series._wrap(_bcast(self._c, shape))

    @staticmethod
    def _common_parts(items: Sequence[Series]) -> list[np.ndarray]:
        """Internal arrays of ``items`` truncated to their smallest order."""
        if not items or not all(isinstance(s, Series) for s in items):
            raise TypeError("expected a non-empty sequence of Series")
        m = min(s._c.shape[0] for s in items)
        return [s._c[:m] for s in items]

    @staticmethod
    def stack(series: Iterable[Series], axis: int = 0) -> Series:
        """Stack series along a new batch axis.

        Parameters
        ----------
        series : iterable of Series
            Series of orders ``n_i`` and batch shapes ``S_i`` (coefficients of shape ``S_i + (n_i + 1,)``),
            truncated to the smallest order ``n = min(n_i)`` and broadcast to a common batch shape ``S``.
        axis : int, optional
            Position of the new axis in the result's batch shape, ``-(len(S) + 1) <= axis <= len(S)``
            (default 0).

        Returns
        -------
        Series
            Order ``n``, batch shape ``S`` with an axis of length ``len(series)`` inserted at ``axis``:
            coefficients of shape ``batch_shape + (n + 1,)``; dtype the numpy result type of the inputs.

        Raises
        ------
        TypeError
            When ``series`` is empty or holds anything other than a :class:`Series`.
        ValueError
            From numpy, when the batch shapes cannot be broadcast together.
        numpy.exceptions.AxisError
            When ``axis`` is out of range for the result's batch.
        """
        parts = Series._common_parts(list(series))
        shape = np.broadcast_shapes(*(p.shape[1:] for p in parts))
        nd = len(shape) + 1
        if not -nd <= axis < nd:
            raise np.exceptions.AxisError(axis, nd)
        ax = axis + 1 if axis >= 0 else axis
        return Series._wrap(np.stack([_bcast(p, shape) for p in parts], axis=ax))

    @staticmethod
    def concatenate(series: Iterable[Series], axis: int = 0) -> Series:
        """Concatenate series along an existing batch axis (truncated to the smallest order).

        Parameters
        ----------
        series : iterable of Series
            Series of orders ``n_i`` and batch shapes ``S_i`` (coefficients of shape ``S_i + (n_i + 1,)``),
            truncated to the smallest order ``n = min(n_i)``.  The ``S_i`` must have the same number of axes
            and agree except along ``axis`` (no broadcasting).
        axis : int, optional
            Batch axis to join along, ``-d <= axis < d`` with ``d = len(S_0)`` the number of batch axes
            (default 0).

        Returns
        -------
        Series
            Order ``n``, batch shape ``S_0`` with its ``axis`` entry replaced by the sum of the lengths
            along ``axis``: coefficients of shape ``batch_shape + (n + 1,)``; dtype the numpy result type of
            the inputs.

        Raises
        ------
        TypeError
            When ``series`` is empty or holds anything other than a :class:`Series`.
        numpy.exceptions.AxisError
            When ``axis`` is out of range for the batch of the first series (always for a 0-d batch).
        ValueError
            From numpy, when the batch shapes differ other than along ``axis``.
        """
        parts = Series._common_parts(list(series))
        nd = parts[0].ndim - 1
        if not -nd <= axis < nd:
            raise np.exceptions.AxisError(axis, nd)
        ax = axis + 1 if axis >= 0 else axis
        return Series._wrap(np.concatenate(parts, axis=ax))

    def truncate(self, order: int) -> Series:
        """The same series truncated to a lower ``order`` (``0 <= order <= self.order``).

        Parameters
        ----------
        order : int
            New truncation order, ``0 <= order <= self.order``.

        Returns
        -------
        Series
            Coefficients ``c_0 .. c_order``, shape ``batch_shape + (order + 1,)``, same batch shape and dtype:
            a view of ``self``'s storage (no copy).

        Raises
        ------
        ValueError
            When ``order`` is negative or larger than ``self.order``.
        """
        if not 0 <= order <= self.order:
            raise ValueError(f"cannot truncate a series of order {self.order} to order {order}")
        return Series._wrap(self._c[: order + 1])

    def pad(self, order: int) -> Series:
        """The same polynomial as a series of higher ``order`` (zero coefficients appended).

        Padding adds no information: the new coefficients are zeros, not the
        true Taylor coefficients of the underlying function.

        Parameters
        ----------
        order : int
            New truncation order, ``order >= self.order``.

        Returns
        -------
        Series
            Same batch shape and dtype: coefficients of shape ``batch_shape + (order + 1,)``, those of
            ``self`` followed by ``order - self.order`` zeros (a new array).

        Raises
        ------
        ValueError
            When ``order < self.order``.
        """
        if order < self.order:
            raise ValueError(f"cannot pad a series of order {self.order} to order {order}")
        c = np.zeros((order + 1,) + self.batch_shape, self.dtype)
        c[: self._c.shape[0]] = self._c
        return Series._wrap(c)

    # ------------------------------------------------------------------ evaluation / calculus

    def eval(self, dt: Any) -> np.ndarray:
        """Evaluate the truncated polynomial at ``t0 + dt`` (Horner).

        Parameters
        ----------
        dt : scalar or array_like
            Offsets from the expansion points, broadcast against the batch shape.

        Returns
        -------
        numpy.ndarray
            Shape ``broadcast(batch_shape, shape(dt))``.
        """
        return self.eval_derivative(dt, 0)

    def eval_derivative(self, dt: Any, k: int) -> np.ndarray:
        """Evaluate the k-th derivative of the truncated polynomial at ``t0 + dt``.

        Parameters
        ----------
        dt : scalar or array_like
            Offsets, broadcast against the batch shape.
        k : int
            Derivative order (``k > order`` gives zeros).

        Returns
        -------
        numpy.ndarray
        """
        dt = np.asarray(dt)
        c = self._c
        m = c.shape[0]
        shape = np.broadcast_shapes(self.batch_shape, dt.shape)
        dtype = np.result_type(c, dt, 1.0)
        if k >= m:
            return np.zeros(shape, dtype)
        if k > 0:
            i = np.arange(m - k)
            fall = _factorials(m)[i + k] / _factorials(m - k)
            c = c[k:] * fall.reshape((-1,) + (1,) * (c.ndim - 1))
        r = np.zeros(shape, dtype) + c[-1]
        for j in range(c.shape[0] - 2, -1, -1):
            r = r * dt + c[j]
        return r

    def shift(self, dt: Any) -> Series:
        """Re-expand the truncated polynomial around ``t0 + dt`` (same order).

        Parameters
        ----------
        dt : scalar or array_like
            Offsets, broadcast against the batch shape.

        Returns
        -------
        Series
            Coefficients ``b_j = sum_{i >= j} C(i, j) c_i dt^(i-j)``.  Only the
            polynomial is shifted: the result is not the exact Taylor series of
            the underlying function at ``t0 + dt``.
        """
        dt = np.asarray(dt)
        m = self._c.shape[0]
        shape = np.broadcast_shapes(self.batch_shape, dt.shape)
        fact = _factorials(m).reshape((m,) + (1,) * len(shape))
        d = _bcast(self._c, shape) * fact
        out = np.array(d, dtype=np.result_type(d, dt), copy=True)
        e = np.ones(shape, out.dtype)
        for p in range(1, m):
            e = e * dt / p
            out[: m - p] += e * d[p:]
        return Series._wrap(out / fact)

    def derivative(self) -> Series:
        """Derivative ``d/dt`` as a series of order ``n - 1``: coefficients ``(k + 1) c_(k+1)``.

        Returns
        -------
        Series
            Order ``self.order - 1``, same batch shape and dtype: coefficients of shape
            ``batch_shape + (order,)``, ``[..., k] = (k + 1) c_(k+1)`` for ``k = 0 .. n - 1``.

        Raises
        ------
        ValueError
            When ``self.order < 1`` (an order-0 series carries no derivative information).
        """
        if self.order < 1:
            raise ValueError("an order-0 series carries no derivative information")
        return Series._wrap(_unflat(_diff_kernel(_flat(self._c)), self.batch_shape))

    def integral(self, c0: Any = 0.0) -> Series:
        """Antiderivative with constant term ``c0``, a series of order ``n + 1``.

        Parameters
        ----------
        c0 : scalar or array_like, optional
            Constant term, broadcast against the batch shape (default 0).

        Returns
        -------
        Series
            Order ``n + 1``, batch shape ``broadcast(batch_shape, shape(c0))``: coefficients of shape
            ``batch_shape + (n + 2,)``, ``r_0 = c0`` and ``r_k = c_(k-1) / k`` for ``k = 1 .. n + 1``;
            dtype the numpy result type of the coefficients and ``c0``.

        Raises
        ------
        ValueError
            From numpy, when ``shape(c0)`` does not broadcast against the batch shape.
        """
        c0 = np.asarray(c0, dtype=np.result_type(self._c, c0))
        shape = np.broadcast_shapes(self.batch_shape, c0.shape)
        r = _int_kernel(_flat(_bcast(self._c, shape)), np.broadcast_to(c0, shape).reshape(-1))
        return Series._wrap(_unflat(r, shape))

    @staticmethod
    def linear_combinations(weights: Any, items: Sequence[Any]) -> list[Series]:
        """Rows of a weight matrix applied to a list of series and constants, ``sum_j w[i, j] items[j]``.

        One matrix product on the coefficient-first storage (the aerodynamic model's coefficients
        are such combinations of its monomials, :meth:`gna.aero.TermTable.coefficients`); a complex
        stack is multiplied as its real and imaginary parts by the real weights.

        Parameters
        ----------
        weights : array_like, shape (p, q)
            Real weights.
        items : sequence of length q
            Series (at least one) and numeric constants (scalars or arrays broadcast against the
            batch); series are truncated to the smallest order.

        Returns
        -------
        list of Series
            ``p`` series, batch shapes broadcast.

        Raises
        ------
        TypeError
            No series among ``items``.
        """
        cs = [x._c if isinstance(x, Series) else None for x in items]
        consts = [x for x, c in zip(items, cs) if c is None]
        if len(consts) == len(cs):
            raise TypeError("linear_combinations needs at least one Series among the items")
        w = np.asarray(weights, dtype=float)
        m = min(c.shape[0] for c in cs if c is not None)
        shapes = {c.shape[1:] for c in cs if c is not None}
        shape = np.broadcast_shapes(*shapes, *(np.shape(x) for x in consts))
        dt = np.result_type(*{c.dtype for c in cs if c is not None}, *consts, 1.0)
        stack = np.zeros((len(items), m) + shape, dt)
        for i, (x, c) in enumerate(zip(items, cs)):
            if c is None:
                stack[i, 0] = x
            elif c.shape[1:] == shape:
                stack[i] = c[:m]
            else:  # leading batch axes of length 1: the assignment broadcasts them
                stack[i] = c[:m].reshape((m,) + (1,) * (len(shape) - c.ndim + 1) + c.shape[1:])
        flat = stack.reshape(len(items), -1)
        out = _small_gemm(w, flat.view(np.float64) if dt.kind == "c" else flat)
        out = out.view(dt).reshape((w.shape[0], m) + shape)
        return [Series._wrap(out[i]) for i in range(w.shape[0])]

    def compose(self, g: Series) -> Series:
        """Composition ``f(g(t)) = sum_k c_k g(t)^k`` (Horner in series arithmetic).

        Parameters
        ----------
        g : Series
            Inner series with zero constant term (exactly, at every batch point); its batch shape is
            broadcast against ``self``'s.

        Returns
        -------
        Series
            Order ``m = min(self.order, g.order)``, batch shape ``broadcast(self.batch_shape, g.batch_shape)``:
            coefficients of shape ``batch_shape + (m + 1,)``.  ``m`` truncated Cauchy products.

        Raises
        ------
        TypeError
            When ``g`` is not a :class:`Series`.
        ValueError
            When a constant term of ``g`` is non-zero; from numpy, when the batch shapes do not broadcast.

        References
        ----------
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        if not isinstance(g, Series):
            raise TypeError("compose expects a Series")
        if np.any(g._c[0] != 0):
            raise ValueError("compose requires an inner series with zero constant term")
        m = min(self._c.shape[0], g._c.shape[0])
        shape = np.broadcast_shapes(self.batch_shape, g.batch_shape)
        f = _flat(_bcast(self._c[:m], shape))
        gg = _flat(_bcast(g._c[:m], shape))
        r = np.zeros((m, f.shape[1]), np.result_type(f, gg))
        r[0] = f[m - 1]
        for k in range(m - 2, -1, -1):
            r = _K.mul(r, gg)
            r[0] += f[k]
        return Series._wrap(_unflat(r, shape))

    # ------------------------------------------------------------------ elementary functions

    def _apply(self, kernel: Callable[[np.ndarray], np.ndarray]) -> Series:
        return Series._wrap(_unflat(kernel(_flat(self._c)), self.batch_shape))

    def _memoised(self, key: str, compute: Callable[[], Any]) -> Any:
        if self._memo is None:
            self._memo = {}
        val = self._memo.get(key)
        if val is None:
            val = self._memo[key] = compute()
        return val

    def square(self) -> Series:
        """``self * self``, the truncated Cauchy product of the series with itself.

        ``c_k = sum_{j=0}^{k} u_j u_(k-j)`` for ``k = 0 .. n``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        u = _flat(self._c)
        return Series._wrap(_unflat(_K.mul(u, u), self.batch_shape))

    def reciprocal(self) -> Series:
        """``1 / self`` (requires a non-zero constant term).

        By the quotient recurrence ``q_0 = 1 / u_0``, ``q_k = -(sum_{j=1}^{k} u_j q_(k-j)) / u_0``.  Where
        ``u_0 = 0`` the coefficients are inf or nan (numpy's RuntimeWarning, no exception).

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        u = _flat(self._c)
        one = np.zeros_like(u)
        one[0] = 1.0
        return Series._wrap(_unflat(_K.div(one, u), self.batch_shape))

    def sqrt(self) -> Series:
        """Principal square root (requires a non-zero constant term).

        By the power recurrence of ``u c' = p u' c`` with ``p = 1/2``:
        ``k u_0 c_k = sum_{j=1}^{k} ((p + 1) j - k) u_j c_(k-j)``, ``c_0 = sqrt(u_0)`` (principal branch; nan
        for a negative real ``u_0``).  Where ``u_0 = 0`` the coefficients of order >= 1 are inf or nan
        (numpy's RuntimeWarning, no exception).

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        return self._apply(lambda u: _K.pow(u, 0.5, np.sqrt(u[0])))

    def exp(self) -> Series:
        """Exponential.

        By the recurrence of ``e' = u' e``: ``e_0 = exp(u_0)``, ``k e_k = sum_{j=1}^{k} j u_j e_(k-j)``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._apply(_K.exp)

    def expm1(self) -> Series:
        """``exp(self) - 1`` with an accurate constant term.

        The coefficients of order >= 1 are those of :meth:`exp` (same recurrence); the constant term is
        ``expm1(u_0)``, accurate for small ``u_0``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._apply(lambda u: _K.exp(u, np.expm1(u[0])))

    def _log_like(self, c0_fun: Callable, shift_one: bool) -> Series:
        def kernel(u: np.ndarray) -> np.ndarray:
            c0 = c0_fun(u[0])
            if u.shape[0] == 1:
                return c0[None]
            den = u[:-1]
            if shift_one:
                den = den.copy()
                den[0] += 1.0
            return _int_kernel(_K.div(_diff_kernel(u), den), c0)

        return self._apply(kernel)

    def log(self) -> Series:
        """Principal natural logarithm, ``log(c0) + integral(u'/u)``.

        ``u'/u`` (order ``n - 1``) is computed by the quotient recurrence and integrated, the constant term
        being ``numpy.log(u_0)``.  Requires ``u_0 != 0`` (else inf or nan coefficients); a negative real
        ``u_0`` gives nan (use a complex dtype for the principal branch).  No exception is raised.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._log_like(np.log, False)

    def log1p(self) -> Series:
        """``log(1 + self)``, ``log1p(c0) + integral(u'/(1+u))``.

        As :meth:`log`, with ``1 + u`` in the denominator and the constant term ``numpy.log1p(u_0)``
        (accurate for small ``u_0``).  Requires ``u_0 != -1``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._log_like(np.log1p, True)

    def sincos(self) -> tuple[Series, Series]:
        """``(sin(self), cos(self))`` by the coupled recurrence (memoised).

        ``s_0 = sin(u_0)``, ``c_0 = cos(u_0)``, ``k s_k = sum_{j=1}^{k} j u_j c_(k-j)`` and
        ``k c_k = -sum_{j=1}^{k} j u_j s_(k-j)`` (from ``s' = u' c``, ``c' = -u' s``).

        Returns
        -------
        tuple of (Series, Series)
            ``(sin(self), cos(self))``, each of the same order, batch shape and dtype as ``self``
            (coefficients of shape ``batch_shape + (order + 1,)``).  Memoised: every call returns the same
            two objects.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """

        def compute() -> tuple[Series, Series]:
            s, c = _K.sincos(_flat(self._c), hyperbolic=False)
            return Series._wrap(_unflat(s, self.batch_shape)), Series._wrap(_unflat(c, self.batch_shape))

        return self._memoised("sincos", compute)

    def sin(self) -> Series:
        """Sine.

        The first of :meth:`sincos`: the cosine is computed with it and memoised, so a following
        ``np.cos(self)`` costs nothing.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self.sincos()[0]

    def cos(self) -> Series:
        """Cosine.

        The second of :meth:`sincos`: the sine is computed with it and memoised.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self.sincos()[1]

    def sinhcosh(self) -> tuple[Series, Series]:
        """``(sinh(self), cosh(self))`` by the coupled recurrence (memoised).

        ``s_0 = sinh(u_0)``, ``c_0 = cosh(u_0)``, ``k s_k = sum_{j=1}^{k} j u_j c_(k-j)`` and
        ``k c_k = sum_{j=1}^{k} j u_j s_(k-j)`` (from ``s' = u' c``, ``c' = u' s``).

        Returns
        -------
        tuple of (Series, Series)
            ``(sinh(self), cosh(self))``, each of the same order, batch shape and dtype as ``self``
            (coefficients of shape ``batch_shape + (order + 1,)``).  Memoised: every call returns the same
            two objects.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """

        def compute() -> tuple[Series, Series]:
            s, c = _K.sincos(_flat(self._c), hyperbolic=True)
            return Series._wrap(_unflat(s, self.batch_shape)), Series._wrap(_unflat(c, self.batch_shape))

        return self._memoised("sinhcosh", compute)

    def sinh(self) -> Series:
        """Hyperbolic sine.

        The first of :meth:`sinhcosh`: the hyperbolic cosine is computed with it and memoised.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self.sinhcosh()[0]

    def cosh(self) -> Series:
        """Hyperbolic cosine.

        The second of :meth:`sinhcosh`: the hyperbolic sine is computed with it and memoised.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self.sinhcosh()[1]

    def tan(self) -> Series:
        """Tangent, by the recurrence of ``t' = (1 + t^2) u'``.

        ``t_0 = tan(u_0)``, ``k t_k = sum_{j=1}^{k} j u_j w_(k-j)`` with ``w = 1 + t^2``, i.e.
        ``w_k = [k = 0] + sum_{j=0}^{k} t_j t_(k-j)``, updated order by order.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._apply(lambda u: _K.tan(u, hyperbolic=False))

    def tanh(self) -> Series:
        """Hyperbolic tangent, by the recurrence of ``t' = (1 - t^2) u'``.

        As :meth:`tan` with ``t_0 = tanh(u_0)`` and ``w = 1 - t^2``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """
        return self._apply(lambda u: _K.tan(u, hyperbolic=True))

    def arctan(self) -> Series:
        """Arc tangent, ``arctan(c0) + integral(u'/(1 + u^2))``.

        ``1 + u^2`` by the Cauchy product, ``u'/(1 + u^2)`` (order ``n - 1``) by the quotient recurrence,
        then integrated with the constant term ``numpy.arctan(u_0)``.  Requires ``1 + u_0^2 != 0`` (for
        complex ``u_0``: ``u_0 != +-i``).

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        """

        def kernel(u: np.ndarray) -> np.ndarray:
            c0 = np.arctan(u[0])
            if u.shape[0] == 1:
                return c0[None]
            v = u[:-1]
            den = _K.mul(v, v)
            den[0] += 1.0
            return _int_kernel(_K.div(_diff_kernel(u), den), c0)

        return self._apply(kernel)

    def _arcsin_like(self, c0_fun: Callable, sign: float) -> Series:
        def kernel(u: np.ndarray) -> np.ndarray:
            c0 = c0_fun(u[0])
            if u.shape[0] == 1:
                return c0[None]
            v = u[:-1]
            w = -_K.mul(v, v)
            w[0] += 1.0
            d = _K.mul(_diff_kernel(u), _K.pow(w, -0.5))
            if sign < 0:
                d = -d
            return _int_kernel(d, c0)

        return self._apply(kernel)

    def arcsin(self) -> Series:
        """Arc sine, ``arcsin(c0) + integral(u' (1 - u^2)^(-1/2))``.

        ``1 - u^2`` by the Cauchy product, its power ``-1/2`` by the power recurrence (see :meth:`sqrt`),
        times ``u'`` and integrated with the constant term ``numpy.arcsin(u_0)``.  Requires ``u_0^2 != 1``;
        a real ``|u_0| > 1`` gives nan coefficients (numpy's RuntimeWarning, no exception).

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        return self._arcsin_like(np.arcsin, 1.0)

    def arccos(self) -> Series:
        """Arc cosine, ``arccos(c0) - integral(u' (1 - u^2)^(-1/2))``.

        As :meth:`arcsin` with the sign of the integral flipped and the constant term
        ``numpy.arccos(u_0)``.

        Returns
        -------
        Series
            Same order, batch shape and dtype as ``self``: coefficients of shape
            ``batch_shape + (order + 1,)``.

        References
        ----------
        Griewank & Walther, *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 13 (Taylor coefficient propagation).
        Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed., §4.7 (manipulation of power series).
        """
        return self._arcsin_like(np.arccos, -1.0)

    # ------------------------------------------------------------------ operators

    def __neg__(self) -> Series:
        return Series._wrap(-self._c)

    def __pos__(self) -> Series:
        return self

    def __add__(self, other: Any) -> Series:
        return _add(self, other)

    def __radd__(self, other: Any) -> Series:
        return _add(other, self)

    def __sub__(self, other: Any) -> Series:
        return _sub(self, other)

    def __rsub__(self, other: Any) -> Series:
        return _sub(other, self)

    def __mul__(self, other: Any) -> Series:
        return _mul(self, other)

    def __rmul__(self, other: Any) -> Series:
        return _mul(other, self)

    def __truediv__(self, other: Any) -> Series:
        return _div(self, other)

    def __rtruediv__(self, other: Any) -> Series:
        return _div(other, self)

    def __pow__(self, other: Any, modulo: Any = None) -> Series:
        if modulo is not None:
            return NotImplemented
        return _pow(self, other)

    def __rpow__(self, other: Any) -> Series:
        return _pow(other, self)

    # ------------------------------------------------------------------ numpy dispatch

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        """numpy ufunc protocol: ``np.sin(s)``, ``arr * s``, ``np.arctan2(s, 1.0)``, ..."""
        if ufunc in _COMPARISON_UFUNCS:
            raise TypeError(_NO_TRUTH_MSG)
        impl = _UFUNCS.get(ufunc)
        if method != "__call__" or kwargs or impl is None:
            return NotImplemented
        return impl(*inputs)


def _check_order(order: Any) -> int:
    if not isinstance(order, numbers.Integral) or order < 0:
        raise ValueError(f"order must be a non-negative integer, got {order!r}")
    return int(order)


# ---------------------------------------------------------------------------
# Binary operations (either operand may be a constant; at least one is a Series)
# ---------------------------------------------------------------------------


def _pair(a: Series, b: Series) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """Truncate to the common order and broadcast batches (internal layout views)."""
    m = min(a._c.shape[0], b._c.shape[0])
    shape = a._c.shape[1:]
    if b._c.shape[1:] == shape:
        return a._c[:m], b._c[:m], shape
    shape = np.broadcast_shapes(shape, b._c.shape[1:])
    return _bcast(a._c[:m], shape), _bcast(b._c[:m], shape), shape


def _pair3(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """Internal arrays truncated to the common order as ``(m, R|1, S)`` operands, and the batch shape.

    Equal batches give ``R = 1``; a batch that is a trailing part of the other (``(nodes,)`` against
    ``(n + 1, nodes)``) is broadcast along the middle axis without a copy; other broadcasts are
    materialised.
    """
    m = min(a.shape[0], b.shape[0])
    sa, sb = a.shape[1:], b.shape[1:]
    if sa == sb:
        n = math.prod(sa)
        return a[:m].reshape(m, 1, n), b[:m].reshape(m, 1, n), sa
    la, lb = len(sa), len(sb)
    if lb < la and sa[la - lb :] == sb:
        n = math.prod(sb)
        return a[:m].reshape(m, -1, n) if n else a[:m].reshape(m, 1, 0), b[:m].reshape(m, 1, n), sa
    if la < lb and sb[lb - la :] == sa:
        n = math.prod(sa)
        return a[:m].reshape(m, 1, n), b[:m].reshape(m, -1, n) if n else b[:m].reshape(m, 1, 0), sb
    shape = np.broadcast_shapes(sa, sb)
    n = math.prod(shape)
    return (_bcast(a[:m], shape).reshape(m, 1, n), _bcast(b[:m], shape).reshape(m, 1, n), shape)


def _operands(x: Any, y: Any) -> tuple[Any, Any] | None:
    """Classify operands: Series stay, other numeric values become constants."""
    if not isinstance(x, Series):
        x = _as_constant(x)
    if not isinstance(y, Series):
        y = _as_constant(y)
    if x is None or y is None:
        return None
    return x, y


def _plus_constant(s_c: np.ndarray, const: Any) -> np.ndarray:
    """Internal array ``s_c`` plus a constant in the constant term (new array)."""
    if type(const) is float or type(const) is int:
        out = s_c.copy()
        out[0] += const
        return out
    shape = s_c.shape[1:]
    if np.ndim(const):
        shape = np.broadcast_shapes(shape, np.shape(const))
    out = np.array(_bcast(s_c, shape), dtype=np.result_type(s_c, const), copy=True)
    out[0] += const
    return out


def _add_sub(a: np.ndarray, b: np.ndarray, subtract: bool) -> np.ndarray:
    """Sum (difference) of two internal arrays, truncated to the common order, batches broadcast."""
    a3, b3, shape = _pair3(a, b)
    r = np.subtract(a3, b3) if subtract else np.add(a3, b3)
    return r.reshape((r.shape[0],) + shape)


def _add(x: Any, y: Any) -> Series:
    if type(x) is Series:
        if type(y) is Series:
            return Series._wrap(_add_sub(x._c, y._c, False))
        if type(y) is float:
            return Series._wrap(_plus_constant(x._c, y))
    ops = _operands(x, y)
    if ops is None:
        return NotImplemented
    x, y = ops
    if isinstance(x, Series) and isinstance(y, Series):
        return Series._wrap(_add_sub(x._c, y._c, False))
    if isinstance(x, Series):
        return Series._wrap(_plus_constant(x._c, y))
    return Series._wrap(_plus_constant(y._c, x))


def _sub(x: Any, y: Any) -> Series:
    if type(x) is Series and type(y) is Series:
        return Series._wrap(_add_sub(x._c, y._c, True))
    ops = _operands(x, y)
    if ops is None:
        return NotImplemented
    x, y = ops
    if isinstance(x, Series) and isinstance(y, Series):
        return Series._wrap(_add_sub(x._c, y._c, True))
    if isinstance(x, Series):
        return Series._wrap(_plus_constant(x._c, np.negative(y)))
    return Series._wrap(_plus_constant(-y._c, x))


def _scale(s: Series, const: Any, divide: bool = False) -> Series:
    """Coefficient-wise product (quotient) with a constant broadcast over the batch."""
    return Series._wrap(_scale_array(s._c, const, divide))


def _scale_array(c: np.ndarray, const: Any, divide: bool = False) -> np.ndarray:
    """Internal array ``c`` times (over) a constant broadcast over the batch (new array)."""
    if type(const) is float or type(const) is int:
        return c / const if divide else c * const
    nb = c.ndim - 1
    nd = max(nb, np.ndim(const))
    if nd > nb:
        c = _bcast(c, (1,) * (nd - nb) + c.shape[1:])
    return c / const if divide else c * const


def _series_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cauchy product of two internal arrays (common order, batches broadcast)."""
    a3, b3, shape = _pair3(a, b)
    r = _K.mul3(a3, b3)
    return r.reshape((r.shape[0],) + shape)


def _series_div(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quotient of two internal arrays (common order, batches broadcast)."""
    a3, b3, shape = _pair3(a, b)
    r = _K.div3(a3, b3)
    return r.reshape((r.shape[0],) + shape)


def _mul(x: Any, y: Any) -> Series:
    if type(x) is Series:
        if type(y) is Series:
            return Series._wrap(_series_mul(x._c, y._c))
        if type(y) is float:
            return Series._wrap(x._c * y)
    elif type(y) is Series and type(x) is float:
        return Series._wrap(y._c * x)
    ops = _operands(x, y)
    if ops is None:
        return NotImplemented
    x, y = ops
    if isinstance(x, Series) and isinstance(y, Series):
        return Series._wrap(_series_mul(x._c, y._c))
    if isinstance(x, Series):
        return _scale(x, y)
    return _scale(y, x)


def _constant_like(const: Any, s: Series) -> Series:
    """Constant series of the order of ``s``."""
    v = np.asarray(const)
    c = np.zeros((s._c.shape[0],) + v.shape, np.result_type(v, 1.0))
    c[0] = v
    return Series._wrap(c)


def _div(x: Any, y: Any) -> Series:
    if type(y) is Series:
        if type(x) is Series:
            return Series._wrap(_series_div(x._c, y._c))
    elif type(x) is Series and type(y) is float:
        return Series._wrap(x._c / y)
    ops = _operands(x, y)
    if ops is None:
        return NotImplemented
    x, y = ops
    if isinstance(y, Series):
        if not isinstance(x, Series):
            x = _constant_like(x, y)
        return Series._wrap(_series_div(x._c, y._c))
    return _scale(x, y, divide=True)


def _int_power(s: Series, p: int) -> Series:
    """Integer power by binary exponentiation (exact; no condition on c0)."""
    if p < 0:
        return _int_power(s, -p).reciprocal()
    u = _flat(s._c)
    result = None
    base = u
    while p:
        if p & 1:
            result = base if result is None else _K.mul(result, base)
        p >>= 1
        if p:
            base = _K.mul(base, base)
    if result is None:
        result = np.zeros_like(u)
        result[0] = 1.0
    elif result is u:
        return s
    return Series._wrap(_unflat(result, s.batch_shape))


def _pow(x: Any, y: Any) -> Series:
    ops = _operands(x, y)
    if ops is None:
        return NotImplemented
    x, y = ops
    if isinstance(y, Series):
        # x ** y = exp(y log x); x may be a constant or a series
        log_x = np.log(x) if not isinstance(x, Series) else x.log()
        return (y * log_x).exp()
    p = np.asarray(y)
    if p.size == 1 and p.ndim <= len(x.batch_shape):
        p = p.reshape(()).item()
        if isinstance(p, complex) and p.imag == 0:
            p = p.real
        if isinstance(p, (bool, int)) or (isinstance(p, float) and p.is_integer() and abs(p) < 2**31):
            return _int_power(x, int(p))
        if p == 0.5:
            return x.sqrt()
        return x._apply(lambda u: _K.pow(u, p))
    shape = np.broadcast_shapes(x.batch_shape, p.shape)
    u = _flat(_bcast(x._c, shape))
    return Series._wrap(_unflat(_K.pow_array(u, np.broadcast_to(p, shape).reshape(-1)), shape))


def _promote(x: Any, like: Series) -> Series | None:
    if isinstance(x, Series):
        return x
    c = _as_constant(x)
    return None if c is None else _constant_like(c, like)


def _arctan2(y: Any, x: Any) -> Series:
    """``arctan2(y, x) = arctan2(y0, x0) + integral((x y' - y x') / (x^2 + y^2))``."""
    like = y if isinstance(y, Series) else x
    y, x = _promote(y, like), _promote(x, like)
    if y is None or x is None:
        return NotImplemented
    ys, xs, shape = _pair(y, x)
    yf, xf = _flat(ys), _flat(xs)
    m = yf.shape[0]
    c0 = _atan2_constant(yf[0], xf[0])
    if m == 1:
        return Series._wrap(_unflat(c0[None], shape))
    y1, x1 = yf[:-1], xf[:-1]
    num = _K.mul(x1, _diff_kernel(yf)) - _K.mul(y1, _diff_kernel(xf))
    den = _K.mul(x1, x1) + _K.mul(y1, y1)
    return Series._wrap(_unflat(_int_kernel(_K.div(num, den), c0), shape))


def _hypot(x: Any, y: Any) -> Series:
    """``sqrt(x^2 + y^2)`` (analytic, principal root)."""
    like = x if isinstance(x, Series) else y
    x, y = _promote(x, like), _promote(y, like)
    if x is None or y is None:
        return NotImplemented
    return (x * x + y * y).sqrt()


def _unary(name: str) -> Callable[[Any], Any]:
    def impl(x: Any) -> Any:
        return getattr(x, name)() if isinstance(x, Series) else NotImplemented

    return impl


_UFUNCS: dict[np.ufunc, Callable[..., Any]] = {
    np.add: _add,
    np.subtract: _sub,
    np.multiply: _mul,
    np.divide: _div,
    np.power: _pow,
    np.float_power: _pow,
    np.negative: lambda x: -x,
    np.positive: lambda x: x,
    np.arctan2: _arctan2,
    np.hypot: _hypot,
    **{
        getattr(np, name): _unary(name)
        for name in (
            "square",
            "reciprocal",
            "sqrt",
            "exp",
            "expm1",
            "log",
            "log1p",
            "sin",
            "cos",
            "tan",
            "arcsin",
            "arccos",
            "arctan",
            "sinh",
            "cosh",
            "tanh",
        )
    },
}

_COMPARISON_UFUNCS = frozenset({np.less, np.less_equal, np.greater, np.greater_equal, np.equal, np.not_equal})
