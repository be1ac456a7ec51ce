"""Spike: a traced stage residual compiled into ONE numba function (feasibility measurement, not production).

The roll's stage-2 residual (gtm-aileron-roll, 17 nodes, first iterate) is traced by
:mod:`planners.series_tape` at each working order; the tape is written out as Python source -- one
function of straight-line calls to small generic njit kernels (Cauchy product, quotient, sin/cos,
sums, scalings, the aerodynamic linear combination) on ``(m, R, S)`` coefficient-first arrays (``R``
the complex-step batch axis, 1 for real unknowns; constant arrays ``(m, 1, S)``, broadcast),
constants passed as arguments, floats as literals -- saved under ``benchmarks/_tape_cache/`` and
compiled with ``numba.njit(cache=True)``.  Its result is compared to the eager evaluation (max
relative difference; not bit-identical: the generated sums may round differently, zero weights of
the linear combination are skipped) and timed against the eager evaluation and the tape replay with
the numpy and the compiled kernels, medians of interleaved repetitions.

Ops handled: those the stage-2 residual uses (``_series_mul``, ``_series_div``, ``_add_sub``,
``_plus_constant``, ``_scale_array`` by a float, ``negative``, ``sincos``/``sinhcosh``,
``_linear_combinations``); any other raises NotImplementedError at generation time.

Usage::

    python benchmarks/bench_tape_compiled.py [--orders 2 10 16] [--repeats 7] [--fresh] [--plan]
    python benchmarks/bench_tape_compiled.py --load-only FILE   # (internal) cached load in a fresh process
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import re
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

CACHE = HERE / "_tape_cache"

KERNELS_SRC = """
import numpy as np
from numba import njit

_J = dict(cache=True, nogil=True, error_model="numpy")


@njit(**_J)
def mul(a, b):
    m = min(a.shape[0], b.shape[0])
    R = max(a.shape[1], b.shape[1])
    S = a.shape[2]
    sa = 1 if a.shape[1] > 1 else 0
    sb = 1 if b.shape[1] > 1 else 0
    out = np.full((m, R, S), a[0, 0, 0] * b[0, 0, 0] * 0.0)
    for r in range(R):
        ra = r * sa
        rb = r * sb
        for j in range(m):
            for l in range(m - j):
                k = j + l
                for i in range(S):
                    out[k, r, i] += a[j, ra, i] * b[l, rb, i]
    return out


@njit(**_J)
def div(a, b):
    m = min(a.shape[0], b.shape[0])
    R = max(a.shape[1], b.shape[1])
    S = a.shape[2]
    sa = 1 if a.shape[1] > 1 else 0
    sb = 1 if b.shape[1] > 1 else 0
    out = np.full((m, R, S), a[0, 0, 0] * b[0, 0, 0] * 0.0)
    for r in range(R):
        ra = r * sa
        rb = r * sb
        for k in range(m):
            for i in range(S):
                acc = a[k, ra, i] + out[0, 0, 0] * 0.0
                for j in range(1, k + 1):
                    acc -= b[j, rb, i] * out[k - j, r, i]
                out[k, r, i] = acc / b[0, rb, i]
    return out


@njit(**_J)
def addsub(a, b, sign):
    m = min(a.shape[0], b.shape[0])
    R = max(a.shape[1], b.shape[1])
    S = a.shape[2]
    sa = 1 if a.shape[1] > 1 else 0
    sb = 1 if b.shape[1] > 1 else 0
    out = np.full((m, R, S), a[0, 0, 0] * 0.0 + b[0, 0, 0] * 0.0)
    for k in range(m):
        for r in range(R):
            ra = r * sa
            rb = r * sb
            if sign > 0:
                for i in range(S):
                    out[k, r, i] = a[k, ra, i] + b[k, rb, i]
            else:
                for i in range(S):
                    out[k, r, i] = a[k, ra, i] - b[k, rb, i]
    return out


@njit(**_J)
def scale(a, s):
    return a * s


@njit(**_J)
def divscale(a, s):
    return a / s


@njit(**_J)
def plusconst(a, s):
    out = a.copy()
    out[0] += s
    return out


@njit(**_J)
def neg(a):
    return -a


