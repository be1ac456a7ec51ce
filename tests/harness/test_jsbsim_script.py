"""``gflat export-jsbsim-script``: the plan replayed by stock JSBSim's script loader agrees with the JSBSim engine."""

import json
from dataclasses import replace

import numpy as np
import pytest

from gna.errors import InputError
from harness.cli import main
from harness.engines import JSBSimEngine, fly
from harness.engines.jsbsim.script import export_script, replay
from planners.generalized import plan_scenario
from planners.scenario import load_scenario


@pytest.fixture(scope="module")
def roll():
    sc = load_scenario("gtm-aileron-roll")
    return sc, plan_scenario(sc)


def _max_differences(replayed, engine, t_max=None):
    t = np.intersect1d(np.round(replayed.index, 9), np.round(engine.index, 9))
    if t_max is not None:
        t = t[t <= t_max + 1e-9]
    a = replayed.set_axis(np.round(replayed.index, 9)).loc[t]
    b = engine.set_axis(np.round(engine.index, 9)).loc[t]
    pos = float(np.max(np.linalg.norm(a[["x", "y", "z"]].to_numpy() - b[["x", "y", "z"]].to_numpy(), axis=1)))
    ang = float(
        np.max(
            np.abs(
                a[["gamma", "chi", "alpha", "beta", "mu"]].to_numpy()
                - b[["gamma", "chi", "alpha", "beta", "mu"]].to_numpy()
            )
        )
    )
    return t.size, pos, ang


@pytest.mark.parametrize("table_dt", [None, 5 / 480])
def test_replay_agrees_with_the_engine(roll, tmp_path, table_dt):
    sc, plan = roll
    b = export_script(tmp_path / "out", sc.name, sc.aircraft, plan, env=sc.env, table_dt=table_dt)
    replayed = replay(b)
    # Stock JSBSim's CSV carries the round-off of its inertial position, which the engine corrects by default
    # (harness.engines.jsbsim.roundoff): the replay is compared with the engine's uncorrected positions.
    runs = fly(
        {"raw": JSBSimEngine(compensate_roundoff=False), "jsbsim": "jsbsim"},
        sc.aircraft,
        None,
        plan,
        (plan.t0, plan.t1),
        env=sc.env,
        dt_out=b.dt_out,
    )
    engine = runs["raw"].df
    n, pos, ang = _max_differences(replayed, engine)
    assert n == engine.index.size  # every output time replayed
    # The engine's samples exactly: round-off (altitude read on the 1e11 ft planet, 4.6e-6 m);
    # 5-step tables: linear interpolation of the controls between the nodes.
    assert pos < (1e-5 if table_dt is None else 2e-3)
    assert ang < (1e-9 if table_dt is None else 1e-4)
    # The correction moves the position only (by the accumulated round-off, here 1.9e-5 m), never the angles.
    corrected = runs["jsbsim"].df
    shift = np.linalg.norm(corrected[["x", "y", "z"]].to_numpy() - engine[["x", "y", "z"]].to_numpy(), axis=1)
    largest = runs["jsbsim"].settings.extra["position_roundoff"]["largest_m"]
    assert 0 < shift.max() <= largest * (1 + 1e-6) + 1e-9 < 1e-4
    assert np.array_equal(
        corrected[["V", "gamma", "chi", "alpha", "beta", "mu"]], engine[["V", "gamma", "chi", "alpha", "beta", "mu"]]
    )


def test_files_and_cli(tmp_path, capsys):
    out = tmp_path / "x"
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(out)]) == 0
    assert (out / "aircraft" / "gtm" / "gtm.xml").is_file()
    init = (out / "aircraft" / "gtm" / "gtm-aileron-roll-init.xml").read_text()
    assert 'version="2.0"' in init and 'unit="FT/SEC"' in init and 'unit="DEG"' in init
    script = (out / "scripts" / "gtm-aileron-roll.xml").read_text()
    assert 'type="CSV"' in script and "simulation/sim-time-sec" in script and 'continuous="true"' in script
    assert "replay" in capsys.readouterr().out
    f = tmp_path / "file"
    f.write_text("")
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(f)]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_names_cannot_escape(roll, tmp_path):
    sc, plan = roll
    with pytest.raises(InputError, match="not a safe identifier"):
        export_script(tmp_path / "o", "../up", sc.aircraft, plan, env=sc.env)
    with pytest.raises(InputError, match="not a safe identifier"):
        replace(sc.aircraft, id="../../evil")  # refused where an aircraft is made
    assert not any(tmp_path.iterdir())


