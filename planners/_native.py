"""The native evaluator of stage programs (``planners/_program.c``): compiled once per machine, loaded by ctypes.

The C source is part of the package.  On first use it is compiled by the system's C compiler (``$CC``,
else Python's own configured compiler, else ``cc``, ``gcc`` or ``clang`` on the path) into the user's cache
folder (``$XDG_CACHE_HOME/gflat/native``, default ``~/.cache/gflat/native``), under a file name keyed by the
source, the compiler's version, its flags and the machine; a changed source or compiler gives another name, so
a stale library is never loaded (it is rebuilt; a build unused for :data:`STALE_DAYS` is removed).  Each process compiles into a
temporary file of its own and renames it into place (atomic), so several processes compiling at once are
safe.  Loading a compiled library costs about a millisecond; compiling it about 3 s of CPU (``-O3``), in the
background by default: the process that finds no library starts the compiler detached and plans on the
numpy path, so a first ``gflat plan`` waits for no compiler (``GFLAT_NATIVE_WAIT=1`` compiles at once).
Without a compiler, or when the compilation fails, :func:`library` returns None and says why: the planner
then runs on the numpy path (or numba's, ``GFLAT_SERIES_BACKEND=compiled``).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import math
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

SOURCE = Path(__file__).with_name("_program.c")
#: Compiler flags: optimised (O3), IEEE arithmetic kept (no fast-math, no fused multiply-adds: the results agree
#: with numpy to 1e-12, Horner's rule bit for bit).
FLAGS = ("-O3", "-shared", "-fPIC", "-std=c99", "-ffp-contract=off")
#: Added on an x86-64 processor that has AVX2 (read from ``/proc/cpuinfo``): the series products on 4 doubles at a
#: time, 1.5x faster per evaluation, the same values (no contraction: each multiply and add rounds as before).
#: The flag is part of the library's cache key, so a cache shared with a processor without AVX2 holds two builds.
SIMD_FLAGS = ("-mavx2",)


@functools.cache
def _cpu_has_avx2() -> bool:
    if platform.machine().lower() not in ("x86_64", "amd64") or not sys.platform.startswith("linux"):
        return False
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return "avx2" in line.split()
    except OSError:
        pass
    return False


def flags() -> tuple:
    """The compiler flags of this machine: :data:`FLAGS`, and :data:`SIMD_FLAGS` where the processor has AVX2.

    Returns
    -------
    tuple of str
    """
    return FLAGS + SIMD_FLAGS if _cpu_has_avx2() else FLAGS


#: Days after which a build for another source or compiler (not loaded since) is removed from the cache.
STALE_DAYS = 7
#: Environment variable naming the C compiler (as for most build tools).
CC_ENV = "CC"

_STATE: dict = {"lib": None, "reason": "", "tried": False}


def cache_dir() -> Path:
    """Where the compiled library is kept: ``$XDG_CACHE_HOME/gflat/native`` (default ``~/.cache/gflat/native``).

    Returns
    -------
    pathlib.Path
    """
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "gflat" / "native"


def _compiler() -> list | None:
    """The C compiler's command (a list: a ``CC`` of several words is split), or None."""
    for cand in (os.environ.get(CC_ENV), sysconfig.get_config_var("CC")):
        if cand:
            words = cand.split()
            if words and shutil.which(words[0]):
                return words
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return None


@functools.cache
def _compiler_version(cc: tuple) -> str:
    try:
        out = subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=30)
        return out.stdout.strip().splitlines()[0] if out.stdout.strip() else out.stderr.strip()[:200]
    except (OSError, subprocess.SubprocessError) as exc:
        return f"unknown ({exc})"


