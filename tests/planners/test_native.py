"""The native evaluator (planners/_program.c through planners._native) against the numpy reference: every
traced operation's series and tangent (property tests over random series), Newton's steps on series run
whole in native code (warm steps, chord steps, precision doubling, the singular fallback), whole plans of
the paper scenarios to 1e-12, and the compiled library's cache (keyed, rebuilt when stale, safe under
concurrent builds, absent compiler)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planners._native as NA
import planners.chained as C
from planners.newton import ResidualEvaluator, newton_series
from planners.program import NativeStageEvaluator, trace
from planners.series import Series

if NA.library(wait=True) is None:  # pragma: no cover - a machine without a C compiler
    pytest.skip(f"native evaluator unavailable: {NA.reason()}", allow_module_level=True)

SET = settings(max_examples=25, deadline=None)
TOL = 1e-12
ROOT = Path(__file__).resolve().parents[2]


def rand_series(rng, order, nodes, c0=(-1.0, 1.0)):
    c = rng.uniform(-1, 1, (order + 1, nodes)) * 0.5 ** np.arange(order + 1)[:, None]
    c[0] = rng.uniform(*c0, nodes)
    return Series._wrap(c)


def close(ref, new, tol=TOL):
    ref, new = np.asarray(ref), np.asarray(new)
    assert ref.shape == new.shape, (ref.shape, new.shape)
    scale = max(1.0, float(np.max(np.abs(ref))))
    assert np.max(np.abs(new - ref)) <= tol * scale, np.max(np.abs(new - ref)) / scale


def _lincomb(w, items):
    lin = next((type(x) for x in items if hasattr(type(x), "linear_combinations")), None)
    if lin is not None:
        return lin.linear_combinations(w, items)
    return [sum(wi * x for wi, x in zip(row, items)) for row in w]


# the functions of tests/planners/test_program.py (the numba evaluator's property tests)
FUNCTIONS = {
    "add-sub": lambda a, b, d: [a + b - d + 2.5, 3.0 - a, b - 1.5],
    "mul-div": lambda a, b, d: [a * b, a / (b + 3.0), d / (a + 3.0), 2.0 / (b + 3.0)],
    "scale": lambda a, b, d: [a * 0.7 / 3.0, -b, +a],
    "sqrt-exp-log": lambda a, b, d: [np.sqrt(a + 3.0), np.exp(b), np.log(a + 3.0), (a + 3.0) ** 0.5],
    "trig": lambda a, b, d: [np.sin(a), np.cos(b) * np.sin(b), np.tan(a * 0.5), np.arctan(b * d)],
    "hyperbolic": lambda a, b, d: [np.sinh(a), np.cosh(b)],
    "powers": lambda a, b, d: [(a + 3.0) ** 1.7, a**2, (b + 3.0) ** -2, a**3 * d],
    "lincomb": lambda a, b, d: _lincomb(np.array([[1.0, 0.5, -2.0], [0.0, 3.0, 1.0]]), [a, a * b * d, 1.0]),
    "products": lambda a, b, d: [a * b * (a + d), (a * a) * (b * b) + d * a],
    "arctan2": lambda a, b, d: [np.arctan2(a + 0.5, b + 3.0), np.arctan2(d, a - 3.0), np.arctan2(-b, 2.0)],
}


@SET
@given(
    name=st.sampled_from(sorted(FUNCTIONS)),
    order=st.integers(0, 18),
    nodes=st.integers(1, 19),
    seed=st.integers(0, 10**6),
)
def test_operations_and_tangents_agree_with_numpy(name, order, nodes, seed):
    """Residual and Jacobian series of each operation (node counts across the native kernels' blocks of 8):
    native program = numpy Series (complex step) to 1e-12."""
    fun = FUNCTIONS[name]
    rng = np.random.default_rng(seed)
    a, b, d = (rand_series(rng, order, nodes) for _ in range(3))
    prog, reason = trace(lambda v: fun(v["a"], v["b"], v["d"]), ("a", "b"), {"d": d}, {"d"})
    assert prog is not None, reason
    ev = NativeStageEvaluator(prog, {"d": d}, nodes)
    ref = ResidualEvaluator(lambda us, k: fun(us[0], us[1], d.truncate(k) if k else d.constant_term))
    stacked = np.stack([a.coeffs, b.coeffs])
    G, J = ev.residual_and_jacobian(stacked, order)
    Gr, Jr = ref.residual_and_jacobian(stacked, order)
    close(Gr, G)
    close(Jr, J)
    close(Gr, ev.residual_only(stacked, order))
    if name == "arctan2":  # numpy's arctan2 takes no complex step on plain arrays: the series' constant terms
        close(Gr[..., 0], ev.const_fun(stacked[..., 0]))
        close(Jr[..., 0], ev.const_jacobian(stacked[..., 0]))
        return
    x0 = stacked[..., 0]
    close(ref.const_fun(x0), ev.const_fun(x0))
    close(ref.const_jacobian(x0), ev.const_jacobian(x0))


@SET
@given(
    name=st.sampled_from(sorted(FUNCTIONS)),
    order=st.integers(0, 9),
    nodes=st.integers(1, 19),
    seed=st.integers(0, 10**6),
)
def test_the_tangent_masks_change_no_value(name, order, nodes, seed):
    """The dependency masks (planners._native.tangent_masks: the tangents known to be zero skipped) give the
    values of the full forward mode, every residual and Jacobian entry equal (an exact zero's sign aside)."""
    fun = FUNCTIONS[name]
    rng = np.random.default_rng(seed)
    a, b, d = (rand_series(rng, order, nodes) for _ in range(3))
    prog, reason = trace(lambda v: fun(v["a"], v["b"], v["d"]), ("a", "b"), {"d": d}, {"d"})
    assert prog is not None, reason
    masked = NA.NativeProgram(prog)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(NA, "tangent_masks", lambda code, n, outs, outs_unk: (np.array(code), np.array(outs_unk)))
        full = NA.NativeProgram(prog)
    assert not np.array_equal(masked.code, full.code)  # two unknowns: the masks are written
    data = prog.data_array({"d": d}, order, nodes)
    x = np.ascontiguousarray(np.stack([a.coeffs, b.coeffs]).swapaxes(1, 2))
    for M in (1, order + 1):
        G, J = masked.evaluate_tangent(x, data, M)
        Gf, Jf = full.evaluate_tangent(x, data, M)
        assert np.array_equal(G, Gf) and np.array_equal(J, Jf)


@SET
@given(order=st.integers(1, 16), nodes=st.integers(1, 11), seed=st.integers(0, 10**6))
def test_the_derivative_op_is_exact_to_one_order_less(order, nodes, seed):
    """A closed-form stage's time derivatives (the DERIV op): its first ``order`` coefficients are those of
    the numpy series, and so are its tangents'."""
    rng = np.random.default_rng(seed)
    a, d = rand_series(rng, order, nodes), rand_series(rng, order, nodes)

    def fun(x, y):
        return [x.derivative() * np.cos(y) + y.derivative(), np.sin(x) * x.derivative()]

    prog, reason = trace(lambda v: fun(v["a"], v["d"]), ("a",), {"d": d}, {"d"})
    assert prog is not None, reason
    ev = NativeStageEvaluator(prog, {"d": d}, nodes)
    G, J = ev.residual_and_jacobian(a.coeffs[None], order)
    ref = fun(a, d)
    for j, r in enumerate(ref):
        close(r.coeffs, G[j][..., :order])
    h = 1e-30  # the Jacobian by a complex step on the numpy path
    Jr = [np.imag(r.coeffs) / h for r in fun(Series(a.coeffs + 0j + np.eye(1, order + 1) * 1j * h), d)]
    for j in range(2):
        close(Jr[j], J[j, 0][..., :order])


def _problem(seed, nodes=9):
    """A well-posed pointwise-in-t system of 3 unknowns with data series (Newton converges from near)."""
    rng = np.random.default_rng(seed)
    order = 9
    d1, d2 = rand_series(rng, order, nodes, (0.5, 1.5)), rand_series(rng, order, nodes, (-0.5, 0.5))

    def fun(u, v, w, p, q):
        return [u + 0.3 * np.sin(v) * u - p, v + 0.2 * u * w - q, w * (2.0 + 0.1 * np.exp(0.5 * u)) - p * q]

    data = {"p": d1, "q": d2}
    prog, reason = trace(lambda v: fun(v["u"], v["v"], v["w"], v["p"], v["q"]), ("u", "v", "w"), data, set(data))
    assert prog is not None, reason

    def residual(us, k):
        p, q = (x.truncate(k) if k else x.constant_term for x in (d1, d2))
        return fun(us[0], us[1], us[2], p, q)

    return order, nodes, data, prog, residual


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_newton_on_series_in_native_code_agrees_with_numpy(seed):
    """The full scheme (pointwise Newton, then precision doubling whole in native code) and the warm steps from
    a perturbed start, with and without a carried Jacobian (chord steps): the numpy reference's solutions,
    steps and Jacobians to 1e-12."""
    order, nodes, data, prog, residual = _problem(seed)
    t = np.linspace(0.0, 2.0, nodes)
    u0 = [Series.constant(np.full(nodes, c), 0) for c in (1.0, 0.2, 0.5)]
    kw = dict(tol=1e-12, names=("u", "v", "w"), t_nodes=t)
    ref, rr = newton_series(residual, u0, order, **kw)
    new, rn = newton_series(residual, u0, order, evaluator=NativeStageEvaluator(prog, data, nodes), **kw)
    assert rr.constant_iterations == rn.constant_iterations  # the pointwise Newton's iterations
    close(rr.constant_residual, rn.constant_residual, 1e-9)
    for a, b in zip(ref, new):
        close(a.coeffs, b.coeffs)
    close(rr.jacobian, rn.jacobian)
    assert rr.doubling_orders == rn.doubling_orders
    close(rr.series_residual, rn.series_residual, 1e-9)
    start = [Series(s.coeffs * (1.0 + 1e-4)) for s in ref]
    for jac in (None, rr.jacobian, rn.jacobian):
        a, ra = newton_series(residual, start, order, warm=True, jacobian=jac, **kw)
        ev = NativeStageEvaluator(prog, data, nodes)
        b, rb = newton_series(residual, start, order, warm=True, jacobian=jac, evaluator=ev, **kw)
        for x, y in zip(a, b):
            close(x.coeffs, y.coeffs)
        assert ra.doubling_orders == rb.doubling_orders  # the same steps
        close(ra.constant_residual, rb.constant_residual, 1e-9)


def test_a_singular_node_falls_back_to_the_numpy_steps():
    """An exactly singular Jacobian at a node: the native steps stop (status 2) and the numpy steps take their
    least-squares step, so the result is the numpy path's."""
    nodes, order = 4, 3
    d = Series._wrap(np.vstack([np.array([1.0, 0.0, 2.0, 3.0]), np.zeros((order, nodes))]))

    def fun(u, v, dd):
        return [u * dd - 1.0 * dd, v - 0.5]  # d(r1)/du = d = 0 at node 1

    prog, _ = trace(lambda v: fun(v["u"], v["v"], v["d"]), ("u", "v"), {"d": d}, {"d"})
    ev = NativeStageEvaluator(prog, {"d": d}, nodes)
    start = [Series(np.full((nodes, order + 1), 0.9)), Series(np.full((nodes, order + 1), 0.4))]
    status = ev.warm_newton_series(start, order, 1.0, None, 1e-12, 8, 2, 0.1)[0]
    assert status == 2
    assert ev.pointwise_newton(np.stack([s.coeffs[..., 0] for s in start]), 1e-12, 20) is None
    assert ev.doubling(np.stack([s.coeffs for s in start]), [1, 3])[0] == 2

    def residual(us, k):
        return fun(us[0], us[1], d.truncate(k) if k else d.constant_term)

    ref = newton_series(residual, start, order, warm=True, t_nodes=np.arange(4.0))[0]
    new = newton_series(residual, start, order, warm=True, t_nodes=np.arange(4.0), evaluator=ev)[0]
    for a, b in zip(ref, new):
        close(a.coeffs, b.coeffs)


@SET
@given(
    intervals=st.integers(1, 12),
    v=st.integers(1, 6),
    d1=st.integers(1, 18),
    N=st.integers(0, 300),
    sort=st.booleans(),
    seed=st.integers(0, 10**6),
)
def test_piecewise_polynomials_in_native_code_are_numpys_bit_for_bit(intervals, v, d1, N, sort, seed):
    """The native Horner (by runs of times in one interval) gives planners.plan._horner's values exactly, on
    sorted grids (the limit checks) and on times in any order."""
    from planners.plan import _horner

    rng = np.random.default_rng(seed)
    c = rng.normal(size=(intervals, v, d1)) * 10.0 ** rng.integers(-3, 4, size=(intervals, v, d1))
    i = rng.integers(0, intervals, N)
    if sort:
        i = np.sort(i)
    s = rng.uniform(0.0, 2.0, N)
    out = NA.horner(c, i, s)
    assert np.array_equal(out, _horner(c[i], s, 0))


def _plan(name, backend):
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario(name)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "program_backend", lambda: backend)
        return plan_motion(sc.problem(), sc.t_nodes, sc.J, e=getattr(sc, "e", 1), name=name)


@pytest.mark.parametrize("name", ["gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip"])
def test_whole_plans_agree_with_the_numpy_path(name):
    """Every series of every iterate of the bundled paper plans: native = numpy path to 1e-12 of each
    variable's coefficient scale; the same Newton steps, feasibility and warnings."""
    ref, new = _plan(name, None), _plan(name, "native")
    assert len(ref.iterates) == len(new.iterates)
    for it_r, it_n in zip(ref.iterates, new.iterates):
        assert set(it_r) == set(it_n)
        for var in it_r:
            close(np.real(it_r[var].coeffs), np.real(it_n[var].coeffs))
        for stage, rep in it_r.reports.items():
            assert rep.doubling_orders == it_n.reports[stage].doubling_orders
            assert rep.constant_iterations == it_n.reports[stage].constant_iterations
            close(rep.constant_residual, it_n.reports[stage].constant_residual, 1e-9)
            close(rep.series_residual, it_n.reports[stage].series_residual, 1e-9)  # a check of each iterate
    assert ref.feasible == new.feasible
    assert ref.warnings == new.warnings
    # the checks: the singularity table (native: the stage-2 program's Jacobian at order 0), the limit grid
    assert ref.singularities.condition == new.singularities.condition
    close(ref.singularities.table.to_numpy(), new.singularities.table.to_numpy())
    assert ref.singularities.failures == new.singularities.failures
    (t_r, c_r, v_r), (t_n, c_n, v_n) = ref._limit_arrays(-1, None), new._limit_arrays(-1, None)
    assert c_r == c_n and np.array_equal(t_r, t_n)
    for a, b in zip(v_r, v_n):
        close(a, b)
    assert [v.text() for v in ref.limit_violations()] == [v.text() for v in new.limit_violations()]


@pytest.mark.parametrize("name", ["gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip"])
def test_the_first_iterate_on_the_native_buffers_is_the_general_paths(name):
    """A second plan of a problem runs its first iterate's stages h >= 2 on the plan's native buffers
    (``_native_first_iterate``: its programs were traced by the first plan): every series, Newton report and
    check bit for bit those of the general path (the first plan), and both within 1e-12 of the numpy path."""
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario(name)
    prob = sc.problem()
    calls = []
    first = C._native_first_iterate

    def counted(*a, **k):
        out = first(*a, **k)
        calls.append(out is not None)
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "_native_first_iterate", counted)
        general = plan_motion(prob, sc.t_nodes, sc.J, e=getattr(sc, "e", 1), name=name)
        lean = plan_motion(prob, sc.t_nodes, sc.J, e=getattr(sc, "e", 1), name=name)
    assert calls == [False, True]  # the first plan traces on the general path, the second takes the buffers
    assert len(general.iterates) == len(lean.iterates)
    for it_g, it_l in zip(general.iterates, lean.iterates):
        assert list(it_g) == list(it_l)
        for var in it_g:
            assert np.array_equal(it_g[var].coeffs, it_l[var].coeffs), var
        assert set(it_g.reports) == set(it_l.reports)
        for stage, rep in it_g.reports.items():
            other = it_l.reports[stage]
            assert rep.doubling_orders == other.doubling_orders
            assert rep.constant_iterations == other.constant_iterations
            assert np.array_equal(rep.constant_residual, other.constant_residual)
            assert np.array_equal(rep.series_residual, other.series_residual)
            assert rep.failures == other.failures and rep.warnings == other.warnings
            assert np.array_equal(rep.jacobian, other.jacobian)
    assert general.warnings == lean.warnings
    assert np.array_equal(general.singularities.table.to_numpy(), lean.singularities.table.to_numpy())
    ref = _plan(name, None)
    for it_r, it_l in zip(ref.iterates, lean.iterates):
        for var in it_r:
            close(np.real(it_r[var].coeffs), np.real(it_l[var].coeffs))


