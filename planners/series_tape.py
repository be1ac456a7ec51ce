"""A stage residual traced into a straight-line program on coefficient arrays, replayed by Newton on series.

Newton's method on series (:func:`planners.newton.newton_series`) evaluates one residual several
times at one working order: the complex-step batch of a Newton step, the real residuals of the
chord steps, the residual of the report.  Between those evaluations only the unknowns'
coefficients change: the residual function, its data (flat outputs, H values, captured by the
closures of :func:`planners.flat.parametrize`) and the sequence of operations are fixed.  Part of
an evaluation's time is interpretation rather than arithmetic: the model code of :mod:`gna`
(named tuples, the aerodynamic term table, dictionary look-ups), the dispatch of :class:`Series`
operators, and the terms computed from the data alone, again at every evaluation.

:class:`TapedResidual` wraps a residual.  Its first evaluation at a working order with series
unknowns runs the residual on *traced series* (:class:`_Traced`): every operation whose result
depends on the unknowns is computed -- by the very internal function the eager :class:`Series`
operation calls after its dispatch (``_series_mul``, ``_add_sub``, ``_plus_constant``,
``_scale_array``, the kernels ``_K.*`` through the series methods), with the same operands in the
same order -- and recorded as an instruction; everything else (the data, and whatever the model
computes from the data alone: density, dynamic pressure, nondimensional rates, the monomials of
the data) is evaluated once, eagerly, and enters the program as a constant.  The following
evaluations at that order replay the instructions on plain coefficient-first arrays (no model
code, no series objects, no dispatch), on real inputs or complex-step ones, on the batch shapes
Newton uses.  The model is defined once: the program is what gna's code does, recorded.

Why the replay equals the eager evaluation bit for bit: each instruction calls the function the
eager path calls, on arrays of the same values and the same memory layout (inputs are copied
into C-ordered coefficient-first arrays exactly as ``Series(coeffs)`` does; constants are the
eager objects themselves).  Functions are deterministic, so equal inputs give equal outputs, by
induction over the program.  The dispatch decisions the trace resolves depend only on the kinds of
the operands (traced, constant series, float, other constant), which do not change between
evaluations; everything that depends on shapes or dtypes (broadcasting a ``(nodes,)`` constant
against the ``(n, nodes)`` complex-step batch, a complex times a real product, the kernels'
choice of loop) is decided again inside the called functions at each replay.  Hence **one tape
replays on any dtype and batch shape**: the program traced on the complex-step batch
``(n, nodes)`` (the first evaluation of a Newton step) serves the real ``(nodes,)`` chord steps.
The alternative, one tape per (dtype, batch shape), was not kept: it pays a second trace (about an
eager evaluation) in every call that mixes the two, which is every warm call of stages 2 and 4
(measured: one complex-step evaluation then one to four real ones per call).

The contract a residual keeps (the stage residuals of :mod:`planners.flat` and of
:mod:`planners.chained` do): its Python control flow does not depend on its unknowns -- neither on
their values (series have no truth value anyway) nor on their type (no ``isinstance(u, Series)``
dispatch: a traced series is not a :class:`Series`) -- and its data do not change while one Newton
call evaluates it.  It may branch on its data (the ISA layer from the altitude) and on the working
order.

Operations the tracer does not record -- anything that needs values (comparisons, truth
values, conversion to arrays), truncation, padding, indexing, stacking, the attributes
``coeffs``, ``batch_shape``, ``dtype``, ``constant_term`` beyond a ``hasattr`` test -- abort the
trace with a :class:`TraceError`; the evaluation is then eager (the same result, the old cost) and
:attr:`TapedResidual.reason` says why.  Any other exception raised while tracing also falls back to
the eager evaluation, which raises it again if it is the residual's own.

Design choices, measured (``python benchmarks/bench_series.py --tape``: the roll's stage residuals,
17 nodes, medians of interleaved runs on a loaded 2-core machine):

* **What a replay saves.**  The replay runs the kernel calls of the unknown-dependent operations
  only (stage 2: 57-59 instructions, stage 4: 24-33).  Stage 4 depends on its unknowns (the
  surfaces) through few terms: a replay costs 0.37-0.65 of an eager evaluation (orders 2-16, real
  and complex-step unknowns, both kernel sets).  Stage 2 depends on its unknowns (alpha, beta, mu,
  F) almost everywhere, and the kernel calls themselves -- a handful of numpy calls each, about
  6 us for a product even at order 2, the order-by-order loops of the quotient and of sin/cos at
  order 16 -- are most of its cost: a replay costs 0.63-0.75 of an eager evaluation on real
  unknowns, 0.75-0.9 on the complex-step batch (whose complex products are arithmetic-bound with
  the numpy kernels).  Cheaper replays would need other kernel calls (a fused or pre-allocated
  product), whose results are not bit-identical to the eager path's: not done here (the plans must
  not change).
* **What a trace costs.**  Recording adds 1-3 us per operation to the eager work: a traced
  evaluation costs 1.1-1.4 eager ones.  Traced intermediates are held by their traced objects only,
  as the model code holds eager series, and the replay releases each after its last use: keeping
  every intermediate alive made both the trace and the replay of the complex-step batch slower than
  the eager evaluation (memory not reused).
* **When to trace** (:data:`WHEN`).  A call at one working order (the warm Newton steps, most calls
  of a plan) is traced at once: its first evaluation, the complex-step batch, and the real ones
  that follow replay the same tape.  The precision-doubling steps evaluate each order once, so the
  default ``"first-order"`` traces only the first order of a call and any order met a second time.
  At plan level the tape is within the timing noise of the eager evaluation (see the report of
  this work): it pays on stage 4 and with the compiled kernels, about breaks even on stage 2 with
  the numpy ones.
* **Interpreter, not generated code.**  The replay is a loop over ``(function, argument slots,
  output slot, slots to release)`` tuples, the arguments fetched by ``map(values.__getitem__,
  slots)`` (under 1 us per instruction); writing the program out as Python source and compiling it
  (as :mod:`gna.tape` does for floats) costs about 430 us for 60 lines, more than the loop's whole
  overhead over the one to four replays a tape gets.
* **No common subexpressions, no dead code.**  Both were implemented and measured: the stage
  residuals compute nothing they do not return and repeat one operation in 57, so the table look-ups
  cost more than they saved; they were removed.
* **Tapes per working order.**  Constants are computed at the working order; truncating the
  constants of a higher order would change rounding (the kernels' sums depend on the order), so a
  new order is a new trace.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .series import (
    Series,
    _add_sub,
    _arctan2,
    _as_constant,
    _constant_like,
    _plus_constant,
    _pow,
    _scale_array,
    _series_div,
    _series_mul,
)

__all__ = ["TapedResidual", "TraceError", "SeriesTape", "WHEN", "trace"]


class TraceError(Exception):
    """The residual did something the tracer does not record (its evaluation is then eager)."""


# ---------------------------------------------------------------------------
# The internal-array functions the instructions call (each one is what the eager Series path calls)
# ---------------------------------------------------------------------------


def _rsub_constant(b: np.ndarray, const: Any) -> np.ndarray:
    """``const - b``, as the eager ``_sub(const, series)``."""
    return _plus_constant(-b, const)


def _method(name: str) -> Callable[[np.ndarray], np.ndarray]:
    """``Series.<name>()`` on an internal array (one output)."""

    def fn(a: np.ndarray) -> np.ndarray:
        return getattr(Series._wrap(a), name)()._c

    fn.__name__ = name
    return fn


def _pair_method(name: str) -> Callable[[np.ndarray], tuple]:
    """``Series.<name>()`` returning a pair (``sincos``, ``sinhcosh``) on an internal array."""

    def fn(a: np.ndarray) -> tuple:
        s, c = getattr(Series._wrap(a), name)()
        return s._c, c._c

    fn.__name__ = name
    return fn


_METHODS = {
    name: _method(name)
    for name in (
        "square",
        "reciprocal",
        "sqrt",
        "exp",
        "expm1",
        "log",
        "log1p",
        "tan",
        "tanh",
        "arctan",
        "arcsin",
        "arccos",
    )
}
_PAIRS = {name: _pair_method(name) for name in ("sincos", "sinhcosh")}


def _pow_constant(a: np.ndarray, p: Any) -> np.ndarray:
    """``series ** p`` for a constant exponent, the eager ``_pow`` (its choice of kernel is made on the
    replay's own batch shape)."""
    return _pow(Series._wrap(a), p)._c


def _linear_combinations(weights: np.ndarray, spec: tuple, *args: Any) -> tuple:
    """``Series.linear_combinations`` with the traced items (``spec[i]`` true) given as internal arrays."""
    items = [Series._wrap(a) if t else a for t, a in zip(spec, args)]
    return tuple(s._c for s in Series.linear_combinations(weights, items))


# ---------------------------------------------------------------------------
# Recording
# ---------------------------------------------------------------------------


class _Recorder:
    """The program under construction: the constants (by slot) and the instructions.

    Traced values are held by their :class:`_Traced` objects only, as eager series are held by the
    model code: an intermediate is freed when the model drops it (keeping them all made the trace
    of the complex-step batch slower than the eager evaluation).
    """

    def __init__(self) -> None:
        self.values: list = []  # constants by slot; None for the slots of traced values
        self.instrs: list = []  # (fn, argument slots, output slot or slice of slots)
        self.const_slots: dict = {}  # constant key -> slot
        self.n_inputs = 0
        self.false = self.true = -1  # slots of the flags False and True, after the inputs'

    def input(self, c: np.ndarray) -> _Traced:
        if len(self.values) != self.n_inputs:
            raise TraceError("the inputs must be the first slots of a recording")
        self.values.append(None)
        self.n_inputs += 1
        return _Traced(self, len(self.values) - 1, c)

    def const(self, x: Any) -> int:
        """Slot of a constant operand (one slot per object; floats by value)."""
        key = x.hex() if type(x) is float else id(x)
        slot = self.const_slots.get(key)
        if slot is None:
            if type(x) is _Traced:
                raise TraceError("a value traced for another evaluation")
            self.values.append(x)  # kept alive: its id stays its key
            slot = self.const_slots[key] = len(self.values) - 1
        return slot

    def emit(self, fn: Callable, slots: tuple, args: list) -> _Traced:
        """Apply ``fn`` to ``args`` (the values of ``slots``), record it, and return its traced result."""
        value = fn(*args)
        if type(value) is not np.ndarray:
            raise TraceError(f"{getattr(fn, '__name__', fn)} did not give an array")
        out = len(self.values)
        self.values.append(None)
        self.instrs.append((fn, slots, out))
        return _Traced(self, out, value)

    def op(self, fn: Callable, *args: Any, n_out: int = 1) -> Any:
        """Apply ``fn`` to the values of ``args`` (traced values or constants) and record it."""
        slots, vals = [], []
        for a in args:
            if type(a) is _Traced and a.rec is self:
                slots.append(a.slot)
                vals.append(a.c)
            else:
                slots.append(self.const(a))
                vals.append(a)
        if n_out == 1:
            return self.emit(fn, tuple(slots), vals)
        outs = tuple(fn(*vals))
        if len(outs) != n_out or not all(type(v) is np.ndarray for v in outs):
            raise TraceError(f"{getattr(fn, '__name__', fn)} did not give {n_out} arrays")
        first = len(self.values)
        self.values.extend([None] * n_out)
        self.instrs.append((fn, tuple(slots), slice(first, first + n_out)))
        return tuple(_Traced(self, first + i, v) for i, v in enumerate(outs))


class _Opaque:
    """Stands for an attribute of a traced series that has no fixed value over the replays (its batch
    shape, dtype, coefficients): present, so that ``hasattr`` tests of duck typing pass, but any use
    aborts the trace."""

    __slots__ = ("what",)

    def __init__(self, what: str) -> None:
        self.what = what

    def _abort(self, *args: Any, **kwargs: Any) -> Any:
        raise TraceError(f"the {self.what} of a traced series was used")

    __array__ = __len__ = __iter__ = __getitem__ = __bool__ = __float__ = __int__ = __index__ = _abort
    __eq__ = __ne__ = __lt__ = __le__ = __gt__ = __ge__ = __add__ = __radd__ = __mul__ = __rmul__ = _abort
    __hash__ = None  # type: ignore[assignment]

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        self._abort()


def _is_series_like(x: Any) -> bool:
    return type(x) is _Traced or isinstance(x, Series)


def _operand(x: Any) -> Any:
    """A traced value or a Series stays; other operands become numeric constants (None: not one)."""
    return x if _is_series_like(x) else _as_constant(x)


def _internal(x: Any) -> Any:
    """What the eager path hands to the internal functions: the traced value, or a Series' array."""
    return x if type(x) is _Traced else x._c


def _rec_of(*xs: Any) -> _Recorder:
    for x in xs:
        if type(x) is _Traced:
            return x.rec
    raise TraceError("no traced operand")


def _binary(x: Any, y: Any) -> tuple | None:
    """The recorder, each operand's slot and value (a traced value's array, a Series' array, or the
    numeric constant) and whether it is a series; None when an operand is not a number (the
    operation is then not ours: NotImplemented)."""
    rec = x.rec if type(x) is _Traced else y.rec
    out = [rec]
    for z in (x, y):
        tz = type(z)
        if tz is _Traced and z.rec is rec:
            out += (z.slot, z.c, True)
        elif tz is float:
            out += (rec.const(z), z, False)
        elif isinstance(z, Series):
            out += (rec.const(z._c), z._c, True)
        else:
            c = _as_constant(z)
            if c is None:
                return None
            out += (rec.const(c), c, False)
    return out


def _t_add(x: Any, y: Any) -> Any:
    b = _binary(x, y)
    if b is None:
        return NotImplemented
    rec, xs, xv, sx, ys, yv, sy = b
    if sx and sy:
        return rec.emit(_add_sub, (xs, ys, rec.false), [xv, yv, False])
    return rec.emit(_plus_constant, (xs, ys), [xv, yv]) if sx else rec.emit(_plus_constant, (ys, xs), [yv, xv])


def _t_sub(x: Any, y: Any) -> Any:
    b = _binary(x, y)
    if b is None:
        return NotImplemented
    rec, xs, xv, sx, ys, yv, sy = b
    if sx and sy:
        return rec.emit(_add_sub, (xs, ys, rec.true), [xv, yv, True])
    if sx:
        # the eager path negates the constant before adding it
        neg = np.negative(yv)
        return rec.emit(_plus_constant, (xs, rec.const(neg)), [xv, neg])
    return rec.emit(_rsub_constant, (ys, xs), [yv, xv])


def _t_mul(x: Any, y: Any) -> Any:
    b = _binary(x, y)
    if b is None:
        return NotImplemented
    rec, xs, xv, sx, ys, yv, sy = b
    if sx and sy:
        return rec.emit(_series_mul, (xs, ys), [xv, yv])
    f = rec.false
    return (
        rec.emit(_scale_array, (xs, ys, f), [xv, yv, False])
        if sx
        else rec.emit(_scale_array, (ys, xs, f), [yv, xv, False])
    )


def _t_div(x: Any, y: Any) -> Any:
    b = _binary(x, y)
    if b is None:
        return NotImplemented
    rec, xs, xv, sx, ys, yv, sy = b
    if sy:
        if not sx:
            # the eager path makes a constant series of the divisor's order (its order is fixed)
            xv = _constant_like(xv, Series._wrap(yv))._c
            xs = rec.const(xv)
        return rec.emit(_series_div, (xs, ys), [xv, yv])
    return rec.emit(_scale_array, (xs, ys, rec.true), [xv, yv, True])


def _t_pow(x: Any, y: Any) -> Any:
    xo, yo = _operand(x), _operand(y)
    if xo is None or yo is None:
        return NotImplemented
    if _is_series_like(yo):
        # x ** y = exp(y log x), as the eager path
        log_x = xo.log() if _is_series_like(xo) else np.log(xo)
        prod = _t_mul(yo, log_x) if (type(yo) is _Traced or type(log_x) is _Traced) else yo * log_x
        return prod.exp()
    p = np.asarray(yo)
    if p.size == 1 and p.ndim > 0:
        # the eager choice (scalar or per-element exponent) would depend on the batch's number of axes
        raise TraceError("a one-element array exponent")
    return _rec_of(xo).op(_pow_constant, xo, yo)


def _promote(x: Any, like: _Traced) -> Any:
    if _is_series_like(x):
        return x
    c = _as_constant(x)
    return None if c is None else _constant_like(c, Series._wrap(like.c))


def _t_arctan2(y: Any, x: Any) -> Any:
    like = y if type(y) is _Traced else x
    yp, xp = _promote(y, like), _promote(x, like)
    if yp is None or xp is None:
        return NotImplemented
    return like.rec.op(_arctan2_series, _internal(yp), _internal(xp))


def _arctan2_series(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The eager ``_arctan2`` of two series given by their internal arrays."""
    return _arctan2(Series._wrap(y), Series._wrap(x))._c


def _t_hypot(x: Any, y: Any) -> Any:
    like = x if type(x) is _Traced else y
    xp, yp = _promote(x, like), _promote(y, like)
    if xp is None or yp is None:
        return NotImplemented
    return (xp * xp + yp * yp).sqrt()


def _unary(name: str) -> Callable[[Any], Any]:
    def impl(x: Any) -> Any:
        return getattr(x, name)() if type(x) is _Traced else NotImplemented

    return impl


_UFUNCS: dict = {
    np.add: _t_add,
    np.subtract: _t_sub,
    np.multiply: _t_mul,
    np.divide: _t_div,
    np.power: _t_pow,
    np.float_power: _t_pow,
    np.negative: lambda x: -x,
    np.positive: lambda x: x,
    np.arctan2: _t_arctan2,
    np.hypot: _t_hypot,
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


class _Traced:
    """A series under tracing: its trace-time internal array ``c`` and its slot on the recorder.

    Supports what :class:`Series` supports on values (operators, the numpy ufuncs of
    :data:`planners.series._UFUNCS`, the elementary-function methods, ``linear_combinations``);
    ``order`` is known (fixed by the working order); anything else aborts the trace.
    """

    __slots__ = ("rec", "slot", "c", "_pairs")

    def __init__(self, rec: _Recorder, slot: int, c: np.ndarray) -> None:
        self.rec, self.slot, self.c = rec, slot, c
        self._pairs: dict | None = None

    # what duck typing may test, without a fixed value
    coeffs = property(lambda self: _Opaque("coefficients"))
    batch_shape = property(lambda self: _Opaque("batch shape"))
    dtype = property(lambda self: _Opaque("dtype"))
    constant_term = property(lambda self: _Opaque("constant term"))

    @property
    def order(self) -> int:
        return self.c.shape[0] - 1

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise TraceError(f"Series.{name} is not traced")

    def __array__(self, *args: Any, **kwargs: Any) -> Any:
        raise TraceError("a traced series converted to an array")

    def __bool__(self) -> bool:
        raise TraceError("a traced series used as a truth value")

    def _no_compare(self, other: Any) -> Any:
        raise TraceError("a traced series compared")

    __lt__ = __le__ = __gt__ = __ge__ = __eq__ = __ne__ = _no_compare
    __hash__ = None  # type: ignore[assignment]

    def __iter__(self):
        raise TraceError("iteration over a traced series")

    # operators, as Series'
    def __neg__(self) -> _Traced:
        return self.rec.op(np.negative, self)

    def __pos__(self) -> _Traced:
        return self

    def __add__(self, o: Any) -> Any:
        return _t_add(self, o)

    def __radd__(self, o: Any) -> Any:
        return _t_add(o, self)

    def __sub__(self, o: Any) -> Any:
        return _t_sub(self, o)

    def __rsub__(self, o: Any) -> Any:
        return _t_sub(o, self)

    def __mul__(self, o: Any) -> Any:
        return _t_mul(self, o)

    def __rmul__(self, o: Any) -> Any:
        return _t_mul(o, self)

    def __truediv__(self, o: Any) -> Any:
        return _t_div(self, o)

    def __rtruediv__(self, o: Any) -> Any:
        return _t_div(o, self)

    def __pow__(self, o: Any, modulo: Any = None) -> Any:
        if modulo is not None:
            return NotImplemented
        return _t_pow(self, o)

    def __rpow__(self, o: Any) -> Any:
        return _t_pow(o, self)

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        impl = _UFUNCS.get(ufunc)
        if method != "__call__" or kwargs or impl is None:
            raise TraceError(f"numpy {ufunc.__name__}.{method} on a traced series")
        return impl(*inputs)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        raise TraceError(f"numpy.{func.__name__} on a traced series")

    # elementary functions, as Series' methods (the pairs memoised, as Series does)
    def _pair(self, name: str) -> tuple:
        if self._pairs is None:
            self._pairs = {}
        pair = self._pairs.get(name)
        if pair is None:
            pair = self._pairs[name] = self.rec.op(_PAIRS[name], self, n_out=2)
        return pair

    def sincos(self) -> tuple:
        return self._pair("sincos")

    def sin(self) -> _Traced:
        return self._pair("sincos")[0]

    def cos(self) -> _Traced:
        return self._pair("sincos")[1]

    def sinhcosh(self) -> tuple:
        return self._pair("sinhcosh")

    def sinh(self) -> _Traced:
        return self._pair("sinhcosh")[0]

    def cosh(self) -> _Traced:
        return self._pair("sinhcosh")[1]

    @staticmethod
    def linear_combinations(weights: Any, items: Sequence[Any]) -> list:
        """``Series.linear_combinations`` of items some of which are traced: one instruction."""
        rec = _rec_of(*items)
        spec = tuple(type(x) is _Traced for x in items)
        w = np.asarray(weights, dtype=float)
        return list(rec.op(_linear_combinations, w, spec, *items, n_out=w.shape[0]))


def _add_method(name: str) -> None:
    fn = _METHODS[name]
    setattr(_Traced, name, lambda self: self.rec.op(fn, self))


for _name in _METHODS:
    _add_method(_name)


# ---------------------------------------------------------------------------
# The program and its replay
# ---------------------------------------------------------------------------


class SeriesTape:
    """A traced residual: instructions on coefficient-first arrays, replayable on new unknowns.

    Built by :func:`trace`.

    Attributes
    ----------
    n_inputs : int
        Number of unknowns.
    order : int
        Working order of the trace (the unknowns have ``order + 1`` coefficients).
    n_instructions : int
        Instructions replayed (every recorded one: no dead-code elimination).
    """

    def __init__(self, rec: _Recorder, n_inputs: int, outputs: list, order: int) -> None:
        self._outputs = tuple(o.slot if type(o) is _Traced else rec.const(o) for o in outputs)
        self._template = rec.values
        self._instrs = rec.instrs
        self._prog: list | None = None
        self.n_inputs = n_inputs
        self.order = order
        #: Which outputs are traced (replayed as internal arrays); the others are constants.
        self.traced_outputs = tuple(type(o) is _Traced for o in outputs)

    def _build(self) -> list:
        """The replayed program, each traced intermediate released after its last use (as the eager
        evaluation frees it); built at the first replay (a tape never replayed costs only its trace)."""
        values, instrs = self._template, self._instrs
        last: dict = {}
        for i, (_, slots, _) in enumerate(instrs):
            for s in slots:
                if values[s] is None:
                    last[s] = i
        for s in self._outputs:
            last.pop(s, None)
        release: list = [[] for _ in instrs]
        for s, i in last.items():
            release[i].append(s)
        self._prog = [(fn, slots, out, tuple(rel)) for (fn, slots, out), rel in zip(instrs, release)]
        return self._prog

    @property
    def n_instructions(self) -> int:
        """Number of instructions replayed."""
        return len(self._instrs)

    def run(self, inputs: Sequence[np.ndarray]) -> list:
        """Replay the program.

        Parameters
        ----------
        inputs : sequence of ndarray
            The unknowns' internal (coefficient-first, C-ordered) arrays, shape ``(order + 1,) + batch``,
            real or complex, any batch shape the residual's data broadcast against.

        Returns
        -------
        list
            One entry per residual output: an internal array, or the constant the residual returned.
        """
        prog = self._prog if self._prog is not None else self._build()
        v = self._template.copy()
        v[: self.n_inputs] = inputs
        get = v.__getitem__
        for fn, slots, out, release in prog:
            v[out] = fn(*map(get, slots))
            for s in release:
                v[s] = None
        return [v[s] for s in self._outputs]


def trace(residual: Callable, u: Sequence[Series], k: int) -> tuple[SeriesTape, list]:
    """Evaluate ``residual(u, k)`` with the unknowns traced, and the program of that evaluation.

    Parameters
    ----------
    residual : callable
        ``residual(u, k) -> list`` of series (or constants), the unknowns ``u`` series of order ``k``.
    u : sequence of Series
        The unknowns (their values are those of this evaluation).
    k : int
        Working order.

    Returns
    -------
    tape : SeriesTape
        The recorded program.
    outputs : list
        The residual's value at ``u``: Series (bit-identical to ``residual(u, k)``) or constants.

    Raises
    ------
    TraceError
        The residual used an operation that is not recorded; or raised (the message names the
        exception).
    """
    rec = _Recorder()
    traced = [rec.input(x._c) for x in u]  # the inputs are the first slots
    rec.false, rec.true = rec.const(False), rec.const(True)
    try:
        out = residual(traced, k)
    except TraceError:
        raise
    except Exception as exc:
        raise TraceError(f"{type(exc).__name__} while tracing: {exc}") from None
    outputs = list(out)
    for o in outputs:
        if type(o) is not _Traced and not isinstance(o, Series) and _as_constant(o) is None:
            raise TraceError(f"a residual of type {type(o).__name__}")
    tape = SeriesTape(rec, len(traced), outputs, k)
    values = [Series._wrap(o.c) if type(o) is _Traced else o for o in outputs]
    return tape, values


#: When :class:`TapedResidual` traces: at the first evaluation of every order (``"first"``); at the
#: first evaluation of the first order met and at the second evaluation of any other (``"first-order"``,
#: the default: a Newton call at one working order traces at once, the precision-doubling steps, one
#: evaluation per order, are not traced); at the second evaluation of every order (``"second"``);
#: never (``"never"``, the eager evaluation, for measurements).
WHEN = ("first", "first-order", "second", "never")


class TapedResidual:
    """A residual evaluated eagerly, traced, or replayed: a drop-in replacement inside one Newton call.

    ``TapedResidual(residual)(u, k)`` returns what ``residual(u, k)`` returns (bit for bit): with
    series unknowns, the first evaluation at a working order ``k`` traces the residual
    (:func:`trace`), the following ones at that order replay the program; plain-array unknowns
    (the pointwise Newton) and any evaluation after a failed trace are eager.

    Parameters
    ----------
    residual : callable
        ``residual(u, k) -> list``, the data it uses fixed while this object is in use (one
        :func:`planners.newton.newton_series` call).
    when : str, optional
        When to trace, one of :data:`WHEN`.

    Attributes
    ----------
    reason : str or None
        Why the residual could not be traced (then every evaluation is eager).
    tapes : dict
        Working order -> :class:`SeriesTape`.
    counts : dict
        Evaluations by kind: ``"eager"``, ``"trace"``, ``"replay"``.
    """

    def __init__(self, residual: Callable, when: str = "first-order") -> None:
        if when not in WHEN:
            raise ValueError(f"when must be one of {', '.join(WHEN)}, got {when!r}")
        self.residual = residual
        self.when = when
        self.reason: str | None = None
        self.tapes: dict = {}
        self.counts = {"eager": 0, "trace": 0, "replay": 0}
        self._seen: set = set()

    def __call__(self, u: Sequence[Any], k: int) -> list:
        """``residual(u, k)``.

        Parameters
        ----------
        u : sequence
            The unknowns: Series of order ``k``, or arrays of constant terms when ``k = 0``.
        k : int
            Working order.

        Returns
        -------
        list
            The residuals.
        """
        if (
            self.when != "never"
            and self.reason is None
            and u
            and all(type(x) is Series and x._c.shape[0] == k + 1 for x in u)
        ):
            tape = self.tapes.get(k)
            if tape is not None:
                if len(u) == tape.n_inputs:
                    self.counts["replay"] += 1
                    return [
                        Series._wrap(o) if t else o for o, t in zip(tape.run([x._c for x in u]), tape.traced_outputs)
                    ]
            elif self.when == "first" or k in self._seen or (self.when == "first-order" and not self._seen):
                try:
                    tape, values = trace(self.residual, u, k)
                except TraceError as exc:
                    self.reason = str(exc)
                else:
                    self.tapes[k] = tape
                    self._seen.add(k)
                    self.counts["trace"] += 1
                    return values
            self._seen.add(k)
        self.counts["eager"] += 1
        return self.residual(u, k)


del _name