def library_path(cc: list) -> Path:
    """The cached library's file for this source, compiler and machine.

    Parameters
    ----------
    cc : list of str
        The compiler command.

    Returns
    -------
    pathlib.Path
    """
    key = hashlib.sha256()
    key.update(SOURCE.read_bytes())
    key.update(_compiler_version(tuple(cc)).encode())
    key.update(" ".join((*cc, *flags())).encode())
    key.update(f"{platform.machine()} {platform.system()} {sys.maxsize}".encode())
    suffix = ".dll" if sys.platform == "win32" else (".dylib" if sys.platform == "darwin" else ".so")
    return cache_dir() / f"gflat_program-{key.hexdigest()[:20]}{suffix}"


def build(cc: list, target: Path) -> None:
    """Compile the source into ``target`` (through a temporary file renamed into place), removing older builds.

    Parameters
    ----------
    cc : list of str
        The compiler command.
    target : pathlib.Path
        The library file (:func:`library_path`).

    Raises
    ------
    OSError, subprocess.SubprocessError
        The compiler failed (its message in the exception).
    """
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=target.suffix + ".tmp", dir=target.parent)
    os.close(fd)
    try:
        out = subprocess.run(
            [*cc, *flags(), "-o", tmp, str(SOURCE), "-lm"], capture_output=True, text=True, timeout=300
        )
        if out.returncode != 0:
            raise OSError(f"{' '.join(cc)} failed: {(out.stderr or out.stdout).strip()[:500]}")
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    # Builds for another source or compiler: removed once unused for STALE_DAYS (another installed version of
    # gflat may still load its own; a file being loaded is not in the way on POSIX)
    for old in target.parent.glob("gflat_program-*"):
        try:
            if old != target and time.time() - old.stat().st_atime > STALE_DAYS * 86400:
                old.unlink()
        except OSError:
            pass


def _declare(lib) -> None:
    P, I, D = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double
    prog = [P, I, P, P, I, I, P, P, I, I, I]
    lib.gf_evaluate.argtypes = prog + [P, I, I, P]
    lib.gf_evaluate_tangent.argtypes = prog + [P, I, I, P, P]
    lib.gf_series_solve.argtypes = [P, P, P, I, I, I]
    lib.gf_warm_newton.argtypes = prog + [P, P, I, I, D, P, I, I, D, P, P]
    lib.gf_doubling.argtypes = prog + [P, I, P, I, P]
    lib.gf_horner.argtypes = [P, I, I, P, P, I, P]
    lib.gf_grid_horner.argtypes = [P, I, I, I, P, I, P, I, P]
    lib.gf_limit_scan.argtypes = [I, I, P, P, P, P, P, P]
    lib.gf_pointwise_newton.argtypes = prog + [P, D, I, P, P]
    lib.gf_pointwise_newton.restype = ctypes.c_int
    lib.gf_iterates.argtypes = [I, P, P, P, P, I, P, P, I, I, I, P, I, P, P, P, P, P, D, P, I, I, D]
    lib.gf_iterates.restype = ctypes.c_int64
    for f in (
        lib.gf_evaluate,
        lib.gf_evaluate_tangent,
        lib.gf_series_solve,
        lib.gf_warm_newton,
        lib.gf_doubling,
        lib.gf_horner,
        lib.gf_grid_horner,
        lib.gf_limit_scan,
    ):
        f.restype = ctypes.c_int


#: Environment variable: ``1`` makes the first use wait for the compilation (tests, benchmarks); unset, a process
#: that finds no library starts the compiler in the background and plans on the numpy path meanwhile.
WAIT_ENV = "GFLAT_NATIVE_WAIT"
#: Seconds a build in progress (its lock file) keeps other processes from starting another.
BUILD_LOCK_S = 300


