"""Compilers for the planner's stage programs, measured on one program: the native evaluator (C, the system's
compiler), numba's evaluator, and CasADi (SX functions built from the same program, run by CasADi's virtual
machine).

The program is the aileron roll's stage-2 residual (the force equations, 4 unknowns) traced by the bundled
plan, evaluated at the working orders of the bundled plan (J = 7, e = 2: kappa - 2 = 18 down to 4, and the
doubling's 1, 2, 4, 9) on its 17 nodes.  Printed per compiler: the one-time cost (compile or build, and the
load in a fresh process), the time of one residual evaluation and of one with its Jacobian series, at each
order (CPU, best of ``--repeat``).  numba and the native evaluator run any program: nothing is compiled per
aircraft or order.  CasADi's SX graph is built per program *and order* (the series recurrences unrolled);
its Jacobian series is CasADi's forward mode with the n constant-series seeds::

    python research/bench_program_compilers.py [--repeat 50] [--orders 4,9,18] [--no-numba]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from planners import program as P  # noqa: E402


def roll_program():
    """The roll's stage-2 program, its data at the top order and the bundled solution's unknowns."""
    import planners.chained as C
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario("gtm-aileron-roll")
    got = {}
    orig = C._stage_evaluator

    def spy(programs, h, stage, data, static, nodes):
        ev = orig(programs, h, stage, data, static, nodes)
        if h == 2 and ev is not None and "ev" not in got:
            got.update(ev=ev, data=data)
        return ev

    C._stage_evaluator = spy
    try:
        plan = plan_motion(sc.problem(), sc.t_nodes, sc.J, e=sc.e)
    finally:
        C._stage_evaluator = orig
    ev = got["ev"]
    sol = plan.iterates[0]
    x = np.stack([sol[n]._c for n in ("alpha", "beta", "mu", "F")])  # (4, K, S)
    return ev.program, ev._data_for(x.shape[1]), x


def best(f, repeat):
    f()
    ts = []
    for _ in range(repeat):
        t0 = time.process_time()
        f()
        ts.append(time.process_time() - t0)
    return min(ts)


# ------------------------------------------------------------------------------------------ CasADi


def casadi_function(prog, M, tangent):
    """An SX function of one node (x (n M), data (D M), parameters) -> residual coefficients (neq M) [and the
    Jacobian series (neq n M)], the program's instructions executed on lists of SX coefficients."""
    import casadi as ca

    n, D = prog.n_unknowns, len(prog.data_names) + len(prog.extra)
    xs = ca.SX.sym("x", n * M)
    ds = ca.SX.sym("d", D * M)
    ps = ca.SX.sym("p", max(len(prog.params), 1))
    X = [[xs[j * M + m] for m in range(M)] for j in range(n)]
    Dd = [[ds[j * M + m] for m in range(M)] for j in range(D)]
    W: dict = {}

    def mul(a, b):
        return [sum(a[j] * b[k - j] for j in range(k + 1)) for k in range(M)]

    def div(a, b):
        q = []
        for k in range(M):
            acc = a[k]
            for j in range(1, k + 1):
                acc = acc - b[j] * q[k - j]
            q.append(acc / b[0])
        return q

    def sincos(u, sign):
        s = [ca.sin(u[0]) if sign < 0 else ca.sinh(u[0])]
        c = [ca.cos(u[0]) if sign < 0 else ca.cosh(u[0])]
        for k in range(1, M):
            s.append(sum(j * u[j] * c[k - j] for j in range(1, k + 1)) / k)
            c.append(sign * sum(j * u[j] * s[k - j] for j in range(1, k + 1)) / k)
        return s, c

    def const(v):
        return [v] + [0] * (M - 1)

    for op, o, a, b, k, _unk in prog.code:
        if op == P.INPUT:
            W[o] = X[a]
        elif op == P.DATA:
            W[o] = Dd[a]
        elif op == P.ADD:
            W[o] = [u + v for u, v in zip(W[a], W[b])]
        elif op == P.SUB:
            W[o] = [u - v for u, v in zip(W[a], W[b])]
        elif op == P.MUL:
            W[o] = mul(W[a], W[b])
        elif op == P.DIV:
            W[o] = div(W[a], W[b])
        elif op == P.NEG:
            W[o] = [-u for u in W[a]]
        elif op == P.ADDC:
            W[o] = [W[a][0] + ps[k]] + W[a][1:]
        elif op == P.RSUBC:
            W[o] = [ps[k] - W[a][0]] + [-u for u in W[a][1:]]
        elif op == P.MULC:
            W[o] = [u * ps[k] for u in W[a]]
        elif op == P.DIVC:
            W[o] = [u / ps[k] for u in W[a]]
        elif op == P.RDIVC:
            W[o] = div(const(ps[k]), W[a])
        elif op in (P.SINCOS, P.SINHCOSH):
            W[o], W[b] = sincos(W[a], -1.0 if op == P.SINCOS else 1.0)
        elif op == P.POW:
            u, pw = W[a], ps[k]
            out = [u[0] ** pw]
            for kk in range(1, M):
                out.append(sum((pw * j - (kk - j)) * u[j] * out[kk - j] for j in range(1, kk + 1)) / (kk * u[0]))
            W[o] = out
        elif op == P.CONST:
            W[o] = const(ps[k])
        elif op == P.AXPY:
            W[o] = [u + ps[k] * v for u, v in zip(W[a], W[b])]
        elif op == P.ZERO:
            W[o] = const(0)
        elif op == P.COPY:
            W[o] = list(W[a])
        else:
            raise NotImplementedError(f"opcode {op} in the CasADi executor")
    res = ca.vertcat(*[c for r in prog.outputs for c in W[int(r)]])
    outs = [res]
    if tangent:  # forward mode with the n seeds "constant series 1 in direction b"
        cols = []
        for j in range(n):
            seed = ca.DM.zeros(n * M, 1)
            seed[j * M] = 1.0
            cols.append(ca.jtimes(res, xs, seed))
        outs.append(ca.horzcat(*cols))
    return ca.Function("stage", [xs, ds, ps], outs)


