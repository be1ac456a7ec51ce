"""Singularity monitor of the flat parametrization along a plan.

Paper section "Flat outputs and their singularities": the stage-2 system
(three force equations plus the fourth flat output) is solvable for the
remaining unknowns only where a determinant does not vanish:

* flat output beta: eq. (cond_beta), the (alpha, mu) Jacobian after F is
  eliminated with eq. (X);
* flat output mu: eq. (stalling_cond), the (alpha, beta) Jacobian after F is
  eliminated -- a lift maximum;
* flat output F: eq. (cond_F), the (alpha, mu) Jacobian after beta is
  eliminated with eq. (chi) -- vanishes for beta = mu = 0 in a vertical plane;
* mixed output: the full 4 x 4 Jacobian.

Eliminating a variable with one equation is a Schur complement, so each
determinant equals ``det(J3) / dR_k/dv`` with ``J3`` the Jacobian of the three
force equations in the three free unknowns.  The monitor also watches
``V cos(gamma)`` (stage 1) and ``cos(beta)`` (stage 3), and warns at the
times where any of them comes near zero or changes sign.  A determinant
numerically zero at a node (:data:`SINGULAR`) is a failure, not a warning:
the stage-2 Newton solution there is one of a continuum (beta as flat output
at zero load factor: any mu gives zero lift) or ill-determined (near-vacuum
density: the aerodynamic forces barely depend on the angles), so the later
iterates built on it are not solutions of the model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from gna.eom import H_NAMES
from gna.solve import jacobian

from .flat import force_residuals

#: A determinant below this fraction of its largest magnitude along the plan is reported ...
NEAR_ZERO = 0.02
#: ... and so is one below this absolute value.  The determinants are built from the stage-2
#: residuals divided by g (dimensionless, per rad or per unit thrust/weight): in ordinary flight
#: they are of order 0.1 to 100.
ABS_TINY = 1e-3
#: A determinant at most this, times ``max(1, its largest magnitude)``, is numerically zero: the stage-2
#: system is singular at that node (as stage 1 is at ``V cos(gamma) <= 1e-6 max(1, V)``,
#: :func:`planners.flat.stage1`).  Bundled scenarios stay above 1.7 (dimensionless, see :data:`ABS_TINY`).
SINGULAR = 1e-6


@dataclass
class SingularityReport:
    """Conditions along the plan, at the nodes.

    Attributes
    ----------
    table : DataFrame
        Columns: the flat output's determinant (``cond_beta``, ``stalling_cond``,
        ``cond_F`` or ``det4``), ``V_cos_gamma``, ``cos_beta``.  Built on first access (the
        warnings do not need it); a report is pickled with it built.
    condition : str
        The determinant's column name.
    warnings : list of str
    failures : list of str
        Where the determinant is numerically zero (:data:`SINGULAR`): the flat
        parametrization is singular there and the plan is not feasible (one
        message naming the times and the condition).
    """

    _table: object  # DataFrame, or a callable building it on first access
    condition: str
    warnings: list = field(default_factory=list)
    failures: list = field(default_factory=list)

    @property
    def table(self) -> pd.DataFrame:
        """The conditions at the nodes, indexed by time."""
        if callable(self._table):
            self._table = self._table()
        return self._table

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_table"] = self.table
        return state


class _Constants(dict):
    """The real constant terms of a solution's series, each read on first use."""

    def __init__(self, series) -> None:
        super().__init__()
        self._series = series

    def __missing__(self, key):
        v = self[key] = np.real(self._series[key]._c[0])
        return v


def _near_zero_times(t, v, name, what) -> list[str]:
    out = []
    scale = np.max(np.abs(v))
    if not np.isfinite(scale) or scale == 0:
        return [f"{name} ({what}) is zero or undefined along the whole plan"]
    small = np.abs(v) < max(NEAR_ZERO * scale, ABS_TINY)
    big = np.abs(v) >= ABS_TINY
    flips = np.flatnonzero((np.sign(v[1:]) != np.sign(v[:-1])) & big[1:] & big[:-1])
    if np.any(small):
        ts = t[small]
        out.append(
            f"{name} ({what}) near zero (< {NEAR_ZERO:g} of its maximum {scale:.3g}) at "
            f"{_ranges(ts)}; minimum {v[small][np.argmin(np.abs(v[small]))]:.3g} at "
            f"t = {ts[np.argmin(np.abs(v[small]))]:.4g} s"
        )
    for i in flips:
        out.append(
            f"{name} ({what}) changes sign between t = {t[i]:.4g} s and t = {t[i + 1]:.4g} s "
            f"({v[i]:.3g} -> {v[i + 1]:.3g}): the flat output is singular there"
        )
    return out


