"""The gflat pytest plugin, tested with pytest's own ``pytester``: a user's three-line validation test."""

import importlib
import importlib.metadata
import tomllib
from pathlib import Path

import numpy  # noqa: F401  (C extensions load once per process: imported before the in-process runs, whose
import pandas  # noqa: F401   module snapshot would drop them and the next run import them again)
import pyarrow  # noqa: F401
import pytest
import scipy.integrate  # noqa: F401

import harness.pytest_plugin  # noqa: F401  (loaded in-process by the runs below with -p)

ROOT = Path(__file__).resolve().parents[2]

USER_TEST = """
def test_twin_otter(gflat_flight):
    gflat_flight("twin-otter-single-engine", engines=["inhouse", "jsbsim"], duration=5.0{extra})
"""


@pytest.fixture
def run(pytester, monkeypatch):
    """Run pytest in-process on the user's test, the plugin loaded by hand (entry points off: the
    installed package may or may not declare it yet)."""
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")

    def go(*args):
        return pytester.runpytest("-p", "harness.pytest_plugin", "-q", *args)

    return go


def test_three_line_test_regenerates_passes_and_fails_when_tightened(pytester, run):
    pytester.makepyfile(test_user=USER_TEST.format(extra=""))
    golden = pytester.path / "gflat_golden" / "test_user" / "test_twin_otter.csv"

    missing = run()  # no golden file yet: a clear failure, how to create it
    missing.assert_outcomes(failed=1)
    missing.stdout.fnmatch_lines(["*golden trajectory*test_twin_otter.csv is missing*--gflat-regen*"])
    assert not golden.exists()

    run("--gflat-regen").assert_outcomes(passed=1)  # written from the first engine (inhouse)
    assert golden.is_file()
    assert golden.read_text().splitlines()[0].startswith("t,x,y,z,V,")

    run().assert_outcomes(passed=1)  # jsbsim within the default tolerances (1e-2 m, 1e-4 rad)

    # The engines differ by 4.1e-6 m in altitude over these 5 s: a 1e-6 m position tolerance fails on jsbsim,
    # with the difference table.
    pytester.makepyfile(test_user=USER_TEST.format(extra=', atol={"position": 1e-6}'))
    tight = run()
    tight.assert_outcomes(failed=1)
    out = tight.stdout.str()
    assert "trajectories differ: jsbsim (actual) vs golden test_twin_otter.csv (expected)" in out
    assert "columns exceed" in out and "(z)" in out
    assert "column   unit    max|diff|" in out and "FAIL" in out


def test_regeneration_replaces_a_stale_golden_file(pytester, run):
    pytester.makepyfile(test_user=USER_TEST.format(extra=""))
    run("--gflat-regen").assert_outcomes(passed=1)
    golden = pytester.path / "gflat_golden" / "test_user" / "test_twin_otter.csv"
    lines = golden.read_text().splitlines()
    head, first = lines[0].split(","), lines[1].split(",")
    first[head.index("z")] = str(float(first[head.index("z")]) + 0.5)  # a stale golden: 0.5 m off at t0
    golden.write_text("\n".join([lines[0], ",".join(first)] + lines[2:]) + "\n")
    stale = run()
    stale.assert_outcomes(failed=1)
    assert "inhouse (actual) vs golden" in stale.stdout.str() and "jsbsim (actual) vs golden" in stale.stdout.str()
    run("--gflat-regen").assert_outcomes(passed=1)
    run().assert_outcomes(passed=1)


def test_option_listed_in_help(pytester, run):
    run("--help").stdout.fnmatch_lines(["*--gflat-regen*"])


def test_entry_point_declared():
    with open(ROOT / "pyproject.toml", "rb") as fh:
        eps = tomllib.load(fh)["project"]["entry-points"]["pytest11"]
    assert eps == {"gflat": "harness.pytest_plugin"}
    module = importlib.import_module(eps["gflat"])
    assert callable(module.pytest_addoption) and hasattr(module, "gflat_flight")
    # When the installed metadata already carries it (pip install of this tree), it is the same.
    installed = [ep for ep in importlib.metadata.entry_points(group="pytest11") if ep.name == "gflat"]
    assert all(ep.value == "harness.pytest_plugin" for ep in installed)


@pytest.mark.parametrize(
    "extra, message",
    [
        (", duration=1e6", "*duration = 1e+06 s is longer than the scenario's span of * s*"),
        (', atol={"position": -1.0}', "*atol of position must be a non-negative number, got -1.0*"),
        (', atol={"positon": 1.0}', "*atol given for positon: neither a group*"),
    ],
)
def test_bad_arguments_fail_before_flying_or_writing(pytester, run, extra, message):
    pytester.makepyfile(
        test_user=USER_TEST.format(extra="").replace("duration=5.0", "duration=5.0" + extra)
        if "duration" not in extra
        else USER_TEST.format(extra="").replace("duration=5.0", extra[2:])
    )
    res = run("--gflat-regen")
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines([message])
    assert not (pytester.path / "gflat_golden").exists()
