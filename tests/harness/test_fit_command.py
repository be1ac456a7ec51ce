"""``gflat fit ... --out FILE``: the output file is checked before the source is read and fitted."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.cli import main


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
    cases = {tmp_path / "missing" / "x.toml": "No such file or directory",
             tmp_path / "a-file" / "x.toml": "Not a directory",
             Path("/proc/gflat-fit.toml"): "No such file or directory"}      # a folder that takes no files
    for out, cause in cases.items():
        err = _one_line(capsys, main(["fit", "gtm", "--out", str(out)]))
        assert err == f"gflat fit: error: cannot write {out}: {cause}\n"
    err = _one_line(capsys, main(["fit", "jsbsim", "F4N", "--mach", "0.5", "--altitude", "3000", "--out",
                                  str(tmp_path / "missing" / "f4n.toml")]))
    assert "cannot write" in err
    assert list(tmp_path.iterdir()) == [tmp_path / "a-file"]          # no probe file left behind


def test_a_folder_given_as_the_file_is_refused_before_fitting(tmp_path, monkeypatch, no_fit, capsys):
    err = _one_line(capsys, main(["fit", "gtm", "--out", str(tmp_path)]))
    assert err == (f"gflat fit: error: --out {tmp_path}: a folder; give the aircraft file's name "
                   f"(e.g. {tmp_path / 'gtm-fit.toml'})\n")
    err = _one_line(capsys, main(["fit", "jsbsim", "aircraft/F4N/F4N.xml", "--mach", "0.5", "--altitude", "0",
                                  "--out", str(tmp_path)]))
    assert f"(e.g. {tmp_path / 'f4n.toml'})" in err                    # the default id, as the source names it
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gtm-fit.toml").mkdir()
    err = _one_line(capsys, main(["fit", "gtm"]))                       # the default file, in the current folder
    assert err.startswith("gflat fit: error: --out gtm-fit.toml: a folder; give the aircraft file's name")


def test_the_default_file_in_a_folder_that_takes_no_files(monkeypatch, no_fit, capsys):
    monkeypatch.chdir("/proc")
    err = _one_line(capsys, main(["fit", "gtm"]))
    assert err == "gflat fit: error: cannot write gtm-fit.toml: No such file or directory\n"


def test_the_default_id_is_the_one_the_source_gives():
    from types import SimpleNamespace

    from gna.fit.sources.jsbsim_aero import resolve
    from harness.commands.fit import _default_ident

    for model in ("F4N", "c172x"):
        args = SimpleNamespace(source="jsbsim", model=model)
        assert _default_ident(args) == resolve(model)[0].lower()
    assert _default_ident(SimpleNamespace(source="linear", csv="data/twin_otter.csv")) == "twin_otter"
    assert _default_ident(SimpleNamespace(source="gtm")) == "gtm-fit"
