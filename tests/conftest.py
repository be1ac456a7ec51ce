"""Test-suite plugins: pytest's own ``pytester`` (the gflat pytest plugin is tested with it).

The Ctrl-C tests send SIGINT to child processes.  A shell running a command in the background without
job control starts it with SIGINT ignored, and an ignored signal stays ignored across ``exec``: the
children would never see the Ctrl-C.  The suite restores the default disposition (Python's
KeyboardInterrupt), which its children then inherit as a user's terminal gives them.

The planner's native evaluator is compiled at once when the suite first needs it (``GFLAT_NATIVE_WAIT=1``),
not in the background as for a first ``gflat plan``: every test plans on the default backend.

The long commands' progress lines (:mod:`harness.progress`) are off (``GFLAT_PROGRESS=off``): the tests read
the commands' own stderr; the tests of progress set the mode they test.
"""

import os
import signal

os.environ.setdefault("GFLAT_NATIVE_WAIT", "1")
os.environ.setdefault("GFLAT_PROGRESS", "off")

pytest_plugins = ["pytester"]

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
