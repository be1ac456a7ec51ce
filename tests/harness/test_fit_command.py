"""``gflat fit ... --out FILE``: the output file is checked before the source is read and fitted."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from harness.cli import main

#: Why /proc takes no file (the OS answers "No such file or directory" for a folder that exists).
_PROC = "/proc exists, but its file system creates no new files or folders there"


@pytest.fixture
def no_fit(monkeypatch):
    """Reading a source or fitting fails the test: the checks come first."""
    import gna.fit.pipeline
    import gna.fit.sources.gtm
    import gna.fit.sources.jsbsim_aero

    def fail(*args, **kwargs):
        pytest.fail("the source was read before --out was checked")

    monkeypatch.setattr(gna.fit.sources.gtm, "GTMSource", fail)
    monkeypatch.setattr(gna.fit.sources.jsbsim_aero, "JSBSimAeroSource", fail)
    monkeypatch.setattr(gna.fit.pipeline, "fit_source", fail)


def _one_line(capsys, rc) -> str:
    assert rc == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


def test_an_output_file_that_cannot_be_written_is_refused_before_fitting(tmp_path, no_fit, capsys):
    (tmp_path / "a-file").write_text("")
    cases = {
        tmp_path / "missing" / "x.toml": f"No such file or directory: its folder {tmp_path / 'missing'} does not exist",
        tmp_path / "a-file" / "x.toml": "Not a directory",
        Path("/proc/gflat-fit.toml"): _PROC,
    }  # a folder that takes no files
    for out, cause in cases.items():
        err = _one_line(capsys, main(["fit", "gtm", "--out", str(out)]))
        assert err == f"gflat fit: error: cannot write {out}: {cause}\n"
    err = _one_line(
        capsys,
        main(
            [
                "fit",
                "jsbsim",
                "F4N",
                "--mach",
                "0.5",
                "--altitude",
                "3000",
                "--out",
                str(tmp_path / "missing" / "f4n.toml"),
            ]
        ),
    )
    assert "cannot write" in err
    assert list(tmp_path.iterdir()) == [tmp_path / "a-file"]  # no probe file left behind


def test_a_folder_given_as_the_file_is_refused_before_fitting(tmp_path, monkeypatch, no_fit, capsys):
    err = _one_line(capsys, main(["fit", "gtm", "--out", str(tmp_path)]))
    assert err == (
        f"gflat fit: error: --out {tmp_path}: a folder; give the aircraft file's name "
        f"(e.g. {tmp_path / 'gtm-fit.toml'})\n"
    )
    err = _one_line(
        capsys,
        main(["fit", "jsbsim", "aircraft/F4N/F4N.xml", "--mach", "0.5", "--altitude", "0", "--out", str(tmp_path)]),
    )
    assert f"(e.g. {tmp_path / 'f4n.toml'})" in err  # the default id, as the source names it
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gtm-fit.toml").mkdir()
    err = _one_line(capsys, main(["fit", "gtm"]))  # the default file, in the current folder
    assert err.startswith("gflat fit: error: --out gtm-fit.toml: a folder; give the aircraft file's name")


def test_the_default_file_in_a_folder_that_takes_no_files(monkeypatch, no_fit, capsys):
    monkeypatch.chdir("/proc")
    err = _one_line(capsys, main(["fit", "gtm"]))
    assert err == f"gflat fit: error: cannot write gtm-fit.toml: {_PROC}\n"


def test_the_default_id_is_the_one_the_source_gives():
    from types import SimpleNamespace

    from gna.fit.sources.jsbsim_aero import resolve
    from harness.commands.fit import _default_ident

    for model in ("F4N", "c172x"):
        args = SimpleNamespace(source="jsbsim", model=model)
        assert _default_ident(args) == resolve(model)[0].lower()
    assert _default_ident(SimpleNamespace(source="linear", csv="data/twin_otter.csv")) == "twin_otter"
    assert _default_ident(SimpleNamespace(source="gtm")) == "gtm-fit"


def test_anything_but_a_regular_file_is_refused_and_left_as_it_is(tmp_path, no_fit, capsys):
    # A device (/dev/null), a pipe, a socket, a link to one: the file, written beside and renamed over it, would
    # replace it by a regular file.
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    (tmp_path / "link").symlink_to(fifo)
    for out, what in ((fifo, "a named pipe (fifo)"), (tmp_path / "link", "a symbolic link to a named pipe (fifo)")):
        err = _one_line(capsys, main(["fit", "gtm", "--out", str(out)]))
        assert err == (
            f"gflat fit: error: cannot write {out}: it is {what}, not a regular file (it would be "
            f"replaced by one): give the path of a new or regular file\n"
        )
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and (tmp_path / "link").is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "pipe"]


def test_a_file_into_a_runs_folder_is_refused(tmp_path, no_fit, capsys):
    # runs are never changed once written: fit's file must not go into a run's folder (nor a folder inside it)
    from harness.rundir import RunDir

    with RunDir(tmp_path / "run", command="paper") as out:
        out.write_text("case", "summary.json", text="{}")
        out.commit()
    run = tmp_path / "run"
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    for out in (run / "manifest.json", run / "case" / "x.toml"):
        err = _one_line(capsys, main(["fit", "gtm", "--out", str(out)]))
        assert err == (
            f"gflat fit: error: cannot write {out}: {run} is the folder of a gflat run, never changed once "
            f"written: give a path outside it\n"
        )
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


def test_an_empty_out_asks_for_a_file(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fit", "gtm", "--out", ""])
    assert exc.value.code == 2
    assert (
        "argument --out: an empty path; give the aircraft file's name, or leave --out out for the default "
        "<id>.toml" in capsys.readouterr().err
    )


def test_a_folder_that_exists_but_takes_no_files_is_named_so_by_every_command(capsys):
    # /proc exists: "No such file or directory" (the OS's answer to a create there) would be untrue.
    assert main(["paper", "--out", "/proc/gflat-x"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"gflat paper: error: output folder /proc/gflat-x: cannot write in /proc: {_PROC}"
    )
    assert main(["report", "/proc"]) == 2
    assert capsys.readouterr().err.strip() == (
        "gflat report: error: /proc is not the folder of a gflat run: no manifest.json there or in any folder "
        "above it; give the folder of a gflat paper or gflat compare run"
    )
