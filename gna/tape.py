"""The equations of motion traced into a straight-line program on floats: the engine's fast path.

:func:`gna.eom.derivatives` is the one definition of the model; it is written with arithmetic and
numpy ufuncs so that it evaluates on floats, arrays and truncated power series.  On one state of
floats most of its cost is interpretation, not arithmetic: ~45 aerodynamic terms walked through
their term table, a numpy ufunc call per sine, a dozen named tuples.  :func:`compile_derivatives`
evaluates that same definition once on *traced values* (:class:`_Traced`, which record every
operation applied to them) for one aircraft, environment and model, and writes the recorded
operations out as one Python function of the 17 floats (12 states, 5 controls) using ``math``:

* every number that does not depend on the state (mass, inertia, geometry, the term table's
  parameters, the atmosphere's constants) is folded into the program as a literal;
* an operation applied twice to the same operands (``cos(beta)`` in the forces and in the G3
  equations) is computed once, and operations no output depends on are dropped;
* a comparison of a traced value (the ISA density chooses its layer from the altitude) is recorded
  as a *guard*: the program re-checks it and returns ``None`` when the state lies on the other
  side, and :class:`CompiledDerivatives` then traces a program for that side (a few at most).

Nothing is re-written by hand, so a change to :mod:`gna.eom`, :mod:`gna.aero` or
:mod:`gna.atmosphere` reaches the fast path with the next compilation.  An operation the tracer
does not know (or a value-dependent branch it cannot guard) makes the compilation fail with the
reason recorded, and :class:`CompiledDerivatives` then evaluates the generic definition: slower,
never different.  Floating-point exceptions of Python floats (division by zero, overflow in
``exp`` or ``pow``, a domain error) also fall back, for that call, to the generic evaluation, which
returns the same inf/NaN the generic engine would.  ``tests/gna/test_tape.py`` checks the program
against the generic evaluation to 1e-12 on random states and controls of every bundled aircraft.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable

import numpy as np

from .aircraft import Aircraft
from .atmosphere import Environment
from .eom import CONTROL_NAMES, STATE_NAMES, Controls, HValues, State, derivatives
from .errors import InputError, describe

__all__ = ["CompiledDerivatives", "compile_derivatives", "TraceError"]

#: Traced programs kept per compiled model (one per side of each guard met, e.g. the ISA layers).
MAX_PROGRAMS = 8


class TraceError(Exception):
    """The definition did something the tracer cannot record (the fast path is then not used)."""


class _TraceArithmeticError(TraceError):
    """A floating-point exception while tracing at one state: another state may trace."""


# Unary and binary operations: (code template, float implementation).  The float implementation
# computes the traced value, with exactly the operation the generated code performs.
_UNARY = {
    "neg": ("-{0}", lambda a: -a),
    "pos": ("+{0}", lambda a: +a),
    "abs": ("abs({0})", abs),
    "cos": ("cos({0})", math.cos),
    "sin": ("sin({0})", math.sin),
    "tan": ("tan({0})", math.tan),
    "exp": ("exp({0})", math.exp),
    "log": ("log({0})", math.log),
    "sqrt": ("sqrt({0})", math.sqrt),
    "arcsin": ("asin({0})", math.asin),
    "arccos": ("acos({0})", math.acos),
    "arctan": ("atan({0})", math.atan),
    "tanh": ("tanh({0})", math.tanh),
    "sinh": ("sinh({0})", math.sinh),
    "cosh": ("cosh({0})", math.cosh),
    "square": ("{0} * {0}", lambda a: a * a),
}
_BINARY = {
    "add": ("{0} + {1}", lambda a, b: a + b),
    "sub": ("{0} - {1}", lambda a, b: a - b),
    "mul": ("{0} * {1}", lambda a, b: a * b),
    "div": ("{0} / {1}", lambda a, b: a / b),
    # math.pow, not **: a negative base with a fractional exponent raises (then the generic
    # evaluation gives numpy's NaN) instead of making a complex number.
    "pow": ("pow({0}, {1})", math.pow),
    "arctan2": ("atan2({0}, {1})", math.atan2),
    "hypot": ("hypot({0}, {1})", math.hypot),
}
_COMPARE = {"lt": "<", "le": "<=", "gt": ">", "ge": ">=", "eq": "==", "ne": "!="}
_COMPARE_FUNCTIONS = {
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
    "eq": operator.eq,
    "ne": operator.ne,
}

_UFUNCS = {
    np.negative: "neg",
    np.positive: "pos",
    np.absolute: "abs",
    np.cos: "cos",
    np.sin: "sin",
    np.tan: "tan",
    np.exp: "exp",
    np.log: "log",
    np.sqrt: "sqrt",
    np.arcsin: "arcsin",
    np.arccos: "arccos",
    np.arctan: "arctan",
    np.tanh: "tanh",
    np.sinh: "sinh",
    np.cosh: "cosh",
    np.square: "square",
    np.add: "add",
    np.subtract: "sub",
    np.multiply: "mul",
    np.true_divide: "div",
    np.power: "pow",
    np.float_power: "pow",
    np.arctan2: "arctan2",
    np.hypot: "hypot",
    np.less: "lt",
    np.less_equal: "le",
    np.greater: "gt",
    np.greater_equal: "ge",
    np.equal: "eq",
    np.not_equal: "ne",
}

_NUMBER = (int, float, np.integer, np.floating)


class _Tape:
    """The recorded program: ``ops[k] = (name, operand refs)``; a ref is a slot index or a float literal."""

    def __init__(self):
        self.ops: list[tuple[str, tuple]] = []
        self.values: list[float] = []
        self.memo: dict[tuple, int] = {}
        self.guards: list[tuple[int, str, object, bool]] = []  # (after op index, comparison, other ref, outcome)

    def input(self, value: float) -> _Traced:
        self.ops.append(("input", ()))
        self.values.append(float(value))
        return _Traced(self, len(self.ops) - 1)

    def apply(self, name: str, args: tuple) -> _Traced | float:
        refs = []
        for a in args:
            if isinstance(a, _Traced):
                if a.tape is not self:
                    raise TraceError("a value traced on another tape")
                refs.append(a.slot)
            elif isinstance(a, _NUMBER) and not isinstance(a, bool):
                refs.append(float(a))
            else:
                raise TraceError(f"operation {name} on a {type(a).__name__}")
        operands = tuple(("s", r) if isinstance(a, _Traced) else ("c", r) for a, r in zip(args, refs))
        # Literals keyed by their bits (0.0 and -0.0 are different operands).
        key = (name, tuple((k, r if k == "s" else r.hex()) for k, r in operands))
        slot = self.memo.get(key)
        if slot is not None:
            return _Traced(self, slot)
        vals = [self.values[r] if isinstance(a, _Traced) else r for a, r in zip(args, refs)]
        try:
            value = (_UNARY[name][1] if len(vals) == 1 else _BINARY[name][1])(*vals)
        except (ArithmeticError, ValueError) as exc:
            raise _TraceArithmeticError(f"{name} of {vals} while tracing: {exc}") from None
        self.ops.append((name, operands))
        self.values.append(float(value))
        self.memo[key] = len(self.ops) - 1
        return _Traced(self, len(self.ops) - 1)

    def compare(self, name: str, a, b) -> bool:
        if isinstance(b, _Traced) and not isinstance(a, _Traced):
            a, b, name = b, a, {"lt": "gt", "le": "ge", "gt": "lt", "ge": "le"}.get(name, name)
        if isinstance(b, _Traced):
            bref, bval = ("s", b.slot), self.values[b.slot]
        elif isinstance(b, _NUMBER) and not isinstance(b, bool):
            bref, bval = ("c", float(b)), float(b)
        else:
            raise TraceError(f"comparison with a {type(b).__name__}")
        outcome = bool(_COMPARE_FUNCTIONS[name](self.values[a.slot], bval))
        self.guards.append((a.slot, name, bref, outcome))
        return outcome


class _Traced:
    """A float under tracing: arithmetic, numpy ufuncs and comparisons are recorded on its tape."""

    __slots__ = ("tape", "slot")

    def __init__(self, tape: _Tape, slot: int):
        self.tape, self.slot = tape, slot

    # Arithmetic.
    def __add__(self, o):
        return self.tape.apply("add", (self, o))

    def __radd__(self, o):
        return self.tape.apply("add", (o, self))

    def __sub__(self, o):
        return self.tape.apply("sub", (self, o))

    def __rsub__(self, o):
        return self.tape.apply("sub", (o, self))

    def __mul__(self, o):
        return self.tape.apply("mul", (self, o))

    def __rmul__(self, o):
        return self.tape.apply("mul", (o, self))

    def __truediv__(self, o):
        return self.tape.apply("div", (self, o))

    def __rtruediv__(self, o):
        return self.tape.apply("div", (o, self))

    def __pow__(self, o):
        return self.tape.apply("pow", (self, o))

    def __rpow__(self, o):
        return self.tape.apply("pow", (o, self))

    def __neg__(self):
        return self.tape.apply("neg", (self,))

    def __pos__(self):
        return self.tape.apply("pos", (self,))

    def __abs__(self):
        return self.tape.apply("abs", (self,))

    # Comparisons become guards of the program.
    def __lt__(self, o):
        return self.tape.compare("lt", self, o)

    def __le__(self, o):
        return self.tape.compare("le", self, o)

    def __gt__(self, o):
        return self.tape.compare("gt", self, o)

    def __ge__(self, o):
        return self.tape.compare("ge", self, o)

    def __eq__(self, o):
        return self.tape.compare("eq", self, o)

    def __ne__(self, o):
        return self.tape.compare("ne", self, o)

    __hash__ = object.__hash__

    @property
    def real(self):
        return self

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if method == "__call__" and not kwargs and ufunc in (np.minimum, np.maximum):
            return _select(self.tape, ufunc is np.minimum, *inputs)
        name = _UFUNCS.get(ufunc)
        if method != "__call__" or kwargs or name is None:
            raise TraceError(f"numpy {ufunc.__name__}.{method} is not traced")
        if name in _COMPARE:
            return self.tape.compare(name, *inputs)
        return self.tape.apply(name, inputs)

    def __array_function__(self, func, types, args, kwargs):
        # The value-dependent choices of numpy on one float: a guard decides, the chosen operand is kept.
        if func is np.real and len(args) == 1 and not kwargs:
            return args[0]
        if func is np.where and len(args) == 3 and not kwargs and isinstance(args[0], (bool, np.bool_)):
            return args[1] if args[0] else args[2]
        if func is np.clip and len(args) == 3 and not kwargs:
            return _select(self.tape, True, _select(self.tape, False, args[0], args[1]), args[2])
        raise TraceError(f"numpy.{func.__name__} is not traced")

    # Anything that would turn the traced value into a constant, or branch on it unguarded.
    def __float__(self):
        raise TraceError("a traced value converted to float")

    def __bool__(self):
        raise TraceError("a traced value used as a truth value")

    def __array__(self, *args, **kwargs):
        raise TraceError("a traced value converted to an array")

    def __index__(self):
        raise TraceError("a traced value used as an index")


def _select(tape: _Tape, smaller: bool, a, b):
    """``np.minimum(a, b)`` (``smaller``) or ``np.maximum(a, b)`` on one float: a guard on ``a <= b``."""
    values = [tape.values[v.slot] if isinstance(v, _Traced) else v for v in (a, b)]
    if any(isinstance(v, float) and math.isnan(v) for v in values):
        raise _TraceArithmeticError("minimum or maximum of a NaN")  # numpy propagates it; a guard would not
    if not isinstance(a, _Traced) and not isinstance(b, _Traced):
        return min(a, b) if smaller else max(a, b)
    a_first = tape.compare("le", a, b) if isinstance(a, _Traced) else not tape.compare("lt", b, a)
    return (a if a_first else b) if smaller else (b if a_first else a)


def _emit(tape: _Tape, outputs: list) -> str:
    """Python source of the traced program (guards re-checked where their operands are known)."""
    n_in = len(STATE_NAMES) + len(CONTROL_NAMES)
    need = [False] * len(tape.ops)
    for o in outputs:
        if isinstance(o, _Traced):
            need[o.slot] = True
    for slot, _, bref, _ in tape.guards:
        need[slot] = True
        if bref[0] == "s":
            need[bref[1]] = True
    for k in range(len(tape.ops) - 1, -1, -1):
        if need[k]:
            for kind, r in tape.ops[k][1]:
                if kind == "s":
                    need[r] = True
    guards_after: dict[int, list] = {}
    for g in tape.guards:
        last = max(g[0], g[2][1] if g[2][0] == "s" else -1)
        guards_after.setdefault(last, []).append(g)

    # An operation used once (not an output, not in a guard) is written into its user's expression,
    # parenthesised: the same operations in the same order, fewer local stores and loads.
    uses = [0] * len(tape.ops)
    for k, (_, refs) in enumerate(tape.ops):
        if need[k]:
            for kind, r in refs:
                if kind == "s":
                    uses[r] += 1
    named = [k < n_in or uses[k] != 1 for k in range(len(tape.ops))]
    for o in outputs:
        if isinstance(o, _Traced):
            named[o.slot] = True
    for slot, _, bref, _ in tape.guards:
        named[slot] = True
        if bref[0] == "s":
            named[bref[1]] = True
    depth = [0] * len(tape.ops)
    text: dict[int, str] = {}

    def ref(kind, r):
        if kind == "c":
            return repr(r)
        return f"v{r}" if named[r] else f"({text.pop(r)})"

    lines = [
        "def program(s, u):",
        "    " + ", ".join(f"v{k}" for k in range(len(STATE_NAMES))) + ", = s",
        "    " + ", ".join(f"v{k}" for k in range(len(STATE_NAMES), n_in)) + ", = u",
    ]
    for k, (name, refs) in enumerate(tape.ops):
        if k >= n_in and need[k]:
            template = _UNARY[name][0] if len(refs) == 1 else _BINARY[name][0]
            depth[k] = 1 + max((depth[r] for kind, r in refs if kind == "s" and not named[r]), default=0)
            if depth[k] > _MAX_DEPTH:
                named[k], depth[k] = True, 0
            expr = template.format(*(ref(*r) for r in refs))
            if named[k]:
                lines.append(f"    v{k} = {expr}")
            else:
                text[k] = expr
        for slot, cmp, bref, outcome in guards_after.get(k, []):
            test = f"v{slot} {_COMPARE[cmp]} {ref(*bref)}"
            lines.append(f"    if {'not ' if outcome else ''}({test}):\n        return None")
    outs = [f"v{o.slot}" if isinstance(o, _Traced) else repr(float(o)) for o in outputs]
    lines.append("    return (" + ", ".join(outs) + ",)")
    return "\n".join(lines) + "\n"


#: Deepest nesting of inlined operations in one expression of a generated program.
_MAX_DEPTH = 40

_NAMESPACE = {
    "cos": math.cos,
    "sin": math.sin,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sqrt": math.sqrt,
    "asin": math.asin,
    "acos": math.acos,
    "atan": math.atan,
    "tanh": math.tanh,
    "sinh": math.sinh,
    "cosh": math.cosh,
    "pow": math.pow,
    "atan2": math.atan2,
    "hypot": math.hypot,
    "abs": abs,
    "inf": math.inf,
    "nan": math.nan,
}


def trace_program(
    aircraft: Aircraft, env: Environment, x, u, model: str = "full", h: HValues | None = None
) -> tuple[Callable, str]:
    """Trace :func:`gna.eom.derivatives` at one state and write it out as a Python function of floats.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft (its parameters become literals of the program).
    env : Environment
        Atmosphere and gravity (likewise).
    x : sequence of 12 float
        The state at which value-dependent branches (the guards) are decided (SI, rad).
    u : sequence of 5 float
        The controls there (``F`` [N], ``eta``, surfaces [rad]).
    model : {"full", "simple"}
        Equations of motion.
    h : HValues, optional
        Neglected-term values of the simple model.

    Returns
    -------
    program : callable
        ``program(s, u) -> tuple of 12 floats`` (the derivatives, in the order of
        :data:`gna.eom.STATE_NAMES`), or ``None`` when a guard fails at ``(s, u)``; ``s`` and ``u``
        are sequences of 12 and 5 Python floats.
    source : str
        Its Python source.

    Raises
    ------
    TraceError
        The definition used an operation that is not recorded (a numpy function other than the
        elementwise ones of :data:`_UFUNCS`, a conversion of a traced value to a float or an array, an
        unguarded truth test) or failed at ``(x, u)``.
    """
    tape = _Tape()
    s = State(*(tape.input(v) for v in x))
    c = Controls(*(tape.input(v) for v in u))
    try:
        with np.errstate(all="ignore"):
            out = derivatives(aircraft, env, s, c, model, h)
    except TraceError:
        raise
    except Exception as exc:  # anything the definition itself refuses on traced values
        raise TraceError(f"{type(exc).__name__}: {describe(exc)}") from None
    outputs = list(out)
    for o in outputs:
        if not isinstance(o, (_Traced,) + _NUMBER):
            raise TraceError(f"a derivative of type {type(o).__name__}")
    source = _emit(tape, outputs)
    namespace = dict(_NAMESPACE)
    exec(compile(source, f"<gna.tape: {getattr(aircraft, 'id', 'aircraft')} {model}>", "exec"), namespace)
    return namespace["program"], source


class CompiledDerivatives:
    """``f(x, u) -> dx/dt`` for one aircraft, environment and model: traced programs, generic fallback.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft.
    env : Environment
        Atmosphere and gravity.
    model : {"full", "simple"}
        Equations of motion.
    h : HValues, optional
        Neglected-term values of the simple model.
    x0 : sequence of 12 float, optional
        A state at which to trace the first program (SI, rad); default: traced at the first call.
    u0 : sequence of 5 float, optional
        The controls there.

    Attributes
    ----------
    programs : list of callable
        The traced programs (empty until the first call when ``x0`` is not given).
    sources : list of str
        Their Python source.
    reason : str or None
        Why the definition could not be traced (then every call is the generic evaluation).
    generic_calls : int
        Calls answered by the generic evaluation (guards failed on every program, a floating-point
        exception, or no program).
    """

    def __init__(
        self, aircraft: Aircraft, env: Environment, model: str = "full", h: HValues | None = None, x0=None, u0=None
    ):
        if model not in ("full", "simple"):
            raise InputError(f"model must be 'full' or 'simple', got {model!r}")
        self.aircraft, self.env, self.model, self.h = aircraft, env, model, h
        self.programs: list[Callable] = []
        self.sources: list[str] = []
        self.reason: str | None = None
        self.generic_calls = 0
        self._failed_traces = 0
        if x0 is not None and u0 is not None:
            self._add_program(list(map(float, x0)), list(map(float, u0)))

    def _add_program(self, s: list, u: list) -> Callable | None:
        if self.reason is not None or len(self.programs) + self._failed_traces >= MAX_PROGRAMS:
            return None
        try:
            program, source = trace_program(self.aircraft, self.env, s, u, self.model, self.h)
        except _TraceArithmeticError:
            self._failed_traces += 1  # this state only (e.g. V = 0): the generic evaluation answers
            return None
        except TraceError as exc:
            if not self.programs:
                self.reason = str(exc)
            return None
        self.programs.append(program)
        self.sources.append(source)
        return program

    def generic(self, s, u) -> tuple:
        """The generic evaluation of :func:`gna.eom.derivatives` on numpy floats.

        Parameters
        ----------
        s : sequence of 12 float
            States (SI, rad).
        u : sequence of 5 float
            Controls.

        Returns
        -------
        tuple of 12 float
            The derivatives (numpy floats; inf/NaN where the model gives them).
        """
        self.generic_calls += 1
        with np.errstate(all="ignore"):
            return tuple(
                derivatives(
                    self.aircraft,
                    self.env,
                    State(*np.asarray(s, dtype=float)),
                    Controls(*np.asarray(u, dtype=float)),
                    self.model,
                    self.h,
                )
            )

    def values(self, s: list, u: list) -> tuple:
        """Derivatives at one state, as a tuple of 12 floats.

        Parameters
        ----------
        s : list of 12 float
            States (Python floats, SI, rad).
        u : list of 5 float
            Controls (Python floats).

        Returns
        -------
        tuple of 12 float
            ``(x', ..., r')`` (SI, rad/s, rad/s^2).
        """
        try:
            for program in self.programs:
                d = program(s, u)
                if d is not None:
                    return d
            program = self._add_program(s, u)
            if program is not None:
                d = program(s, u)
                if d is not None:
                    return d
        except (ArithmeticError, ValueError, TypeError):
            pass  # a float exception: numpy's inf/NaN semantics below
        return self.generic(s, u)

    def __call__(self, x, u) -> np.ndarray:
        """Derivatives at one state.

        Parameters
        ----------
        x : ndarray, shape (12,)
            States (SI, rad).
        u : array_like, shape (5,)
            Controls (``F`` [N], ``eta``, surfaces [rad]).

        Returns
        -------
        ndarray, shape (12,)
            ``(x', ..., r')`` (SI, rad/s, rad/s^2).
        """
        return np.array(
            self.values(
                x.tolist() if isinstance(x, np.ndarray) else list(map(float, x)),
                u.tolist() if isinstance(u, np.ndarray) else list(map(float, u)),
            ),
            dtype=float,
        )


def compile_derivatives(
    aircraft: Aircraft, env: Environment | None = None, model: str = "full", h: HValues | None = None, x0=None, u0=None
) -> CompiledDerivatives:
    """The fast float path of :func:`gna.eom.derivatives` for one aircraft, environment and model.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft.
    env : Environment, optional
        Atmosphere and gravity; default the ISA.
    model : {"full", "simple"}
        Equations of motion.
    h : HValues, optional
        Neglected-term values of the simple model.
    x0 : sequence of 12 float, optional
        State at which to trace the first program (SI, rad).
    u0 : sequence of 5 float, optional
        Controls there.

    Returns
    -------
    CompiledDerivatives
        Callable ``f(x, u) -> ndarray (12,)``; ``f.values(list, list) -> tuple`` for lists of floats.

    Raises
    ------
    InputError
        ``model`` is neither ``"full"`` nor ``"simple"``.
    """
    return CompiledDerivatives(aircraft, env if env is not None else Environment(), model, h, x0, u0)