@njit(**_J)
def sincos(u, sign):
    m, R, S = u.shape
    s = np.empty_like(u)
    c = np.empty_like(u)
    for r in range(R):
        for i in range(S):
            if sign < 0:
                s[0, r, i] = np.sin(u[0, r, i])
                c[0, r, i] = np.cos(u[0, r, i])
            else:
                s[0, r, i] = np.sinh(u[0, r, i])
                c[0, r, i] = np.cosh(u[0, r, i])
        for k in range(1, m):
            ik = 1.0 / k
            for i in range(S):
                ss = s[0, r, i] * 0.0
                cc = ss
                for j in range(1, k + 1):
                    v = j * u[j, r, i]
                    ss += v * c[k - j, r, i]
                    cc += v * s[k - j, r, i]
                s[k, r, i] = ss * ik
                c[k, r, i] = cc * (sign * ik)
    return s, c
"""


# the generated program imports the kernels (compiled and cached once per machine, shared by every tape)
PROGRAM_HEAD = """import numpy as np
from numba import njit
from tape_kernels import _J, mul, div, addsub, scale, divscale, plusconst, neg, sincos
"""


# ---------------------------------------------------------------------------
# Code generation
# ---------------------------------------------------------------------------


class Generated:
    """The source of one tape's compiled function and its constant arguments."""

    def __init__(self, tape, n_nodes: int) -> None:
        import planners.series as S
        import planners.series_tape as T

        values, instrs = tape._template, tape._instrs
        self.n_inputs = tape.n_inputs
        self.S = n_nodes
        self.const_args: list = []  # arrays (m, 1, S), in argument order
        self.const_names: dict = {}  # slot -> argument name
        traced = set(range(tape.n_inputs))
        lines: list = []
        skipped: set = set()

        def const_array(slot: int) -> str:
            name = self.const_names.get(slot)
            if name is None:
                v = values[slot]
                v = np.asarray(v._c if hasattr(v, "_c") else v)
                if v.ndim == 1:  # a batch-less series: broadcast over the nodes
                    v = np.broadcast_to(v[:, None], (v.shape[0], n_nodes))
                if v.ndim != 2 or v.shape[1] != n_nodes:
                    raise NotImplementedError(f"constant array of shape {v.shape}")
                self.const_args.append(np.ascontiguousarray(v.reshape(v.shape[0], 1, n_nodes), dtype=float))
                name = self.const_names[slot] = f"c{slot}"
            return name

        def arr(slot: int) -> str:
            return f"t{slot}" if slot in traced else const_array(slot)

        def scalar(slot: int) -> str:
            v = values[slot]
            if isinstance(v, (float, int, np.floating)) and not isinstance(v, bool):
                return repr(float(v))
            raise NotImplementedError(f"non-scalar constant {type(v).__name__}")

        for fn, slots, out in instrs:
            name = getattr(fn, "__name__", str(fn))
            if isinstance(out, slice):
                outs = list(range(out.start, out.stop))
            else:
                outs = [out]
            lhs = ", ".join(f"t{o}" for o in outs) + ("," if len(outs) == 1 and isinstance(out, slice) else "")
            if fn is S._series_mul:
                rhs = f"mul({arr(slots[0])}, {arr(slots[1])})"
            elif fn is S._series_div:
                rhs = f"div({arr(slots[0])}, {arr(slots[1])})"
            elif fn is S._add_sub:
                rhs = f"addsub({arr(slots[0])}, {arr(slots[1])}, {-1.0 if values[slots[2]] else 1.0})"
            elif fn is S._plus_constant:
                rhs = f"plusconst({arr(slots[0])}, {scalar(slots[1])})"
            elif fn is S._scale_array:
                rhs = f"{'divscale' if values[slots[2]] else 'scale'}({arr(slots[0])}, {scalar(slots[1])})"
            elif fn is np.negative:
                rhs = f"neg({arr(slots[0])})"
            elif name in ("sincos", "sinhcosh"):
                rhs = f"sincos({arr(slots[0])}, {-1.0 if name == 'sincos' else 1.0})"
            elif fn is T._linear_combinations:
                traced.update(outs)
                lines += self._lincomb(values[slots[0]], values[slots[1]], slots[2:], outs, arr, traced, values)
                continue
            else:
                skipped.add(name)
                rhs = f"unsupported_{name}()"
            traced.update(outs)
            lines.append(f"    {lhs} = {rhs}")
        if skipped:
            raise NotImplementedError(f"ops not generated: {sorted(skipped)}")
        self.outputs = tape._outputs
        if not all(tape.traced_outputs):
            raise NotImplementedError("constant outputs")
        args = [f"x{i}" for i in range(self.n_inputs)] + list(self.const_names.values())
        head = [f"    t{i} = x{i}" for i in range(self.n_inputs)]
        ret = "    return (" + ", ".join(f"t{s}" for s in self.outputs) + ",)"
        body = "\n".join(head + lines + [ret])
        self.n_lines = len(lines)
        program = "def program(" + ", ".join(args) + "):\n" + body + "\n"
        # names by order of appearance, not by tape slot: equal programs give equal sources (one compile)
        rename: dict = {}

        def canon(mo) -> str:
            key = mo.group(0)
            if key not in rename:
                rename[key] = f"{mo.group(1)}{sum(1 for r in rename if r[0] == mo.group(1))}"
            return rename[key]

        program = re.sub(r"\b([tc])(\d+)\b", canon, program)
        self.source = PROGRAM_HEAD + "\n\n@njit(**_J)\n" + program

    @staticmethod
    def _lincomb(w, spec, item_slots, outs, arr, traced, values) -> list:
        """``out_i = sum_j w[i, j] item_j`` unrolled: series items over all coefficients, scalar items
        on the constant term; zero weights skipped."""
        w = np.asarray(w, dtype=float)
        series, scalars = [], []
        for j, (is_traced, s) in enumerate(zip(spec, item_slots)):
            v = values[s]
            if is_traced or hasattr(v, "_c"):
                series.append((j, s))
            else:
                scalars.append((j, float(v)))
        tr = [s for j, s in series if s in traced]
        ref = arr(tr[0])
        lines = [f"    _m, _R, _S = {ref}.shape"]
        for s in tr[1:]:
            lines.append(f"    _R = max(_R, t{s}.shape[1])")
        lines.append(f"    _z = {ref}[0, 0, 0] * 0.0")
        for o in outs:
            lines.append(f"    t{o} = np.full((_m, _R, _S), _z)")
        # step variables for the broadcast of each series item
        names = {}
        for j, s in series:
            a = arr(s)
            names[j] = a
            lines.append(f"    _s{j} = 1 if {a}.shape[1] > 1 else 0")
        lines.append("    for _r in range(_R):")
        lines.append("        for _k in range(_m):")
        lines.append("            for _i in range(_S):")
        for i, o in enumerate(outs):
            terms = [f"{float(w[i, j])!r} * {names[j]}[_k, _r * _s{j}, _i]" for j, _ in series if w[i, j] != 0.0]
            if terms:
                lines.append(f"                t{o}[_k, _r, _i] = " + " + ".join(terms))
        const_terms = {
            o: " + ".join(f"{float(w[i, j] * v)!r}" for j, v in scalars if w[i, j] != 0.0 and v != 0.0)
            for i, o in enumerate(outs)
        }
        for o, t in const_terms.items():
            if t:
                lines.append(f"    t{o}[0] += {t}")
        return lines