def test_the_export_is_a_run_and_a_second_export_needs_replace(tmp_path, capsys):
    from harness.rundir import MANIFEST

    from .test_validation import SHORT

    out = tmp_path / "x"
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(out)]) == 0
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["command"] == "export-jsbsim-script"
    assert [f["path"] for f in manifest["files"]] == [
        "aircraft/gtm/gtm-aileron-roll-init.xml",
        "aircraft/gtm/gtm.xml",
        "scripts/gtm-aileron-roll.xml",
    ]
    (tmp_path / "short.toml").write_text(SHORT)
    assert main(["export-jsbsim-script", str(tmp_path / "short.toml"), "--out", str(out)]) == 2
    assert f"output folder {out} exists: give --replace" in capsys.readouterr().err
    assert main(["export-jsbsim-script", str(tmp_path / "short.toml"), "--out", str(out), "--replace"]) == 0
    listed = [f["path"] for f in json.loads((out / MANIFEST).read_text())["files"]]
    assert listed == ["aircraft/a7/a7.xml", "aircraft/a7/short-init.xml", "scripts/short.xml"]  # the earlier gone
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == sorted([*listed, MANIFEST])


def test_the_folder_is_checked_before_planning(tmp_path, monkeypatch, capsys):
    from harness.commands import export_script as command
    from harness.rundir import RunDir

    monkeypatch.setattr(command, "plan_scenario", lambda sc: pytest.fail("planned before checking --out"))
    with RunDir(tmp_path / "paper", command="paper") as paper:
        paper.write_text("index.html", text="<p>")
        paper.commit()
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(tmp_path / "paper")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists: give --replace" in err
    (tmp_path / "paper" / "mine.txt").write_text("the user's")
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(tmp_path / "paper"), "--replace"]) == 2
    assert "holds mine.txt" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "paper").iterdir()) == ["index.html", "manifest.json", "mine.txt"]
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(tmp_path / "paper" / "sub")]) == 2
    assert "lies inside" in capsys.readouterr().err
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", "/", "--replace"]) == 2
    assert "file-system root" in capsys.readouterr().err


def test_the_csv_holds_the_output_grid_and_ends_at_t1(roll, tmp_path):
    import pandas as pd

    sc, plan = roll
    for dt_out in (b_dt := 1 / 480, 0.025):
        b = export_script(tmp_path / f"o{dt_out}", sc.name, sc.aircraft, plan, env=sc.env, dt_out=dt_out)
        assert b.dt == pytest.approx(b_dt)
        replay(b)
        t = pd.read_csv(b.root / b.output).iloc[:, 0].to_numpy()
        assert t[0] == pytest.approx(plan.t0) and t[-1] == pytest.approx(plan.t1, abs=1e-9)  # not t1 + dt
        assert t.size == round((plan.t1 - plan.t0) / dt_out) + 1


@pytest.mark.parametrize(
    "flag, value, words",
    [
        ("--dt-out", "0.001", ["--dt-out = 0.001 s", "0.002083333333 s", "0.48 of a step", "(1 step)"]),
        ("--dt-out", "0.02", ["--dt-out = 0.02 s", "9.6 steps", "0.02083333333 (10 steps)"]),
        ("--table-dt", "0.001", ["--table-dt = 0.001 s", "0.48 of a step"]),
        ("--table-dt", "0.003", ["--table-dt = 0.003 s", "1.44 steps"]),
        ("--table-dt", "100", ["--table-dt 100 s", "node step 0.5 s"]),
    ],
)
def test_intervals_that_are_not_whole_steps_are_refused_before_planning(
    flag, value, words, tmp_path, monkeypatch, capsys
):
    from harness.commands import export_script as command

    monkeypatch.setattr(command, "plan_scenario", lambda sc: pytest.fail("planned before checking the intervals"))
    out = tmp_path / "x"
    assert main(["export-jsbsim-script", "gtm-aileron-roll", "--out", str(out), flag, value]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and all(w in err for w in words), err
    assert not out.exists()


def test_the_library_refuses_the_same_intervals(roll, tmp_path):
    sc, plan = roll
    with pytest.raises(InputError, match="not a whole number of JSBSim steps"):
        export_script(tmp_path / "a", sc.name, sc.aircraft, plan, env=sc.env, dt_out=0.02)
    with pytest.raises(InputError, match="longer than the plan's node step 0.5 s"):
        export_script(tmp_path / "b", sc.name, sc.aircraft, plan, env=sc.env, table_dt=480 / 480)
