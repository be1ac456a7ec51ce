"""Progress of the long commands (:mod:`harness.progress`): plain lines in order, none with -q, rich's live
lines on a terminal (a pseudo-terminal), stages reported from forked workers."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from harness.cli import main, progress_command
from harness.parallel import ForkPool, run_all
from harness.progress import Progress, choose_mode, seconds_text

ROOT = Path(__file__).resolve().parents[2]

#: A plain progress line: the wall clock, the seconds since the start, the command, the stage and its duration.
LINE = re.compile(r"^\[\d\d:\d\d:\d\d \+\d+\.\d s\] gflat (?P<cmd>[a-z ]+): (?P<text>.*)$")


def _stages(text: str, cmd: str) -> list[str]:
    out = []
    for line in text.splitlines():
        m = LINE.match(line)
        if m and m["cmd"] == cmd:
            out.append(m["text"])
    return out


def test_plain_lines_in_order_with_their_stage_and_elapsed_figure():
    buf = io.StringIO()
    ticks = iter(float(k) for k in range(100))
    with Progress("paper", mode="plain", stream=buf, clock=lambda: next(ticks)) as p:
        with p.stage("planning a"):
            pass
        token = p.begin("flying a (open loop, inhouse)")
        p.done("drawing states.png of a", 0.25)  # a worker's stage, finished elsewhere
        p.end(token, seconds=12.5)
        with pytest.raises(RuntimeError), p.stage("failing"):
            raise RuntimeError("no line for a stage that raised")
    lines = buf.getvalue().splitlines()
    assert all(LINE.match(line) for line in lines), lines
    assert _stages(buf.getvalue(), "paper") == [
        "started",
        "planning a done in 1.00 s",
        "drawing states.png of a done in 0.25 s",
        "flying a (open loop, inhouse) done in 12.5 s",
    ]
    elapsed = [float(re.search(r"\+(\d+\.\d) s\]", line)[1]) for line in lines]
    assert elapsed == sorted(elapsed) and elapsed[0] < elapsed[-1]  # the fake clock's seconds since the start
    assert p.lines == _stages(buf.getvalue(), "paper")[1:]


def test_counted_stage_a_line_per_step():
    buf = io.StringIO()
    with Progress("campaign run", mode="plain", stream=buf) as p:
        token = p.begin("campaign tiny: cases", total=2)
        p.advance(token, "a done")
        p.advance(token, "b failed")
        p.end(token)
    assert _stages(buf.getvalue(), "campaign run")[1:3] == [
        "campaign tiny: cases 1/2: a done",
        "campaign tiny: cases 2/2: b failed",
    ]
    assert _stages(buf.getvalue(), "campaign run")[3].startswith("campaign tiny: cases done in ")


def test_mode_choice():
    assert choose_mode(io.StringIO(), environ={}) == "plain"
    assert choose_mode(io.StringIO(), quiet=True, environ={"GFLAT_PROGRESS": "live"}) == "off"
    assert choose_mode(io.StringIO(), environ={"GFLAT_PROGRESS": "off"}) == "off"
    assert choose_mode(io.StringIO(), environ={"GFLAT_PROGRESS": "nonsense"}) == "plain"
    assert seconds_text(0.123) == "0.12 s" and seconds_text(42.0) == "42.0 s" and seconds_text(125) == "2 min 05 s"


def test_which_commands_show_progress():
    assert progress_command(["paper", "--loop", "open"]) == "paper"
    assert progress_command(["-v", "fit", "jsbsim", "f16"]) == "fit jsbsim"
    assert progress_command(["campaign", "run", "x", "--out", "y"]) == "campaign run"
    for words in (["trim", "f16c"], ["fit", "compare", "gtm"], ["campaign", "status", "d"], ["paper", "-q"]):
        assert progress_command(words) is None, words
    assert progress_command(["paper", "--help"]) is None and progress_command(["--quiet", "report", "d"]) is None


def test_a_pools_stages_and_its_workers_reach_the_parent_in_order():
    buf = io.StringIO()

    def task(k):
        def fn():
            with worker_progress.stage(f"figure {k}"):
                pass
            return k

        return fn

    with Progress("paper", mode="plain", stream=buf) as worker_progress:
        assert run_all([task(0), task(1)], 2, "writing", progress=worker_progress) == [0, 1]
    stages = _stages(buf.getvalue(), "paper")[1:]
    for k in (0, 1):  # each worker's own stage arrives before the pool's line of that worker
        mine = [s for s in stages if s.startswith(f"figure {k} ") or s.startswith(f"writing ({k + 1} of 2)")]
        assert [s.split(" done in ")[0] for s in mine] == [f"figure {k}", f"writing ({k + 1} of 2)"], stages
    with Progress("paper", mode="plain", stream=io.StringIO()) as p, ForkPool(1, progress=p) as pool:  # in process
        pool.submit("a", lambda: 1, what="alone")
        assert pool.next_result() == ("a", 1)
    assert [s.split(" done in ")[0] for s in p.lines] == ["alone"]


def test_the_command_line_plain_lines_and_none_with_q(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("GFLAT_PROGRESS", "plain")
    missing = str(tmp_path / "none")
    assert main(["report", missing]) == 2
    err = capsys.readouterr().err
    assert _stages(err, "report") == ["started", _stages(err, "report")[1]]
    assert _stages(err, "report")[1].startswith("loading the command's modules done in ")
    assert err.splitlines()[-1].startswith("gflat report: error: ")
    for quiet in (["-q"], ["--quiet"]):
        assert main(["report", missing, *quiet]) == 2
        err = capsys.readouterr().err
        assert not _stages(err, "report") and err.startswith("gflat report: error: "), err
    assert main(["trim", "no-such-aircraft", "--speed", "50"]) == 2  # not a long command: no progress
    assert not _stages(capsys.readouterr().err, "trim")


@pytest.mark.skipif(sys.platform == "win32", reason="no pseudo-terminals")
def test_on_a_terminal_rich_draws_a_live_line(tmp_path):
    import pty

    script = textwrap.dedent(
        """
        import sys
        from harness.progress import Progress
        with Progress("demo", mode="auto") as p:
            with p.stage("flying the demo"):
                print("a line the command prints")
        print("after", p.mode)
        """
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT), TERM="xterm", COLUMNS="100")
    env.pop("GFLAT_PROGRESS", None)
    leader, follower = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-c", script], stdin=follower, stdout=follower, stderr=follower, env=env, cwd=ROOT
    )
    os.close(follower)
    out = b""
    while True:  # read until the child closes the terminal
        try:
            chunk = os.read(leader, 4096)
        except OSError:
            break
        if not chunk:
            break
        out += chunk
    os.close(leader)
    assert proc.wait() == 0
    text = out.decode("utf-8", "replace")
    assert "\x1b[?25l" in text  # rich hides the cursor while it draws the live lines
    assert "gflat demo" in text  # the command's own live line
    assert "flying the demo done in" in text and "a line the command prints" in text
    assert "after live" in text