def load_module(path: Path):
    if str(path.parent) not in sys.path:
        sys.path.insert(0, str(path.parent))
    return importlib.import_module(path.stem)


def write_source(gen: Generated) -> Path:
    CACHE.mkdir(exist_ok=True)
    (CACHE / ".gitignore").write_text("*\n")  # generated files and numba's cache: never committed
    kernels = CACHE / "tape_kernels.py"
    if not kernels.exists() or kernels.read_text() != KERNELS_SRC:
        kernels.write_text(KERNELS_SRC)
    h = hashlib.sha1(gen.source.encode()).hexdigest()[:12]
    path = CACHE / f"tape_{h}.py"
    if not path.exists():
        path.write_text(gen.source)
    return path


def as3(c: np.ndarray) -> np.ndarray:
    """An unknown's internal array as ``(m, R, S)``: real ``(m, S)`` -> ``(m, 1, S)``."""
    return c.reshape(c.shape[0], 1, c.shape[1]) if c.ndim == 2 else c


# ---------------------------------------------------------------------------
# Measurement
# ---------------------------------------------------------------------------


def time_us(fn, loops: int) -> float:
    t0 = time.perf_counter()
    for _ in range(loops):
        fn()
    return (time.perf_counter() - t0) / loops * 1e6


def rel_diff(got: list, want: list) -> tuple:
    """Max over outputs of max|got - want| / max|want|, for the real and the imaginary parts."""
    re = im = 0.0
    for g, w in zip(got, want):
        g = np.asarray(g).reshape(np.shape(w))
        for part, fn in (("re", np.real), ("im", np.imag)):
            wp, gp = fn(w), fn(g)
            scale = np.max(np.abs(wp))
            if scale == 0:
                continue
            d = float(np.max(np.abs(gp - wp)) / scale)
            if part == "re":
                re = max(re, d)
            else:
                im = max(im, d)
    return re, im


