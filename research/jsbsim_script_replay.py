"""A paper plan replayed by stock JSBSim's script loader against the gflat JSBSim engine (open loop).

Exports the scenario with ``harness.engines.jsbsim.script.export_script`` (the ``gflat
export-jsbsim-script`` files), runs the script with ``jsbsim.FGFDMExec(root).load_script`` and compares
its CSV output with ``harness.engines.fly(["jsbsim"], ...)`` of the same plan: prints the largest
position and angle differences over the first 10 s and the whole span, for control tables at every
JSBSim step and every 5 steps (1/96 s), and draws them in ``reports/out/jsbsim-script/<scenario>.png``.

Usage: ``python research/jsbsim_script_replay.py [SCENARIO ...]`` (from the repository root; default
twin-otter-single-engine gtm-aileron-roll).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from harness.engines import JSBSimEngine, fly  # noqa: E402
from harness.engines.jsbsim.script import export_script, replay  # noqa: E402
from planners.generalized import plan_scenario  # noqa: E402
from planners.scenario import load_scenario  # noqa: E402

ANGLES = ["gamma", "chi", "alpha", "beta", "mu"]


def differences(replayed, engine):
    """Times, position distance [m] and largest angle difference [rad] at the common output times."""
    t = np.intersect1d(np.round(replayed.index, 9), np.round(engine.index, 9))
    a = replayed.set_axis(np.round(replayed.index, 9)).loc[t]
    b = engine.set_axis(np.round(engine.index, 9)).loc[t]
    pos = np.linalg.norm(a[["x", "y", "z"]].to_numpy() - b[["x", "y", "z"]].to_numpy(), axis=1)
    ang = np.max(np.abs(a[ANGLES].to_numpy() - b[ANGLES].to_numpy()), axis=1)
    return t, pos, ang


def main(names) -> None:
    out = ROOT / "reports" / "out" / "jsbsim-script"
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        sc = load_scenario(name)
        plan = plan_scenario(sc)
        # Stock JSBSim's positions carry the round-off of its inertial position: the engine's uncorrected ones.
        raw = {"jsbsim": JSBSimEngine(compensate_roundoff=False)}
        engine = fly(raw, sc.aircraft, None, plan, (plan.t0, plan.t1), env=sc.env, dt_out=0.025)["jsbsim"].df
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for table_dt, label in ((None, "tables at every JSBSim step"), (5 / 480, "tables every 5 steps (1/96 s)")):
            with tempfile.TemporaryDirectory() as tmp:
                b = export_script(tmp, sc.name, sc.aircraft, plan, env=sc.env, table_dt=table_dt)
                t, pos, ang = differences(replay(b), engine)
            first = t <= t[0] + 10.0 + 1e-9
            print(
                f"{name} ({label}, step {b.dt:.6g} s, {b.rows} rows): max |position difference| "
                f"{pos[first].max():.3e} m over the first 10 s, {pos.max():.3e} m over {t[0]:g}..{t[-1]:g} s; "
                f"max |angle difference| {ang[first].max():.3e} rad / {ang.max():.3e} rad"
            )
            axes[0].semilogy(t, np.maximum(pos, 1e-16), label=label)
            axes[1].semilogy(t, np.maximum(ang, 1e-18), label=label)
        axes[0].set_ylabel("|position difference| [m]")
        axes[1].set_ylabel("max |angle difference| [rad]")
        axes[1].set_xlabel("t [s]")
        axes[0].set_title(f"{name}: stock JSBSim script replay vs the gflat JSBSim engine (open loop)")
        for ax in axes:
            ax.grid(True, which="both", alpha=0.3)
            ax.legend()
        fig.tight_layout()
        fig.savefig(out / f"{name}.png", dpi=110)
        plt.close(fig)
        print(f"  figure: {out / f'{name}.png'}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["twin-otter-single-engine", "gtm-aileron-roll"])
