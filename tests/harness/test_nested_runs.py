"""No command writes a new run inside another run's folder (complete, interrupted, or being written)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from harness.cli import main
from harness.outdir import OutputDir

from .test_outguard import _files, _holder, _run

ROOT = Path(__file__).resolve().parents[2]

#: Every command taking an output folder (``--out``), with what it needs besides.
COMMANDS = {
    "plan": ["plan", "gtm-aileron-roll"],
    "compare": ["compare", "gtm-aileron-roll", "--J", "1"],
    "paper": ["paper"],
    "export-jsbsim-script": ["export-jsbsim-script", "gtm-aileron-roll"],
    "export-jsbsim": ["export-jsbsim", "gtm"],
    "campaign": ["campaign", "run", "paper-dispersions", "--samples", "1"],
}


@pytest.mark.parametrize("finish", [True, False])
@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_folder_inside_a_run_is_refused(tmp_path, capsys, name, finish):
    run = tmp_path / "C25"
    _run(run, "paper", names=("index.html", "s/open/report.json"), finish=finish)
    before = _files(tmp_path)
    for target in (run / "s" / "open", run / "s" / "new", run / "sub" / "deeper"):
        assert main([*COMMANDS[name], "--out", str(target)]) == 2
        err = capsys.readouterr().err
        what = "a complete run" if finish else "an interrupted (or running) run"
        assert err.count("\n") == 1, err
        assert f"output folder {target} lies inside {run}, the folder of {what} of 'gflat paper'" in err
        assert _files(tmp_path) == before and sorted(p.name for p in tmp_path.iterdir()) == ["C25"]
        assert not (run / "sub").exists() and not (run / "s" / "new").exists()


def test_a_folder_inside_a_run_being_written_is_refused(tmp_path):
    """``gflat compare --out LP2/case/open`` while ``gflat paper --out LP2`` runs (before its first file, too)."""
    run = tmp_path / "LP2"
    proc = _holder(run)
    try:
        (run / ".gflat-incomplete").unlink()  # only the lock tells: as before the first file
        out = subprocess.run(
            [sys.executable, "-m", "harness.cli", *COMMANDS["compare"], "--out", str(run / "case" / "open")],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert out.returncode == 2, out.stderr
        assert out.stderr.count("\n") == 1
        assert f"lies inside {run}, the folder of a gflat run writing it now" in out.stderr
        assert not (run / "case").exists()
    finally:
        proc.communicate("\n", timeout=60)


def test_a_run_writes_its_own_sub_folders_and_beside_other_runs(tmp_path):
    out = OutputDir(tmp_path / "run", command="paper")
    out.sub("case", "open").write_text("a.txt", text="a")  # its own case folder: not a new run
    out.finish()
    OutputDir(tmp_path / "other", command="compare").finish()  # a sibling of a run is fine
    OutputDir(tmp_path / "run", command="paper").finish()  # the run's own folder again


def test_the_default_folders_of_plan_and_compare_sit_side_by_side(tmp_path, monkeypatch):
    """`gflat plan X` and `gflat compare X` with their default folders: neither lies inside the other's run."""
    monkeypatch.chdir(tmp_path)
    assert main(["plan", "gtm-aileron-roll", "--J", "1"]) == 0
    assert main(["compare", "gtm-aileron-roll", "--loop", "open", "--J", "1"]) == 0
    assert main(["plan", "gtm-aileron-roll", "--J", "1"]) == 0  # and again, after the comparison
    root = tmp_path / "reports" / "out" / "gtm-aileron-roll"
    assert sorted(p.name for p in root.iterdir()) == ["open", "plan"]
    assert (root / "plan" / ".gflat-complete.json").is_file() and (root / "open" / ".gflat-complete.json").is_file()