def test_a_second_plan_of_a_problem_traces_nothing():
    """The stages' programs are kept per system and grid: planning the same problem again traces no stage."""
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario("twin-otter-single-engine")
    prob = sc.problem()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "program_backend", lambda: "native")
        plan_motion(prob, sc.t_nodes, 2, e=1)
        import planners.program as P

        def refuse(*a, **k):
            raise AssertionError("traced again")

        mp.setattr(P, "trace", refuse)
        plan_motion(prob, sc.t_nodes, 3, e=1)


# ------------------------------------------------------------------------------ the library and its cache

_BUILD = r"""
import sys
import planners._native as NA
cc = NA._compiler()
NA.build(cc, NA.library_path(cc))
print(NA.library() is not None)
"""


def test_concurrent_builds_give_one_loadable_library(tmp_path):
    """Two processes compiling into an empty cache at once: each writes its own temporary file and renames it
    into place; the library loads and no temporary file is left."""
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path), PYTHONPATH=str(ROOT))
    procs = [
        subprocess.Popen([sys.executable, "-c", _BUILD], env=env, stdout=subprocess.PIPE, text=True) for _ in range(2)
    ]
    outs = [p.communicate()[0].strip() for p in procs]
    assert all(p.returncode == 0 for p in procs) and outs == ["True", "True"]
    files = sorted(x.name for x in (tmp_path / "gflat" / "native").iterdir())
    assert len(files) == 1 and files[0].startswith("gflat_program-"), files