def load_only(path: str, shapes_file: str) -> None:
    """In a fresh process: import the generated module and call it once per dtype (cached load)."""
    spec = json.loads(Path(shapes_file).read_text())
    t0 = time.perf_counter()
    import numba  # noqa: F401

    t_numba = time.perf_counter() - t0
    t0 = time.perf_counter()
    mod = load_module(Path(path))
    t_import = time.perf_counter() - t0
    res = {"import numba (s)": t_numba, "import module (s)": t_import}
    for kind, arg_specs in spec.items():
        xs = []
        for shape, dt, writeable in arg_specs:  # the same numba types as in the measuring process
            x = np.full(shape, 0.1, np.dtype(dt))
            x[0] += 1.0
            x.flags.writeable = writeable
            xs.append(x)
        t0 = time.perf_counter()
        mod.program(*xs)
        res[f"first call {kind} (s)"] = time.perf_counter() - t0
    print(json.dumps(res))


def plan_breakdown(repeats: int) -> None:
    """Stage-2 evaluations of one roll plan by kind (what a generated program could replace: the replays)."""
    import collections
    import importlib as il

    import planners.series_tape as T
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    newton, flat = il.import_module("planners.newton"), il.import_module("planners.flat")
    made: list = []

    class Counting(T.TapedResidual):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            self.tk: collections.Counter = collections.Counter()
            self.orders: collections.Counter = collections.Counter()
            made.append(self)

        def __call__(self, u, k):
            before = dict(self.counts)
            t0 = time.perf_counter()
            r = super().__call__(u, k)
            dt = time.perf_counter() - t0
            kind = next(key for key in self.counts if self.counts[key] != before[key])
            if kind == "eager" and not hasattr(u[0], "_c"):
                kind = "eager k=0"
            elif kind != "eager k=0":
                self.orders[(kind, "complex" if np.iscomplexobj(u[0]._c) else "real", k)] += 1
            self.tk[kind] += dt
            return r

    orig_t, orig_n = newton.TapedResidual, flat.newton_series
    labels: list = []

    def capture(residual, u0, order, **kw):
        labels.append("stage 2" if len(labels) % 2 == 0 else "stage 4")
        return orig_n(residual, u0, order, **kw)

    newton.TapedResidual, flat.newton_series = Counting, capture
    try:
        sc = load_scenario("gtm-aileron-roll")
        plan_scenario(sc)
        rows = []
        for _ in range(repeats):
            made.clear()
            labels.clear()
            t0 = time.perf_counter()
            plan_scenario(sc)
            total = time.perf_counter() - t0
            tk: collections.Counter = collections.Counter()
            orders: collections.Counter = collections.Counter()
            for lab, m in zip(labels, made):
                if lab == "stage 2":
                    tk.update(m.tk)
                    orders.update(m.orders)
            rows.append((total, tk, orders))
    finally:
        newton.TapedResidual, flat.newton_series = orig_t, orig_n
    med = float(np.median([r[0] for r in rows])) * 1e3
    kinds = rows[0][1].keys()
    print(
        f"one roll plan ({S_name()} kernels): {med:.0f} ms; stage-2 evaluations, ms per plan (median of {repeats}): "
        + ", ".join(f"{k} {np.median([r[1][k] for r in rows]) * 1e3:.1f}" for k in kinds)
    )
    by: dict = collections.defaultdict(list)
    for (kind, dt, k), n in sorted(rows[0][2].items()):
        by[(kind, dt)].append(f"k={k}: {n}")
    for key, v in by.items():
        print(f"  {key[0]} {key[1]}: " + ", ".join(v))


