"""Hardening, third round, kind 4: every count and size a file or a flag sets is bounded before any work.

Each refusal is one line naming the value and the bound (exit 2 from the command line, nothing written);
a TOML file nested too deep is refused by name (never a RecursionError); a campaign case past its
wall-time budget ends as a timeout naming its time and the budget, and the campaign goes on.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from gna.schema import MAX_DEPTH, MAX_FILE_BYTES, MAX_ITEMS, read_toml
from harness.campaign.execute import CaseTimeout, run_sample, time_budget
from harness.campaign.spec import MAX_CASE_SPECS, MAX_DISPERSIONS, load_campaign
from harness.campaign.store import CampaignStore
from harness.cli import main
from harness.parallel import max_workers
from planners.scenario import MAX_REPORT_TIMES, load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "planners" / "scenarios" / "gtm-aileron-roll.toml"
AIRCRAFT = ROOT / "gna" / "data" / "aircraft" / "f16c.toml"
CAMPAIGN = ROOT / "tests" / "harness" / "campaign"


def _one_line_exit_2(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err
    return err


def _tiny_campaign(tmp_path: Path, extra: str = "", case_extra: str = "") -> Path:
    (tmp_path / "tiny-level.toml").write_text((CAMPAIGN / "tiny-level.toml").read_text())
    text = (CAMPAIGN / "tiny.toml").read_text()
    text = text.replace("samples = 3\n", f"samples = 3\n{extra}\n").replace(
        "dt_out = 0.1\n", f"dt_out = 0.1\n{case_extra}\n"
    )
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- TOML size and shape, every file


@pytest.mark.parametrize(
    "text, words",
    [
        ("a = " + "[" * 3000 + "]" * 3000, f"nested deeper than the bound of {MAX_DEPTH} levels"),
        ("a = " + "{b = " * 3000 + "1" + "}" * 3000, f"nested deeper than the bound of {MAX_DEPTH} levels"),
        ("a" + ".a" * 60 + " = 1", f"levels deep, above the bound of {MAX_DEPTH}"),
        ("[" + ".".join(["t"] * 60) + "]\nk = 1", f"levels deep, above the bound of {MAX_DEPTH}"),
        ("a = [" + ", ".join(["1"] * (MAX_ITEMS + 1)) + "]", f"a has {MAX_ITEMS + 1} items, above the bound"),
        ("\n".join(f"k{i} = 1" for i in range(MAX_ITEMS + 1)), f"{MAX_ITEMS + 1} keys, above the bound"),
    ],
    ids=["deep-lists", "deep-inline-tables", "deep-dotted-key", "deep-table-header", "long-list", "many-keys"],
)
def test_k4_a_toml_file_too_deep_or_too_long_is_one_line_naming_the_file(tmp_path, text, words):
    path = tmp_path / "x.toml"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        read_toml(path)
    assert "x.toml" in str(exc.value) and words in str(exc.value)


@pytest.mark.parametrize("command", ["plan", "trim", "campaign"])
def test_k4_a_deep_file_is_refused_by_every_command_without_a_traceback(tmp_path, capsys, command):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 5000 + "]" * 5000)
    argv = {
        "plan": ["plan", str(path), "--out", str(tmp_path / "out")],
        "trim": ["trim", str(path), "--speed", "100"],
        "campaign": ["campaign", "run", str(path), "--out", str(tmp_path / "out")],
    }[command]
    err = _one_line_exit_2(argv, capsys)
    assert "deep.toml" in err and "nested deeper than the bound" in err and "Recursion" not in err
    assert not (tmp_path / "out").exists()


def test_k4_an_input_file_above_the_size_bound_is_refused_before_reading(tmp_path):
    path = tmp_path / "big.toml"
    with open(path, "wb") as fh:
        fh.truncate(MAX_FILE_BYTES + 1)  # sparse: nothing to write
    with pytest.raises(InputError, match=rf"{MAX_FILE_BYTES + 1} bytes, above the bound of {MAX_FILE_BYTES}"):
        read_toml(path)


# --------------------------------------------------------------------------- lists of scenario and aircraft files


def test_k4_report_times_beyond_their_bound_are_refused_with_the_count(tmp_path):
    text = SCENARIO.read_text()
    times = ", ".join("0.0" for _ in range(MAX_REPORT_TIMES + 1))
    path = tmp_path / "roll.toml"
    path.write_text(text.replace("times = [-1.9]", f"times = [{times}]"))
    with pytest.raises(
        InputError, match=rf"times has {MAX_REPORT_TIMES + 1} items, above the bound of {MAX_REPORT_TIMES}"
    ):
        load_scenario(path)
    many = ", ".join("0.0" for _ in range(200_000))  # the attack's 200,000 times: the file's own bound first
    path.write_text(text.replace("times = [-1.9]", f"times = [{many}]"))
    with pytest.raises(InputError, match=r"report.times has 200000 items, above the bound of 10000"):
        load_scenario(path)


def test_k4_an_aero_table_beyond_its_bound_is_refused(tmp_path):
    from gna.aero import MAX_TERMS

    extra = "".join(
        f'  {{ coef = "CD", monomial = "alpha^{1 + i % 12}*beta^{1 + (i // 12) % 12}*phat^{1 + i // 144}", value = 0.0 }},\n'
        for i in range(MAX_TERMS)
    )
    path = tmp_path / "f16c.toml"
    path.write_text(AIRCRAFT.read_text().replace("terms = [\n", "terms = [\n" + extra, 1))
    with pytest.raises(InputError, match=rf"terms has \d+ items, above the bound of {MAX_TERMS}"):
        load_aircraft(path)


# --------------------------------------------------------------------------- campaign files and flags


def test_k4_campaign_expansions_and_dispersion_sets_are_bounded_before_any_check(tmp_path):
    path = _tiny_campaign(tmp_path)
    loops = ", ".join(['"closed"'] * (MAX_CASE_SPECS + 1))
    text = path.read_text().replace('loop = "closed"', f"loop = [{loops}]")
    path.write_text(text)
    with pytest.raises(
        InputError, match=rf"expand to {MAX_CASE_SPECS + 1} cases .*above the bound of {MAX_CASE_SPECS}"
    ):
        load_campaign(path)
    path = _tiny_campaign(tmp_path)
    sets = "".join(f'\n[dispersions.d{i}]\naero = "none"\n' for i in range(MAX_DISPERSIONS + 1))
    path.write_text(path.read_text() + sets)
    with pytest.raises(
        InputError, match=rf"{MAX_DISPERSIONS + 2} dispersion sets, above the bound of {MAX_DISPERSIONS}"
    ):
        load_campaign(path)


@pytest.mark.parametrize(
    "case_extra, words",
    [("jsbsim_dt = 1e-7", "jsbsim_dt 1e-07 s"), ("dt_out = 1e-9", "dt_out 1e-09 s")],
)
def test_k4_a_campaign_case_too_long_to_fly_is_refused_when_the_file_is_read(tmp_path, case_extra, words):
    path = _tiny_campaign(tmp_path, case_extra=case_extra)
    if case_extra.startswith("dt_out"):
        path.write_text(path.read_text().replace("dt_out = 0.1\n", "", 1))
    with pytest.raises(InputError) as exc:
        load_campaign(path)
    assert words in str(exc.value) and "above the bound 1e+07" in str(exc.value) and "(case level)" in str(exc.value)


def _refused(argv, capsys) -> str:
    """The last line of stderr of a command line refused with exit 2 (a usage error or an InputError)."""
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    return err.splitlines()[-1]


@pytest.mark.parametrize(
    "argv, words",
    [
        (["campaign", "run", "paper-dispersions", "--workers", "10000"], "--workers: 10000: above the bound of {w}"),
        (["paper", "--jobs", "5000"], "--jobs: 5000: above the bound of {w} worker processes"),
        (["campaign", "run", "paper-dispersions", "--dask", "local:10000"], "N = 10000: above the bound of {w}"),
        (["fit", "gtm", "--samples", "1000000000"], "--samples: 1000000000 is above the bound of 200000"),
        (["fit", "gtm", "--test", "99999999999"], "--test: 99999999999 is above the bound of 200000"),
        (["campaign", "run", "paper-dispersions", "--case-budget", "0"], "--case-budget: must be positive"),
    ],
)
def test_k4_counts_set_by_flags_are_bounded_before_any_work(argv, words, tmp_path, capsys):
    out = tmp_path / "out"
    line = _refused([*argv, "--out", str(out)], capsys)
    assert words.format(w=max_workers()) in line
    assert not out.exists()


def test_k4_the_worker_bound_is_a_multiple_of_the_cpus():
    from harness.parallel import WORKERS_PER_CPU, default_jobs

    assert max_workers() == WORKERS_PER_CPU * default_jobs() >= WORKERS_PER_CPU


# --------------------------------------------------------------------------- the per-case time budget


def test_k4_time_budget_stops_a_busy_loop_and_is_silent_when_met():
    give_up = time.monotonic() + 600.0  # a safety bound only: the budget's timer is what ends this loop
    with pytest.raises(CaseTimeout):
        with time_budget(0.05):
            while time.monotonic() < give_up:
                pass
    with time_budget(float("inf")):
        pass
    with time_budget(3600.0):  # met: the timer is cancelled on leaving
        total = sum(range(1000))
    assert total == 499500


def test_k4_a_case_past_its_budget_ends_as_a_timeout_and_the_campaign_goes_on(tmp_path, capsys):
    camp = load_campaign(_tiny_campaign(tmp_path, extra="case_budget_s = 1e-3"))
    assert camp.case_budget_s == 1e-3
    task = camp.tasks()[0]
    assert task.budget_s == 1e-3
    out = run_sample(task)  # planning alone takes longer than a millisecond
    assert out["status"] == "failed" and out["metrics"] is None and out["files"] == {}
    assert out["error"].startswith("timeout: the case ran ") and "over its budget of 0.001 s" in out["error"]
    folder = tmp_path / "camp"
    argv = ["campaign", "run", str(tmp_path / "tiny.toml"), "--out", str(folder), "--workers", "1", "--quiet"]
    assert main(argv) == 1  # every case ran to its end, none is pending, but a timeout leaves no result
    assert "3 of 3 case(s) failed (an error or a timeout: no result)" in capsys.readouterr().err
    st = CampaignStore(folder)
    try:
        rows = st.rows()
    finally:
        st.close()
    assert len(rows) == 3 and all(r["status"] == "failed" and r["error"].startswith("timeout:") for r in rows)
    capsys.readouterr()
    assert main([*argv, "--retry-failed", "--case-budget", "inf"]) == 0  # the flag overrides the file
    assert "3 computed" in capsys.readouterr().err
    st = CampaignStore(folder)
    try:
        assert [r["status"] for r in st.rows()] == ["done"] * 3
    finally:
        st.close()
    assert json.loads(json.dumps(camp.tasks()[0].parameters())) == camp.tasks()[0].parameters()


# --------------------------------------------------------------------------- messages never end in an empty clause


def test_messages_built_from_an_exception_never_end_empty(tmp_path, capsys, monkeypatch):
    from gna.errors import GflatError, InputError, describe

    assert str(InputError("")) == "InputError (without a message)"
    assert describe(OSError()) == "OSError (without a message)"
    try:
        try:
            raise ValueError("the real cause")
        except ValueError as inner:
            raise OSError() from inner
    except OSError as exc:
        assert describe(exc) == "OSError (ValueError: the real cause)"
    assert describe(OSError(28, "No space left on device")) == "No space left on device"

    def empty_oserror(args):
        raise OSError()

    from harness.cli import build_parser

    parser = build_parser()  # a command whose work raises an OSError without a message
    args = parser.parse_args(["trim", "f16c", "--speed", "150"])
    args.func = empty_oserror
    monkeypatch.setattr(type(parser), "parse_args", lambda self, argv=None: args)
    assert main(["trim", "f16c", "--speed", "150"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "gflat trim: error: cannot write the output: OSError (without a message)"
    assert not err.endswith(": ") and issubclass(InputError, GflatError)


# --- fourth round (docs/hardening.md): home folders that cannot be expanded, a closed standard output ----------


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "x.toml", "--out", "~nosuchuser-gflat/x"],
        ["fit", "gtm", "--out", "~nosuchuser-gflat/a.toml"],
        ["report", "~nosuchuser-gflat/run"],
        ["fit", "jsbsim", "~nosuchuser-gflat/F4N/F4N.xml"],
    ],
)
def test_an_unknown_users_home_is_one_line(argv, capsys):
    try:
        rc = main(argv)
    except SystemExit as stop:  # an option's error
        rc = stop.code
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "\n" not in err and "Traceback" not in err
    assert "cannot expand '~nosuchuser-gflat': no such user" in err


def test_an_empty_home_never_makes_a_path_of_the_root(monkeypatch, capsys):
    monkeypatch.setenv("HOME", "")
    with pytest.raises(SystemExit) as stop:
        main(["plan", "x.toml", "--out", "~/x"])
    assert stop.value.code == 2
    assert "cannot expand '~': HOME is set but empty" in capsys.readouterr().err


def test_a_closed_standard_output_is_an_error_not_a_silent_success():
    proc = subprocess.run(
        [sys.executable, "-m", "gflat", "aircraft"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1])),
        preexec_fn=lambda: os.close(1),
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "gflat: error: the standard output is closed, so nothing gflat prints could be read: run it with an open "
        "one (> FILE, or > /dev/null to discard it)"
    )
