"""Safe arithmetic expressions of time for scenario files.

Flat outputs and prescribed inputs are written as text such as
``"29.10852587*t + 50*sin(t/60)"``.  The text is parsed with :mod:`ast` and
only numbers, the variable ``t``, named constants, ``+ - * / **`` and a fixed
set of functions are accepted -- never ``eval`` of arbitrary code.  The
compiled expression evaluates on floats, numpy arrays and truncated power
series (through numpy's ufunc dispatch).
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from gna.errors import InputError, describe
from gna.units import DEG, G0, KT

FUNCTIONS: dict[str, Callable] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "arctan": np.arctan,
    "atan": np.arctan,
    "arcsin": np.arcsin,
    "asin": np.arcsin,
    "arccos": np.arccos,
    "acos": np.arccos,
    "arctan2": np.arctan2,
    "atan2": np.arctan2,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
}

#: Constants every expression may use (SI): kt converts knots to m/s, deg degrees to rad.
CONSTANTS: dict[str, float] = {
    "pi": math.pi,
    "e": math.e,
    "g0": G0,
    "kt": KT,
    "deg": DEG,
    "kmh": 1000.0 / 3600.0,
    "ft": 0.3048,
}

_BINOPS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNOPS = {ast.USub: operator.neg, ast.UAdd: operator.pos}

#: Bounds on an expression's size: its text, the nodes of its syntax tree and their nesting.  The paper's
#: flat outputs have tens of nodes; the bounds keep a pathological file from exhausting the parser's stack
#: or the planner's time.
MAX_TEXT = 4000

#: Characters of an expression a message quotes (the rest elided: a message stays one readable line).
SHOWN_CHARS = 80


def _shown(text) -> str:
    """``text`` quoted for a message, at most :data:`SHOWN_CHARS` characters of it."""
    text = str(text)
    if len(text) <= SHOWN_CHARS:
        return repr(text)
    return f"{text[:SHOWN_CHARS]!r}... ({len(text)} characters)"


MAX_NODES = 2000
MAX_DEPTH = 200


def _depth(tree: ast.AST) -> int:
    """Nesting depth of a syntax tree (iterative: a deep tree must not exhaust the stack here either)."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        stack.extend((child, d + 1) for child in ast.iter_child_nodes(node))
    return deepest


@dataclass(frozen=True)
class Expression:
    """A compiled expression of ``t``.

    Call it with ``t`` (float, array or Series).  ``text`` keeps the source.
    """

    text: str
    _fn: Callable = None  # type: ignore[assignment]
    depends_on_t: bool = True

    def __call__(self, t):
        return self._fn(t)

    def __str__(self) -> str:
        return self.text