def bench_casadi(prog, data, x, orders, repeat):
    import casadi as ca

    S = x.shape[2]
    rows = []
    build_total = 0.0
    for K in orders:
        M = K + 1
        t0 = time.process_time()
        fr = casadi_function(prog, M, False).map(S)
        ft = casadi_function(prog, M, True).map(S)
        build = time.process_time() - t0
        build_total += build
        xa = ca.DM(np.ascontiguousarray(x[:, :M].transpose(0, 1, 2)).reshape(-1, S))
        da = ca.DM(np.ascontiguousarray(data[:, :M]).reshape(-1, S))
        pa = ca.DM(np.tile(prog.params[:, None] if prog.params.size else np.zeros((1, 1)), (1, S)))
        tr = best(lambda fr=fr, xa=xa, da=da, pa=pa: fr(xa, da, pa), repeat)
        tt = best(lambda ft=ft, xa=xa, da=da, pa=pa: ft(xa, da, pa), repeat)
        ref = prog.native().evaluate(np.ascontiguousarray(x[:, :M]), data, M)
        got = np.array(fr(xa, da, pa)).reshape(len(prog.outputs), M, S)
        err = float(np.max(np.abs(got - ref)) / max(1.0, np.max(np.abs(ref))))
        rows.append((K, build, tr, tt, err))
    return rows, build_total


# ------------------------------------------------------------------------------------------ the others

_FRESH_NATIVE = r"""
import time
t0 = time.perf_counter(); c0 = time.process_time()
import planners._native as N
lib = N.library()
print(f"{time.perf_counter() - t0:.3f} {time.process_time() - c0:.3f} {lib is not None}")
"""

_FRESH_NUMBA = r"""
import time
t0 = time.perf_counter(); c0 = time.process_time()
import numpy as np
from planners import program as P
K = P._kernels()
code = np.array([[P.INPUT, 0, 0, -1, -1, 1], [P.MUL, 1, 0, 0, -1, 3]], dtype=np.int64)
x = np.ones((1, 3, 2)); d = np.zeros((0, 3, 2))
K.evaluate(code, np.zeros(1), x, d, 2, np.array([1]))
K.evaluate_tangent(code, np.zeros(1), x, d, 2, np.array([1]), np.array([1]))
print(f"{time.perf_counter() - t0:.3f} {time.process_time() - c0:.3f} True")
"""


