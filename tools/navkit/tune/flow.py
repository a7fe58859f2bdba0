"""`navkit tune wheel` and `navkit tune heading`: identify, design, write, verify, check
robustness, report. See docs/tune.md."""

from __future__ import annotations

import datetime
import functools
import json
import math
import sys
from pathlib import Path

import numpy as np

from navkit.tune import config as cfg
from navkit.tune import design as dsg
from navkit.tune import experiment as exp
from navkit.tune import ident, robust

__all__ = ["TuneError", "tune_wheel", "tune_heading", "extract_move", "extract_turn", "WHEEL_KEYS"]

WHEEL_KEYS = dsg.WHEEL_SCALES
VERIFY_T0 = 0.5      # s: when a verification mission's command is written
SETTLE_S = 1.0       # s: a verification move's cruise / a heading select's hold


class TuneError(ValueError):
    """One line for the user: what failed and where."""


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")


def _rev() -> str:
    from navkit.sim.harness import git_revision

    return git_revision()


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, Path):
        return str(x)
    return x


def _mean_model(models: list) -> ident.Model:
    kind = models[0].kind
    avg = lambda a: float(np.mean([getattr(m, a) for m in models]))  # noqa: E731
    return ident.Model(kind, avg("gain_mm_s"), avg("tau1_s"), avg("tau2_s"), avg("delay_s"), avg("deadband"))


def _same_data(a, b) -> bool:
    """True if records a and b hold the same samples (both wheels of a symmetric robot)."""
    return len(a.segments) == len(b.segments) and all(
        np.array_equal(x.u, y.u) and np.array_equal(x.y, y.y) and np.array_equal(x.at, y.at)
        for x, y in zip(a.segments, b.segments))


def _choose(by_kind: dict, want: str) -> str:
    """The model kind to design on: `want`, or 'auto': the lower Akaike information criterion
    n*ln(RSS/n) + 2*(parameters) (sopdt has one parameter more than fopdt's four), so the
    second time constant must pay for itself."""
    if want != "auto":
        return want

    def aic(f, k):
        rss = (f.nrmse ** 2) * max(f.n, 1)  # in units of the record's variance: the same for both
        return f.n * math.log(max(rss, 1e-300) / f.n) + 2 * k

    return "sopdt" if aic(by_kind["sopdt"], 5) < aic(by_kind["fopdt"], 4) else "fopdt"


def _model_line(m: ident.Model) -> str:
    taus = f"tau {m.tau1_s * 1000:.1f} ms" + (f" and {m.tau2_s * 1000:.1f} ms" if m.kind == "sopdt" else "")
    return (f"{m.kind} K {m.gain_mm_s:.1f} mm/s per duty, {taus}, dead time {m.delay_s * 1000:.1f} ms, "
            f"dead band {m.deadband:.3f} duty")


def _align(t: np.ndarray, y: np.ndarray, level: float) -> float:
    """First time y crosses `level` (linear interpolation); nan if never."""
    above = np.nonzero(y >= level)[0] if level >= 0 else np.nonzero(y <= level)[0]
    if len(above) == 0:
        return math.nan
    i = int(above[0])
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (t[i] - t[i - 1]) * (level - y[i - 1]) / (y[i] - y[i - 1]))


def _truth(out: Path, col: str) -> tuple[np.ndarray, np.ndarray]:
    from navkit.sim.results import read_mcap

    mc = read_mcap(Path(out) / "run.mcap", topics={"/truth"})
    rows = [json.loads(d) for _, _, d in mc.messages]
    return np.array([r["t"] for r in rows]), np.array([r[col] for r in rows])


