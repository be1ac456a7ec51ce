"""harness: engines, metrics, validation cases and the ``gflat`` command line.

The public API is :mod:`gflat`; this ``__init__`` imports nothing (the ``gflat`` command line starts
without the planners and numpy).

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