def test_the_cache_is_keyed_and_stale_builds_are_replaced(tmp_path, monkeypatch):
    """Another source or compiler gives another file name; building it removes the builds unused for
    STALE_DAYS (another installed version's recent build stays)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cc = NA._compiler()
    path = NA.library_path(cc)
    assert path.parent == tmp_path / "gflat" / "native"
    stale = path.parent / "gflat_program-00000000000000000000.so"
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"not a library")
    NA._compiler_version.cache_clear()
    monkeypatch.setattr(NA, "_compiler_version", lambda cc: "another compiler 1.0")
    other = NA.library_path(cc)
    assert other != path
    recent = path.parent / "gflat_program-11111111111111111111.so"
    recent.write_bytes(b"another version's library")
    old = time.time() - (NA.STALE_DAYS + 1) * 86400
    os.utime(stale, (old, old))
    NA.build(cc, other)
    assert other.exists() and not stale.exists() and recent.exists()


def test_without_a_compiler_the_plans_run_on_numpy(monkeypatch):
    """No C compiler: no library, the reason said, and the stages run on the numpy path."""
    monkeypatch.setattr(NA, "_STATE", {"lib": None, "reason": "", "tried": False})
    monkeypatch.setattr(NA, "_compiler", lambda: None)
    assert NA.library() is None and "no C compiler" in NA.reason()
    assert NA.library(wait=True) is None
    import planners.series as S

    monkeypatch.setattr(S, "BACKEND", "native")
    assert C.program_backend() is None and not C.compiled_programs()


def test_the_later_iterates_run_in_one_native_call():
    """After iterate 0, the plan's remaining iterates are one native call, each with its wall time."""
    calls = []
    orig = NA.iterates

    def spy(*args):
        calls.append(args[9:11])  # j0, j1
        return orig(*args)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(NA, "iterates", spy)
        plan = _plan("gtm-aileron-roll", "native")
    assert calls == [(1, plan.J + 1)]
    assert sorted(plan.timings) == list(range(plan.J + 1)) and all(v > 0 for v in plan.timings.values())


