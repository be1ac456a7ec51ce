"""The engine's fast path (gna.tape) equals the generic evaluation of gna.eom.derivatives.

The traced program is the one definition written out on floats; on random states and controls of
every bundled aircraft, both atmospheres and both models it must agree with the generic
evaluation to 1e-12 (relative to the size of each derivative's terms), follow the ISA's layers
through its guards, and fall back to the generic evaluation where Python floats would raise.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import zlib

import numpy as np
import pytest

from gna.aircraft import list_aircraft, load_aircraft
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.eom import Controls, HValues, State, derivatives
from gna.tape import CompiledDerivatives, compile_derivatives, trace_program
from gna.trim import trim_level

AIRCRAFT = list_aircraft()
gsim = importlib.import_module("gna.simulate")  # the module (gna.simulate is also the function)


def _random_points(rng, n, high=False):
    """States and controls spread over the models' envelopes (SI, rad)."""
    X = np.empty((n, 12))
    X[:, 0:2] = rng.uniform(-5e3, 5e3, (n, 2))
    X[:, 2] = -rng.uniform(12e3, 19e3, n) if high else -rng.uniform(-1e3, 10.9e3, n)
    X[:, 3] = rng.uniform(20.0, 300.0, n)
    X[:, 4] = rng.uniform(-0.6, 0.6, n)
    X[:, 5] = rng.uniform(-math.pi, math.pi, n)
    X[:, 6] = rng.uniform(-0.3, 0.6, n)
    X[:, 7] = rng.uniform(-0.3, 0.3, n)
    X[:, 8] = rng.uniform(-1.2, 1.2, n)
    X[:, 9:12] = rng.uniform(-1.5, 1.5, (n, 3))
    U = np.empty((n, 5))
    U[:, 0] = rng.uniform(0.0, 5e4, n)
    U[:, 1] = rng.uniform(-1.0, 1.0, n)
    U[:, 2:5] = rng.uniform(-0.4, 0.4, (n, 3))
    return X, U


def _generic(craft, env, x, u, model="full", h=None):
    return np.array(derivatives(craft, env, State(*x), Controls(*u), model, h), dtype=float)


def _assert_equal(fast, ref, where):
    # Scale: the derivative itself, floored by 1 (unit of each derivative): the two evaluations run
    # the same operations, differing at most in the last bits of a libm function.
    err = np.abs(np.asarray(fast, dtype=float) - ref) / np.maximum(np.abs(ref), 1.0)
    assert np.all(err <= 1e-12), f"{where}: worst relative difference {err.max():.3g} at index {err.argmax()}"


@pytest.mark.parametrize("name", AIRCRAFT)
@pytest.mark.parametrize("atmosphere", ["isa", "constant"])
@pytest.mark.parametrize("model", ["full", "simple", "simple-h"])
def test_program_equals_generic_evaluation(name, atmosphere, model):
    craft = load_aircraft(name)
    env = Environment(ISA()) if atmosphere == "isa" else Environment(ConstantDensity(0.9))
    rng = np.random.default_rng(zlib.crc32(f"{name} {atmosphere} {model}".encode()))
    h = HValues(*rng.uniform(-0.2, 0.2, 6)) if model == "simple-h" else None
    mdl = "full" if model == "full" else "simple"
    f = compile_derivatives(craft, env, mdl, h)
    X, U = _random_points(rng, 200)
    for x, u in zip(X, U):
        _assert_equal(f(x, u), _generic(craft, env, x, u, mdl, h), f"{name} {atmosphere} {model} at {x}, {u}")
    assert f.reason is None and len(f.programs) == 1 and f.generic_calls == 0


def test_guards_follow_the_isa_layers():
    """Traced in the troposphere, the program refuses a state above 11 km; a second program is traced."""
    craft, env = load_aircraft("f16c"), Environment()
    rng = np.random.default_rng(7)
    (x_low, *_), (u_low, *_) = _random_points(rng, 1)
    f = compile_derivatives(craft, env, x0=x_low, u0=u_low)
    X, U = _random_points(rng, 50, high=True)
    assert f.programs[0](X[0].tolist(), U[0].tolist()) is None
    for x, u in zip(X, U):
        _assert_equal(f(x, u), _generic(craft, env, x, u), "stratosphere")
    assert len(f.programs) == 2 and f.generic_calls == 0
    X, U = _random_points(rng, 20)
    for x, u in zip(X, U):
        _assert_equal(f(x, u), _generic(craft, env, x, u), "troposphere")
    assert "11000.0" in f.sources[0]


