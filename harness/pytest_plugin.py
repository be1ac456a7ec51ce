"""The gflat pytest plugin: fly a scenario on named engines and compare with a golden trajectory.

Registered through the ``pytest11`` entry point ``gflat`` (installed with the
package; ``-p harness.pytest_plugin`` loads it by hand).  A user's validation
test is three lines::

    def test_twin_otter(gflat_flight):
        gflat_flight("twin-otter-single-engine", engines=["inhouse", "jsbsim"], duration=5.0,
                     atol={"position": 1e-2, "angle": 1e-4})

The golden trajectory lives beside the test file, in
``gflat_golden/<test module>/<test name>.csv`` (a ``.parquet`` file of the same
stem is read as well, e.g. one written by another simulator).  ``pytest
--gflat-regen`` (re)writes it from the first engine's run instead of comparing.
Every named engine is compared with it by
:func:`harness.testing.assert_trajectories_close`; the failure message carries
the difference table of each engine that differs.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    import pandas as pd

# numpy, pandas, the engines and the planners are imported when a test uses the fixture, so that the
# plugin costs nothing to the other test sessions of an environment where gflat is installed.

#: Folder of the golden trajectories, beside the test file.
GOLDEN_DIR = "gflat_golden"

#: Command-line flag that rewrites the golden trajectories.
REGEN_OPTION = "--gflat-regen"


def pytest_addoption(parser) -> None:
    """Add ``--gflat-regen`` to pytest's command line.

    Parameters
    ----------
    parser : pytest.Parser
        pytest's option parser.
    """
    group = parser.getgroup("gflat", "gflat golden trajectories")
    group.addoption(
        REGEN_OPTION,
        action="store_true",
        default=False,
        help="write the golden trajectories of gflat_flight tests from the first engine's run "
        "instead of comparing with them",
    )


def golden_path(test_file: str | Path, test_name: str) -> Path:
    """Where the golden trajectory of a test lives: ``<dir>/gflat_golden/<module>/<test name>.csv``.

    Parameters
    ----------
    test_file : str or pathlib.Path
        The test module's file.
    test_name : str
        The test's name (parameters in brackets included; characters outside ``[A-Za-z0-9_.-]``
        are replaced by ``_``).

    Returns
    -------
    pathlib.Path
    """
    test_file = Path(test_file)
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", test_name).strip("._") or "test"
    return test_file.parent / GOLDEN_DIR / test_file.stem / f"{stem}.csv"


class GoldenError(Exception):
    """A golden trajectory that cannot be used: the message names the file, the cause and the way out."""


def _bad_golden(path: Path, cause: str) -> GoldenError:
    return GoldenError(
        f"golden trajectory {path} is unusable: {cause}; regenerate it with 'pytest {REGEN_OPTION}' on this "
        f"test, review it and commit it"
    )


def read_golden(path: Path, columns: Sequence[str] = ()) -> pd.DataFrame:
    """A golden trajectory: ``path`` (CSV, first column the time ``t`` [s]) or its ``.parquet`` sibling, checked.

    Parameters
    ----------
    path : pathlib.Path
        The CSV path (:func:`golden_path`).
    columns : sequence of str
        Columns the comparison needs (each must be present).

    Returns
    -------
    pandas.DataFrame
        Indexed by ``t`` [s]: at least two rows, times finite and increasing, every value finite.

    Raises
    ------
    FileNotFoundError
        When neither file exists.
    GoldenError
        An empty, truncated, corrupt or undecodable file, or one without the needed columns: one line
        naming the file and the cause and saying to run ``pytest --gflat-regen``.
    """
    import numpy as np
    import pandas as pd

    parquet = path.with_suffix(".parquet")
    source = parquet if not path.is_file() and parquet.is_file() else path
    if not source.is_file():
        raise FileNotFoundError(str(path))
    if source.stat().st_size == 0:
        raise _bad_golden(source, "the file is empty")
    try:
        if source is parquet:
            df = pd.read_parquet(parquet)
            df = df.set_index("t") if "t" in df.columns else df
        else:
            df = pd.read_csv(path, index_col=0)
    except Exception as exc:  # pandas, pyarrow and the codecs raise many types for a damaged file
        cause = str(exc).strip().splitlines()[0] if str(exc).strip() else "no detail"
        raise _bad_golden(source, f"it cannot be read ({type(exc).__name__}: {cause})") from None
    from gna.trajectory import CONTROL_NAMES, STATE_NAMES

    foreign = [str(c) for c in df.columns if c not in STATE_NAMES + CONTROL_NAMES]
    if foreign:  # never ignored: an edited file, or another tool's
        raise _bad_golden(
            source,
            f"column {', '.join(map(repr, foreign))} is no trajectory column (a golden file has the states "
            f"and controls {', '.join(STATE_NAMES + CONTROL_NAMES)})",
        )
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise _bad_golden(
            source, f"no column {', '.join(map(repr, missing))} (it has {', '.join(map(str, df.columns))})"
        )
    if len(df) < 2:
        raise _bad_golden(source, f"{len(df)} row(s), a trajectory needs at least two")
    try:
        t = np.asarray(df.index, dtype=float)
        values = df.to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise _bad_golden(source, f"a value is not a number ({exc})") from None
    if not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0):
        raise _bad_golden(source, "the times (first column) are not finite and increasing")
    bad = ~np.isfinite(values)
    if bad.any():
        i, j = (int(k[0]) for k in np.nonzero(bad))
        raise _bad_golden(
            source, f"row {i + 1} (t = {t[i]:g} s) has {df.columns[j]} = {values[i, j]} (a truncated line?)"
        )
    df.index = pd.Index(t, name="t")
    return df


def write_golden(path: Path, result) -> None:
    """Write a run's 12 states and 5 controls as a golden CSV (17 significant digits: exact round trip).

    Parameters
    ----------
    path : pathlib.Path
        Destination (folders created; written atomically).
    result : SimulationResult
        The run.
    """
    import numpy as np
    import pandas as pd

    from gna.eom import CONTROL_NAMES, STATE_NAMES

    path.parent.mkdir(parents=True, exist_ok=True)
    df = result.df[list(STATE_NAMES + CONTROL_NAMES)]
    df.index = pd.Index(np.asarray(df.index, dtype=float), name="t")
    tmp = path.with_name(path.name + ".tmp")
    df.to_csv(tmp, float_format="%.17g")
    tmp.replace(path)


class GflatFlight:
    """The ``gflat_flight`` fixture's value: call it to fly and check a scenario.

    Parameters
    ----------
    test_file : pathlib.Path
        The test module's file (relative scenario paths are tried beside it first).
    golden : pathlib.Path
        The test's golden CSV (:func:`golden_path`).
    regen : bool
        Write the golden trajectory instead of comparing.
    """

    def __init__(self, test_file: Path, golden: Path, regen: bool):
        self.test_file, self.golden, self.regen = Path(test_file), golden, regen

    def has_golden(self) -> bool:
        """Whether the golden file (CSV, or its Parquet sibling) exists.

        Returns
        -------
        bool
        """
        return self.golden.is_file() or self.golden.with_suffix(".parquet").is_file()

    def __call__(
        self,
        scenario,
        engines: Sequence[str] = ("jsbsim",),
        *,
        duration: float | None = None,
        atol=None,
        rtol=None,
        columns: Sequence[str] | None = None,
        dt_out: float = 0.02,
        J: int | None = None,
    ) -> dict:
        """Plan ``scenario``, fly its plan open loop on ``engines`` and compare each run with the golden file.

        Parameters
        ----------
        scenario : str, pathlib.Path or mapping
            A bundled scenario name, a scenario TOML path (relative paths are tried beside the test
            file first), or a scenario as a dict (:func:`planners.scenario.scenario_from_dict`).
        engines : sequence of str
            Engine names (:func:`harness.engines.fly`); the first one writes the golden file on
            ``--gflat-regen``.
        duration : float, optional
            Fly only the first ``duration`` seconds of the plan [s] (at most the scenario's span).
        atol, rtol, columns
            Tolerances and columns of :func:`harness.testing.assert_trajectories_close` (default the
            12 states, 1e-2 m, 1e-3 m/s, 1e-4 rad, 1e-3 rad/s).
        dt_out : float
            Output interval [s].
        J : int, optional
            Generalized-flatness iterations (default the scenario's).

        Returns
        -------
        dict of str to SimulationResult
            The runs by engine name.

        Raises
        ------
        pytest.fail.Exception
            When the golden file is missing (the message says how to create it), a run did not
            complete, or an argument is bad (``duration`` beyond the scenario's span, a bad
            tolerance or column: checked before flying or writing).
        AssertionError
            When an engine's run differs from the golden trajectory (difference tables in the message).
        """
        __tracebackhide__ = True  # failures point at the user's test line, not at this method
        from gna.errors import InputError
        from gna.trajectory import COLUMNS, CONTROL_NAMES, STATE_NAMES
        from planners.generalized import plan_scenario
        from planners.scenario import load_scenario, scenario_from_dict

        from .engines import fly
        from .testing import assert_trajectories_close, check_tolerances

        if isinstance(scenario, Mapping):
            sc = scenario_from_dict(scenario, J=J)
        else:
            local = self.test_file.parent / str(scenario)
            sc = load_scenario(local if local.is_file() else scenario, J=J)
        cols = tuple(columns) if columns is not None else STATE_NAMES
        unknown = [c for c in cols if c not in COLUMNS]
        try:
            if unknown:
                raise InputError(f"columns {', '.join(map(str, unknown))} are not trajectory columns")
            check_tolerances(atol, rtol, cols)  # before flying, and before --gflat-regen writes
            span = float(sc.t_nodes[-1] - sc.t_nodes[0])
            if duration is not None:
                if (
                    isinstance(duration, bool)
                    or not isinstance(duration, (int, float))
                    or not (math.isfinite(duration) and duration > 0)
                ):
                    raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
                if duration > span * (1 + 1e-12):
                    raise InputError(
                        f"duration = {duration:g} s is longer than the scenario's span of {span:g} s "
                        f"(t = {sc.t_nodes[0]:g} .. {sc.t_nodes[-1]:g} s)"
                    )
        except InputError as exc:
            pytest.fail(f"gflat_flight({sc.name!r}): {exc}", pytrace=False)
        plan = plan_scenario(sc)
        t0, t1 = plan.t0, plan.t1 if duration is None else min(plan.t1, plan.t0 + float(duration))
        runs = fly(list(engines), sc.aircraft, None, plan, (t0, t1), env=sc.env, dt_out=dt_out)
        stopped = [f"{name}: {r.message}" for name, r in runs.items() if not r.completed]
        if stopped:
            pytest.fail(f"gflat_flight({sc.name!r}): run(s) did not complete: {'; '.join(stopped)}", pytrace=False)
        if self.regen:
            write_golden(self.golden, runs[engines[0]])
            return runs
        unusable = None
        try:
            needed = [c for c in cols if c in STATE_NAMES + CONTROL_NAMES]  # the columns write_golden writes
            golden = read_golden(self.golden, needed) if self.has_golden() else None
        except GoldenError as exc:
            unusable = str(exc)
        if unusable is not None:  # failed outside the except: the one message, not "during handling of ..."
            pytest.fail(f"gflat_flight({sc.name!r}): {unusable}", pytrace=False)
        if golden is None:
            pytest.fail(
                f"golden trajectory {self.golden} is missing; create it from the {engines[0]!r} run with "
                f"'pytest {REGEN_OPTION}' on this test, review it and commit it",
                pytrace=False,
            )
        g0, g1 = float(golden.index[0]), float(golden.index[-1])
        if g0 > t0 + 1e-9 or g1 < t1 - 1e-9:
            cause = f"it covers t = {g0:g} .. {g1:g} s, the run {t0:g} .. {t1:g} s (truncated, or for another duration)"
            pytest.fail(f"gflat_flight({sc.name!r}): {_bad_golden(self.golden, cause)}", pytrace=False)
        failures = []
        for name, r in runs.items():
            try:
                assert_trajectories_close(
                    golden, r, atol=atol, rtol=rtol, columns=columns, labels=(f"golden {self.golden.name}", name)
                )
            except AssertionError as exc:
                failures.append(str(exc))
        if failures:
            raise AssertionError(f"gflat_flight({sc.name!r}, t = {t0:g} .. {t1:g} s):\n" + "\n\n".join(failures))
        return runs


@pytest.fixture
def gflat_flight(request) -> GflatFlight:
    """Fly a scenario on named engines and compare with the golden trajectory stored beside the test.

    Parameters
    ----------
    request : pytest.FixtureRequest
        pytest's request (the test's file and name, the ``--gflat-regen`` option).

    Returns
    -------
    GflatFlight
        Call it as ``gflat_flight(scenario, engines=[...], duration=..., atol=..., rtol=...)``.
    """
    return GflatFlight(
        request.path, golden_path(request.path, request.node.name), bool(request.config.getoption(REGEN_OPTION))
    )
