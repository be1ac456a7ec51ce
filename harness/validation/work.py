"""Up-front bounds on the work of a validation case's flights: engine steps and output samples, before any work.

Used by ``gflat compare`` and ``gflat paper`` (``--max-steps``) and by every case of a campaign (checked when
the campaign file is read).
"""

from __future__ import annotations

import math

from gna.errors import InputError

from ..engines.jsbsim.run import MAX_JSBSIM_DT

__all__ = [
    "MAX_STEPS",
    "SAMPLE_COST",
    "COMPUTABLE_STEPS",
    "MAX_JSBSIM_DT",
    "flight_steps",
    "flight_work",
    "check_steps",
]

#: Default bound on a command's work (``--max-steps``): engine steps plus SAMPLE_COST x output samples of all
#: its flights.  Measured on gtm-aileron-roll: a JSBSim step takes about 330 bytes and 10 us, an output sample
#: (two engines, tables, figures, files) about 3.7 kB and 0.25 ms; 1e7 is about 3.5 GB, and the bundled
#: scenarios need less than 1e6.
MAX_STEPS = 1.0e7
#: Steps an output sample counts for.
SAMPLE_COST = 10


def flight_steps(case, scenario, settings) -> tuple[int, int]:
    """Engine steps and output samples of a case's flights over its scenario's span, before any work.

    Parameters
    ----------
    case : ValidationCase
    scenario : planners.scenario.Scenario
    settings : CompareSettings
        The case's resolved settings (``dt_out``, ``jsbsim_dt``, ``self_convergence``).

    Returns
    -------
    steps, samples : int

    Every engine flies the span once (closed loop: the reference engine also flies the open loop and the flat
    plan's feedforward); a JSBSim engine takes ``ceil(span / jsbsim_dt)`` steps (and twice as many again with
    ``self_convergence``); every flight records ``span / dt_out + 1`` samples.  The in-house engine's adaptive
    steps are not counted.
    """
    span = scenario.t1 - scenario.t0
    samples = int(span / settings.dt_out + 1e-9) + 1
    steps = max(math.ceil(span / settings.jsbsim_dt - 1e-9), 1)
    engines = list(case.engines) + ([case.engines[0]] * 2 if case.loop == "closed" else [])
    jsbsim = [e for e in engines if str(e).startswith("jsbsim")]
    if settings.self_convergence:
        jsbsim += [e for e in case.engines if str(e).startswith("jsbsim")] * 2  # a flight at dt / 2
        engines += [e for e in case.engines if str(e).startswith("jsbsim")]
    return steps * len(jsbsim), samples * len(engines)


def flight_work(flights, name: str) -> float:
    """The work of one flight of a case set up for flying, in the units of :func:`flight_steps`: what to fly first.

    Parameters
    ----------
    flights : harness.validation.flights.CaseFlights
        The case (:func:`harness.validation.flights.case_flights`).
    name : str
        One of its flights: an engine label, or the closed loop's open-loop or flat-plan flight (the
        reference engine's).

    Returns
    -------
    float
        Engine steps + :data:`SAMPLE_COST` x output samples over the span: a JSBSim engine's
        ``ceil(span / dt)`` steps, and in closed loop one more run of its models per feedback update
        (:class:`harness.engines.jsbsim.JSBSimEngine`'s controller notes); the in-house engine's adaptive steps
        are not counted (as in :func:`flight_steps`).  Used to start the longest flights first.
    """
    from .flights import OPEN_LOOP

    plan, settings = flights.plan, flights.settings
    span = plan.t1 - plan.t0
    samples = int(span / settings.dt_out + 1e-9) + 1
    engine = flights.engines.get(name, flights.engines[flights.case.engines[0]])
    dt = getattr(engine, "dt", None)
    steps = 0
    if dt is not None:
        steps = max(math.ceil(span / dt - 1e-9), 1)
        if flights.closed_loop is not None and name != OPEN_LOOP:  # the feedback re-runs the models at every update
            every = getattr(engine, "controller_dt", None)
            steps += steps if every is None else max(math.ceil(span / every - 1e-9), 1)
    return float(steps + SAMPLE_COST * samples)