def test_constants_folded_and_subexpressions_shared():
    craft = load_aircraft("gtm")
    _, source = trace_program(craft, Environment(), [0, 0, -100, 30, 0, 0, 0.05, 0, 0, 0, 0, 0], [20, 0, 0, 0, 0])
    assert "aircraft" not in source and "State" not in source
    assert source.count("cos(v7)") == 1 and source.count("sin(v7)") == 1  # cos, sin(beta) computed once
    assert repr(craft.mass.mass) in source


def test_float_exceptions_fall_back_to_the_generic_evaluation():
    """V = 0 divides by zero: Python raises, numpy gives inf/NaN; the call returns numpy's numbers."""
    craft = load_aircraft("a7")
    f = compile_derivatives(craft, Environment())
    x = np.array([0, 0, -1000, 0.0, 0, 0, 0.1, 0, 0, 0, 0, 0])
    u = np.array([1e4, 0, 0, 0, 0])
    with np.errstate(all="ignore"):
        ref = _generic(craft, Environment(), x, u)
    got = f(x, u)
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(ref))
    assert f.generic_calls == 1 and not np.all(np.isfinite(got))
    # The failure belonged to that state: the next one is traced.
    x[3] = 120.0
    _assert_equal(f(x, u), _generic(craft, Environment(), x, u), "after a failed trace")
    assert f.reason is None and len(f.programs) == 1 and f.generic_calls == 1


@dataclasses.dataclass(frozen=True)
class _TabulatedDensity:
    """An atmosphere the tracer cannot record (np.interp): the generic evaluation is used."""

    def density(self, h):
        return np.interp(h, [-2000.0, 20000.0], [1.4, 0.09])

    def describe(self):
        return "tabulated"


def test_untraceable_definition_uses_the_generic_evaluation():
    craft = load_aircraft("gtm")
    env = Environment(_TabulatedDensity())
    f = compile_derivatives(craft, env)
    x = np.array([0, 0, -100, 30, 0.01, 0, 0.05, 0.01, 0.02, 0.01, 0.02, 0.03])
    u = np.array([20, 0.1, 0.01, -0.02, 0.0])
    np.testing.assert_array_equal(f(x, u), _generic(craft, env, x, u))
    assert f.programs == [] and f.reason and f.generic_calls == 1


@dataclasses.dataclass(frozen=True)
class _LayeredDensity:
    """Value-dependent numpy choices (maximum, clip, where): recorded as guards."""

    def density(self, h):
        hc = np.clip(h, -1000.0, 15000.0)
        base = 1.2 * np.exp(-np.maximum(hc, 0.0) / 8500.0)
        return np.where(h > 5000.0, 0.98 * base, base)

    def describe(self):
        return "layered"


def test_value_dependent_choices_become_guards():
    craft = load_aircraft("f4")
    env = Environment(_LayeredDensity())
    f = compile_derivatives(craft, env)
    rng = np.random.default_rng(3)
    for high in (False, True, False):
        X, U = _random_points(rng, 40, high)
        X[:5, 2] = 500.0  # below the ground of the clip
        for x, u in zip(X, U):
            _assert_equal(f(x, u), _generic(craft, env, x, u), f"layered at z = {x[2]}")
    assert f.reason is None and f.generic_calls == 0 and 2 <= len(f.programs) <= 8


def test_bad_model_is_refused():
    with pytest.raises(ValueError, match="model"):
        CompiledDerivatives(load_aircraft("gtm"), Environment(), "coarse")


def _generic_only(aircraft, env, model, h, x0, u0):
    f = CompiledDerivatives(aircraft, env, model, h)
    f.reason = "generic evaluation forced by the test"
    return f


@pytest.mark.parametrize("model", ["full", "simple"])
def test_simulation_equals_the_generic_right_hand_side(monkeypatch, model):
    """The same run with the generic evaluation: the same trajectory (1e-9 relative, in practice equal)."""
    craft = load_aircraft("f16c")
    tr = trim_level(craft, 150.0, 3000.0)
    u0 = np.array(tr.controls, dtype=float)

    def controls(t):
        return u0 + np.array([0.1 * u0[0], 0.0, 0.02, 0.01, 0.02]) * math.sin(0.7 * t)

    args = (craft, controls, (0.0, 8.0), np.array(tr.state, dtype=float))
    fast = gsim.simulate(*args, model=model)
    monkeypatch.setattr(gsim, "compile_derivatives", _generic_only)
    slow = gsim.simulate(*args, model=model)
    assert fast.completed and slow.completed
    a, b = fast.df.to_numpy(), slow.df.to_numpy()
    err = np.max(np.abs(a - b), axis=0) / np.maximum(np.max(np.abs(b), axis=0), 1e-300)
    assert a.shape == b.shape and np.all(err <= 1e-9), dict(zip(fast.df.columns, err))
