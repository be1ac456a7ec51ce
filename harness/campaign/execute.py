"""One campaign sample, run as a pure function of its task (case, dispersion, seed).

:func:`run_sample` plans the case's scenario on the nominal aircraft (cached
per process: planning is deterministic), draws the sample
(:func:`harness.campaign.sampling.draw_sample`), flies the dispersed aircraft
from the offset initial state on every engine (closed loop: the scenario's
tracking feedback about the nominal plan) and returns the metrics and the
trajectories.  It writes nothing: the runner stores the outcome.  A
``[tracking.perturbation]`` of the scenario is replaced by the campaign's
dispersion.

Every sample is judged by the case's three verdicts
(:mod:`harness.validation.verdicts`), to tell the plan from the controller:
the same path is planned for the sample's (dispersed) aircraft, and its
``flyable`` verdict says whether a plan exists (``infeasible`` when the
planner finds none: Newton failure, domain, singularity) and stays within the
aircraft's limits; ``tracking`` judges the feedback flying the nominal plan on
the dispersed aircraft; ``engines_agree`` the difference tables.  The sample's
``cause`` (:func:`harness.validation.verdicts.cause`) is ``pass``,
``infeasible``, ``unflyable``, ``controller failure`` or ``engines disagree``.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import io
import math
import threading
import time
import traceback
from dataclasses import replace

import numpy as np

from gna.errors import DomainError, GflatError, describe
from planners.generalized import plan_scenario

from ..engines import fly, get_engine
from ..metrics import engine_tables, max_position_error
from ..validation import case_settings, plan_case
from ..validation.closed import closed_loop_setup, sampled_engines, saturated_seconds
from ..validation.run import with_step
from ..validation.verdicts import (
    VERDICT_NAMES,
    cause,
    engines_agree_verdict,
    flyable_verdict,
    infeasible_flyable,
    judge,
    tracking_verdict,
)
from .sampling import dispersed_aircraft, draw_sample
from .spec import SampleTask

__all__ = ["run_sample", "frame_to_parquet", "SAMPLE_STATUSES", "CaseTimeout", "time_budget"]

#: Outcome of a sample: ``done`` (metrics recorded, whatever the runs did) or ``failed`` (an error, or a
#: timeout: the error then starts with ``timeout:`` and names the time taken and the budget).
SAMPLE_STATUSES: tuple[str, ...] = ("done", "failed")


class CaseTimeout(BaseException):
    """A case ran past its wall-time budget (a BaseException: no ``except Exception`` of the work swallows it)."""


@contextlib.contextmanager
def time_budget(seconds: float):
    """Raise :class:`CaseTimeout` in the calling thread once ``seconds`` of wall time have passed.

    A daemon watcher thread injects the exception into the thread running the work
    (``PyThreadState_SetAsyncExc``), so the budget holds in this process, in a pool's worker process and in a
    Dask worker's thread alike; it lands between two Python bytecodes (a long call into C, one JSBSim step,
    finishes first).  Leaving the block stops the watcher and withdraws an exception not yet delivered.

    Parameters
    ----------
    seconds : float
        The budget [s]; ``inf`` for none.

    Raises
    ------
    CaseTimeout
        The budget was exhausted inside the block.
    """
    if not math.isfinite(seconds):
        yield
        return
    tid = ctypes.c_ulong(threading.get_ident())
    lock = threading.Lock()
    state = {"armed": False, "done": False, "fired": False}
    deadline = time.monotonic() + seconds

    def watch():
        # Sleeps in short slices and shares only ``state`` and ``lock`` with the worker: no Event or Timer,
        # whose own locks an exception landing in the worker thread could leave held (seen under coverage's
        # tracer: Timer.cancel and the timer's Event.set deadlocked).
        while not state["done"]:
            remaining = deadline - time.monotonic()
            if remaining <= 0.0 and state["armed"]:
                with lock:
                    if not state["done"]:
                        state["fired"] = True
                        ctypes.pythonapi.PyThreadState_SetAsyncExc(tid, ctypes.py_object(CaseTimeout))
                return
            time.sleep(min(remaining, 0.05) if state["armed"] else 0.001)

    threading.Thread(target=watch, name="gflat-case-budget", daemon=True).start()
    # armed only once start() has returned: an exception landing inside Thread.start (slow under a tracer)
    # would leave threading's own locks held
    state["armed"] = True
    delivered = False
    try:
        yield
    except CaseTimeout:
        delivered = True
        raise
    finally:
        # done under the lock the watcher injects under: no injection after it; one fired but not yet
        # delivered is withdrawn (only then: withdrawing a delivered one hung the process under coverage's
        # tracer, the thread that had injected never getting the interpreter lock back)
        with lock:
            state["done"] = True
            if state["fired"] and not delivered:
                ctypes.pythonapi.PyThreadState_SetAsyncExc(tid, None)


def frame_to_parquet(df) -> bytes:
    """A trajectory frame as Parquet bytes (the one place the campaign writes Parquet).

    Parameters
    ----------
    df : pandas.DataFrame
        Indexed by ``t`` [s].

    Returns
    -------
    bytes
    """
    buf = io.BytesIO()
    df.to_parquet(buf, engine="pyarrow", index=True)
    return buf.getvalue()


@functools.lru_cache(maxsize=8)
def _planned(case):
    # Planning is deterministic: one plan per case and worker process.
    return plan_case(case)


def _finite_or_none(v: float):
    return float(v) if math.isfinite(v) else None


def sample_flyable(scenario, aircraft) -> tuple[dict, float]:
    """The flyable verdict of the scenario's path planned for a (dispersed) aircraft.

    Parameters
    ----------
    scenario : planners.scenario.Scenario
        The case's scenario (its path, grid, J, recorded violations).
    aircraft : gna.aircraft.Aircraft
        The sample's aircraft.

    Returns
    -------
    (dict, float)
        :func:`harness.validation.verdicts.flyable_verdict` of the new plan, or
        :func:`~harness.validation.verdicts.infeasible_flyable` when there is none (the planner's
        first failure as the reason), and its planning time [s].  (The time goes to the sample's timings: the metrics stay the
        same bit for bit from run to run.)
    """
    t = time.perf_counter()
    try:
        plan = plan_scenario(replace(scenario, aircraft=aircraft))
    except DomainError as exc:
        out = infeasible_flyable(str(exc))
    else:
        if plan.feasible:
            out = flyable_verdict(plan, scenario.known)
        else:
            singular = plan.singularities.failures if plan.singularities is not None else []
            out = infeasible_flyable(
                (singular or plan.newton_failures or plan.domain_failures[-1:] or ["not feasible"])[0]
            )
    return out, time.perf_counter() - t


def _fly(task: SampleTask):
    case = task.spec.case
    planned = _planned(case)
    plan, scenario = planned.plan, planned.scenario
    draw = draw_sample(plan.aircraft, task.dispersion, task.seed)
    span = (plan.t0, plan.t1)
    settings = case_settings(case, scenario)  # as run_case: the case's > the scenario's [compare] > defaults
    engines = {n: with_step(get_engine(n), settings.jsbsim_dt) for n in case.engines}
    aircraft = dispersed_aircraft(plan.aircraft, draw)
    if case.loop == "closed":
        nominal = replace(scenario, tracking=replace(scenario.tracking, perturbation=None))
        setup = closed_loop_setup(plan, nominal)
        ctl, j = setup.controller, setup.feedforward_iterate
        engines = sampled_engines(engines, scenario.tracking.controller_dt)
        runs = fly(
            engines,
            aircraft,
            setup.x0 + draw.offsets,
            ctl.controls,
            span,
            env=plan.env,
            controller=ctl,
            dt_out=settings.dt_out,
        )
    else:
        ctl, j = None, plan.J
        runs = fly(
            engines,
            aircraft,
            np.asarray(plan.initial_state(j), dtype=float) + draw.offsets,
            plan.control_function(j),
            span,
            env=plan.env,
            dt_out=settings.dt_out,
        )
    return plan, draw, runs, ctl, j, planned.planning_time_s, settings, sample_flyable(scenario, aircraft)


def _metrics(plan, runs, ctl, j, settings, flyable: dict, known=()) -> dict:
    span = (plan.t0, plan.t1)
    ref = lambda t: plan.state(t, j)  # noqa: E731 - the flat outputs tracked
    out_runs, sat = {}, {}
    for label, res in runs.items():
        sat[label] = saturated_seconds(ctl, res) if ctl is not None else {"any": 0.0}
        out_runs[label] = {
            "status": res.status,
            "t_end": float(res.t_end),
            "max_position_error_m": _finite_or_none(max_position_error(res, ref)),
            "max_position_error_after_5s_m": _finite_or_none(max_position_error(res, ref, (plan.t0 + 5.0, None))),
            "saturated_s": float(sat[label]["any"]),
        }
    tables = (
        engine_tables(runs, span, settings.tolerances, settings.windows, rtol=settings.rtol or None)
        if len(runs) > 1
        else {}
    )
    verdicts = {
        "flyable": flyable,
        "tracking": tracking_verdict(
            runs,
            ref,
            span,
            settings.tracking_tolerance,
            settings.settle_time,
            sat if ctl is not None else None,
            clipped=ctl is None or bool(getattr(ctl, "saturate", True)),
        ),
        "engines_agree": engines_agree_verdict(runs, tables),
    }
    judged = judge(verdicts, known)
    return {
        "runs": out_runs,
        "differences": verdicts["engines_agree"]["differences"],
        "verdicts": {k: verdicts[k] for k in VERDICT_NAMES},
        "cause": cause(verdicts, known),
        "failures": judged["unrecorded"],
        "pass": bool(judged["pass"]),
        **({"tracking": getattr(ctl, "design", "paper")} if ctl is not None else {}),  # which design flew
    }


def run_sample(task: SampleTask) -> dict:
    """Run one sample: draw, fly every engine, measure.

    Parameters
    ----------
    task : SampleTask
        The case, dispersion set, sample index and seed.

    Returns
    -------
    dict
        ``case_id``, ``status`` (``done`` or ``failed``), ``metrics`` (``runs``:
        engine -> status, ``t_end`` [s], ``max_position_error_m``,
        ``max_position_error_after_5s_m`` [m] (None when not finite),
        ``saturated_s`` [s]; ``differences``: engine -> ``max_position_m``,
        ``max_angle_rad``, ``pass``, ``failing`` (variables beyond their
        tolerance, with the window); ``verdicts``: ``flyable`` (of the path
        planned for the sample's aircraft, :func:`sample_flyable`),
        ``tracking``, ``engines_agree``; ``cause``
        (:data:`harness.validation.verdicts.CAUSES`); ``failures`` (what
        the scenario does not record); ``pass``: no such failure), ``draw`` (the dispersed
        parameters by name), ``error`` (message of a failed sample; a sample
        past its wall-time budget ``task.budget_s`` is stopped and fails with
        ``timeout: ...`` naming its time and the budget),
        ``timings`` (``plan_s``, ``sample_plan_s``: the path planned for the sample's aircraft, ``fly_s``,
        ``total_s``) and ``files``
        (file name -> bytes: ``<engine>.parquet`` trajectories).  Runs that
        leave the flight domain are data (``done``, ``pass`` false); only an
        error raised while planning or flying makes a sample ``failed``.
    """
    t_start = time.perf_counter()
    out = {
        "case_id": task.case_id,
        "status": "failed",
        "metrics": None,
        "draw": None,
        "error": None,
        "timings": {},
        "files": {},
    }
    try:
        with time_budget(task.budget_s):
            plan, draw, runs, ctl, j, plan_s, settings, (flyable, replan_s) = _fly(task)
            t_fly = time.perf_counter()
            metrics = _metrics(plan, runs, ctl, j, settings, flyable, _planned(task.spec.case).scenario.known)
            files = {}
            if task.trajectories:
                for label, res in runs.items():
                    df = res.df
                    if res.controller_states is not None:
                        df = df.join(res.controller_states)
                    files[f"{label}.parquet"] = frame_to_parquet(df)
        out.update(metrics=metrics, draw=draw.parameters(), files=files, status="done")
        out["timings"] = {"plan_s": plan_s, "sample_plan_s": replan_s, "fly_s": t_fly - t_start}
    except CaseTimeout:
        took = time.perf_counter() - t_start
        out["error"] = (
            f"timeout: the case ran {took:.3g} s, over its budget of {task.budget_s:g} s "
            f"(case_budget_s in the campaign file, --case-budget S); stopped, the campaign goes on"
        )
        out["timings"] = {"budget_s": task.budget_s}
    except GflatError as exc:
        out["error"] = f"{type(exc).__name__}: {describe(exc)}"
    except Exception as exc:  # a bug, kept with its traceback in the store
        out["error"] = f"{type(exc).__name__}: {describe(exc)}\n{traceback.format_exc(limit=8)}"
    out["timings"]["total_s"] = time.perf_counter() - t_start
    return out
