"""Checks of a campaign's cases before anything runs: the scenario, J and the settings of every expanded case.

A campaign that names a scenario that does not exist, or asks the planner for
an impossible J, is refused when the file is read (one line naming the file,
the case, the key and the value), not recorded as failed cases after the run:
each expanded case's scenario is loaded (with the case's J: the scenario's own
checks, the tracking feedforward iterate against J included), its comparison
settings merged with the scenario's ``[compare]`` table, and its output grid
checked against the scenario's span.  Nothing is planned or flown.
"""

from __future__ import annotations

import difflib
from pathlib import Path

from gna.errors import InputError
from gna.schema import did_you_mean
from gna.trajectory import output_grid
from planners.flat import check_iterations
from planners.scenario import list_scenarios, load_scenario

from ..validation import ValidationCase, case_settings
from ..validation.work import MAX_STEPS, check_steps

__all__ = ["MAX_CASES", "MAX_DASK_TIMEOUT_S", "check_case", "check_samples", "closest_name"]

#: Default bound on a campaign run's cases, samples x cases x dispersion sets (``gflat campaign run --max-cases``):
#: a case takes seconds, so 1e5 cases are days of computing; the bundled campaign has 48.
MAX_CASES = 1.0e5

#: Longest wait for a Dask scheduler at an address (``--dask-timeout``) [s]: an hour; a scheduler that has not
#: answered by then is not starting (and beyond about 1e9 s the wait overflows the platform's time).
MAX_DASK_TIMEOUT_S = 3600.0


def closest_name(value: str, names) -> str:
    """`` (did you mean 'n'?)``: :func:`gna.schema.did_you_mean`, else the closest of ``names`` at a looser cutoff.

    Parameters
    ----------
    value : str
        The name found.
    names : iterable of str
        The accepted names.

    Returns
    -------
    str
        The suggestion, or an empty string.
    """
    names = list(names)
    hint = did_you_mean(value, names)  # difflib or a unique prefix, as for misspelt keys
    if hint:
        return hint
    looser = difflib.get_close_matches(value, names, n=1, cutoff=0.4)
    return f" (did you mean {looser[0]!r}?)" if looser else ""


def _is_bare_name(value: str) -> bool:
    # The rule of gna.schema.find_file: a path has a separator or ends in .toml, or exists.
    return not any(sep in value for sep in ("/", "\\")) and not value.endswith(".toml") and not Path(value).exists()


def check_case(case: ValidationCase, where: str, loaded: dict | None = None) -> None:
    """Check one expanded campaign case without planning it.

    Parameters
    ----------
    case : harness.validation.ValidationCase
        The case (its scenario path already resolved against the campaign file's folder).
    where : str
        File and case, for the message (``my.toml [[cases]] #1 (case to-J4)``).
    loaded : dict, optional
        Cache ``(scenario, J) -> Scenario`` shared by the cases of one campaign.

    Raises
    ------
    InputError
        One line naming ``where``, the key and the value: a scenario that is
        neither bundled (with the closest bundled name) nor a loadable file, J
        outside the planner's bounds (:func:`planners.flat.check_iterations`),
        a scenario that refuses this J (e.g. its tracking feedforward iterate),
        a bad ``[compare]`` value of the scenario, flights of more than
        :data:`harness.validation.work.MAX_STEPS` engine steps and output samples
        (:func:`harness.validation.work.check_steps`), or an output grid ``dt_out``
        that does not divide the scenario's span (:func:`gna.trajectory.output_grid`).
    """
    loaded = {} if loaded is None else loaded
    if case.J is not None and case.J != "auto":
        check_iterations(case.J, where)
    name = case.scenario
    if _is_bare_name(name):
        names = list_scenarios()
        if name not in names:
            raise InputError(
                f"{where}: scenario = {name!r} is not a bundled scenario{closest_name(name, names)}; "
                f"bundled scenarios: {', '.join(names)} (or give the path of a .toml file)"
            )
    key = (name, case.J)
    if key not in loaded:
        try:
            loaded[key] = load_scenario(name, J=case.J)
        except InputError as exc:
            raise InputError(
                f"{where}: scenario = {name!r}" + (f" with J = {case.J!r}" if case.J is not None else "") + f": {exc}"
            ) from None
    sc = loaded[key]
    try:
        settings = case_settings(case, sc)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    check_steps(  # the work of the case's flights bounded before its grids are built
        [(case, sc, settings)], MAX_STEPS, where, ("jsbsim_dt", "dt_out"), None
    )
    try:
        output_grid(sc.t0, sc.t1, settings.dt_out)
    except InputError as exc:
        origin = {"scenario": f"{sc.path or sc.name} [compare] ", "default": "the default "}.get(
            settings.sources["dt_out"], ""
        )
        raise InputError(f"{where}: {origin}{exc}") from None


def check_samples(campaign, samples: int | None, bound: float = MAX_CASES) -> int:
    """Refuse a campaign run of more than ``bound`` cases before anything is expanded or written.

    Parameters
    ----------
    campaign : harness.campaign.spec.Campaign
        The loaded campaign (its cases and dispersion sets).
    samples : int or None
        Samples per case and dispersion set (``--samples``); None: the campaign's.
    bound : float
        Largest number of cases (``inf`` for none).

    Returns
    -------
    int
        The number of cases, ``samples x cases x dispersion sets``.

    Raises
    ------
    InputError
        One line naming the samples, the resulting count and the bound.
    """
    n = campaign.samples if samples is None else samples
    pairs = len(campaign.cases) * len(campaign.dispersions)
    total = n * pairs
    if total > bound:
        raise InputError(
            f"campaign {campaign.name!r}: --samples {n} x {pairs} case-dispersion pairs = {total:.3g} "
            f"cases, above the bound {bound:.3g} (--max-cases N to raise it, inf for none)"
        )
    return total
