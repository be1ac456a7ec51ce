"""Every aircraft of the installed jsbsim package: ``gflat fit jsbsim NAME`` with its defaults, and an S-turn.

For each aircraft under ``jsbsim.get_default_root_dir()/aircraft``:

1. ``gflat fit jsbsim NAME --out <tmp>/NAME.toml`` (no other option); an aircraft it cannot represent gives
   the command's one line, kept as the reason.
2. An S-turn like ``planners/scenarios/f16-s-turn.toml`` adapted to the aircraft: its reference speed ``V0``
   and altitude, the half-width scaled with the speed (``A = 235 m * V0 / 195 m/s``: the same speed
   modulation ``A w / V0`` and period 60 s), the F-16 scenario's lambda lists with the speed loop ``I1``
   slowed to the engine's measured thrust lag (fastest pole at most ``0.75 / thrust_lag``; the paper's
   design assumes an immediate thrust).
3. ``gflat compare`` of it closed loop on ``inhouse,jsbsim-source``: the largest distance of JSBSim's original
   aircraft to the flat outputs after 5 s.

Usage (one command; about a minute of CPU per aircraft that fits)::

    python benchmarks/jsbsim_aircraft.py [NAMES...] [--write docs/jsbsim.md]

Prints the Markdown table; ``--write`` replaces the block between the markers of ``docs/jsbsim.md``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- jsbsim-aircraft table: begin -->", "<!-- jsbsim-aircraft table: end -->"
F16_SCENARIO = ROOT / "planners" / "scenarios" / "f16-s-turn.toml"


def _gflat(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    import os

    env = {**os.environ, **env}
    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=1800
    )


def s_turn(name: str, fitted: dict) -> str:
    """The S-turn scenario text for a fitted aircraft file (its parsed TOML)."""
    ref = fitted["fit"]["reference"]
    V0, h = float(ref["V_ms"]), float(ref["altitude_m"])
    lag = float(fitted.get("engines", {}).get("thrust_lag_s", 0.0))
    scale = min(1.0, 0.75 / (3.0 * lag)) if lag > 0 else 1.0
    text = F16_SCENARIO.read_text(encoding="utf-8")
    out = []
    for line in text.splitlines():
        if line.startswith("name = "):
            line = f'name = "{name}-s-turn"'
        elif line.startswith("aircraft = "):
            line = f'aircraft = "{name}.toml"'
        elif line.startswith("V0 = "):
            line = f"V0 = {V0:.6g}"
        elif line.startswith("h = "):
            line = f"h = {h:.6g}"
        elif line.startswith("A = "):
            line = f"A = {235.0 * V0 / 195.0:.6g}"
        elif line.startswith("I1 = "):
            line = f"I1 = [{', '.join(f'{scale * v:.4g}' for v in (1.0, 2.0, 3.0))}]"
        out.append(line)
    return "\n".join(out) + "\n"


def one(name: str, work: Path) -> dict:
    """Fit, plan and fly ``name``; a row of the table."""
    fit = _gflat("fit", "jsbsim", name, "--out", f"{name}.toml", cwd=work)
    if fit.returncode != 0:
        reason = (fit.stderr.strip().splitlines() or ["(no message)"])[-1].removeprefix("gflat fit: error: ")
        return {"name": name, "fits": False, "reason": reason}
    fitted = tomllib.loads((work / f"{name}.toml").read_text(encoding="utf-8"))
    row = {
        "name": name,
        "fits": True,
        "V0": fitted["fit"]["reference"]["V_ms"],
        "label": fitted["fit"]["reference"]["label"],
        "lag": fitted["engines"].get("thrust_lag_s", 0.0),
        "offset": fitted["engines"].get("thrust_line_offset_m", 0.0),
        "torque": fitted["engines"].get("torque_arm_m", 0.0),
        "r2": {c: s["test"]["r2"] for c, s in fitted["fit"]["statistics"].items()},
    }
    (work / f"{name}-s-turn.toml").write_text(s_turn(name, fitted), encoding="utf-8")
    cmp = _gflat(
        "compare", f"{name}-s-turn.toml", "--loop", "closed", "--engines", "inhouse,jsbsim-source", "--json", cwd=work
    )
    try:
        res = json.loads(cmp.stdout)
    except json.JSONDecodeError:
        row["s_turn"] = (cmp.stderr.strip().splitlines() or ["no output"])[-1]
        return row
    runs = res.get("runs", {})
    src, inh = runs.get("jsbsim-source", {}), runs.get("inhouse", {})
    row["s_turn_m"] = src.get("max_position_error_after_5s_m")
    row["inhouse_m"] = inh.get("max_position_error_after_5s_m")
    row["status"] = src.get("status")
    row["saturated_s"] = src.get("saturated_s")
    return row


def table(rows: list[dict]) -> str:
    """The Markdown table of the rows."""
    lines = [
        "| aircraft | `gflat fit jsbsim NAME` | reference | held-out R² (CD, CL, Cm, Cl, Cn) | thrust lag [s] | "
        "thrust line below CG [m] | torque arm [m] | S-turn on the original, max distance after 5 s [m] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if not r["fits"]:
            lines.append(f"| {r['name']} | no: {r['reason'].replace('|', '/')} | | | | | | |")
            continue
        r2 = ", ".join(f"{r['r2'][c]:.3f}" for c in ("CD", "CL", "Cm", "Cl", "Cn") if c in r["r2"])
        if "s_turn_m" in r and r["s_turn_m"] is not None:
            st = f"{r['s_turn_m']:.3g}" + ("" if r.get("status") == "completed" else f" ({r.get('status')})")
            if r.get("saturated_s"):
                st += f", saturated {r['saturated_s']:.3g} s"
        else:
            st = str(r.get("s_turn", r.get("status", "?"))).replace("|", "/")
        lines.append(
            f"| {r['name']} | fits | {r['label']} ({r['V0']:.4g} m/s) | {r2} | {r['lag']:.3g} | "
            f"{r['offset']:.3g} | {r['torque']:.3g} | {st} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="aircraft (default: every one of the jsbsim package)")
    ap.add_argument("--write", type=Path, help="replace the table block of this Markdown file")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from gna.fit.sources.jsbsim_aero import available_aircraft, default_root

    names = args.names or available_aircraft(default_root())
    rows = []
    with tempfile.TemporaryDirectory(prefix="gflat-jsbsim-aircraft-") as tmp:
        for name in names:
            rows.append(one(name, Path(tmp)))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    text = table(rows)
    print(text)
    if args.write:
        doc = args.write.read_text(encoding="utf-8")
        if BEGIN not in doc or END not in doc:
            raise SystemExit(f"{args.write}: no {BEGIN} ... {END} block")
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        args.write.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