def fresh(script, cache):
    """(wall, CPU) of ``script`` in a new process with the cache folder ``cache``."""
    env = dict(os.environ, XDG_CACHE_HOME=str(cache), PYTHONPATH=str(ROOT), GFLAT_NATIVE_WAIT="1")
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    wall, cpu, ok = out.stdout.split()
    return float(wall), float(cpu)


def main() -> None:
    """Measure and print."""
    os.environ.setdefault("GFLAT_NATIVE_WAIT", "1")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=50)
    ap.add_argument("--orders", default="1,2,4,9,18")
    ap.add_argument("--no-numba", action="store_true")
    ap.add_argument("--no-casadi", action="store_true")
    args = ap.parse_args()
    orders = [int(v) for v in args.orders.split(",")]
    prog, data, x = roll_program()
    print(f"roll stage-2 program: {prog.code.shape[0]} instructions, {prog.n_registers} registers, {x.shape[2]} nodes")
    with tempfile.TemporaryDirectory() as tmp:
        first = fresh(_FRESH_NATIVE, tmp)
        again = fresh(_FRESH_NATIVE, tmp)
        print(
            f"native (C, {' '.join(__import__('planners._native', fromlist=['x'])._compiler() or ['-'])}): "
            f"compile + load in a fresh cache {first[0]:.2f} s wall ({first[1]:.2f} s CPU of this process; the "
            f"compiler's own CPU not counted), load from the cache {again[0] * 1e3:.1f} ms wall"
        )
        if not args.no_numba:
            nfirst = fresh(_FRESH_NUMBA, tmp)
            nagain = fresh(_FRESH_NUMBA, tmp)
            print(
                f"numba: import + compile in a fresh cache {nfirst[0]:.1f} s wall ({nfirst[1]:.1f} s CPU), "
                f"import + load from the cache {nagain[0]:.2f} s wall ({nagain[1]:.2f} s CPU)"
            )
    nat = prog.native()
    print(f"{'order':>5} {'native res':>11} {'native jac':>11}", end="")
    if not args.no_numba:
        print(f" {'numba res':>10} {'numba jac':>10}", end="")
    print("   [us per evaluation, all nodes; CPU, best of repeats]")
    K_ = None if args.no_numba else P._kernels()
    for K in orders:
        M = K + 1
        xm = np.ascontiguousarray(x[:, :M])
        dm = np.ascontiguousarray(data[:, :M])
        tr = best(lambda xm=xm, M=M: nat.evaluate(xm, data, M), args.repeat)
        tt = best(lambda xm=xm, M=M: nat.evaluate_tangent(xm, data, M), args.repeat)
        line = f"{K:>5} {tr * 1e6:>11.1f} {tt * 1e6:>11.1f}"
        if K_ is not None:
            a = (prog.code, prog.params, xm, dm, prog.n_registers, prog.outputs)
            nr = best(lambda a=a: K_.evaluate(*a), args.repeat)
            nt = best(lambda a=a: K_.evaluate_tangent(*a, prog.outputs_unk), args.repeat)
            line += f" {nr * 1e6:>10.1f} {nt * 1e6:>10.1f}"
        print(line)
    if not args.no_casadi:
        rows, total = bench_casadi(prog, data, x, orders, max(5, args.repeat // 5))
        print("CasADi SX (one function per order; map over the nodes; the VM):")
        print(f"{'order':>5} {'build [s]':>10} {'res [us]':>10} {'jac [us]':>10} {'vs native':>10}")
        for K, build, tr, tt, err in rows:
            print(f"{K:>5} {build:>10.3f} {tr * 1e6:>10.1f} {tt * 1e6:>10.1f} {err:>10.1e}")
        print(
            f"  build of these {len(orders)} orders: {total:.2f} s CPU (a plan needs every working order of each stage)"
        )


if __name__ == "__main__":
    main()
