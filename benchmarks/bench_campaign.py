"""Batched closed-loop Monte Carlo of the Twin Otter single-engine scenario (60 s) against single runs.

Samples of the ``paper-dispersions`` campaign's dispersion set (fitted standard
errors of the aerodynamic terms, mass, inertia, CG, initial offsets) flown with
the paper's tracking feedback on the in-house model: one at a time by the
single-run engine (:class:`harness.engines.InHouseEngine`, DOP853 at 1e-10), and
all at once by :func:`harness.campaign.montecarlo.fly_batch` (per-sample DOP853
at the same tolerances, vectorised over samples).  Prints both rates as samples
per 60 s of wall time on one core, and the largest position difference between
the two engines on the samples flown by both::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/bench_campaign.py [--samples 1000] [--singles 2]

(one thread: numpy's BLAS would otherwise use both cores).  Expect +-15 % scatter on a shared 2-core
machine.  A sample whose anti-windup slides (seed 4495825943198835301 among the default 1000) is stopped after
``--max-steps`` (5000, about 6 times the median) and reported as stalled.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from harness.campaign import dispersed_aircraft, draw_sample, load_campaign, sample_seed
from harness.campaign.montecarlo import batch_metrics, fly_batch
from harness.engines import InHouseEngine
from harness.validation import ValidationCase, plan_case
from harness.validation.closed import closed_loop_setup


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1000, help="samples flown by the batched engine")
    ap.add_argument("--singles", type=int, default=2, help="samples flown one at a time (rate and accuracy)")
    ap.add_argument("--seconds", type=float, default=60.0, help="span flown from t0 [s]")
    ap.add_argument("--method", default="DOP853", help="batched integrator")
    ap.add_argument(
        "--max-steps",
        type=int,
        default=5000,
        help="per-sample step budget (a sliding mode of the anti-windup stalls a few samples, on the "
        "single-run engine too)",
    )
    args = ap.parse_args(argv)
    disp = load_campaign("paper-dispersions").dispersions[0]
    planned = plan_case(ValidationCase("twin-otter-single-engine", loop="closed"))
    plan = planned.plan
    span = (plan.t0, min(plan.t1, plan.t0 + args.seconds))
    draws = [draw_sample(plan.aircraft, disp, sample_seed(1, "bench", k)) for k in range(args.samples)]
    setup = closed_loop_setup(plan, planned.scenario)
    engine = InHouseEngine()
    singles = []
    t, c = time.perf_counter(), time.process_time()
    for d in draws[: args.singles]:
        singles.append(
            engine.simulate(
                dispersed_aircraft(plan.aircraft, d),
                setup.controller.controls,
                span,
                setup.x0 + d.offsets,
                env=plan.env,
                controller=setup.controller,
                dt_out=0.05,
            )
        )
    t_single = (time.perf_counter() - t) / max(args.singles, 1)
    c_single = (time.process_time() - c) / max(args.singles, 1)
    t, c = time.perf_counter(), time.process_time()
    res, ctl, j = fly_batch(plan, planned.scenario, draws, t_span=span, method=args.method, max_steps=args.max_steps)
    t_batch, c_batch = time.perf_counter() - t, time.process_time() - c
    metrics = batch_metrics(res, plan, j, ctl)
    diff = max(
        (
            float(np.linalg.norm(r.df[["x", "y", "z"]].to_numpy() - res.X[:, :3, i], axis=1).max())
            for i, r in enumerate(singles)
        ),
        default=float("nan"),
    )
    done = sum(m["status"] == "completed" for m in metrics)
    stalled = [i for i, m in enumerate(metrics) if m["status"] == "stalled"]
    errs = np.array([m["max_position_error_m"] or np.nan for m in metrics])
    print(f"twin-otter-single-engine closed loop, {span[1] - span[0]:g} s, dispersion '{disp.name}'")
    print(
        f"single-run engine: {t_single:.2f} s per sample (CPU {c_single:.2f} s) -> {60.0 / t_single:.1f} samples "
        f"per 60 s"
    )
    print(
        f"batched ({args.method}): {args.samples} samples in {t_batch:.1f} s (CPU {c_batch:.1f} s; {res.nfev} "
        f"batched evaluations) -> {60.0 * args.samples / t_batch:.0f} samples per 60 s "
        f"({t_single * args.samples / t_batch:.1f}x the single-run engine)"
    )
    print(f"batched vs single runs ({len(singles)} samples): max position difference {diff:.2e} m")
    if res.steps is not None:
        order = np.argsort(res.steps)[::-1][:3]
        print(
            f"steps per sample: median {int(np.median(res.steps))}, largest "
            + ", ".join(f"{res.steps[i]} (sample {i}, seed {draws[i].seed})" for i in order)
        )
    if stalled:
        print(
            f"stalled after {args.max_steps} steps (sliding mode of the conditional integration): "
            + ", ".join(f"sample {i} (seed {draws[i].seed}, t = {metrics[i]['t_end']:.4g} s)" for i in stalled)
        )
    print(
        f"completed {done}/{args.samples}; max distance to the flat outputs: median {np.nanmedian(errs):.3f} m, "
        f"worst {np.nanmax(errs):.3f} m"
    )


if __name__ == "__main__":
    main()