#: Engine steps + SAMPLE_COST x output samples beyond which a run is refused whatever ``--max-steps`` says
#: (about 2**53: the arrays alone would take petabytes).
COMPUTABLE_STEPS = 9e15


def _check_sizes(scenario, settings, command: str, keys) -> None:
    """A JSBSim step and an output interval within the scenario's span (and the step within MAX_JSBSIM_DT)."""
    span = scenario.t1 - scenario.t0

    def named(key: str, flag: str) -> str:
        if settings.sources.get(key) == "scenario":
            return f"{scenario.path or scenario.name} [compare] {key}"
        return flag

    bound = min(span, MAX_JSBSIM_DT)
    if settings.jsbsim_dt > bound * (1 + 1e-9):
        why = (
            f"{scenario.name}'s span"
            if span < MAX_JSBSIM_DT
            else "gflat's largest JSBSim step: the GTM diverges at 0.05 s"
        )
        raise InputError(
            f"{command}: {named('jsbsim_dt', keys[0])} {settings.jsbsim_dt:g} s is above its bound {bound:g} s ({why})"
        )
    if settings.dt_out > span * (1 + 1e-9):
        raise InputError(
            f"{command}: {named('dt_out', keys[1])} {settings.dt_out:g} s is above its bound {span:g} s "
            f"({scenario.name}'s span)"
        )


def check_steps(planned, bound: float, command: str, keys=("--jsbsim-dt", "--dt-out"), flag="--max-steps") -> None:
    """Refuse a command whose flights would take more than ``bound`` engine steps plus SAMPLE_COST x output samples.

    Parameters
    ----------
    planned : list of tuple
        ``(case, scenario, settings)`` of every flight group.
    bound : float
        Largest engine steps + :data:`SAMPLE_COST` x output samples (``inf``: only :data:`COMPUTABLE_STEPS`).
    command : str
        What the message names first (``compare``, a campaign file and case).
    keys : pair of str
        How the step and the output interval are named (flags, or a file's keys).
    flag : str or None
        The flag raising the bound, for the message; None: the bound is fixed (a campaign case).

    Raises
    ------
    InputError
        One line naming the step and output interval, the span, the counts and the bound, before anything
        is planned; or a JSBSim step above the smaller of the span and :data:`MAX_JSBSIM_DT`, an output
        interval above the span (one line naming the value, where it was set, and the bound).
    """
    for _, scenario, settings in planned:
        _check_sizes(scenario, settings, command, keys)
    steps = samples = 0
    for case, scenario, settings in planned:
        st, sa = flight_steps(case, scenario, settings)
        steps, samples = steps + st, samples + sa
    cost = steps + SAMPLE_COST * samples
    if cost > min(bound, COMPUTABLE_STEPS):
        how = f"{flag} N to raise it, inf for none" if flag else "a fixed bound: use a coarser step or output grid"
        if cost > COMPUTABLE_STEPS:  # whatever the bound: no machine holds the arrays (2**53 samples)
            bound, how = (
                COMPUTABLE_STEPS,
                "no machine holds the arrays of such a run" + (f", whatever {flag} says" if flag else ""),
            )
        names = ", ".join(dict.fromkeys(f"{sc.name} ({sc.t1 - sc.t0:g} s)" for _, sc, _ in planned))
        s = max(planned, key=lambda p: sum(flight_steps(*p)))[2]
        raise InputError(
            f"{command}: {keys[0]} {s.jsbsim_dt:g} s and {keys[1]} {s.dt_out:g} s over {names} "
            f"make {steps:.3g} engine steps + {SAMPLE_COST} x {samples:.3g} output samples = "
            f"{cost:.3g}, above the bound {bound:.3g} ({how})"
        )