def S_name() -> str:
    import planners.series as S

    return "compiled" if S._K is S._CompiledKernels else "numpy"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orders", type=int, nargs="+", default=[2, 10, 16])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--load-only", nargs=2, metavar=("FILE", "SHAPES"))
    parser.add_argument("--fresh", action="store_true", help="empty the cache first (measure first compiles)")
    parser.add_argument("--plan", action="store_true", help="also: stage-2 evaluations of one plan by kind")
    args = parser.parse_args()
    if args.fresh and CACHE.exists():
        import shutil

        shutil.rmtree(CACHE)
    if args.load_only:
        load_only(*args.load_only)
        return

    from bench_series import _roll_residuals, _unknowns

    import planners.series as S
    from planners.series import Series
    from planners.series_tape import TapedResidual

    S._CompiledKernels.mul(np.ones((2, 1)), np.ones((2, 1)))  # load the compiled kernels before timing
    kernels = {"numpy": S._NumpyKernels, "compiled": S._CompiledKernels}
    saved = S._K
    residual, u, top = _roll_residuals()["stage 2"]
    n_nodes = u[0]._c.shape[1]
    # away from the solution (the first iterate's residual there is ~1e-14: cancellation, no relative scale)
    rng = np.random.default_rng(1)
    u = [Series(x.coeffs * (1 + 1e-2 * rng.uniform(-1, 1, x.coeffs.shape))) for x in u]
    print(
        f"stage-2 residual of gtm-aileron-roll ({n_nodes} nodes, first iterate); microseconds per evaluation, "
        f"median of {args.repeats} interleaved runs"
    )
    summary = []
    for k in args.orders:
        k = min(k, top)
        S._K = S._NumpyKernels
        # trace on the complex-step batch (as Newton does); the generated function is shape/dtype generic
        xc = _unknowns(u, k, "complex")
        tr = TapedResidual(residual, "first")
        tr(xc, k)
        tape = tr.tapes[k]
        gen = Generated(tape, n_nodes)
        path = write_source(gen)
        fresh = not any(CACHE.glob(f"__pycache__/{path.stem}*.nbi"))
        t0 = time.perf_counter()
        mod = load_module(path)
        t_import = time.perf_counter() - t0
        prog = mod.program
        consts = gen.const_args
        print(
            f"\norder {k}: {tape.n_instructions} instructions -> {gen.n_lines} generated lines, "
            f"{len(consts)} constant arrays; source {path.relative_to(HERE.parent)} "
            f"({'new' if fresh else 'already in the numba cache'})"
        )
        shapes = {}
        for kind in ("real", "complex"):
            x = xc if kind == "complex" else _unknowns(u, k, "real")
            ins = [v._c for v in x]
            in3 = [as3(c) for c in ins]
            t0 = time.perf_counter()
            prog(*in3, *consts)
            t_first = time.perf_counter() - t0
            shapes[kind] = [(list(a.shape), a.dtype.str, bool(a.flags.writeable)) for a in in3 + consts]

            def run_gen(ins=ins):
                outs = prog(*[as3(c) for c in ins], *consts)  # noqa: B023
                return [o.reshape((o.shape[0],) + ins[0].shape[1:]) for o in outs]

            S._K = S._NumpyKernels
            eager = [r._c for r in residual([Series._wrap(c) for c in ins], k)]
            got = run_gen()
            d_re, d_im = rel_diff(got, eager)
            S._K = S._CompiledKernels
            eager_c = [r._c for r in residual([Series._wrap(c) for c in ins], k)]
            dc_re, dc_im = rel_diff(got, eager_c)
            p_re, p_im = rel_diff(eager_c, eager)
            modes = {}
            for kname, kern in kernels.items():
                modes[f"eager {kname}"] = (kern, lambda ins=ins: residual([Series._wrap(c) for c in ins], k))  # noqa: B023
                modes[f"replay {kname}"] = (kern, lambda ins=ins: tape.run(ins))  # noqa: B023
            modes["generated"] = (S._NumpyKernels, run_gen)
            loops = {}
            for m, (kern, f) in modes.items():
                S._K = kern
                loops[m] = max(1, int(3e3 / max(1.0, time_us(f, 3))))
            t = {m: [] for m in modes}
            for _ in range(args.repeats):
                for m, (kern, f) in modes.items():
                    S._K = kern
                    t[m].append(time_us(f, loops[m]))
            med = {m: float(np.median(v)) for m, v in t.items()}
            S._K = saved
            print(
                f"  {kind:<8} first call (compile{' or cached load' if not fresh else ''}) {t_first:7.2f} s; "
                f"max rel diff vs eager numpy: re {d_re:.1e} im {d_im:.1e}; vs eager compiled: re {dc_re:.1e} "
                f"im {dc_im:.1e}; (peer: eager compiled vs eager numpy re {p_re:.1e} im {p_im:.1e})"
            )
            print(
                "           "
                + "  ".join(f"{m} {v:7.1f}" for m, v in med.items())
                + f"   eager numpy / generated {med['eager numpy'] / med['generated']:.1f}x"
            )
            summary.append((k, kind, med))
        # cached load in a fresh process
        shapes_file = CACHE / f"{path.stem}.shapes.json"
        shapes_file.write_text(json.dumps(shapes))
        out = subprocess.run(
            [sys.executable, __file__, "--load-only", str(path), str(shapes_file)],
            capture_output=True,
            text=True,
            check=True,
        )
        print(f"  fresh process (cached): {out.stdout.strip()}   (module import here: {t_import:.2f} s)")
    if args.plan:
        print()
        for kern in (S._NumpyKernels, S._CompiledKernels):
            S._K = kern
            plan_breakdown(args.repeats)
        S._K = saved


if __name__ == "__main__":
    main()