def test_a_post_that_changes_a_native_iterate_sends_it_back_to_python():
    """A stage's post-processing (chi, mu made continuous) runs after the native iterates: where it changes
    a result (here: a new series object, the same values), that iterate and the later ones are computed again
    on the general path, and the plan is the numpy path's."""
    import planners.flat as F

    ref = _plan("twin-otter-single-engine", None)
    with pytest.MonkeyPatch.context() as mp:
        orig = F._unwrap_constant
        mp.setattr(F, "_unwrap_constant", lambda angle: orig(angle) + 0.0)
        new = _plan("twin-otter-single-engine", "native")
    for it_r, it_n in zip(ref.iterates, new.iterates):
        for var in it_r:
            close(np.real(it_r[var].coeffs), np.real(it_n[var].coeffs))


def test_a_scenario_gives_one_problem_whose_programs_are_reused():
    """Scenario.problem() returns the same (immutable) problem while the scenario's fields are the same objects:
    plan_scenario twice traces the stages once; a scenario with another field gets a new problem."""
    import dataclasses

    import planners.program as P
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    sc = load_scenario("gtm-forward-slip")
    assert sc.problem() is sc.problem()
    assert dataclasses.replace(sc, h=sc.h).problem() is not sc.problem()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "program_backend", lambda: "native")
        plan_scenario(sc, J=1)
        mp.setattr(P, "trace", lambda *a, **k: (_ for _ in ()).throw(AssertionError("traced again")))
        plan_scenario(sc, J=1)


