"""One output convention: ``--json`` on every command, validated against its schema; help texts; default folders.

The parser tree is walked, so that a new command without ``--json``, a schema, a description or examples
fails here.  Every command then runs once with ``--json`` on cheap arguments (a 4 s scenario, a tiny
campaign, a small fit), from a current folder of its own, and its stdout is checked to be exactly one JSON
object valid against the command's schema.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
from importlib import resources
from pathlib import Path

import jsonschema
import pytest

from harness.cli import build_parser, main
from harness.commands import _json

from .test_validation import SHORT

ROOT = Path(__file__).resolve().parents[2]
TINY = Path(__file__).parent / "campaign" / "tiny.toml"
LINEAR_CSV = str(resources.files("gna") / "data" / "sources" / "twin_otter" / "aircraft_dat_clean.csv")


def _parsers(parser: argparse.ArgumentParser, words=()):
    """(words, parser, leaf) of every command and sub-command."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, p in action.choices.items():
                subs = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
                yield (*words, name), p, not subs
                yield from _parsers(p, (*words, name))


COMMANDS = {" ".join(w): (p, leaf) for w, p, leaf in _parsers(build_parser())}
LEAVES = sorted(name for name, (_, leaf) in COMMANDS.items() if leaf)


def _validate(obj: dict, name: str) -> None:
    jsonschema.validate(obj, _json.schema(name), cls=jsonschema.Draft202012Validator)


# --- the parser tree ----------------------------------------------------------------------------------


def test_every_command_takes_json_and_names_a_schema():
    assert {"plan", "paper", "report", "campaign run", "campaign report", "fit jsbsim"} <= set(LEAVES)
    for name in LEAVES:
        p, _ = COMMANDS[name]
        assert "--json" in p._option_string_actions, f"gflat {name} has no --json"
        schema = p.get_default("json_schema")
        assert schema and (_json.SCHEMAS / f"{schema}.json").is_file(), f"gflat {name}: no output schema"


def test_the_schemas_are_valid_and_each_is_used():
    used = {COMMANDS[n][0].get_default("json_schema") for n in LEAVES} | {_json.ERROR_SCHEMA}
    files = {p.stem for p in _json.SCHEMAS.glob("*.json")}
    assert files == used
    for name in files:
        s = _json.schema(name)
        jsonschema.Draft202012Validator.check_schema(s)
        assert s["type"] == "object" and s["additionalProperties"] is False, name
        assert all(p.get("description") for p in s["properties"].values()), f"{name}: a key without a meaning"


def test_docs_cli_lists_the_keys_of_every_schema():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_schemas", ROOT / "scripts" / "make_schemas.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = mod.CLI_DOC.read_text(encoding="utf-8")
    assert text == mod.cli_page(text, mod.output_schemas()), "docs/cli.md is stale: run python scripts/make_schemas.py"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_help_has_a_description_and_examples_in_plain_text(name):
    p, _ = COMMANDS[name]
    text = p.format_help()
    assert p.description and len(p.description) > 40, f"gflat {name} --help has no description"
    assert "\nexamples:\n  gflat " in text, f"gflat {name} --help has no example"
    assert "``" not in text and ":func:" not in text and ":class:" not in text, f"gflat {name} --help shows reST"


def test_help_texts_say_what_the_commands_do():
    compare = COMMANDS["compare"][0]
    assert "--loop closed" in compare.description and "open loop" not in compare.format_usage()
    from harness.cli import COMMANDS as TABLE

    assert "open or closed loop" in TABLE["compare"][1]
    script = COMMANDS["export-jsbsim-script"][0].description
    assert "JSBSim --root" not in script and "jsbsim --root" in script


# --- every command run with --json ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """A current folder for the runs, holding the short scenario."""
    d = tmp_path_factory.mktemp("json")
    (d / "short.toml").write_text(SHORT)
    return d


