"""The compiled evaluator of traced stage programs (:mod:`planners.program`): one numba function for the
residual series and one for the residual with its exact tangent, each running a whole program in one call.

A program is data, not code: an integer table, one row ``(op, out, a, b, k, unk)`` per instruction of the
traced residual (the operation, its output and operand registers, a parameter index, whether it depends on
the unknowns), and a float vector of parameters (the aircraft's numbers, the aerodynamic weights).  So these
two functions, compiled once per machine (``cache=True``; numba keys its cache by this file and its own
version), serve every stage residual of every aircraft and scenario: there is nothing to compile per
aircraft or per structure, and a plan never waits for a compiler after the first use on a machine.

Registers hold truncated power series on a batch of nodes, coefficient first, ``(M, S)``: M coefficients
(working order + 1), S nodes.  The recurrences are those of :mod:`planners.series` (Cauchy product,
quotient, sqrt, exp, log, sin/cos, sinh/cosh, real powers, arctan, tan).  The tangent is forward mode on
series in real arithmetic: one tangent series per unknown (the seed of unknown j is the constant series 1
in direction j), propagated by the derivative rules of each operation, so the result is the Jacobian
series ``d r_a / d u_b`` (exact; no complex step).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath=False)

# opcodes (planners.program writes them)
INPUT, DATA, ADD, SUB, MUL, DIV, NEG, ADDC, RSUBC, MULC, DIVC, RDIVC = range(12)
SQRT, EXP, LOG, SINCOS, SINHCOSH, POW, ARCTAN, CONST, AXPY, ZERO, TAN, COPY = range(12, 24)


@njit(**_JIT)
def _mul(a, b, out):
    M, S = out.shape
    for k in range(M):
        for i in range(S):
            acc = 0.0
            for j in range(k + 1):
                acc += a[j, i] * b[k - j, i]
            out[k, i] = acc


@njit(**_JIT)
def _mul_add(a, b, out):
    """out += a * b (Cauchy)."""
    M, S = out.shape
    for k in range(M):
        for i in range(S):
            acc = 0.0
            for j in range(k + 1):
                acc += a[j, i] * b[k - j, i]
            out[k, i] += acc


@njit(**_JIT)
def _div(a, b, out):
    M, S = out.shape
    for k in range(M):
        for i in range(S):
            acc = a[k, i]
            for j in range(1, k + 1):
                acc -= b[j, i] * out[k - j, i]
            out[k, i] = acc / b[0, i]


@njit(**_JIT)
def _sqrt(u, out):
    M, S = out.shape
    for i in range(S):
        out[0, i] = np.sqrt(u[0, i])
    for k in range(1, M):
        for i in range(S):
            acc = u[k, i]
            for j in range(1, k):
                acc -= out[j, i] * out[k - j, i]
            out[k, i] = acc / (2.0 * out[0, i])


@njit(**_JIT)
def _exp(u, out):
    M, S = out.shape
    for i in range(S):
        out[0, i] = np.exp(u[0, i])
    for k in range(1, M):
        for i in range(S):
            acc = 0.0
            for j in range(1, k + 1):
                acc += j * u[j, i] * out[k - j, i]
            out[k, i] = acc / k


@njit(**_JIT)
def _log(u, out):
    M, S = out.shape
    for i in range(S):
        out[0, i] = np.log(u[0, i])
    for k in range(1, M):
        for i in range(S):
            acc = 0.0
            for j in range(1, k):
                acc += j * out[j, i] * u[k - j, i]
            out[k, i] = (u[k, i] - acc / k) / u[0, i]


@njit(**_JIT)
def _sincos(u, s, c, sign):
    """sin/cos (sign -1) or sinh/cosh (sign +1)."""
    M, S = s.shape
    for i in range(S):
        if sign < 0:
            s[0, i] = np.sin(u[0, i])
            c[0, i] = np.cos(u[0, i])
        else:
            s[0, i] = np.sinh(u[0, i])
            c[0, i] = np.cosh(u[0, i])
    for k in range(1, M):
        for i in range(S):
            ss = 0.0
            cc = 0.0
            for j in range(1, k + 1):
                v = j * u[j, i]
                ss += v * c[k - j, i]
                cc += v * s[k - j, i]
            s[k, i] = ss / k
            c[k, i] = sign * cc / k


@njit(**_JIT)
def _pow(u, p, out):
    M, S = out.shape
    for i in range(S):
        out[0, i] = u[0, i] ** p
    for k in range(1, M):
        for i in range(S):
            acc = 0.0
            for j in range(1, k + 1):
                acc += (p * j - (k - j)) * u[j, i] * out[k - j, i]
            out[k, i] = acc / (k * u[0, i])


@njit(**_JIT)
def _arctan(u, out):
    """arctan(u) = arctan(u0) + integral(u' / (1 + u^2))."""
    M, S = out.shape
    w = np.empty((M, S))
    _mul(u, u, w)
    for i in range(S):
        w[0, i] += 1.0
        out[0, i] = np.arctan(u[0, i])
    # q = u' / w at order M - 2, out_k = q_{k-1} / k
    q = np.empty((max(M - 1, 1), S))
    for k in range(M - 1):
        for i in range(S):
            acc = (k + 1) * u[k + 1, i]
            for j in range(1, k + 1):
                acc -= w[j, i] * q[k - j, i]
            q[k, i] = acc / w[0, i]
    for k in range(1, M):
        for i in range(S):
            out[k, i] = q[k - 1, i] / k


@njit(**_JIT)
def _tan(u, out):
    """tan(u) = sin(u) / cos(u)."""
    M, S = out.shape
    s = np.empty((M, S))
    c = np.empty((M, S))
    _sincos(u, s, c, -1.0)
    _div(s, c, out)


@njit(**_JIT)
def _value_op(op, o, a, b, k, W, p, x, data):
    """Instruction ``(op, o, a, b, k)`` on the registers ``W``."""
    if op == INPUT:
        W[o, :, :] = x[a]
    elif op == DATA:
        W[o, :, :] = data[a]
    elif op == ADD:
        W[o, :, :] = W[a] + W[b]
    elif op == SUB:
        W[o, :, :] = W[a] - W[b]
    elif op == MUL:
        _mul(W[a], W[b], W[o])
    elif op == DIV:
        _div(W[a], W[b], W[o])
    elif op == NEG:
        W[o, :, :] = -W[a]
    elif op == ADDC:
        W[o, :, :] = W[a]
        W[o, 0, :] += p[k]
    elif op == RSUBC:
        W[o, :, :] = -W[a]
        W[o, 0, :] += p[k]
    elif op == MULC:
        W[o, :, :] = W[a] * p[k]
    elif op == DIVC:
        W[o, :, :] = W[a] / p[k]
    elif op == RDIVC:
        W[o, :, :] = 0.0
        W[o, 0, :] = p[k]
        _div(W[o].copy(), W[a], W[o])
    elif op == SQRT:
        _sqrt(W[a], W[o])
    elif op == EXP:
        _exp(W[a], W[o])
    elif op == LOG:
        _log(W[a], W[o])
    elif op == SINCOS:
        _sincos(W[a], W[o], W[b], -1.0)
    elif op == SINHCOSH:
        _sincos(W[a], W[o], W[b], 1.0)
    elif op == POW:
        _pow(W[a], p[k], W[o])
    elif op == ARCTAN:
        _arctan(W[a], W[o])
    elif op == CONST:
        W[o, :, :] = 0.0
        W[o, 0, :] = p[k]
    elif op == AXPY:
        W[o, :, :] = W[a] + p[k] * W[b]
    elif op == ZERO:
        W[o, :, :] = 0.0
    elif op == TAN:
        _tan(W[a], W[o])
    elif op == COPY:
        W[o, :, :] = W[a]


@njit(**_JIT)
def evaluate(code, p, x, data, nreg, outs):
    """The residual series of a program.

    Parameters
    ----------
    code : int64 array (I, 6)
        ``(op, out, a, b, k, unk)`` per instruction.
    p : float64 array (P,)
        Parameters.
    x : float64 array (n, M, S)
        The unknowns' coefficients, coefficient first.
    data : float64 array (D, M, S)
        The data series (flat outputs, earlier stages, neglected values).
    nreg : int
        Registers.
    outs : int64 array (neq,)
        Registers of the residuals.

    Returns
    -------
    float64 array (neq, M, S)
    """
    M, S = x.shape[1], x.shape[2]
    W = np.empty((nreg, M, S))
    for i in range(code.shape[0]):
        _value_op(code[i, 0], code[i, 1], code[i, 2], code[i, 3], code[i, 4], W, p, x, data)
    res = np.empty((outs.shape[0], M, S))
    for j in range(outs.shape[0]):
        res[j] = W[outs[j]]
    return res


@njit(**_JIT)
def evaluate_tangent(code, p, x, data, nreg, outs, outs_unk):
    """The residual series and its Jacobian series ``d r_a / d u_b`` (forward mode on series, real arithmetic).

    Parameters as :func:`evaluate`; ``outs_unk`` (neq,) int64: 1 where a residual depends on the unknowns.

    Returns
    -------
    (float64 array (neq, M, S), float64 array (neq, n, M, S))
    """
    n, M, S = x.shape
    W = np.empty((nreg, M, S))
    T = np.empty((nreg, n, M, S))
    tmp = np.empty((M, S))
    tmp2 = np.empty((M, S))
    for i in range(code.shape[0]):
        op, o, a, b, k, unk = code[i, 0], code[i, 1], code[i, 2], code[i, 3], code[i, 4], code[i, 5]
        _value_op(op, o, a, b, k, W, p, x, data)
        if unk == 0:
            continue
        # unk: 1 = only operand a carries a tangent, 2 = only b, 3 = both
        ta = unk == 1 or unk == 3
        tb = unk == 2 or unk == 3
        for d in range(n):
            To = T[o, d]
            if op == INPUT:
                To[:, :] = 0.0
                if a == d:
                    To[0, :] = 1.0
            elif op == ADD or op == SUB:
                sgn = 1.0 if op == ADD else -1.0
                if ta and tb:
                    To[:, :] = T[a, d] + sgn * T[b, d]
                elif ta:
                    To[:, :] = T[a, d]
                else:
                    To[:, :] = sgn * T[b, d]
            elif op == MUL:
                To[:, :] = 0.0
                if ta:
                    _mul_add(T[a, d], W[b], To)
                if tb:
                    _mul_add(W[a], T[b, d], To)
            elif op == DIV:
                # (da - q db) / b
                if tb:
                    _mul(W[o], T[b, d], tmp)
                    if ta:
                        tmp2[:, :] = T[a, d] - tmp
                    else:
                        tmp2[:, :] = -tmp
                else:
                    tmp2[:, :] = T[a, d]
                _div(tmp2, W[b], To)
            elif op == NEG or op == RSUBC:
                To[:, :] = -T[a, d]
            elif op == ADDC or op == COPY:
                To[:, :] = T[a, d]
            elif op == MULC:
                To[:, :] = T[a, d] * p[k]
            elif op == DIVC:
                To[:, :] = T[a, d] / p[k]
            elif op == RDIVC:
                # c = p / a: dc = -c da / a
                _mul(W[o], T[a, d], tmp)
                _div(tmp, W[a], To)
                To[:, :] = -To
            elif op == SQRT:
                # dc = du / (2 c)
                _div(T[a, d], W[o], To)
                To[:, :] = 0.5 * To
            elif op == EXP:
                _mul(W[o], T[a, d], To)
            elif op == LOG:
                _div(T[a, d], W[a], To)
            elif op == SINCOS or op == SINHCOSH:
                _mul(W[b], T[a, d], To)  # d sin = cos du
                _mul(W[o], T[a, d], T[b, d])  # d cos = -sin du, d cosh = sinh du
                if op == SINCOS:
                    T[b, d][:, :] = -T[b, d]
            elif op == POW:
                # dc = p c du / u
                _mul(W[o], T[a, d], tmp)
                _div(tmp, W[a], To)
                To[:, :] = p[k] * To
            elif op == ARCTAN:
                _mul(W[a], W[a], tmp)
                tmp[0, :] += 1.0
                _div(T[a, d], tmp, To)
            elif op == TAN:
                _mul(W[o], W[o], tmp)
                tmp[0, :] += 1.0
                _mul(tmp, T[a, d], To)
            elif op == AXPY:
                if ta and tb:
                    To[:, :] = T[a, d] + p[k] * T[b, d]
                elif ta:
                    To[:, :] = T[a, d]
                else:
                    To[:, :] = p[k] * T[b, d]
    neq = outs.shape[0]
    res = np.empty((neq, M, S))
    jac = np.zeros((neq, n, M, S))
    for j in range(neq):
        res[j] = W[outs[j]]
        if outs_unk[j]:
            jac[j] = T[outs[j]]
    return res, jac


@njit(**_JIT)
def series_solve(J, J0inv, G):
    """Solve ``J(t) D(t) = G(t)`` order by order: ``D_m = J0^-1 (G_m - sum_{l=1..m} J_l D_{m-l})``.

    Parameters
    ----------
    J : float64 array (neq, n, M, S)
        Jacobian series, coefficient first.
    J0inv : float64 array (S, n, n)
        Inverse of the constant term at each node.
    G : float64 array (n, M, S)
        Right-hand side.

    Returns
    -------
    float64 array (n, M, S)
    """
    n, M, S = G.shape
    D = np.empty((n, M, S))
    r = np.empty(n)
    for i in range(S):
        for m in range(M):
            for a in range(n):
                acc = G[a, m, i]
                for l in range(1, m + 1):
                    for b in range(n):
                        acc -= J[a, b, l, i] * D[b, m - l, i]
                r[a] = acc
            for a in range(n):
                acc = 0.0
                for b in range(n):
                    acc += J0inv[i, a, b] * r[b]
                D[a, m, i] = acc
    return D
