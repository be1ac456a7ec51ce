"""planners: flat and generalized-flat motion planning on truncated power series.

One module per section of the paper: :mod:`.series` (truncated power series), :mod:`.flat` (the flat
parametrization), :mod:`.generalized` (generalized flatness, :func:`~.generalized.plan_scenario`),
:mod:`.newton`, :mod:`.plan` (:class:`~.plan.Plan`), :mod:`.scenario`, :mod:`.singularity`,
:mod:`.tracking` (the tracking feedback along a plan).  The public API is :mod:`gflat`; this
``__init__`` imports nothing.
"""
