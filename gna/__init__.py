"""gna: the in-house aircraft model.

Grauer--Morelli generic nonlinear aerodynamics as term tables, the 12-state
wind-frame equations of motion (one definition for floats, arrays and power
series), atmosphere, trim and simulation.

The public API is :mod:`gflat` (``import gflat``); this package's ``__init__`` imports nothing, so that
``gna.errors`` (which the ``gflat`` command line needs before it parses its arguments) loads without numpy.
"""
