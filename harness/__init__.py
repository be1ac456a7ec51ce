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

from .engines import fly
from .metrics import difference_table
from .testing import assert_trajectories_close
from .validation import CaseResult, ValidationCase, run_case

__all__ = ["fly", "run_case", "ValidationCase", "CaseResult", "difference_table", "assert_trajectories_close"]