def library(wait: bool | None = None):
    """The loaded native library, or None when it cannot be had (yet).

    A library in the cache is loaded (about a millisecond).  Without one, ``wait`` (default: the environment
    variable :data:`WAIT_ENV` set to 1) compiles it now (about 3 s of CPU); else the compiler is started in the
    background, detached, and this process gets None (its plans run on the numpy path: a first ``gflat plan``
    pays no compilation), the next ones load the library.  One background build at a time (a lock file);
    a failed build is not retried for a day.

    Parameters
    ----------
    wait : bool, optional
        Compile now rather than in the background.

    Returns
    -------
    ctypes.CDLL or None
        None: :func:`reason` says why (no C compiler, a failed compilation, a compilation under way).
    """
    lib = _STATE["lib"]
    if lib is not None:  # loaded: the planner's many calls return here
        return lib
    if wait is None:
        wait = os.environ.get(WAIT_ENV, "").strip() == "1"
    if _STATE["tried"] and _STATE.get("final"):
        return _STATE["lib"]
    if _STATE["tried"] and not wait:
        # a build in the background: its library is loaded once it is there (checked every few seconds)
        target = _STATE.get("target")
        if target is None or time.monotonic() < _STATE.get("next_check", 0.0) or not target.exists():
            _STATE["next_check"] = time.monotonic() + 2.0
            return None
    _STATE["tried"] = True
    cc = _compiler()
    if cc is None:
        _STATE["reason"] = "no C compiler found (set CC, or install cc, gcc or clang)"
        _STATE["final"] = True
        return None
    target = _STATE["target"] = library_path(cc)
    failed = target.with_name("." + target.name + ".failed")
    try:
        if not target.exists():
            if failed.exists() and time.time() - failed.stat().st_mtime < 86400 and not wait:
                _STATE["reason"] = f"the native evaluator failed to compile: {failed.read_text()[:300]}"
                return None
            if not wait and _build_in_background(cc, target):
                _STATE["reason"] = "the native evaluator is being compiled in the background"
                return None
            try:
                build(cc, target)
            except (OSError, subprocess.SubprocessError) as exc:
                try:
                    failed.write_text(str(exc))
                except OSError:
                    pass
                raise
        lib = ctypes.CDLL(str(target))
        _declare(lib)
    except (OSError, subprocess.SubprocessError) as exc:
        _STATE["reason"] = f"the native evaluator could not be built or loaded: {exc}"
        _STATE["final"] = True
        return None
    _STATE["lib"] = lib
    return lib


_BACKGROUND = r"""
import os, sys, time
sys.path.insert(0, sys.argv[3])
lock = sys.argv[2]
try:
    from planners import _native as N
    try:
        N.build(N._compiler(), N.Path(sys.argv[1]))
    except Exception as exc:
        N.Path(sys.argv[1]).with_name("." + N.Path(sys.argv[1]).name + ".failed").write_text(str(exc))
finally:
    try:
        os.unlink(lock)
    except OSError:
        pass
"""


