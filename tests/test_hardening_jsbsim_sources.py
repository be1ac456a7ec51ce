"""Hardening, third round, kind 6: the JSBSim sources (``gflat fit jsbsim``, ``JSBSimAeroSource``, the
``jsbsim-source`` engine) check property names against the loaded model, take a relative ``--root``, and
load aircraft without their ``<output>``/``<input>`` directives: no file written, no socket bound, no
temporary folder left, JSBSim's console output captured.  Real JSBSim.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from gna.aero import AeroState
from gna.aircraft import load_aircraft
from gna.errors import InputError
from gna.fit.sources.jsbsim_aero import IO_ELEMENTS, JSBSimAeroSource, default_root, loadable_model
from gna.fit.sources.jsbsim_xml import parse
from gna.trim import trim_level
from harness.cli import main
from harness.engines.base import EngineError
from harness.engines.jsbsim.source import JSBSimSourceEngine

STATE = AeroState(0.05, 0.01, 0.0, 0.0, 0.0, 0.0, -0.02, 0.0)


def _jsbsim_root_copy(tmp_path: Path, *aircraft: str) -> Path:
    """A JSBSim root under ``tmp_path/jroot``: copies of ``aircraft``, links to the package's engines and systems."""
    root = tmp_path / "jroot"
    (root / "aircraft").mkdir(parents=True)
    for name in aircraft:
        shutil.copytree(default_root() / "aircraft" / name, root / "aircraft" / name)
    for sub in ("engine", "systems"):
        (root / sub).symlink_to(default_root() / sub, target_is_directory=True)
    return root


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"surfaces": {"dm": ("fcs/elevatr-pos-rad", 1.0)}}, "'fcs/elevatr-pos-rad' (surface dm"),
        ({"configuration": {"gear/gear-pos-nrm": 0.0}}, "'gear/gear-pos-nrm' (configuration)"),
    ],
)
def test_k6_misspelled_property_names_are_refused_with_the_closest(kw, words):
    with pytest.raises(InputError) as exc:
        JSBSimAeroSource("f16", mach=0.6, altitude=3000.0, **kw)
    text = str(exc.value)
    assert (
        words in text
        and "is not a property of the loaded model (did you mean 'fcs/elevator-pos-rad'?)" in text
        or ("did you mean 'gear/gear-pos-norm'?" in text)
    )


def test_k6_cli_misspelled_surface_property_is_one_line(capsys):
    argv = ["fit", "jsbsim", "f16", "--mach", "0.6", "--altitude", "3000", "--property", "dm=fcs/elevatr-pos-rad"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "did you mean 'fcs/elevator-pos-rad'?" in err


def test_k6_a_misspelled_surface_in_a_fitted_provenance_is_refused_by_the_source_engine():
    ac = load_aircraft("f16-jsbsim")
    tr = trim_level(ac, 195.0, 3000.0)
    prov = dict(ac.provenance)
    prov["source_model"] = prov["source_model"].replace("dn = fcs/rudder-pos-rad", "dn = fcs/ruder-pos-rad")
    bad = dataclasses.replace(ac, provenance=prov)
    with pytest.raises((InputError, EngineError), match=r"'fcs/ruder-pos-rad' .*did you mean 'fcs/rudder-pos-rad'\?"):
        JSBSimSourceEngine().simulate(bad, tr.controls, (0.0, 0.1), tr.state, dt_out=0.05)


def test_k6_a_relative_root_works(tmp_path, monkeypatch):
    _jsbsim_root_copy(tmp_path, "f16")
    monkeypatch.chdir(tmp_path)
    rel = JSBSimAeroSource("f16", mach=0.6, altitude=3000.0, root="jroot")
    ref = JSBSimAeroSource("f16", mach=0.6, altitude=3000.0)
    assert rel.root == (tmp_path / "jroot").resolve()
    assert np.array_equal(rel.body_coefficients(STATE), ref.body_coefficients(STATE))
    with pytest.raises(InputError, match=r"JSBSim root 'nowhere': .* is not a folder"):
        JSBSimAeroSource("f16", mach=0.6, altitude=3000.0, root="nowhere")


@pytest.mark.parametrize("name", ["B17", "c172x", "737"])
def test_k6_aircraft_with_output_and_input_directives_sample_silently(name, tmp_path, capfd, monkeypatch):
    root = _jsbsim_root_copy(tmp_path, name)
    temp = tmp_path / "temp"  # this test's own temporary folder: other tests' (in other workers) stay apart
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    xml = parse(root / "aircraft" / name / f"{name}.xml")
    assert any(child.tag in IO_ELEMENTS for child in xml)  # the case under test: the file has them
    before_root = set(root.rglob("*"))
    capfd.readouterr()
    kw = {"surfaces": {"dl": ("fcs/left-aileron-pos-rad", -1.0)}} if name != "737" else {}
    src = JSBSimAeroSource(name, mach=0.3, altitude=1000.0, root=root, **kw)
    c = src.body_coefficients(AeroState(*(np.full(20, v) for v in STATE)))
    assert np.isfinite(c).all()
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out[:300], err[:300])  # no banner, no "unable to open", no socket bind
    assert set(root.rglob("*")) == before_root  # nothing written into the JSBSim root
    assert not (set(os.listdir(tmp_path)) - {"jroot", "temp"})
    assert list(temp.iterdir()) == []  # no temporary folder left


def test_k6_loadable_model_strips_only_the_io_children(tmp_path):
    root = _jsbsim_root_copy(tmp_path, "c172x")
    folder = root / "aircraft" / "c172x"
    with loadable_model("c172x", folder) as copy:
        assert copy != folder and (copy / "c172x.xml").is_file()
        stripped = parse(copy / "c172x.xml")
        assert not [c for c in stripped if c.tag in IO_ELEMENTS]
        assert len(list(stripped)) == len([c for c in parse(folder / "c172x.xml") if c.tag not in IO_ELEMENTS])
        assert all((copy / p.name).exists() for p in folder.iterdir())
    assert not copy.exists()
    shutil.copytree(default_root() / "aircraft" / "F4N", root / "aircraft" / "F4N")
    with loadable_model("F4N", root / "aircraft" / "F4N") as same:  # no such directives: the folder itself
        assert same == root / "aircraft" / "F4N"


# --- fourth round (docs/hardening.md) ------------------------------------------------------------------------


@pytest.mark.parametrize("model", ["../../etc/passwd", "sub/F4N", "", "F4N/.."])
def test_a_model_name_that_is_a_path_is_refused_before_any_file_is_named(model, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    assert main(["fit", "jsbsim", model, "--samples", "200", "--test", "50"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"gflat fit: error: JSBSim aircraft {model!r}: not an aircraft's name") and "\n" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sub"] and not any((tmp_path / "sub").iterdir())


def test_a_property_factor_beyond_its_bounds_is_an_option_error(capsys):
    for factor in ("1e308", "-1e-9"):
        with pytest.raises(SystemExit) as stop:
            main(["fit", "jsbsim", "F4N", "--property", f"dm=fcs/elevator-pos-rad:{factor}"])
        assert stop.value.code == 2
        err = capsys.readouterr().err.strip()
        assert "argument --property: FACTOR" in err and "outside its bounds" in err and "\n" not in err


def test_the_beta_help_gives_the_sideslip_default(capsys):
    with pytest.raises(SystemExit):
        main(["fit", "jsbsim", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "|sideslip| (default 15 within the aerodynamic tables' data)" in out
