"""`navkit tune`: wheel and heading loop gains from experiments, by identification (numpy
least squares), design (python-control), verification (co-simulation) and a Monte Carlo
over plant variations. See docs/tune.md.

    navkit tune wheel --mission config/missions/tune_wheels.toml --out build/tune/wheel
    navkit tune wheel --log "Data 11-25-26 10;00;00.txt" --out build/tune/robot
    navkit tune heading --wheel build/tune/wheel --out build/tune/heading

Modules: `ident` (models and fits), `design` (loops and designs), `experiment` (logs and
co-simulation runs), `config` (the tuned config copy), `robust` (plant variations),
`plots`, `flow` (the two commands).
"""

from __future__ import annotations

import sys
from pathlib import Path

from navkit.cli import count_int, fraction, positive_float

__all__ = ["add_arguments", "run"]


def _count_fraction(text: str) -> float:
    """0 or a fraction below 1."""
    return 0.0 if text.strip() in ("0", "0.0") else fraction(text)


def _common(p, pm_help: str) -> None:
    p.add_argument("--out", "-o", type=Path, required=True, help="output folder (tune.json, PNGs, config/)")
    p.add_argument("--pm", type=positive_float, default=60.0, help=pm_help)
    p.add_argument("--bandwidth", type=positive_float, default=None, metavar="HZ",
                   help="crossover frequency (Hz) instead of the automatic choice")
    p.add_argument("--overshoot", type=positive_float, default=5.0, metavar="PCT",
                   help="largest predicted overshoot (%%, default 5)")
    p.add_argument("--gm-min", type=positive_float, default=6.0, metavar="DB",
                   help="least gain margin (dB, default 6)")
    p.add_argument("--samples", type=count_int, default=50, metavar="N",
                   help="Monte Carlo plant samples, analytic (default 50; 0 = none)")
    p.add_argument("--cosim-samples", type=count_int, default=0, metavar="M",
                   help="co-simulate the first M samples through navkit.sweep (default 0)")
    p.add_argument("--variation", type=fraction, default=0.2,
                   help="plant variation of the Monte Carlo, +/- fraction (default 0.2)")
    p.add_argument("--seed", type=int, default=1, help="seed of the samples and of the co-simulations (default 1)")
    p.add_argument("--workers", type=int, default=None, help="Dask workers of --cosim-samples (default: one per CPU)")
    p.add_argument("--frame-ms", type=positive_float, default=20.0,
                   help="host frame of the tuner's co-simulations (ms, default 20: a 50 Hz datalog)")
    p.add_argument("--no-verify", action="store_true", help="skip the co-simulated verification")
    p.add_argument("--build", type=Path, default=None, help="build folder (default: $NAVKIT_BUILD_DIR or build/)")


def add_arguments(parser) -> None:
    """Arguments of `navkit tune wheel|heading`."""
    sub = parser.add_subparsers(dest="loop", metavar="LOOP", required=True)
    w = sub.add_parser("wheel", help="the wheel-speed loops (wheel_kff, wheel_kp, wheel_ki, wheel_kd)")
    src = w.add_mutually_exclusive_group(required=True)
    src.add_argument("--mission", type=Path, help="co-simulate this mission's experiment on its plant")
    src.add_argument("--log", type=Path, help="a recorded experiment: run.mcap or a host datalog")
    w.add_argument("--config", type=Path, default=None, help="input host config folder (default: config/)")
    w.add_argument("--firmware", choices=("fmu", "avr"), default="fmu",
                   help="the co-simulations' firmware: fmu (the core built for the host) or avr (the AVR image "
                   "in simavr, at its 400 Hz ceiling); `tune heading` takes the wheel tuning's")
    w.add_argument("--model", choices=("auto", "fopdt", "sopdt"), default="auto",
                   help="model to design on (auto: sopdt if its NRMSE is 10 %% lower)")
    w.add_argument("--derivative", action="store_true", help="PID (kd = kp*0.25/wc) instead of PI")
    w.add_argument("--compute-delay", type=count_int, default=1, metavar="TICKS",
                   help="computation delay of a tick in the loop (ticks, default 1)")
    w.add_argument("--gain-spread", type=_count_fraction, default=0.2, metavar="FRAC",
                   help="the overshoot limit (and the heading's on top) also holds with a motor constant this "
                   "much weaker: gain / (1 - FRAC), time constants / (1 - FRAC)^2 (default 0.2; 0 = the "
                   "identified model alone)")
    w.add_argument("--max-nrmse", type=positive_float, default=0.3, help="worst acceptable fit (default 0.3)")
    w.add_argument("--step-speed", type=positive_float, default=None, metavar="MM_S",
                   help="verification move speed (mm/s; default 40 %% of the model's top speed, at most 300)")
    w.add_argument("--step-accel", type=positive_float, default=3000.0, metavar="MM_S2",
                   help="verification move acceleration (mm/s^2, default 3000)")
    _common(w, "phase margin target (deg, default 60)")
    h = sub.add_parser("heading", help="the heading-select gain (heading_kp) on top of tuned wheel loops")
    h.add_argument("--wheel", type=Path, required=True, help="the --out folder of `navkit tune wheel`")
    h.add_argument("--mission", type=Path, default=None,
                   help="mission whose plant verifies (default: the wheel tuning's mission)")
    h.add_argument("--turn-deg", type=positive_float, default=90.0, help="verification heading select (deg)")
    h.add_argument("--turn-rate", type=positive_float, default=60.0, help="its rate (deg/s, default 60)")
    h.add_argument("--turn-accel", type=positive_float, default=180.0, help="its acceleration (deg/s^2)")
    _common(h, "phase margin target (deg, default 60)")


