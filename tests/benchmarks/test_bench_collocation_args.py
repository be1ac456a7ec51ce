"""The collocation benchmark's command line: every argument checked before any work, Ctrl-C in one line."""

from __future__ import annotations

import pytest

from .conftest import benchmark_module

pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def bc():
    with benchmark_module("bench_collocation", "bench_collocation_args") as mod:
        yield mod


@pytest.fixture
def no_work(bc, monkeypatch):
    monkeypatch.setattr(bc, "bench_scenario", lambda *a, **k: pytest.fail("ran before checking the arguments"))


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--step", "1e-9"], "8e+09 nodes"),
        (["--step", "1000"], "longer than the 8 s span"),
        (["--step", "0.3"], "does not divide the 8 s span"),
        (["--e", "100"], "--e: a whole number from 0 to 10"),
        (["--J", "31"], "--J: a whole number from 0 to 30"),
        (["--J", "1000"], "got '1000'"),
        (["--factors", "0"], "--factors"),
        (["--factors", "nan"], "--factors"),
        (["--factors", "1e-9"], "collocation intervals"),
        (["--factors="], "--factors"),
        (["--factors=-4"], "--factors"),
        (["--graphs", "QX"], "--graphs"),
        (["--scenarios", "nope"], "unknown scenario 'nope'"),
        (["--repeat", "0"], "--repeat: at least 1"),
        (["--repeat", "-2"], "--repeat: at least 1"),
        (["--json", "/proc/x"], "--json: cannot write '/proc/x'"),
        (["--json", "/nonexistent-folder/x.json"], "does not exist"),
        (["--markdown", "/tmp"], "is a folder"),
    ],
)
def test_bad_arguments_are_one_usage_line(bc, no_work, argv, words, capsys):
    if argv[:1] == ["--step"] or argv[:1] == ["--factors"] and "1e-9" in argv:
        argv = [*argv, "--scenarios", "gtm-aileron-roll"]
    with pytest.raises(SystemExit) as exc:
        bc.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err
    assert ": error: " in err.strip().splitlines()[-1]


def test_ctrl_c_is_one_line(bc, monkeypatch, capsys):
    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(bc, "bench_scenario", interrupted)
    with pytest.raises(SystemExit) as exc:
        bc.main(["--scenarios", "gtm-aileron-roll", "--quick"])
    assert exc.value.code == 130
    assert capsys.readouterr().err == "bench_collocation: interrupted\n"


def test_quick_help_says_what_it_runs(bc, capsys):
    with pytest.raises(SystemExit):
        bc.main(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "the 8x grid only" in out and "4x" not in out


def test_a_plan_that_cannot_be_made_is_one_line_and_exit_1(bc, capsys):
    """J = 30 on the roll diverges past the iteration's floor: the planner's one-line error, no traceback."""
    with pytest.raises(SystemExit) as exc:
        bc.main(["--quick", "--J", "30", "--scenarios", "gtm-aileron-roll", "--guess", "plan-j0"])
    assert exc.value.code == 1
    err = capsys.readouterr().err.strip().splitlines()
    # the diverged iterate leaves the domain (numpy path: finite values outside it; the native path: non-finite)
    assert len(err) == 1 and err[0].startswith("bench_collocation: error: ")
    assert "outside the physical domain" in err[0] or "non-finite values" in err[0]