def _singular_nodes(t, v, name, what, kind) -> list[str]:
    """One message when the determinant ``v`` is numerically zero at some nodes (:data:`SINGULAR`)."""
    finite = np.isfinite(v)
    if not finite.any():
        return []
    tiny = SINGULAR * max(1.0, float(np.max(np.abs(v[finite]))))
    bad = finite & (np.abs(v) <= tiny)
    if not bad.any():
        return []
    i = int(np.flatnonzero(bad)[0])
    return [
        f"stage 2 of the flat parametrization is singular at {_ranges(t[bad])}: {name} ({what}) = "
        f"{float(v[i]) or 0.0:.3g} at t = {t[i]:.4g} s (numerically zero, |{name}| <= {tiny:.3g}): the force "
        f"equations do not determine the other unknowns there -- a singularity of the fourth flat output "
        f"zeta = {kind!r} (choose another) or too little aerodynamic force (density, speed)"
    ]


def _ranges(ts) -> str:
    """``t = a, b s`` for a few times, ``t = a .. b s (n nodes)`` for more."""
    if len(ts) <= 4:
        return "t = " + ", ".join(f"{x:.4g}" for x in ts) + " s"
    return f"t = {ts[0]:.4g} .. {ts[-1]:.4g} s ({len(ts)} nodes)"


def _native_jacobian(sol, s, d1, h, u) -> np.ndarray | None:
    """The force equations' Jacobian ``(3, 4, nodes)`` in ``(alpha, beta, mu, F)`` at the nodes by the plan's traced
    stage-2 program at order 0 on the native evaluator (forward mode on the same operations: the complex step's
    values to rounding), or None (another backend, or no such program for this plan).

    The program's data at the nodes are the constant terms the numpy evaluation reads: the flat outputs and stage
    1's series of the iterate, ``c_1`` for a first derivative, the neglected terms ``h``; its first three outputs
    are :func:`planners.flat.force_residuals`, its unknowns :data:`planners.flat.STAGE2_UNKNOWNS`."""
    from . import chained
    from .flat import STAGE2_UNKNOWNS

    cached = getattr(sol, "_inputs", None)
    if not cached or chained.program_backend() != "native":
        return None
    entry = (cached.get("programs") or {}).get(2)
    prog = entry[0] if entry else None
    system = cached.get("system")
    stage = system.stages[1] if system is not None and len(system.stages) > 1 else None
    if prog is None or stage is None or tuple(stage.unknowns) != STAGE2_UNKNOWNS or prog.n_unknowns != 4:
        return None
    hv = dict(zip(H_NAMES, h))
    nodes = u.shape[1]
    series = [*prog.data_names, *prog.extra]
    D = np.empty((len(series), 1, nodes))
    for r, n in enumerate(series):
        if not isinstance(n, str):  # a series of the trace's own
            v = np.real(n._c[0])
        elif n in hv:
            v = np.real(getattr(hv[n], "constant_term", hv[n]))
        elif n.endswith("'") and n[:-1] in d1:
            v = d1[n[:-1]]
        elif n in sol.series:
            v = s[n]
        else:
            known = cached["derivs"].get(n, cached["known"].get(n))
            if known is None:
                return None
            v = np.real(known._c[0])
        D[r, 0] = v
    x = np.ascontiguousarray(u, dtype=float)[:, None, :]
    return prog.native().evaluate_tangent(x, D, 1)[1][:3, :, 0, :]