def run(args) -> int:
    """Run `navkit tune`; 0 on success, 1 with one line on stderr for a bad input or result."""
    from navkit.tune import config, design, experiment, flow, ident

    if not args.pm < 90:
        print(f"navkit tune {args.loop}: --pm {args.pm:g}: must be below 90 deg", file=sys.stderr)
        return 2
    try:
        if args.loop == "wheel":
            r = flow.tune_wheel(args)
        else:
            r = flow.tune_heading(args)
    except (flow.TuneError, experiment.ExperimentError, ident.IdentError, design.DesignError,
            config.ConfigError) as e:
        print(f"navkit tune {args.loop}: {e}", file=sys.stderr)
        return 1
    _report(args, r)
    return 0


def _report(args, r: dict) -> None:
    out = Path(args.out)
    mq = r["margins_quantised"]
    print(f"tuned     {r['kind']}: " + ", ".join(f"{k} {v}" for k, v in r["raw"].items())
          + "  (was " + ", ".join(f"{v}" for v in r["previous_raw"].values()) + ")")
    if r["kind"] == "wheel":
        m = r["model"]
        print(f"model     {m['kind']}: K {m['gain_mm_s']:.1f} mm/s/duty, tau {m['tau1_s'] * 1000:.1f} ms"
              + (f" + {m['tau2_s'] * 1000:.1f} ms" if m["kind"] == "sopdt" else "")
              + f", dead time {m['delay_s'] * 1000:.1f} ms, dead band {m['deadband']:.3f}; NRMSE "
              + ", ".join(f"{x['wheel']} {x['fits'][m['kind']]['nrmse']:.3f}" for x in r["records"]))
    print(f"margins   phase {mq['phase_margin_deg']:.1f} deg, gain {mq['gain_margin_db']:.1f} dB, "
          f"crossover {mq['crossover_hz']:.2f} Hz (quantised gains)")
    pred = r["predicted"].get("move") or r["predicted"].get("heading_select")
    line = f"step      predicted overshoot {pred['overshoot_pct']:.1f} %, rise {pred['rise_time_s'] * 1000:.0f} ms"
    if r.get("simulated"):
        s = next(iter(v for k, v in r["simulated"].items() if isinstance(v, dict)))
        unit = "mm/s" if r["kind"] == "wheel" else "deg"
        line += (f"; co-simulated overshoot {s['overshoot_pct']:.1f} %, rise {s['rise_time_s'] * 1000:.0f} ms; "
                 f"apart by {s['rms_deviation']:.1f} {unit} RMS")
    print(line)
    a = r["robustness"].get("analytic")
    if a:
        print(f"robust    {a['samples']} plants +/-{a['variation'] * 100:g} %: worst phase margin "
              f"{a['worst_phase_margin_deg']:.1f} deg, gain margin {a['worst_gain_margin_db']:.1f} dB, "
              f"overshoot {a['worst_overshoot_pct']:.1f} %, unstable {a['unstable']}")
    c = r["robustness"].get("cosim")
    if c:
        worst = c["worst_overshoot_pct"]
        print(f"cosim     {c['ok']} of {c['runs']} runs co-simulated"
              + (f", worst overshoot {worst:.1f} %" if worst is not None else "")
              + (f", {len(c['failed'])} failed (tune.json)" if c["failed"] else ""))
    pngs = "fit.png  bode.png  step.png" if r["kind"] == "wheel" else "bode.png  step.png"
    print(f"outputs   {out}/  tune.json  {pngs}  config/")