def _run(words, capsys, where: Path) -> tuple[int, dict, str]:
    """``gflat WORDS`` run in-process from ``where``: exit status, the one JSON object on stdout, stderr."""
    capsys.readouterr()
    old = os.getcwd()
    os.chdir(where)
    try:
        rc = main(list(map(str, words)))
    finally:
        os.chdir(old)
    out = capsys.readouterr()
    try:
        obj = json.loads(out.out)
    except json.JSONDecodeError as exc:
        raise AssertionError(
            f"gflat {' '.join(map(str, words))}: stdout is not one JSON object:\n{out.out[:2000]}"
        ) from exc
    assert isinstance(obj, dict)
    return rc, obj, out.err


@pytest.fixture(scope="module")
def paper_folder(work):
    """A paper run of the short scenario, open loop (what test_validation's paper tests do not cover: --loop
    open, its files and text), for ``gflat paper`` and ``gflat report``."""
    from harness.commands import paper

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(paper, "PAPER_SCENARIOS", (str(work / "short.toml"),))
        mp.chdir(work)
        import contextlib
        import io

        buf, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
            rc = main(["paper", "--loop", "open", "--jobs", "1", "--out", "paper", "--json"])
    assert rc == 0, err.getvalue()[-2000:]
    return work / "paper", json.loads(buf.getvalue()), err.getvalue()


@pytest.fixture(scope="module")
def campaign_folder(work):
    import contextlib
    import io

    buf, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        rc = main(
            ["campaign", "run", str(TINY), "--out", str(work / "camp"), "--samples", "1", "--workers", "1"]
            + ["--quiet", "--json"]
        )
    assert rc == 0, err.getvalue()[-2000:]
    return work / "camp", json.loads(buf.getvalue())


def _quick_regenerate(monkeypatch):
    import gna.fit.regenerate

    def quick(out_dir=None, ids=None, check=False, today=None, committed_dir=None, write=None):
        write(Path(out_dir) / "gtm.toml", "x = 1\n")
        return {"gtm": []}

    monkeypatch.setattr(gna.fit.regenerate, "regenerate", quick)


#: command -> its words after gflat (without --json); {w}: the current folder of the runs.
RUNS = {
    "aircraft": ["aircraft"],
    "trim": ["trim", "f16c", "--speed", "152.4", "--altitude", "3048"],
    "plan": ["plan", "short.toml", "--out", "{w}/plan", "--csv"],
    "compare": ["compare", "short.toml", "--out", "{w}/compare", "--dt-out", "0.1"],
    "export-jsbsim": ["export-jsbsim", "a7", "--out", "{w}/xml"],
    "export-jsbsim-script": ["export-jsbsim-script", "short.toml", "--out", "{w}/script", "--table-dt", "0.5"],
    "fit jsbsim": ["fit", "jsbsim", "c172x", "--samples", "200", "--test", "50", "--no-trim-check"]
    + ["--out", "{w}/c172x.toml"],
    "fit gtm": ["fit", "gtm", "--samples", "300", "--test", "100", "--out", "{w}/gtm-fit.toml"],
    "fit linear": ["fit", "linear", LINEAR_CSV, "--speed", "72", "--engines", "2", "--engine-offset", "2.8"]
    + ["--samples", "300", "--test", "100", "--no-trim-check", "--out", "{w}/to.toml"],
    "fit compare": ["fit", "compare", "gtm", "--speed", "40"],
    "fit regenerate": ["fit", "regenerate", "gtm", "--out", "{w}/fits"],
}