def monitor(plan, j: int = 0) -> SingularityReport:
    """Evaluate the singularity conditions at the nodes of iterate ``j``.

    Parameters
    ----------
    plan : Plan
        The plan (its problem gives the flat output's kind).
    j : int
        Iterate (default 0: the flat plan).

    Returns
    -------
    SingularityReport
        The determinant of the flat output's stage-2 system (eq. cond_beta, stalling_cond,
        cond_F, or the mixed 4x4), ``V cos(gamma)`` [m/s] and ``cos(beta)`` at the nodes, warnings, and
        failures where the determinant is numerically zero (:data:`SINGULAR`).

    Notes
    -----
    The force equations' Jacobian at the nodes: on the native evaluator, for iterate 0, the plan's traced
    stage-2 program's at order 0 (forward mode, the complex step's values to rounding); where that gives a
    warning or a failure, and on the other backends, the complex step on the numpy model (the messages quote
    the reference's values).
    """
    prob = plan.problem
    ac, env = prob.aircraft, prob.env
    sol = plan.iterates[j]
    s = _Constants(sol.series)  # the constant terms read (those of coeffs[..., 0]) when asked
    d1 = {k: np.real(sol.series[k]._c[1]) for k in ("V", "gamma", "chi")}
    if j == 0:
        h = prob.h
    else:
        h = plan.iterates[j - 1].h_values()
        h = type(h)(*(np.real(v.constant_term) if hasattr(v, "constant_term") else v for v in h))
    kind = prob.zeta.kind

    def fun(u):
        alpha, beta, mu, F = u
        return np.stack(
            np.broadcast_arrays(
                *force_residuals(
                    ac,
                    env,
                    s["z"],
                    s["V"],
                    s["gamma"],
                    s["chi"],
                    d1["V"],
                    d1["gamma"],
                    d1["chi"],
                    s["eta"],
                    h,
                    alpha,
                    beta,
                    mu,
                    F,
                )
            )
        )

    u = np.stack([s["alpha"], s["beta"], s["mu"], s["F"]])

    def condition(Jm):
        idx = {"alpha": 0, "beta": 1, "mu": 2, "F": 3}
        if kind in ("beta", "mu", "F"):
            free = [v for v in ("alpha", "beta", "mu", "F") if v != kind]
            J3 = Jm[:, [idx[v] for v in free]]
            det3 = np.linalg.det(np.moveaxis(J3, -1, 0))
            if kind == "F":
                name, what, pivot = (
                    "cond_F",
                    "eq. cond_F: (alpha, mu) Jacobian with beta eliminated",
                    Jm[2, idx["beta"]],
                )
            elif kind == "beta":
                name, what, pivot = (
                    "cond_beta",
                    "eq. cond_beta: (alpha, mu) Jacobian with F eliminated",
                    Jm[0, idx["F"]],
                )
            else:
                name, what, pivot = (
                    "stalling_cond",
                    "eq. stalling_cond: (alpha, beta) Jacobian with F eliminated",
                    Jm[0, idx["F"]],
                )
            with np.errstate(divide="ignore", invalid="ignore"):
                return det3 / pivot, name, what
        t_nodes = plan.t_nodes
        f1, f2 = prob.zeta.f1(t_nodes), prob.zeta.f2(t_nodes)
        row = np.stack(np.broadcast_arrays(0.0 * t_nodes, f1 + 0 * t_nodes, f2 + 0 * t_nodes, 0.0 * t_nodes))
        J4 = np.concatenate([Jm, row[None]], axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            # divided by the thrust pivot, as the other conditions: dimensionless like them
            cond = np.linalg.det(np.moveaxis(J4, -1, 0)) / Jm[0, idx["F"]]
        return cond, "det4", "4x4 Jacobian of the mixed flat output, F eliminated"

    t = plan.t_nodes
    Jm = _native_jacobian(sol, s, d1, h, u) if j == 0 else None
    if Jm is not None:
        cond, name, what = condition(Jm)
        warnings = _near_zero_times(t, cond, name, what)
        if warnings or _singular_nodes(t, np.real(cond), name, what, kind):
            Jm = None  # near a singularity the messages quote the complex step's values, as on the numpy path
    if Jm is None:
        Jm = jacobian(fun, u, "complex-batched")  # (3, 4, nodes): one evaluation for the 4 columns
        cond, name, what = condition(Jm)
        warnings = _near_zero_times(t, cond, name, what)
    vcg = s["V"] * np.cos(s["gamma"])
    cb = np.cos(s["beta"])

    def table() -> pd.DataFrame:
        return pd.DataFrame({name: cond, "V_cos_gamma": vcg, "cos_beta": cb}, index=pd.Index(t, name="t"))

    if np.min(np.abs(vcg)) < 1.0:
        warnings.append(
            f"V cos(gamma) below 1 m/s at {_ranges(t[np.abs(vcg) < 1.0])} (stage 1 singular: vertical flight path)"
        )
    if np.min(cb) < 0.2:
        warnings.append(f"cos(beta) below 0.2 at {_ranges(t[cb < 0.2])} (stage 3 singular)")
    failures = _singular_nodes(t, np.real(cond), name, what, kind)
    return SingularityReport(table, name, warnings, failures)
