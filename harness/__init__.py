"""harness: engines, metrics, validation cases and the ``gflat`` command line.

Public face: :func:`fly` (one problem on several engines),
:class:`ValidationCase` / :func:`run_case` / :class:`CaseResult` (plan, fly,
compare), :func:`difference_table` (trajectory metrics) and
:func:`assert_trajectories_close` (for users' tests).

Rooms
-----
engines
    Dynamics engines (in-house model, JSBSim) behind one protocol and a
    registry of names; :func:`engines.fly`.  A new simulator goes here.
metrics
    Pure metrics of trajectories: difference tables, tolerances, windows,
    deviation from the plan (``max_position_error``).  Neither simulates nor writes.
validation
    Validation cases (picklable, loadable from TOML) and :func:`run_case`;
    the closed loop (the paper's tracking feedback) plugs in here; campaigns
    map :func:`run_case` over cases.
testing
    ``assert_trajectories_close`` and smooth test inputs; ``pytest_plugin``: the
    ``gflat_flight`` fixture (golden trajectories beside the test, ``--gflat-regen``).
cli, commands
    The ``gflat`` tool: each command parses, calls validation/planners, renders
    (via :mod:`reports`) and writes; no workflow logic.
"""

import importlib

__all__ = ["fly", "run_case", "ValidationCase", "CaseResult", "difference_table", "assert_trajectories_close"]

#: Public name -> the module defining it.  Imported on first use (PEP 562), so that ``harness.cli``
#: starts without the planners and can report a bad setting read at their import as one line.
_PUBLIC = {
    "fly": ".engines",
    "difference_table": ".metrics",
    "assert_trajectories_close": ".testing",
    "run_case": ".validation",
    "ValidationCase": ".validation",
    "CaseResult": ".validation",
}


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