@pytest.mark.parametrize("name", LEAVES)
def test_every_command_prints_one_json_object_valid_against_its_schema(
    name, work, paper_folder, campaign_folder, capsys, monkeypatch
):
    schema = COMMANDS[name][0].get_default("json_schema")
    if name == "paper":
        folder, obj, err = paper_folder
        assert obj["pass"] and [c["loop"] for c in obj["cases"]] == ["open"]
        assert "in-house vs JSBSim (open loop" in err and "closed loop with the tracking feedback" not in err
        assert (folder / "short" / "open" / "summary.json").is_file() and not (folder / "short" / "closed").exists()
        plan = json.loads((folder / "short" / "plan" / "summary.json").read_text())["files"]
        assert (
            sorted(f for f in os.listdir(folder / "short" / "plan") if f.startswith("plan-j"))
            == sorted(v for k, v in plan.items() if k.startswith("plan-j"))
            == ["plan-j0.parquet", "plan-j1.parquet", "plan-j2.parquet"]
        )  # one naming, no CSV without --csv
        assert Path(obj["report"]["pdf"]).is_file() and obj["execution"]["cpu_s"]["total"] > 0
    elif name == "report":
        rc, obj, _ = _run(["report", paper_folder[0], "--no-pdf", "--json"], capsys, work)
        assert rc == 0 and obj["pdf"] is None and Path(obj["index"]).is_file() and len(obj["pages"]) == 1
    elif name == "campaign run":
        obj = campaign_folder[1]
        assert obj["pending"] == 0 and obj["computed"] == obj["cases"] and obj["reruns"] == []
        _validate(obj, schema)
        words = ["campaign", "run", TINY, "--out", campaign_folder[0], "--samples", "1", "--only", "level.fit.0000"]
        rc, obj, _ = _run([*words, "--quiet", "--json"], capsys, work)  # a done case computed again, compared
        assert rc == 0 and [r["case_id"] for r in obj["reruns"]] == ["level.fit.0000"] and obj["computed"] == 0
        assert obj["reruns"][0]["same_as_stored"] is True
    elif name.startswith("campaign "):
        extra = ["--no-pdf"] if name.endswith("report") else []
        rc, obj, _ = _run([*name.split(), campaign_folder[0], *extra, "--json"], capsys, work)
        assert rc == 0
    else:
        if name == "fit regenerate":
            _quick_regenerate(monkeypatch)
        words = [w.replace("{w}", str(work)) for w in RUNS[name]]
        rc, obj, err = _run([*words, "--json"], capsys, work)
        assert rc == 0, err[-2000:]
    _validate(obj, schema)
    if name == "compare":  # the manifest names the gflat command that made the run, also run in-process
        manifest = json.loads((Path(obj["out"]) / "manifest.json").read_text())
        assert manifest["command_line"] == ["gflat", *words, "--json"]
    if name == "plan":
        assert obj["feasible"] and {"plan-j0", "plan-j2", "plan-j2.csv", "singularities"} <= set(obj["files"])
        assert obj["files"]["plan-j2"] == "plan-j2.parquet"


def test_the_contract_keys_stay(work, capsys):
    """The keys of plan, compare and trim --json before every command had --json are still there."""
    rc, obj, _ = _run(["trim", "f16c", "--speed", "10", "--altitude", "1000", "--json"], capsys, work)
    assert rc == 1 and obj["converged"] is False and "did not converge" in obj["message"]
    _validate(obj, "trim")
    trim = _json.schema("trim")["properties"]
    assert {"aircraft", "converged", "values", "residuals", "max_residual"} <= set(trim)
    plan = set(_json.schema("plan")["properties"])
    assert {"planning_time_s", "feasible", "infeasible_reason", "equation_residual_per_iterate", "warnings"} <= plan
    assert {"open_loop_max_position_error_m", "open_loop_message", "J_rule", "orders", "timings_s"} <= plan
    compare = set(_json.schema("compare")["properties"])
    assert {"scenario", "loop", "runs", "differences", "pass", "failures", "verdicts", "settings"} <= compare