_FIRST = r"""
import planners._native as NA
print(NA.library() is None, "background" in NA.reason())
"""


def test_a_first_use_compiles_in_the_background(tmp_path):
    """Without a library in the cache (and without GFLAT_NATIVE_WAIT=1) a process starts the compiler detached and
    plans on the numpy path at once; the library appears in the cache for the next processes."""
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path), PYTHONPATH=str(ROOT))
    env.pop("GFLAT_NATIVE_WAIT", None)
    out = subprocess.run([sys.executable, "-c", _FIRST], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"]
    folder = tmp_path / "gflat" / "native"
    deadline = time.monotonic() + 600  # the compiler's own time on a loaded machine
    while time.monotonic() < deadline and not any(f.name.startswith("gflat_program-") for f in folder.iterdir()):
        time.sleep(0.2)
    lock = [f for f in folder.iterdir() if f.name.endswith(".building")]
    while lock and time.monotonic() < deadline and lock[0].exists():
        time.sleep(0.2)
    assert [f.name for f in folder.iterdir() if f.name.startswith("gflat_program-")]
    again = subprocess.run(
        [sys.executable, "-c", "import planners._native as NA; print(NA.library() is not None)"],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert again.stdout.strip() == "True"


@pytest.mark.parametrize(
    "changes",
    [
        {},  # the weave: cond_beta, regular
        {"flat_outputs": {"zeta": "mix", "zeta_value": "0", "f1": "1", "f2": "1"}, "time": {"t1": 10.0}},
        {"flat_outputs": {"zeta": "mu", "zeta_value": "0.3*sin(t/5)"}, "time": {"t1": 10.0}},
        {  # cond_beta numerically zero at every node (a failure)
            "flat_outputs": {"x": "150*t", "y": "0", "z": "-3000 + 0.5*g0*t**2", "zeta": "beta", "zeta_value": "0"},
            "time": {"t0": -3.0, "t1": 3.0, "step": 0.25},
        },
    ],
)
def test_the_singularity_monitor_on_the_native_jacobian_is_the_complex_steps(changes):
    """The monitor's stage-2 Jacobian from the traced program at order 0 (forward mode, native) = the complex
    step on the numpy model: the table to 1e-12, the same warnings and failures."""
    import planners.singularity as SG
    from planners.generalized import plan_scenario

    from .conftest import make_scenario

    plan = plan_scenario(make_scenario(**changes), J=1)
    sol = plan.iterates[0]
    assert C.program_backend() == "native" and sol._inputs.get("programs", {}).get(2, (None,))[0] is not None
    new = SG.monitor(plan)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "program_backend", lambda: None)
        ref = SG.monitor(plan)
    assert new.condition == ref.condition
    close(ref.table.to_numpy(), new.table.to_numpy())
    assert new.warnings == ref.warnings and new.failures == ref.failures


@pytest.mark.parametrize(
    "changes",
    [
        {"flat_outputs": {"zeta": "mix", "zeta_value": "0", "f1": "1", "f2": "1"}, "time": {"t1": 10.0}},
        {  # stage 2 singular at every node: the pointwise Newton may leave nodes above the tolerance
            "flat_outputs": {"x": "150*t", "y": "0", "z": "-3000 + 0.5*g0*t**2", "zeta": "beta", "zeta_value": "0"},
            "time": {"t0": -3.0, "t1": 3.0, "step": 0.25},
        },
        {"flat_outputs": {"zeta": "F", "zeta_value": "30000"}, "time": {"t1": 6.0}, "generalized": {"J": 2}},
    ],
)
def test_a_second_plan_is_the_first_bit_for_bit(changes):
    """Whichever path the first iterate of a second plan takes (the native buffers, or the general path when
    the pointwise Newton needs its memory restarts or the native steps hand back), it is the first plan's."""
    from planners.generalized import plan_scenario

    from .conftest import make_scenario

    sc = make_scenario(**changes)
    a, b = plan_scenario(sc), plan_scenario(sc)
    assert len(a.iterates) == len(b.iterates)
    for it_a, it_b in zip(a.iterates, b.iterates):
        for var in it_a:
            assert np.array_equal(it_a[var].coeffs, it_b[var].coeffs, equal_nan=True), var
        for stage, rep in it_a.reports.items():
            assert rep.doubling_orders == it_b.reports[stage].doubling_orders
            assert rep.constant_iterations == it_b.reports[stage].constant_iterations
    assert a.warnings == b.warnings