def _truth_turn(out: Path) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and truth heading of a run as the turn from its start heading (deg,
    clockwise positive, in (-180, 180])."""
    t, h = _truth(out, "heading_deg")
    return t, np.where(h > 180.0, h - 360.0, h)


def _verify(args, out: Path, mission: Path, firmware: str, read, final: float, level: float,
            tp: np.ndarray, yp: np.ndarray, t_end: float, never: str, label: str, key: str,
            curves: list, rows: list) -> dict:
    """Co-simulate the verification mission into out/verify and set its truth (read(run
    folder) -> times s, values) beside the prediction (tp s, yp): both aligned where they
    first reach level * final, the run cut to the prediction's t_end (s). Returns the step
    figures of the run over `final`, with overshoot_pct past `final` and the RMS and largest
    deviation from the prediction (the values' unit), added to `rows` as "co-simulated"; the
    aligned times and values go to `curves` as `label`. Returns the report's "simulated"
    entry: those figures under `key`, the run folder, the mission and the run time (s) that
    became 0. Raises TuneError "<run>: <never>" when the run never reaches the level."""
    vdir = out / "verify"
    exp.run_cosim(mission, vdir, config_dir=out / "config", build=args.build,
                  frame_s=args.frame_ms / 1000.0, truth_hz=1000.0, seed=args.seed, firmware=firmware)
    ts, ys = read(vdir)
    t_sim = _align(ts, ys, level * final)
    t_pred = _align(tp, yp, level * final)
    if not math.isfinite(t_sim):
        raise TuneError(f"{vdir}: {never}")
    start = t_sim - t_pred
    keep = (ts >= start) & (ts <= start + t_end)
    tsim, ysim = ts[keep] - start, ys[keep]
    info = dsg.step_info(tsim, ysim / final)
    info["overshoot_pct"] = max(float(ysim.max()) - final, 0.0) / final * 100.0
    diff = ysim - np.interp(tsim, tp, yp)
    info["rms_deviation"] = float(np.sqrt(np.mean(diff ** 2)))
    info["max_deviation"] = float(np.max(np.abs(diff)))
    curves.append((label, tsim, ysim))
    rows.append(("co-simulated", info))
    return {key: info, "run": str(vdir), "mission": str(mission), "aligned_at_s": start}


def _info_text(rows: list) -> str:
    lines = [f"{'':<22}{'rise s':>8}{'settle s':>10}{'overshoot %':>13}"]
    for label, info in rows:
        if info:
            lines.append(f"{label:<22}{info['rise_time_s']:>8.3f}{info['settling_time_s']:>10.3f}"
                         f"{info['overshoot_pct']:>13.2f}")
    return "\n".join(lines)


# ---------------------------------------------------------------- sweep extract functions

def extract_move(run_dir: Path, summary: dict, *, t0: float, t1: float, speed: float) -> dict:
    """Figures of a verification move (navkit.sweep extract): peak truth speed (mm/s) and
    overshoot (%) over the setpoint speed between t0 and t1 (s)."""
    t, v = _truth(run_dir, "v_mm_s")
    keep = (t >= t0) & (t <= t1)
    peak = float(v[keep].max()) if keep.any() else math.nan
    return {"peak_mm_s": peak, "overshoot_pct": max(peak - speed, 0.0) / speed * 100.0}


def extract_turn(run_dir: Path, summary: dict, *, t0: float, target: float) -> dict:
    """Figures of a verification heading select (navkit.sweep extract): overshoot (%) of the
    truth heading (deg, clockwise from the start) past `target` after t0 (s), and the final
    heading error (deg)."""
    t, h = _truth_turn(run_dir)
    keep = t >= t0
    peak = float(h[keep].max()) if keep.any() else math.nan
    return {"overshoot_pct": max(peak - target, 0.0) / target * 100.0, "final_error_deg": float(h[-1] - target)}


def _sweep(mission_path: Path, samples: list, nominal: dict, config: Path, out: Path, build, workers,
           extract) -> dict:
    """Co-simulate the samples with navkit.sweep.run_sweep; worst overshoot and failures."""
    from navkit.sweep import RunSpec, run_sweep

    runs = [RunSpec(plant=robust.overrides(nominal, f), seed=1, config=config) for f in samples]
    results = run_sweep(mission_path, runs, out, workers=workers, progress=False, keep="failed",
                        extract=extract, build=build, plot=False)
    ok = [r for r in results if r.ok]
    failed = [{"index": r.index, "plant": r.spec.plant, "error": r.error} for r in results if not r.ok]
    ovs = [r.figures.get("overshoot_pct") for r in ok]
    ovs = [o for o in ovs if o is not None and math.isfinite(o)]
    return {"runs": len(results), "ok": len(ok), "failed": failed,
            "worst_overshoot_pct": max(ovs) if ovs else None,
            "overshoot_pct": ovs, "table": str(Path(out) / "results.csv")}


# ---------------------------------------------------------------- wheel

def _wheel_setup(args):
    from navkit.paths import repo_root

    config_src = Path(args.config) if args.config else repo_root() / "config"
    try:
        rate = cfg.geometry_value(config_src, "control_rate", args.build)
        previous = {k: int(cfg.motion_value(config_src, k, args.build)) for k in WHEEL_KEYS}
        pwm_limit = cfg.motion_value(config_src, "pwm_limit", args.build) * dsg._scale("pwm_limit")
    except cfg.ConfigError as e:
        raise TuneError(str(e)) from None
    return config_src, 1.0 / rate, previous, pwm_limit


def tune_wheel(args) -> dict:
    """The whole `navkit tune wheel`; returns tune.json's content. Raises TuneError,
    exp.ExperimentError, ident.IdentError, dsg.DesignError, cfg.ConfigError."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    config_src, dt, previous, pwm_limit = _wheel_setup(args)
    mission = None
    if args.mission:
        mission = exp.load_mission(args.mission)
        if not exp.mission_has_experiment(args.mission):
            raise TuneError(f"{args.mission}: no wheel experiment: a [[command]] with excite_mode (and "
                            f"mc_datalog_cmd = \"wheels\") is needed, e.g. config/missions/tune_wheels.toml")
        exp_dir = out / "experiment"
        summary = exp.run_cosim(args.mission, exp_dir, config_dir=config_src, build=args.build,
                                frame_s=args.frame_ms / 1000.0, seed=args.seed, firmware=args.firmware)
        # the tick the micro ran (the AVR image runs its ceiling, 400 Hz, whatever the config says)
        dt = 1.0 / float(summary.get("control_rate_hz") or 1.0 / dt)
        records = exp.records_from_mcap(exp_dir / "run.mcap")
        source = {"mission": str(Path(args.mission).resolve()), "experiment_run": str(exp_dir),
                  "firmware": args.firmware}
    else:
        records = exp.records_from_log(args.log)
        source = {"log": str(Path(args.log).resolve())}

    fits = []
    for rec in records:
        same = next((by for r, by in fits if _same_data(r, rec)), None)  # a symmetric robot's wheels
        fits.append((rec, same or ident.fit_both_segments(rec.segments, rec.ts)))
    kind = _choose(fits[0][1], args.model)
    if args.model == "auto" and len(fits) > 1:
        kinds = [_choose(f, "auto") for _, f in fits]
        kind = "sopdt" if kinds.count("sopdt") > len(kinds) / 2 else "fopdt"
    model = _mean_model([f[kind].model for _, f in fits])
    worst_fit = max(f[kind].nrmse for _, f in fits)
    if worst_fit > args.max_nrmse:
        raise TuneError(f"the {kind} model does not fit the experiment: NRMSE {worst_fit:.3f} > "
                        f"{args.max_nrmse:g} (see {out / 'fit.png'} once written; a longer or richer experiment, "
                        f"or --max-nrmse)")

    reach = model.gain_mm_s * max(pwm_limit - model.deadband, 0.0)
    speed = float(args.step_speed) if args.step_speed else float(max(10 * round(min(300.0, 0.4 * reach) / 10), 10))
    accel = float(args.step_accel)
    design = dsg.design_wheel(model, dt, pm_deg=args.pm, bandwidth_hz=args.bandwidth,
                              derivative=args.derivative, compute_delay=args.compute_delay,
                              overshoot_pct=args.overshoot, ramp_s=speed / accel, speed_mm_s=speed,
                              gm_min_db=args.gm_min, gain_spread=args.gain_spread,
                              allow_miss=args.bandwidth is not None)
    mq = design.margins_quantised
    raw = dict(design.raw)
    ov = design.step_quantised["move"]["overshoot_pct"]
    if ov > args.overshoot:  # only with --bandwidth: the crossover then fixes kp and ki
        print(f"warning: navkit tune wheel: at a {args.bandwidth:g} Hz crossover the predicted move overshoots by "
              f"{ov:.1f} %, above --overshoot {args.overshoot:g} %", file=sys.stderr)
    provenance = [
        f"navkit tune wheel, {_now()}, git {_rev()}",
        f"from {'mission ' + args.mission.name if args.mission else 'log ' + Path(args.log).name}: "
        f"{len(records)} record(s), NRMSE " + ", ".join(f"{r.wheel} {f[kind].nrmse:.3f}" for r, f in fits),
        f"model: {_model_line(model)}",
        f"targets: phase margin {args.pm:g} deg, overshoot {args.overshoot:g} % (also with a motor constant "
        f"{args.gain_spread * 100:g} % weaker), gain margin >= {args.gm_min:g} dB, {1 / dt:g} Hz, "
        f"computation delay {args.compute_delay} tick(s)",
        f"result: phase margin {mq['phase_margin_deg']:.1f} deg, gain margin {mq['gain_margin_db']:.1f} dB, "
        f"crossover {mq['crossover_hz']:.2f} Hz",
        "previous: " + ", ".join(f"{k} {v}" for k, v in previous.items()),
    ]
    config_rate = cfg.geometry_value(config_src, "control_rate", args.build)
    if abs(config_rate - 1.0 / dt) > 0.5:
        provenance.insert(-1, f"designed at {1 / dt:g} Hz, the rate the {args.firmware} firmware ran "
                              f"(control_rate here: {config_rate:g} Hz)")
    ini = cfg.write_tuned(config_src, out / "config", raw, "wheel", provenance, args.build)

    quant = {k: {"designed": v, "quantised": getattr(design.quantised, k),
                 "relative_change": (getattr(design.quantised, k) - v) / v if v else 0.0}
             for k, v in design.gains.as_dict().items()}
    result = {
        "kind": "wheel", "date": _now(), "git_revision": _rev(), "source": source,
        "config_in": str(config_src), "config_out": str(out / "config"), "ini": str(ini),
        "records": [{"wheel": r.wheel, "experiments": len(r.segments), "replayed": r.replayed,
                     "samples": int(sum(len(sg.y) for sg in r.segments)), "sample_period_s": r.sample_period_s,
                     "fits": {k: {"model": f.model.as_dict(), "nrmse": f.nrmse} for k, f in by.items()}}
                    for r, by in fits],
        "model": model.as_dict(),
        "targets": design.targets,
        "gains": design.gains.as_dict(), "gains_quantised": design.quantised.as_dict(),
        "raw": raw, "previous_raw": previous, "quantisation": quant,
        "margins": design.margins, "margins_quantised": design.margins_quantised,
        "predicted": design.step_quantised,
        "verify": {"speed_mm_s": speed, "accel_mm_s2": accel},
    }

    # the predicted move (quantised gains) and, with a mission, the co-simulated one
    t_end = speed / accel + SETTLE_S
    tp, yp = dsg.move_response(design.quantised, design.plant, model, speed, speed / accel, t_end)
    curves = [("predicted (model, quantised gains)", tp, yp)]
    rows = [("predicted", design.step_quantised["move"])]
    verify_mission = None
    if mission is not None and not args.no_verify:
        dist = int(round(speed * speed / accel + speed * SETTLE_S + 50))
        cmd = {"t": VERIFY_T0, "fwd_cmd": "start", "accel": int(accel), "speed": int(speed), "distance": dist}
        text = exp.mission_text(mission, VERIFY_T0 + 2 * speed / accel + SETTLE_S + 1.0, [cmd],
                                note="navkit tune wheel: verification move")
        verify_mission = out / "verify_wheel.toml"
        verify_mission.write_text(text)
        # how far prediction and co-simulation part: deviations in mm/s
        result["simulated"] = _verify(
            args, out, verify_mission, args.firmware, lambda d: _truth(d, "v_mm_s"), speed, 0.05, tp, yp,
            t_end, f"the verification move never reached 5 % of {speed:g} mm/s",
            "co-simulated (truth speed)", "move", curves, rows)
    else:
        result["simulated"] = None
    curves.append(("setpoint", tp, speed * np.minimum(tp / (speed / accel), 1.0)))

    # robustness
    def sample_loop(m):
        p = dsg.plant_d(m, dt, args.compute_delay)
        loop, t = dsg.wheel_loops(design.quantised, p)

        def overshoot():
            _, yy = dsg.move_response(design.quantised, p, m, speed, speed / accel, speed / accel + SETTLE_S,
                                      loop=loop, t=t)
            return max(float(yy.max()) - speed, 0.0) / speed * 100.0
        return loop, overshoot

    extract = functools.partial(extract_move, t0=VERIFY_T0, t1=VERIFY_T0 + speed / accel + SETTLE_S + 0.5,
                                speed=speed)
    result["robustness"] = _robust(args, args.firmware, model, mission, verify_mission, out, sample_loop, extract)

    # figures
    from navkit.tune import plots

    plots.fit_png(out / "fit.png", fits)
    loops = [("designed", dsg.wheel_loops(design.gains, design.plant)[0]),
             ("quantised", dsg.wheel_loops(design.quantised, design.plant)[0])]
    plots.bode_png(out / "bode.png", loops, f"wheel loop, PM {mq['phase_margin_deg']:.1f} deg, "
                   f"GM {mq['gain_margin_db']:.1f} dB, crossover {mq['crossover_hz']:.2f} Hz")
    table = _info_text(rows) + "\n\ngains (raw): " + ", ".join(f"{k} {v}" for k, v in raw.items())
    table += _robust_text(result["robustness"])
    plots.step_png(out / "step.png", curves, f"wheel speed, move at {speed:g} mm/s, {accel:g} mm/s^2",
                   "speed (mm/s)", table)
    (out / "tune.json").write_text(json.dumps(_jsonable(result), indent=2) + "\n")
    return result


def _robust(args, firmware: str, model: ident.Model, mission, verify_mission, out: Path, sample_loop,
            extract) -> dict:
    """The robustness section of a tuning: over args.samples plant variations (+/-
    args.variation) of `model`, sample_loop(scaled model) -> (open loop, overshoot()) gives
    each sample's loop and the function of its overshoot (%, called only for a stable
    loop); their margins (deg, dB) and overshoots, the worst of each; with
    --cosim-samples and a verification mission, the first samples co-simulated through
    navkit.sweep and `extract`ed (SIL only)."""
    res = {"samples": args.samples, "variation": args.variation, "seed": args.seed}
    if args.samples <= 0:
        return res
    from navkit.paths import build_dir
    from navkit.sim.harness import fmu_paths

    build = Path(args.build) if args.build else build_dir()
    nominal = robust.plant_nominal(fmu_paths(build)[1], dict(mission.plant) if mission else {})
    if nominal is None:
        res["note"] = "the plant FMU lacks the parameters the analytic part scales"
        return res
    samples = robust.draw(args.samples, args.seed, args.variation)
    per = []
    for f in samples:
        loop, overshoot = sample_loop(model.scaled(*robust.model_ratios(nominal, f)))
        stable = dsg.stable(loop)
        mg = dsg.margins(loop) if stable else {"phase_margin_deg": math.nan, "gain_margin_db": math.nan}
        per.append({"factors": f, "stable": stable, "phase_margin_deg": mg["phase_margin_deg"],
                    "gain_margin_db": mg["gain_margin_db"], "overshoot_pct": overshoot() if stable else math.inf})
    res["analytic"] = {
        "samples": len(per), "variation": args.variation, "unstable": sum(not p["stable"] for p in per),
        "worst_phase_margin_deg": robust.worst(per, "phase_margin_deg", True),
        "worst_gain_margin_db": robust.worst(per, "gain_margin_db", True),
        "worst_overshoot_pct": robust.worst(per, "overshoot_pct", False),
        "per_sample": per,
    }
    if args.cosim_samples > 0 and verify_mission is not None and firmware != "fmu":
        res["cosim_note"] = "co-simulated samples run the firmware FMU only (navkit.sweep): skipped for --firmware avr"
    elif args.cosim_samples > 0 and verify_mission is not None:
        res["cosim"] = _sweep(verify_mission, samples[:args.cosim_samples], nominal, out / "config",
                              out / "robust", args.build, args.workers, extract)
    return res


def _robust_text(res: dict) -> str:
    """The Monte Carlo lines of a step plot's table ("" without an analytic part)."""
    a = res.get("analytic")
    if not a:
        return ""
    return (f"\n\nMonte Carlo ({a['samples']} plants, +/-{a['variation'] * 100:g} %):\n"
            f"  worst PM {a['worst_phase_margin_deg']:.1f} deg, GM {a['worst_gain_margin_db']:.1f} dB,\n"
            f"  overshoot {a['worst_overshoot_pct']:.1f} %")


# ---------------------------------------------------------------- heading

def tune_heading(args) -> dict:
    """The whole `navkit tune heading` on top of a wheel tuning's folder; returns tune.json's
    content."""
    wheel_dir = Path(args.wheel)
    tj_path = wheel_dir / "tune.json"
    if not tj_path.is_file():
        raise TuneError(f"{tj_path}: no such file (--wheel takes the --out folder of `navkit tune wheel`)")
    try:
        tj = json.loads(tj_path.read_text())
        model = ident.Model(**tj["model"])
        gq = dsg.WheelGains(**tj["gains_quantised"])
        dt = 1.0 / float(tj["targets"]["control_rate_hz"])
        cd = int(tj["targets"]["compute_delay_ticks"])
        firmware = tj.get("source", {}).get("firmware", "fmu")
    except (ValueError, KeyError, TypeError) as e:
        raise TuneError(f"{tj_path}: not a wheel tuning's tune.json ({type(e).__name__}: {e})") from None
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    config_src = wheel_dir / "config"
    try:
        previous = int(cfg.motion_value(config_src, "heading_kp", args.build))
    except cfg.ConfigError as e:
        raise TuneError(str(e)) from None
    plant = dsg.plant_d(model, dt, cd)
    _, tw = dsg.wheel_loops(gq, plant)
    spread = float(tj["targets"].get("gain_spread", 0.0))
    also = []
    if spread > 0:
        also.append(dsg.wheel_loops(gq, dsg.plant_d(dsg.corner_model(model, spread), dt, cd))[1])
    hd = dsg.design_heading(tw, pm_deg=args.pm, bandwidth_hz=args.bandwidth, overshoot_pct=args.overshoot,
                            gm_min_db=args.gm_min, also_on=also)
    mq = hd.margins_quantised
    provenance = [
        f"navkit tune heading, {_now()}, git {_rev()}",
        f"on the wheel loops of {tj_path} ({_model_line(model)})",
        f"targets: phase margin {args.pm:g} deg, overshoot {args.overshoot:g} %, gain margin >= {args.gm_min:g} dB"
        + (f" (also with a motor constant {spread * 100:g} % weaker)" if spread > 0 else ""),
        f"result: phase margin {mq['phase_margin_deg']:.1f} deg, gain margin {mq['gain_margin_db']:.1f} dB, "
        f"crossover {mq['crossover_hz']:.2f} Hz",
        f"previous: heading_kp {previous}",
    ]
    ini = cfg.write_tuned(config_src, out / "config", {"heading_kp": hd.raw}, "heading", provenance, args.build)
    mission_path = Path(args.mission) if args.mission else (
        Path(tj["source"]["mission"]) if "mission" in tj.get("source", {}) else None)
    mission = exp.load_mission(mission_path) if mission_path else None
    rate, accel, target = float(args.turn_rate), float(args.turn_accel), float(args.turn_deg)
    t_end = target / rate + 2 * rate / accel + SETTLE_S
    tp, yp = dsg.heading_response(tw, hd.kp_quantised, target, rate, accel, t_end)
    pred_info = dsg.step_info(tp, yp / target)
    result = {
        "kind": "heading", "date": _now(), "git_revision": _rev(), "wheel_tuning": str(tj_path),
        "config_in": str(config_src), "config_out": str(out / "config"), "ini": str(ini),
        "model": model.as_dict(), "wheel_gains_quantised": gq.as_dict(), "targets": hd.targets,
        "heading_kp": hd.kp, "heading_kp_quantised": hd.kp_quantised, "raw": {"heading_kp": hd.raw},
        "previous_raw": {"heading_kp": previous},
        "quantisation": {"heading_kp": {"designed": hd.kp, "quantised": hd.kp_quantised,
                                        "relative_change": (hd.kp_quantised - hd.kp) / hd.kp}},
        "margins": hd.margins, "margins_quantised": hd.margins_quantised,
        "predicted": {"step": hd.step_quantised["step"], "heading_select": pred_info},
        "verify": {"target_deg": target, "turn_rate_dps": rate, "turn_accel_dps2": accel},
    }
    curves = [("predicted (HdgSel law on the model)", tp, yp)]
    rows = [("predicted", pred_info)]
    verify_mission = None
    if mission is not None and not args.no_verify:
        cmd = {"t": VERIFY_T0, "turn_mode": "heading_select", "turn_rate": int(round(rate * 10)),
               "turn_accel": int(round(accel * 10)), "turn_distance": int(round(target * 10))}
        verify_mission = out / "verify_heading.toml"
        verify_mission.write_text(exp.mission_text(mission, VERIFY_T0 + t_end + 1.0, [cmd],
                                                   note="navkit tune heading: verification heading select"))
        # deviations in deg
        result["simulated"] = _verify(
            args, out, verify_mission, firmware, _truth_turn, target, 0.02, tp, yp, t_end,
            f"the verification heading select never turned 2 % of {target:g} deg",
            "co-simulated (truth heading)", "heading_select", curves, rows)
    else:
        result["simulated"] = None

    import control

    def sample_loop(m):
        _, twi = dsg.wheel_loops(gq, dsg.plant_d(m, dt, cd))
        loop = hd.kp_quantised * dsg.heading_plant(twi)
        return loop, lambda: dsg.step_info(control.feedback(loop, 1), t_end=2.0)["overshoot_pct"]

    extract = functools.partial(extract_turn, t0=VERIFY_T0, target=target)
    result["robustness"] = _robust(args, firmware, model, mission, verify_mission, out, sample_loop, extract)

    from navkit.tune import plots

    plots.bode_png(out / "bode.png", [("designed", hd.kp * hd.plant), ("quantised", hd.kp_quantised * hd.plant)],
                   f"heading loop, PM {mq['phase_margin_deg']:.1f} deg, GM {mq['gain_margin_db']:.1f} dB, "
                   f"crossover {mq['crossover_hz']:.2f} Hz")
    table = _info_text(rows) + f"\n\nheading_kp raw {hd.raw} (was {previous})" + _robust_text(result["robustness"])
    plots.step_png(out / "step.png", curves + [("target", tp, np.full_like(tp, target))],
                   f"heading select to {target:g} deg at {rate:g} deg/s, {accel:g} deg/s^2", "heading (deg)", table)
    (out / "tune.json").write_text(json.dumps(_jsonable(result), indent=2) + "\n")
    return result