def compile_expression(
    text: str | float | int, constants: Mapping[str, float] | None = None, where: str = "expression"
) -> Expression:
    """Parse ``text`` into an :class:`Expression`.

    Parameters
    ----------
    text : str, float or int
        An expression of ``t`` [s] (numbers, ``t``, constants, ``+ - * / **``, :data:`FUNCTIONS`), or a
        number (a constant expression).
    constants : mapping of str to float, optional
        Named constants added to (and overriding) :data:`CONSTANTS`, e.g. a scenario file's ``[constants]``.
    where : str
        What the expression is, for the messages (e.g. ``"outputs.x"``).

    Returns
    -------
    Expression
        The compiled expression; ``depends_on_t`` is False when ``t`` does not occur (it is then evaluated
        once, and its value broadcast to the shape of ``t``).

    Raises
    ------
    InputError
        A non-finite number, a value that is neither a number nor a string, a text longer than
        :data:`MAX_TEXT` or a tree beyond :data:`MAX_NODES` / :data:`MAX_DEPTH`, a syntax error, an unknown
        name or function, a wrong argument count, a forbidden construct (attribute access, subscripts,
        comprehensions, ...), or a constant expression that cannot be evaluated; each naming ``where``.
        A negative number to a fractional power raises it when the expression is evaluated (here already
        for an expression without ``t``).
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
        if not math.isfinite(value):
            raise InputError(f"{where}: value is {value}")
        return Expression(repr(value), lambda t, v=value: v + 0.0 * t, depends_on_t=False)
    if not isinstance(text, str):
        raise InputError(f"{where}: expected a number or an expression string, got {type(text).__name__}")
    names = dict(CONSTANTS)
    if constants:
        names.update({k: float(v) for k, v in constants.items()})
    if len(text) > MAX_TEXT:
        raise InputError(
            f"{where}: expression of {len(text)} characters; at most {MAX_TEXT} (define [constants] for repeated parts)"
        )
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise InputError(f"{where}: cannot parse {_shown(text)} ({exc.msg})") from None
    except (RecursionError, MemoryError):
        raise InputError(f"{where}: expression nested too deeply to parse ({_shown(text)})") from None
    n_nodes = sum(1 for _ in ast.walk(tree))
    if n_nodes > MAX_NODES or _depth(tree) > MAX_DEPTH:
        raise InputError(
            f"{where}: expression too large ({n_nodes} syntax nodes, nesting {_depth(tree)}; at most "
            f"{MAX_NODES} and {MAX_DEPTH}) in {text[:60]!r}..."
        )
    uses_t = False

    def real_pow(a, b, t):
        r = operator.pow(a, b)
        if isinstance(r, complex) or (isinstance(r, np.ndarray) and np.iscomplexobj(r)):
            at = f" at t = {t:g} s" if isinstance(t, (int, float)) else ""
            raise InputError(
                f"{where}: {_shown(text)} is not real{at} (a negative number to a fractional power: {a!r} ** {b!r})"
            )
        return r

    def constant(fn) -> float:
        """The value of a part of the expression without t, or one line saying why it has none."""
        try:
            with np.errstate(all="raise"):
                return fn(0.0)
        except InputError:
            raise
        except (ArithmeticError, ValueError, FloatingPointError, OverflowError) as exc:
            cause = "a number too large for a float" if isinstance(exc, OverflowError) else describe(exc)
            raise InputError(f"{where}: {_shown(text)} cannot be evaluated ({cause})") from None

    def build(node) -> Callable:
        """``node`` as a function of t; a part without t (``1/0`` in ``1/0 + t``) evaluated once, here, so that
        it fails when the expression is read, not later while planning."""
        fn = build_node(node)
        if isinstance(node, (ast.Expression, ast.Constant, ast.Name)) or any(
            isinstance(n, ast.Name) and n.id == "t" for n in ast.walk(node)
        ):
            return fn
        v = constant(fn)
        return lambda t: v

    def build_node(node) -> Callable:
        nonlocal uses_t
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            v = float(node.value)
            return lambda t: v
        if isinstance(node, ast.Name):
            if node.id == "t":
                uses_t = True
                return lambda t: t
            if node.id in names:
                v = names[node.id]
                return lambda t: v
            raise InputError(
                f"{where}: unknown name {_shown(node.id)} in {_shown(text)}; use t, {', '.join(sorted(names))}"
            )
        if isinstance(node, ast.BinOp) and type(node.op) is ast.Pow:
            a, b = build(node.left), build(node.right)
            return lambda t: real_pow(a(t), b(t), t)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            op, a, b = _BINOPS[type(node.op)], build(node.left), build(node.right)
            return lambda t: op(a(t), b(t))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNOPS:
            op, a = _UNOPS[type(node.op)], build(node.operand)
            return lambda t: op(a(t))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
            if node.func.id not in FUNCTIONS:
                raise InputError(
                    f"{where}: unknown function {_shown(node.func.id)} in {_shown(text)}; allowed: {', '.join(sorted(FUNCTIONS))}"
                )
            f = FUNCTIONS[node.func.id]
            args = [build(a) for a in node.args]
            nargs = 2 if f is np.arctan2 else 1
            if len(args) != nargs:
                raise InputError(f"{where}: {node.func.id} takes {nargs} argument(s) in {_shown(text)}")
            if nargs == 1:
                a0 = args[0]
                return lambda t: f(a0(t))
            a0, a1 = args
            return lambda t: f(a0(t), a1(t))
        raise InputError(
            f"{where}: construct {type(node).__name__} not allowed in {_shown(text)} "
            f"(numbers, t, constants, + - * / **, and functions only)"
        )

    fn = build(tree)
    if not uses_t:
        const = constant(fn)
        fn0 = fn
        fn = lambda t, c=const: c + 0.0 * t  # noqa: E731  keep the shape/type of t
        del fn0
    return Expression(text.strip(), fn, depends_on_t=uses_t)
