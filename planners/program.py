"""Stage residuals traced once into programs and evaluated whole by compiled code (the compiled planning layer).

Newton's method on series (:func:`planners.newton.newton_series`) evaluates each stage residual dozens of
times per plan: the model code of :mod:`gna` (written once, plain arithmetic) runs on :class:`Series`, and
most of an evaluation's time is the interpreter (dispatch, named tuples, the kernels' numpy calls), not
arithmetic.  Here the residual is run once per plan on *traced* series (:class:`Sym`), which record every
operation into a program: a table of instructions on registers plus a vector of parameters.  Every number
the model code brings (the aircraft's mass, geometry, the aerodynamic weights, the atmosphere's
constants) is a parameter, not a literal; the data (flat outputs, earlier stages' series, the neglected
values) are inputs; so the program's table depends on the *structure* of the aircraft and scenario only,
and the evaluator (:mod:`planners._program_kernels`, two numba functions compiled once per machine) runs
any program: the residual series, or the residual with its Jacobian series by forward mode on series in
real arithmetic (exact; it replaces the complex-step Jacobian of the numpy path).

What the tracer allows: arithmetic with series, floats and node arrays, the ufuncs and series methods the
stage residuals use (sqrt, exp, log, sin/cos, sinh/cosh, real powers, arctan, tan),
:meth:`Series.linear_combinations` (the aerodynamic model), and reading the constant term of a value that
depends only on the *static* data (the series of a plan that do not depend on the neglected terms: flat
outputs, prescribed inputs, stage 1, derived terms): the ISA layer chosen from the altitude, a decision
that holds for the whole plan.  Anything else (a value read from the unknowns or from data that change
between iterates, comparisons, truth values, operations not listed) raises :class:`TraceError`; the stage
then runs on the numpy path (:func:`trace` returns None and says why).

The numpy path (:mod:`planners.series` with ``GFLAT_SERIES_BACKEND=numpy``) is the reference: the
programs' residuals and Jacobians agree with it to 1e-12 (``tests/planners/test_program.py``).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from .series import Series

__all__ = ["Program", "Sym", "TraceError", "trace", "available"]

# opcodes: the same numbers as planners._program_kernels (kept here so that tracing needs no numba)
(INPUT, DATA, ADD, SUB, MUL, DIV, NEG, ADDC, RSUBC, MULC, DIVC, RDIVC) = range(12)
(SQRT, EXP, LOG, SINCOS, SINHCOSH, POW, ARCTAN, CONST, AXPY, ZERO, TAN, COPY) = range(12, 24)
#: The time derivative (native evaluator only: the closed-form stages): coefficient m is (m + 1) a_(m+1), the
#: last coefficient of the working order is 0 (a program using it is exact to one order less).
DERIV = 24
#: arctan2(y, x) (native evaluator only): arctan2(y0, x0) + integral((x y' - y x') / (x^2 + y^2)).
ATAN2 = 25


class TraceError(Exception):
    """The residual did something a program cannot record (the stage then runs on the numpy path)."""


def cache_dir() -> str:
    """Where the compiled evaluator's machine code is kept: ``$XDG_CACHE_HOME/gflat/numba`` (default
    ``~/.cache/gflat/numba``).  numba keys its files by the kernels' source and its own version (stale
    files are rebuilt) and writes each through a temporary file renamed into place, so several processes
    compiling at once are safe.

    Returns
    -------
    str
    """
    import os

    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "gflat", "numba")


def _kernels():
    """The compiled evaluator (:mod:`planners._program_kernels`), its cache under :func:`cache_dir`."""
    import sys

    mod = sys.modules.get("planners._program_kernels")
    if mod is not None:
        return mod
    import importlib

    import numba.core.config as config

    before = config.CACHE_DIR
    config.CACHE_DIR = cache_dir()  # read when the kernels are decorated (at their import)
    try:
        return importlib.import_module("planners._program_kernels")
    finally:
        config.CACHE_DIR = before


def available() -> bool:
    """Whether the compiled evaluator can be used (numba importable).

    Returns
    -------
    bool
    """
    import importlib.util

    return importlib.util.find_spec("numba") is not None


class _Recorder:
    """The instructions (SSA: one node per instruction) and parameters of one trace."""

    def __init__(self, static_values: Sequence) -> None:
        self.code: list = []  # (op, a, b, k, unk_a, unk_b) per node; the node id is the index
        self.unk: list = []  # node depends on the unknowns
        self.var: list = []  # node depends on the unknowns or on data that change between calls
        self.params: list = []
        self.static = list(static_values)  # data index -> Series (static data) or None
        self.second: dict = {}  # node -> node of the second output (SINCOS, SINHCOSH)
        self.pairs: dict = {}  # (op, node) -> (first, second) memo of sincos
        self._concrete: dict = {}

    def param(self, v) -> int:
        self.params.append(float(v))
        return len(self.params) - 1

    def node(self, op, a=-1, b=-1, k=-1, unk=False, var=False) -> Sym:
        ua = a >= 0 and self.unk[a] if op not in (INPUT, DATA, CONST, ZERO) else False
        ub = b >= 0 and self.unk[b] if op not in (SINCOS, SINHCOSH) else False
        if op == INPUT:
            ua = True
        self.code.append((op, a, b, k, ua, ub))
        u = unk or ua or ub
        self.unk.append(u)
        self.var.append(
            var
            or u
            or (a >= 0 and op not in (INPUT, DATA) and self.var[a])
            or (b >= 0 and op not in (SINCOS, SINHCOSH) and self.var[b])
        )
        return Sym(self, len(self.code) - 1)

    def concrete(self, i: int) -> Series:
        """The value of a static node, evaluated eagerly on the numpy path (memoised)."""
        if self.var[i]:
            raise TraceError("a value that depends on the unknowns or on changing data was read")
        if i in self._concrete:
            return self._concrete[i]
        op, a, b, k, _, _ = self.code[i]
        p = self.params
        if op == DATA:
            v = self.static[a]
        elif op in (ADD, SUB, MUL, DIV):
            x, y = self.concrete(a), self.concrete(b)
            v = {ADD: np.add, SUB: np.subtract, MUL: np.multiply, DIV: np.divide}[op](x, y)
        elif op == NEG:
            v = -self.concrete(a)
        elif op == ADDC:
            v = self.concrete(a) + p[k]
        elif op == RSUBC:
            v = p[k] - self.concrete(a)
        elif op == MULC:
            v = self.concrete(a) * p[k]
        elif op == DIVC:
            v = self.concrete(a) / p[k]
        elif op == RDIVC:
            v = p[k] / self.concrete(a)
        elif op in (SQRT, EXP, LOG, ARCTAN, TAN):
            v = getattr(self.concrete(a), {SQRT: "sqrt", EXP: "exp", LOG: "log", ARCTAN: "arctan", TAN: "tan"}[op])()
        elif op == POW:
            v = self.concrete(a) ** p[k]
        elif op == DERIV:
            v = self.concrete(a).derivative()
        elif op == ATAN2:
            v = np.arctan2(self.concrete(a), self.concrete(b))
        else:
            raise TraceError(f"reading the value of operation {op} is not supported")
        self._concrete[i] = v
        return v


def _is_number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool) or isinstance(v, np.floating)


class Sym:
    """A traced series: a node of a program being recorded (arithmetic as :class:`Series`)."""

    __slots__ = ("rec", "i")
    __array_priority__ = 1000

    def __init__(self, rec: _Recorder, i: int) -> None:
        self.rec = rec
        self.i = i

    # ---------------------------------------------------------------- values (static data only)

    @property
    def constant_term(self):
        """The constant term of a static value (a decision of the trace); else :class:`TraceError`."""
        return self.rec.concrete(self.i).constant_term

    def _refuse(self, *args, **kwargs):
        raise TraceError("a traced series has no truth value, comparison, conversion or array view")

    __bool__ = __float__ = __array__ = __lt__ = __le__ = __gt__ = __ge__ = __eq__ = __ne__ = _refuse
    __hash__ = object.__hash__

    def __getattr__(self, name):
        raise AttributeError(f"a traced series has no {name!r}")

    # ---------------------------------------------------------------- operands

    def _operand(self, other):
        """A Sym for ``other`` (a Sym, or a node array of constants), or a float, or None."""
        if isinstance(other, Sym):
            if other.rec is not self.rec:
                raise TraceError("operands of two traces")
            return other
        if _is_number(other):
            return float(other)
        if isinstance(other, np.ndarray) and other.dtype.kind in "fi":
            if other.ndim == 0:
                return float(other)
            return self._data_array(other)
        if isinstance(other, Series):
            raise TraceError("an untraced Series met a traced one (data not declared)")
        return None

    def _data_array(self, arr: np.ndarray) -> Sym:
        """An array of node constants as a constant series of the data (static)."""
        rec = self.rec
        s = Series.constant(np.asarray(arr, dtype=float), 0)
        rec.static.append(s)
        return rec.node(DATA, len(rec.static) - 1)

    def _bin(self, other, op, opc, reverse=False):
        o = self._operand(other)
        if o is None:
            return NotImplemented
        rec = self.rec
        if isinstance(o, float):
            return rec.node(opc, self.i, -1, rec.param(o)) if opc is not None else None
        return rec.node(op, o.i, self.i) if reverse else rec.node(op, self.i, o.i)

    def __add__(self, other):
        return self._bin(other, ADD, ADDC)

    __radd__ = __add__

    def __sub__(self, other):
        if _is_number(other):
            return self + (-float(other))
        return self._bin(other, SUB, None)

    def __rsub__(self, other):
        if _is_number(other):
            rec = self.rec
            return rec.node(RSUBC, self.i, -1, rec.param(other))
        return self._bin(other, SUB, None, reverse=True)

    def __mul__(self, other):
        return self._bin(other, MUL, MULC)

    __rmul__ = __mul__

    def __truediv__(self, other):
        return self._bin(other, DIV, DIVC)

    def __rtruediv__(self, other):
        if _is_number(other):
            rec = self.rec
            return rec.node(RDIVC, self.i, -1, rec.param(other))
        return self._bin(other, DIV, None, reverse=True)

    def __neg__(self):
        return self.rec.node(NEG, self.i)

    def __pos__(self):
        return self

    def __pow__(self, other, modulo=None):
        if modulo is not None or not _is_number(other):
            raise TraceError("a power with a series exponent")
        p = float(other)
        if p.is_integer() and abs(p) < 2**31:
            return self._int_power(int(p))
        if p == 0.5:
            return self._f_sqrt()
        rec = self.rec
        return rec.node(POW, self.i, -1, rec.param(p))

    def __rpow__(self, other):
        if not _is_number(other) or float(other) <= 0:
            raise TraceError("a power with a series exponent")
        return (self * math.log(float(other)))._f_exp()

    def _int_power(self, p: int):
        if p < 0:
            return self._int_power(-p)._f_reciprocal()
        if p == 0:
            rec = self.rec
            return rec.node(CONST, -1, -1, rec.param(1.0))
        result, base = None, self
        while p:
            if p & 1:
                result = base if result is None else result * base
            p >>= 1
            if p:
                base = base * base
        return result

    # ---------------------------------------------------------------- functions

    def _unary(self, op):
        return self.rec.node(op, self.i)

    def _f_sqrt(self):
        return self._unary(SQRT)

    def _f_exp(self):
        return self._unary(EXP)

    def _f_log(self):
        return self._unary(LOG)

    def _f_arctan(self):
        return self._unary(ARCTAN)

    def _f_tan(self):
        return self._unary(TAN)

    def derivative(self):
        """The time derivative (:data:`DERIV`: the program is then exact to one order less).

        Returns
        -------
        Sym
        """
        return self._unary(DERIV)

    def _f_square(self):
        return self * self

    def _f_reciprocal(self):
        return 1.0 / self

    def _pair(self, op):
        rec = self.rec
        key = (op, self.i)
        if key not in rec.pairs:
            first = rec.node(op, self.i)
            second = rec.node(COPY, first.i)  # placeholder node of the second output, filled by the op
            rec.code[second.i] = (ZERO, -1, -1, -1, False, False)  # written by the pair op, never executed
            rec.code[first.i] = (op, self.i, second.i, -1, rec.unk[self.i], False)
            rec.second[first.i] = second.i
            rec.unk[second.i] = rec.unk[first.i]
            rec.var[second.i] = rec.var[first.i]
            rec.pairs[key] = (first, second)
        return rec.pairs[key]

    def _f_sincos(self):
        return self._pair(SINCOS)

    def _f_sinhcosh(self):
        return self._pair(SINHCOSH)

    def _f_sin(self):
        return self._f_sincos()[0]

    def _f_cos(self):
        return self._f_sincos()[1]

    def _f_sinh(self):
        return self._f_sinhcosh()[0]

    def _f_cosh(self):
        return self._f_sinhcosh()[1]

    @staticmethod
    def linear_combinations(weights, items) -> list:
        """Rows of ``weights`` applied to ``items``, as :meth:`planners.series.Series.linear_combinations`.

        Every nonzero weight is a parameter; a zero weight's term is left out (constant folding: ``acc + 0 x``
        is ``acc``, up to the sign of an exact zero), so the program depends on which weights are zero (the
        structure of the aerodynamic model: of stage 2's 238 recorded instructions on the roll, 73 were such
        terms) and on none of the other weights' values.

        Parameters
        ----------
        weights : array_like, shape (p, q)
            Real weights (parameters of the program).
        items : sequence of length q
            Traced series (at least one) and numbers.

        Returns
        -------
        list of Sym
            ``p`` traced series.

        Raises
        ------
        TraceError
            No traced series among ``items``, or an item of another type.
        """
        w = np.asarray(weights, dtype=float)
        syms = [x for x in items if isinstance(x, Sym)]
        if not syms:
            raise TraceError("linear_combinations without a traced series")
        rec = syms[0].rec
        out = []
        for i in range(w.shape[0]):
            const = 0.0
            acc = None
            for j, x in enumerate(items):
                if isinstance(x, Sym):
                    if w[i, j] == 0.0:
                        continue
                    if acc is None:
                        acc = rec.node(MULC, x.i, -1, rec.param(w[i, j]))
                    else:
                        acc = rec.node(AXPY, acc.i, x.i, rec.param(w[i, j]))
                elif _is_number(x):
                    const += w[i, j] * float(x)
                else:
                    raise TraceError(f"linear_combinations item of type {type(x).__name__}")
            if acc is None:  # every traced item's weight zero
                out.append(rec.node(CONST, -1, -1, rec.param(const)))
            else:
                out.append(rec.node(ADDC, acc.i, -1, rec.param(const)))
        return out

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if method != "__call__" or kwargs:
            raise TraceError(f"ufunc {ufunc.__name__}.{method}")
        impl = _UFUNCS.get(ufunc)
        if impl is None:
            raise TraceError(f"ufunc {ufunc.__name__} is not traced")
        return impl(*inputs)


def _arctan2(y, x):
    """arctan2 of two traced series (a number or node array operand becomes a constant series)."""
    like = y if isinstance(y, Sym) else x
    rec = like.rec

    def as_sym(v):
        o = like._operand(v)
        if isinstance(o, float):
            return rec.node(CONST, -1, -1, rec.param(o))
        if o is None:
            raise TraceError(f"arctan2 of a {type(v).__name__}")
        return o

    return rec.node(ATAN2, as_sym(y).i, as_sym(x).i)


def _as_sym_pair(x, y):
    like = x if isinstance(x, Sym) else y
    return like


def _ufunc_binary(name):
    def impl(x, y):
        if isinstance(x, Sym):
            return getattr(x, f"__{name}__")(y)
        return getattr(y, f"__r{name}__")(x)

    return impl


def _ufunc_unary(name):
    def impl(x):
        return getattr(x, "_f_" + name)()

    return impl


_UFUNCS: dict = {
    np.add: _ufunc_binary("add"),
    np.subtract: _ufunc_binary("sub"),
    np.multiply: _ufunc_binary("mul"),
    np.divide: _ufunc_binary("truediv"),
    np.power: _ufunc_binary("pow"),
    np.arctan2: _arctan2,
    np.negative: lambda x: -x,
    np.positive: lambda x: x,
    **{
        getattr(np, n): _ufunc_unary(n)
        for n in ("sqrt", "exp", "log", "sin", "cos", "tan", "arctan", "sinh", "cosh", "square", "reciprocal")
    },
}


class Program:
    """A traced stage residual: its instruction table, parameters and data layout, run by compiled code.

    Attributes
    ----------
    code : ndarray of int64, shape (I, 6)
        ``(op, out, a, b, k, unk)`` per instruction (registers allocated, dead code removed).
    params : ndarray, shape (P,)
        The numbers of the model (aircraft, atmosphere, aerodynamic weights).
    data_names : tuple of str
        The data series, in the order of the data input.
    n_unknowns, n_registers : int
    outputs : ndarray of int64, shape (neq,)
        Registers of the residuals.
    outputs_unk : ndarray of int64, shape (neq,)
        1 where a residual depends on the unknowns.
    extra : list of Series
        Constant series of node arrays the residual brought (appended to the data).
    """

    def __init__(self, code, params, data_names, n_unknowns, n_registers, outputs, outputs_unk, extra):
        self.code = code
        self.params = params
        self.data_names = data_names
        self.n_unknowns = n_unknowns
        self.n_registers = n_registers
        self.outputs = outputs
        self.outputs_unk = outputs_unk
        self.extra = extra

    def native(self):
        """This program laid out for the native evaluator (:class:`planners._native.NativeProgram`), made once.

        Returns
        -------
        planners._native.NativeProgram
        """
        nat = self.__dict__.get("_native")
        if nat is None:
            from ._native import NativeProgram

            nat = self.__dict__["_native"] = NativeProgram(self)
        return nat

    @property
    def structure_key(self) -> str:
        """Hash of the instruction table: equal for aircraft and scenarios of the same structure."""
        import hashlib

        return hashlib.sha256(self.code.tobytes() + str(len(self.params)).encode()).hexdigest()[:16]

    # --------------------------------------------------------------- evaluation

    def data_array(self, data: Mapping, k: int, nodes: int) -> np.ndarray:
        """The data series at working order k as one array (truncated or zero-padded).

        Parameters
        ----------
        data : mapping of str -> Series
            At least :attr:`data_names`, batch shape (nodes,) or ().
        k : int
            Working order.
        nodes : int
            Number of nodes.

        Returns
        -------
        ndarray, shape (D, k + 1, nodes)
        """
        series = [data[n] for n in self.data_names] + self.extra
        out = np.zeros((len(series), k + 1, nodes))
        for j, s in enumerate(series):
            c = s._c
            m = min(c.shape[0], k + 1)
            out[j, :m] = c[:m] if c.ndim == 2 else c[:m, None]
        return out

    def residual(self, x: np.ndarray, data: np.ndarray) -> np.ndarray:
        """Residual series at the unknowns, by the compiled evaluator.

        Parameters
        ----------
        x : ndarray, shape (n, M, S)
            The unknowns' coefficients, coefficient first (M coefficients, S nodes).
        data : ndarray, shape (D, M, S)
            :meth:`data_array` at order M - 1.

        Returns
        -------
        ndarray, shape (neq, M, S)
        """
        return _kernels().evaluate(self.code, self.params, x, data, self.n_registers, self.outputs)

    def residual_and_jacobian(self, x: np.ndarray, data: np.ndarray) -> tuple:
        """Residual series and Jacobian series at the unknowns (forward mode on series).

        Parameters
        ----------
        x : ndarray, shape (n, M, S)
            The unknowns' coefficients, coefficient first.
        data : ndarray, shape (D, M, S)
            :meth:`data_array` at order M - 1.

        Returns
        -------
        (ndarray (neq, M, S), ndarray (neq, n, M, S))
        """
        return _kernels().evaluate_tangent(
            self.code, self.params, x, data, self.n_registers, self.outputs, self.outputs_unk
        )


def _allocate(rec: _Recorder, outs: list) -> tuple:
    """Dead code removed, registers allocated by liveness (an output never shares a register with an operand)."""
    n = len(rec.code)
    first_of = {second: first for first, second in rec.second.items()}
    leaf = (INPUT, DATA, CONST, ZERO)

    def operands(i):
        op, a, b, _, _, _ = rec.code[i]
        if op in leaf:
            return ()
        if op in (SINCOS, SINHCOSH):
            return (a,)
        return tuple(j for j in (a, b) if j >= 0)

    live = [False] * n
    for o in outs:
        live[o] = True
    for i in range(n - 1, -1, -1):
        if not live[i]:
            continue
        if i in first_of:
            live[first_of[i]] = True
            continue
        for j in operands(i):
            live[j] = True
    last = {}
    for i in range(n):
        if live[i] and i not in first_of:
            for j in operands(i):
                last[j] = i
    for o in outs:
        last[o] = n
    reg, free, rows = {}, [], []
    nreg = 0

    def alloc():
        nonlocal nreg
        if free:
            return free.pop()
        nreg += 1
        return nreg - 1

    for i in range(n):
        if not live[i] or i in first_of:
            continue
        op, a, b, k, ua, ub = rec.code[i]
        reg[i] = alloc()
        made = [i]
        if op in (SINCOS, SINHCOSH):
            reg[b] = alloc()
            made.append(b)
        ra = a if op in leaf else reg[a]
        rb = reg[b] if b >= 0 else b
        unk = 1 if op == INPUT else (1 if ua else 0) + (2 if ub else 0)
        rows.append((op, reg[i], ra, rb, k, unk))
        for j in set(operands(i)):  # an operand used twice (a * a) is freed once
            if last.get(j) == i:
                free.append(reg[j])
        for j in made:
            if last.get(j, -1) < i:  # an output never used (one of a pair)
                free.append(reg[j])
    code = np.array(rows, dtype=np.int64).reshape(-1, 6)
    # the data actually read, renumbered
    used = sorted({int(r[2]) for r in rows if r[0] == DATA})
    remap = {d: j for j, d in enumerate(used)}
    for r in code:
        if r[0] == DATA:
            r[2] = remap[int(r[2])]
    return code, nreg, np.array([reg[o] for o in outs], dtype=np.int64), used


def trace(
    residual: Callable,
    unknowns: Sequence[str],
    data: Mapping,
    static: set,
) -> tuple[Program | None, str]:
    """Trace ``residual(v)`` into a :class:`Program`.

    Parameters
    ----------
    residual : callable
        ``residual(v) -> list``, ``v`` mapping every name to a series (the stage residuals of
        :mod:`planners.chained`).
    unknowns : sequence of str
        The unknowns (the program's inputs ``x``).
    data : mapping of str -> Series
        Every other name the residual reads, batch shape (nodes,).
    static : set of str
        The data names that do not change while the program is used (their constant terms may be read).

    Returns
    -------
    (Program or None, str)
        The program, or None and the reason it could not be traced.
    """
    names = tuple(data)
    if not all(isinstance(data[n], Series) and len(data[n].batch_shape) <= 1 for n in names):
        return None, "data that are not series of one batch axis"
    rec = _Recorder([data[n] if n in static else None for n in names])
    v = {}
    for j, n in enumerate(names):
        v[n] = rec.node(DATA, j, var=n not in static)
    for j, n in enumerate(unknowns):
        v[n] = rec.node(INPUT, j, unk=True)
    try:
        out = list(residual(v))
    except TraceError as exc:
        return None, str(exc)
    except (TypeError, ValueError, AttributeError) as exc:  # an operation the tracer does not handle
        return None, f"{type(exc).__name__}: {exc}"
    nodes = []
    for r in out:
        if isinstance(r, Sym):
            nodes.append(r.i)
        elif _is_number(r):
            nodes.append(rec.node(CONST, -1, -1, rec.param(r)).i)
        else:
            return None, f"a residual of type {type(r).__name__}"
    code, nreg, outs, used = _allocate(rec, nodes)
    outs_unk = np.array([1 if rec.unk[i] else 0 for i in nodes], dtype=np.int64)
    data_names = tuple(names[d] for d in used if d < len(names))
    extra = [rec.static[d] for d in used if d >= len(names)]
    prog = Program(code, np.array(rec.params, dtype=float), data_names, len(unknowns), nreg, outs, outs_unk, extra)
    return prog, ""


class StageEvaluator:
    """A :class:`Program` bound to one Newton call's data: the evaluations of
    :class:`planners.newton.ResidualEvaluator`, by the compiled evaluator.

    Parameters
    ----------
    program : Program
        The stage's program.
    data : mapping of str -> Series
        The data series of this call (at the stage's order or above), batch shape (nodes,).
    nodes : int
        Number of nodes.
    """

    def __init__(self, program: Program, data: Mapping, nodes: int) -> None:
        self.program = program
        self.data = data
        self.nodes = nodes
        self._arrays: dict = {}

    def _data(self, k: int) -> np.ndarray:
        if k not in self._arrays:
            self._arrays[k] = self.program.data_array(self.data, k, self.nodes)
        return self._arrays[k]

    def residual_and_jacobian(self, stacked: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Residual series and Jacobian series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, *batch, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        (ndarray, ndarray)
            ``G`` (neq, *batch, K) and ``Jc`` (neq, n, *batch, K): coefficient m of ``d r_a / d u_b``.
        """
        x = np.ascontiguousarray(np.swapaxes(stacked, 1, 2), dtype=float)
        G, J = self.program.residual_and_jacobian(x, self._data(k))
        return np.swapaxes(G, 1, 2), np.swapaxes(J, 2, 3)

    def residual_only(self, stacked: np.ndarray, k: int) -> np.ndarray:
        """Residual series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, *batch, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        ndarray, shape (neq, *batch, K)
        """
        x = np.ascontiguousarray(np.swapaxes(stacked, 1, 2), dtype=float)
        return np.swapaxes(self.program.residual(x, self._data(k)), 1, 2)

    def const_fun(self, x: np.ndarray) -> np.ndarray:
        """Constant term of the residual at constant unknowns (the pointwise problem).

        Parameters
        ----------
        x : ndarray, shape (n, *batch)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, *batch)
        """
        xx = np.ascontiguousarray(np.real(x), dtype=float)[:, None, :]
        return self.program.residual(xx, self._data(0))[:, 0, :]

    def const_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`const_fun`.

        Parameters
        ----------
        x : ndarray, shape (n, *batch)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, n, *batch)
        """
        xx = np.ascontiguousarray(np.real(x), dtype=float)[:, None, :]
        return self.program.residual_and_jacobian(xx, self._data(0))[1][:, :, 0, :]

    def series_residual(self, u: list, order: int, batch: tuple) -> np.ndarray:
        """Max abs coefficient of the residual series at ``u``, per node.

        Parameters
        ----------
        u : list of Series
            The unknowns at order ``order``.
        order : int
            Working order.
        batch : tuple of int
            Batch shape of the nodes.

        Returns
        -------
        ndarray, shape batch
        """
        stacked = np.stack([np.broadcast_to(np.real(s.coeffs), batch + (order + 1,)) for s in u])
        return np.max(np.abs(self.residual_only(stacked, order)), axis=(0, 2))


class NativeStageEvaluator(StageEvaluator):
    """A :class:`StageEvaluator` run by the native evaluator (``planners/_program.c``, :mod:`planners._native`),
    which also runs Newton's steps on series whole (:meth:`warm_newton`, :meth:`doubling`).

    One data array at the highest order serves every working order (the native calls read the first M
    coefficients of each datum).

    Parameters
    ----------
    program : Program
        The stage's program.
    data : mapping of str -> Series
        The data series of this call, batch shape (nodes,).
    nodes : int
        Number of nodes.
    """

    def __init__(self, program: Program, data: Mapping, nodes: int) -> None:
        super().__init__(program, data, nodes)
        self.nat = program.native()
        self._top = None

    def _data_for(self, M: int) -> np.ndarray:
        """The data at M coefficients or more, coefficient first (D, Md >= M, S)."""
        top = self._top
        if top is None or top.shape[1] < M:
            series = [self.data[n] for n in self.program.data_names] + self.program.extra
            k = max([M - 1] + [s.order for s in series])
            top = self._top = self.program.data_array(self.data, k, self.nodes)
        return top

    def residual_and_jacobian(self, stacked: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Residual series and Jacobian series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, nodes, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        (ndarray, ndarray)
            ``G`` (neq, nodes, K) and ``Jc`` (neq, n, nodes, K).
        """
        x = np.ascontiguousarray(np.swapaxes(stacked, 1, 2), dtype=float)
        G, J = self.nat.evaluate_tangent(x, self._data_for(k + 1), k + 1)
        return np.swapaxes(G, 1, 2), np.swapaxes(J, 2, 3)

    def residual_only(self, stacked: np.ndarray, k: int) -> np.ndarray:
        """Residual series at the unknowns' coefficients.

        Parameters
        ----------
        stacked : ndarray, shape (n, nodes, K)
            Taylor coefficients of the n unknowns (coefficient last).
        k : int
            Working order, ``K - 1``.

        Returns
        -------
        ndarray, shape (neq, nodes, K)
        """
        x = np.ascontiguousarray(np.swapaxes(stacked, 1, 2), dtype=float)
        return np.swapaxes(self.nat.evaluate(x, self._data_for(k + 1), k + 1), 1, 2)

    def const_fun(self, x: np.ndarray) -> np.ndarray:
        """Constant term of the residual at constant unknowns (the pointwise problem).

        Parameters
        ----------
        x : ndarray, shape (n, nodes)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, nodes)
        """
        xx = np.ascontiguousarray(np.real(x), dtype=float)[:, None, :]
        return self.nat.evaluate(xx, self._data_for(1), 1)[:, 0, :]

    def const_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`const_fun`.

        Parameters
        ----------
        x : ndarray, shape (n, nodes)
            Values of the unknowns.

        Returns
        -------
        ndarray, shape (neq, n, nodes)
        """
        xx = np.ascontiguousarray(np.real(x), dtype=float)[:, None, :]
        return self.nat.evaluate_tangent(xx, self._data_for(1), 1)[1][:, :, 0, :]

    def _coefficients(self, us, K: int) -> np.ndarray:
        """Series ``us`` (batch (S,) or ()) as one coefficient-first array (n, K, S), truncated or zero-padded."""
        x = np.zeros((len(us), K, self.nodes))
        for j, u in enumerate(us):
            c = u._c
            m = min(c.shape[0], K)
            x[j, :m] = np.real(c[:m]) if c.ndim == 2 else np.real(c[:m, None])
        return x

    def warm_newton_series(self, base, order, step, carried, tol, maxsteps, chord_steps, chord_proof):
        """Newton and chord steps at the full working order from ``base``, whole in native code: the loop of
        :func:`planners.newton._warm_newton` (same steps, same tests).

        Parameters
        ----------
        base : list of Series
            The start (batch shape (nodes,)), truncated or zero-padded to ``order``.
        order : int
            Working order.
        step : float
            The smallest node spacing [s] (coefficient m of the residual is weighted by ``step^m``).
        carried : ndarray, shape (n, n, nodes, K' >= order + 1), or None
            The Jacobian series of a nearby problem (:attr:`planners.newton.SeriesNewtonReport.jacobian`);
            ignored when its shape does not fit or it is not finite.
        tol : float
            Tolerance.
        maxsteps, chord_steps : int
            :data:`planners.newton.WARM_MAXSTEPS`, :data:`planners.newton.CHORD_STEPS`.
        chord_proof : float
            :data:`planners.newton.CHORD_PROOF`.

        Returns
        -------
        tuple
            ``(status, u, Jc, cres, evaluations)``: status 0 solved (u the list of Series, Jc (n, n, nodes, K)
            the Jacobian series of the last step, cres (nodes,) the constant-term residual bound), 1 not
            solved (the caller's full scheme follows), 2 a singular node (the caller reruns the numpy steps).
        """
        K = order + 1
        x = self._coefficients(base, K)
        n, S = x.shape[0], x.shape[2]
        has = False
        Jc = None
        if carried is not None:
            Jn = getattr(carried, "base", None)  # a report's Jacobian is a view of the native layout
            if (
                isinstance(Jn, np.ndarray)
                and Jn.ndim == 4
                and Jn.shape[:2] == (n, n)
                and Jn.shape[2] >= K
                and Jn.shape[3] == S
                and np.shares_memory(Jn, carried)
            ):
                Jc = np.ascontiguousarray(Jn[:, :, :K])
            else:
                Jc = np.ascontiguousarray(np.swapaxes(np.asarray(carried, dtype=float), 2, 3)[:, :, :K])
            has = Jc.shape == (n, n, K, S) and bool(np.all(np.isfinite(Jc)))
        if not has:
            Jc = np.empty((n, n, K, S))
        w = step ** np.arange(K, dtype=float)
        st, cres, steps = self.nat.warm_newton(
            x, self._data_for(K), Jc, has, tol, w, maxsteps, chord_steps, chord_proof
        )
        if st != 0:
            return st, None, None, None, steps
        return st, [Series._wrap(x[j]) for j in range(n)], np.swapaxes(Jc, 2, 3), cres, steps

    def pointwise_newton(self, x0: np.ndarray, tol: float, maxiter: int):
        """:func:`gna.solve.newton` on the constant terms (damped, the Jacobian of :meth:`const_jacobian`), whole
        in native code.

        Parameters
        ----------
        x0 : ndarray, shape (n, nodes)
            The start.
        tol : float
            Tolerance on each node's max-norm residual.
        maxiter : int
            Iterations at most.

        Returns
        -------
        gna.solve.NewtonResult or None
            None at an exactly singular node (the caller runs :func:`gna.solve.newton`, which takes a
            least-squares step there); ``history`` holds the final residual only.
        """
        from gna.solve import NewtonResult

        x = np.array(np.real(x0), dtype=float, order="C")
        status, res, its = self.nat.pointwise_newton(x, self._data_for(1), tol, maxiter)
        if status != 0:
            return None
        return NewtonResult(x=x, residual=res, iterations=its, converged=res <= tol, history=[float(np.max(res))])

    def doubling(self, stacked, orders):
        """The precision-doubling steps of :func:`planners.newton.newton_series`, whole in native code.

        Parameters
        ----------
        stacked : ndarray, shape (n, nodes, K)
            The pointwise solution in the constant terms, the starting guess above (coefficient last).
        orders : sequence of int
            Working orders, increasing, ending at ``K - 1``.

        Returns
        -------
        tuple
            ``(status, x, Jc)``: status 0 (x (n, nodes, K), Jc (n, n, nodes, K) of the last step) or 2 (a
            singular node: the caller reruns the numpy steps).
        """
        K = stacked.shape[-1]
        x = np.ascontiguousarray(np.swapaxes(stacked, 1, 2), dtype=float)
        n, S = x.shape[0], x.shape[2]
        Jc = np.empty((n, n, K, S))
        st = self.nat.doubling(x, self._data_for(K), np.asarray(orders, dtype=np.int64), Jc)
        return st, np.swapaxes(x, 1, 2), np.swapaxes(Jc, 2, 3)