def test_an_error_is_one_line_on_stderr_and_one_json_object_on_stdout(work, capsys):
    rc, obj, err = _run(["plan", "barrel-roll", "--json"], capsys, work)
    assert rc == 2 and err.count("\n") == 1 and "unknown scenario 'barrel-roll'" in err
    _validate(obj, "error")
    assert obj == {"command": "plan", "error": err.strip(), "exit_status": 2}
    rc, obj, err = _run(["campaign", "status", str(work), "--json"], capsys, work)
    assert rc == 2 and obj["command"] == "campaign status" and "not a campaign folder" in obj["error"]


# --- printed commands run as printed; default folders under the current one ---------------------------------


def test_the_printed_replay_command_runs_as_printed(work, capsys, tmp_path):
    rc, obj, _ = _run(["export-jsbsim-script", "short.toml", "--out", "script-replay", "--json"], capsys, work)
    assert rc == 0
    words = shlex.split(obj["replay"])
    assert words[0] == "jsbsim" and f"--root={work / 'script-replay'}" in words
    assert f"--outputpath={work}" in words  # the CSV goes to the current folder, not into the run's
    old = os.getcwd()
    os.chdir(work)
    try:
        assert main(["export-jsbsim-script", "short.toml", "--out", "script-replay", "--replace"]) == 0
    finally:
        os.chdir(old)
    assert f"    {obj['replay']}\n" in capsys.readouterr().out  # the text form prints the same line
    exe = shutil.which("jsbsim")
    if exe is None:
        pytest.skip("no jsbsim executable on PATH (the jsbsim package installs one)")
    done = subprocess.run(obj["replay"], shell=True, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    rows = (work / "short.csv").read_text().splitlines()
    assert rows[0].startswith("Time,") and len(rows) == 1 + 160 + 1  # 4 s at 0.025 s, both ends
    assert not (work / "script-replay" / "short.csv").exists()
    (work / "short.csv").unlink()


def test_default_output_folders_are_under_the_current_folder(tmp_path, capsys):
    (tmp_path / "short.toml").write_text(SHORT)
    rc, obj, _ = _run(["plan", "short.toml", "--json"], capsys, tmp_path)
    assert rc == 0 and Path(obj["out"]) == tmp_path / "reports" / "out" / "short" / "plan"
    assert (tmp_path / "reports" / "out" / "short" / "plan" / "plan-j2.parquet").is_file()
    rc, obj, _ = _run(["export-jsbsim", "a7", "--json"], capsys, tmp_path)
    assert rc == 0 and obj["files"] == [str(tmp_path / "aircraft_xml" / "a7" / "a7.xml")]
    assert Path(obj["files"][0]).is_file()
    rc, obj, _ = _run(["export-jsbsim", "a7", "--check", "--json"], capsys, tmp_path)
    assert rc == 0 and obj["current"] and obj["out"] == str(tmp_path / "aircraft_xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["aircraft_xml", "reports", "short.toml"]


def test_fit_regenerate_refuses_to_write_into_an_installed_package(monkeypatch, capsys, tmp_path):
    from harness.commands import fit

    monkeypatch.setattr(fit, "_source_checkout", lambda: False)
    rc, obj, err = _run(["fit", "regenerate", "gtm", "--json"], capsys, tmp_path)
    assert rc == 2 and "installed package: give --out DIR" in obj["error"] and not list(tmp_path.iterdir())


def test_text_written_below_python_cannot_reach_the_json_on_stdout():
    """A library printing from C (JSBSim does, from C++) writes to file descriptor 1: with --json it lands on
    stderr, and stdout is still the one object."""
    import sys

    code = (
        "import os, sys\n"
        "from harness import cli\n"
        "from harness.commands import aircraft\n"
        "real = aircraft.run\n"
        "aircraft.run = lambda args: (os.write(1, b'from C\\n'), print('from Python'), real(args))[2]\n"
        "sys.exit(cli.main(['aircraft', 'f16c', '--json']))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    _validate(json.loads(done.stdout), "aircraft")
    assert "from C" in done.stderr and "from Python" in done.stderr