def _build_in_background(cc: list, target: Path) -> bool:
    """Start the compilation in a detached process (a lock file keeps others from starting another): True when
    one was started or is under way, False when it could not be (the caller then compiles now)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    lock = target.with_name("." + target.name + ".building")
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        try:
            if time.time() - lock.stat().st_mtime < BUILD_LOCK_S:
                return True  # another process is compiling
            lock.unlink()  # a stale lock (a build that died)
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except OSError:
            return True
    except OSError:
        return False
    os.write(fd, str(os.getpid()).encode())
    os.close(fd)
    root = str(Path(__file__).resolve().parents[1])
    try:
        subprocess.Popen(
            [sys.executable, "-c", _BACKGROUND, str(target), str(lock), root],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            close_fds=True,
        )
    except OSError:
        os.unlink(lock)
        return False
    return True


def reason() -> str:
    """Why :func:`library` is None (empty when it is not, or was not tried).

    Returns
    -------
    str
    """
    return _STATE["reason"]


def _ptr(a: np.ndarray) -> int:
    return a.ctypes.data


#: Unknowns a dependency mask can name (bits 2.. and :data:`UNK_SHIFT`.. of a row's ``unk``: ``_program.c``).
UNK_BITS = 30
UNK_SHIFT = 32


def tangent_masks(code: np.ndarray, n: int, outputs: np.ndarray, outputs_unk: np.ndarray) -> tuple:
    """A program's table with, in each row's ``unk``, the unknowns each operand's tangent depends on.

    Forward mode carries one tangent series per unknown; most registers depend on a few of the unknowns
    only (stage 2's tangents on 214 of 400 (row, unknown) pairs), and the others' tangents are zero.  With
    these masks the native evaluator neither computes nor reads them: an operation whose operand's tangent is
    zero for an unknown takes the one-operand form for it (as for an operand that depends on no unknown), and
    a residual's Jacobian column of an unknown it does not depend on is filled with zeros.

    Parameters
    ----------
    code : ndarray of int64, shape (I, 6)
        :attr:`planners.program.Program.code` (``unk`` 0..3: operand a, b carry a tangent).
    n : int
        Number of unknowns.
    outputs, outputs_unk : ndarray of int64, shape (neq,)
        The residuals' registers, and 1 where a residual depends on the unknowns.

    Returns
    -------
    (ndarray of int64 (I, 6), ndarray of int64 (neq,))
        The table with ``unk | mask_a << 2 | mask_b << UNK_SHIFT`` (bit d: depends on unknown d), and the
        residuals' ``1 | mask << 2``; the inputs unchanged when ``n > UNK_BITS`` (every tangent computed).
    """
    code = np.array(code, dtype=np.int64)
    outs_unk = np.array(outputs_unk, dtype=np.int64)
    if n > UNK_BITS or code.shape[0] == 0:
        return code, outs_unk
    from .program import INPUT, SINCOS, SINHCOSH

    mask: dict = {}  # register -> the unknowns its current value depends on
    for row in code:
        op, o, a, b, unk = int(row[0]), int(row[1]), int(row[2]), int(row[3]), int(row[5])
        if op == INPUT:
            ma, mb = 1 << a, 0
            mask[o] = ma
        else:
            ma = mask.get(a, 0) if unk & 1 else 0
            mb = mask.get(b, 0) if unk & 2 else 0
            mask[o] = (ma | mb) if unk else 0
            if op in (SINCOS, SINHCOSH):
                mask[b] = mask[o]
        if unk:
            row[5] = (unk & 3) | ma << 2 | mb << UNK_SHIFT
    for j, r in enumerate(outputs):
        if outs_unk[j]:
            outs_unk[j] = 1 | mask.get(int(r), 0) << 2
    return code, outs_unk


class NativeProgram:
    """A :class:`planners.program.Program`'s arrays, laid out for the native calls.

    Parameters
    ----------
    program : planners.program.Program
        The traced program.
    """

    def __init__(self, program) -> None:
        self.lib = library()
        self.code, self.outs_unk = tangent_masks(program.code, program.n_unknowns, program.outputs, program.outputs_unk)
        self.params = np.ascontiguousarray(program.params, dtype=float)
        if self.params.size == 0:
            self.params = np.zeros(1)
        self.outs = np.ascontiguousarray(program.outputs, dtype=np.int64)
        self.n = program.n_unknowns
        self.nreg = program.n_registers
        self.neq = len(self.outs)
        # the program's own pointers, once (the arrays are kept alive by this object)
        self._head = (_ptr(self.code), self.code.shape[0], _ptr(self.params))
        self._tail = (self.nreg, _ptr(self.outs), _ptr(self.outs_unk), self.neq, self.n)
        self._data_ptr: tuple = (None, 0)

    def _args(self, data: np.ndarray) -> tuple:
        held, ptr = self._data_ptr
        if held is not data:
            ptr = _ptr(data)
            self._data_ptr = (data, ptr)
        return (*self._head, ptr, data.shape[1], *self._tail, data.shape[2])

    def evaluate(self, x: np.ndarray, data: np.ndarray, M: int) -> np.ndarray:
        """Residual series (neq, M, S) at ``x`` (n, Mx >= M, S), data (D, Md >= M, S), both C-contiguous."""
        res = np.empty((self.neq, M, data.shape[2]))
        self.lib.gf_evaluate(*self._args(data), _ptr(x), x.shape[1], M, _ptr(res))
        return res

    def evaluate_tangent(self, x: np.ndarray, data: np.ndarray, M: int) -> tuple:
        """Residual series (neq, M, S) and Jacobian series (neq, n, M, S)."""
        S = data.shape[2]
        res = np.empty((self.neq, M, S))
        jac = np.empty((self.neq, self.n, M, S))
        self.lib.gf_evaluate_tangent(*self._args(data), _ptr(x), x.shape[1], M, _ptr(res), _ptr(jac))
        return res, jac

    def warm_newton(self, x, data, Jc, has_carried, tol, weights, maxsteps, chord_steps, chord_proof):
        """``gf_warm_newton``: status (0 solved, 1 not, 2 singular), cres (S,), evaluations; x, Jc updated."""
        S = data.shape[2]
        cres = np.empty(S)
        steps = ctypes.c_int64(0)
        st = self.lib.gf_warm_newton(
            *self._args(data),
            _ptr(x),
            _ptr(Jc),
            x.shape[1],
            int(has_carried),
            float(tol),
            _ptr(weights),
            int(maxsteps),
            int(chord_steps),
            float(chord_proof),
            _ptr(cres),
            ctypes.addressof(steps),
        )
        return st, cres, steps.value

    def pointwise_newton(self, x, data, tol: float, maxiter: int):
        """``gf_pointwise_newton``: status (0, or 2 singular), residuals (S,), iterations; x (n, S) updated."""
        S = data.shape[2]
        res = np.empty(S)
        its = ctypes.c_int64(0)
        st = self.lib.gf_pointwise_newton(
            *self._args(data), _ptr(x), float(tol), int(maxiter), _ptr(res), ctypes.addressof(its)
        )
        return st, res, its.value

    def doubling(self, x, data, orders: np.ndarray, Jc) -> int:
        """``gf_doubling``: status (0, or 2 singular); x (n, Mx, S) and Jc (n, n, Mx, S) updated."""
        return self.lib.gf_doubling(*self._args(data), _ptr(x), x.shape[1], _ptr(orders), len(orders), _ptr(Jc))


def horner(c: np.ndarray, i: np.ndarray, s: np.ndarray) -> np.ndarray | None:
    """Piecewise polynomials at many times by Horner's rule in native code, or None without the library.

    Parameters
    ----------
    c : ndarray, shape (intervals, v, d + 1)
        Coefficients in ascending powers of the offset.
    i : ndarray of int, shape (N,)
        The interval of each time.
    s : ndarray, shape (N,)
        The offsets from the intervals' starts.

    Returns
    -------
    ndarray, shape (v, N), or None
        The values (those of :func:`planners.plan._horner` bit for bit).
    """
    lib = _STATE["lib"] if _STATE["tried"] else None
    if lib is None:
        return None
    c = np.ascontiguousarray(c, dtype=float)
    i = np.ascontiguousarray(i, dtype=np.int64)
    s = np.ascontiguousarray(s, dtype=float)
    out = np.empty((c.shape[1], s.size))
    lib.gf_horner(_ptr(c), c.shape[1], c.shape[2], _ptr(i), _ptr(s), s.size, _ptr(out))
    return out


def loaded():
    """The native library when it is loaded already (None otherwise: nothing is compiled or loaded here).

    Returns
    -------
    ctypes.CDLL or None
    """
    return _STATE["lib"] if _STATE["tried"] else None


def grid_horner(c: np.ndarray, tn: np.ndarray, t: np.ndarray, out: np.ndarray, pad: bool = False) -> bool:
    """Interval polynomials on many times, each in its interval of the nodes, by Horner's rule in native code.

    The values of ``planners.plan._horner(c[i], t - tn[i], 0)`` with ``i = clip(searchsorted(tn, t, "right") - 1,
    0, len(tn) - 2)``, bit for bit; with ``pad``, those of ``c`` zero-padded to a higher degree (for finite offsets).

    Parameters
    ----------
    c : ndarray, shape (len(tn) - 1, v, d + 1)
        Coefficients in ascending powers of the offset from the interval's start.
    tn : ndarray, shape (nodes,)
        The nodes [s], increasing, at least two.
    t : ndarray, shape (N,)
        The times [s].
    out : ndarray, shape (v, N)
        Written (C-contiguous rows: a slice of rows of a larger C-contiguous array will do).
    pad : bool
        Start from a padded zero (the reference evaluates ``c`` padded with zero coefficients).

    Returns
    -------
    bool
        False without the library (``out`` untouched).
    """
    lib = loaded()
    if lib is None:
        return False
    c = np.ascontiguousarray(c, dtype=float)
    tn = np.ascontiguousarray(tn, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    if not (out.flags.c_contiguous and out.dtype == np.float64 and out.shape == (c.shape[1], t.size)):
        raise ValueError("grid_horner: out must be a C-contiguous float array of shape (v, N)")
    if c.shape[0] != tn.size - 1 or tn.size < 2:
        raise ValueError("grid_horner: one polynomial per interval of at least two nodes")
    if lib.gf_grid_horner(_ptr(c), c.shape[1], c.shape[2], int(pad), _ptr(tn), tn.size, _ptr(t), t.size, _ptr(out)):
        raise MemoryError("grid_horner: no memory for the offsets")
    return True


def limit_scan(t: np.ndarray, sides: list) -> list:
    """:func:`gna.limits.scan_sides` in native code (the same results), or numpy's without the library.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s].
    sides : list of (Limit, str, ndarray, float or ndarray)
        As :func:`gna.limits.scan_sides`.

    Returns
    -------
    list
        Per side: None, or ``(i, first, last)``.
    """
    from gna.limits import scan_sides

    lib = loaded()
    n = len(sides)
    if lib is None or not n:
        return scan_sides(t, sides)
    N = t.size
    ints = np.zeros((4, n), dtype=np.int64)  # the quantities' and bounds' addresses, the bounds' kinds, the sides
    vp, kind, lower, bp = ints
    bc = np.zeros(n)
    held, p = None, 0
    for q, (_lim, side, v, bound) in enumerate(sides):
        if v is not held:  # a limit's two sides read one quantity: its address once
            if not (type(v) is np.ndarray and v.dtype == np.float64 and v.shape == (N,) and v.flags.c_contiguous):
                return scan_sides(t, sides)
            held, p = v, v.ctypes.data
        vp[q] = p
        lower[q] = side == "lower"
        if type(bound) is np.ndarray:
            if not (bound.dtype == np.float64 and bound.shape == (N,) and bound.flags.c_contiguous):
                return scan_sides(t, sides)
            kind[q], bp[q] = 2, bound.ctypes.data
        else:
            b = float(bound)
            if not (math.isnan(b) or b == (-math.inf if side == "lower" else math.inf)):
                kind[q], bc[q] = 1, b  # else unbounded on that side: skipped
    res = np.empty((n, 4), dtype=np.int64)
    lib.gf_limit_scan(N, n, *(a.ctypes.data for a in (vp, kind, lower, bc, bp, res)))
    return [None if r[0] == 0 else (r[1], r[2], r[3]) for r in res.tolist()]


def iterates(*args) -> int:
    """``gf_iterates`` (the generalized-flatness iterates whole, :func:`planners.chained._native_run`): the
    first iterate not completed.

    Parameters
    ----------
    *args
        The arguments of ``gf_iterates`` in ``planners/_program.c``, arrays as numpy arrays.

    Returns
    -------
    int
    """
    lib = library()
    conv = [_ptr(a) if isinstance(a, np.ndarray) else a for a in args]
    return int(lib.gf_iterates(*conv))
