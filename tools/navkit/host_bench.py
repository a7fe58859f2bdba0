"""`navkit bench-host`: how well navkit-host keeps its real-time frame schedule.

Runs the real binary in real-time mode (`--clock real`) at each rate (default 10 Hz and
100 Hz) for a given time against a pseudo-terminal whose other end answers every host
frame with a micro_data (a configured micro, so the host sends commands), and reads the
host's `--timing-log`. Prints, per rate:

- frame start error (actual start - scheduled start t0 + k*T): median, p99, max, in us;
- cumulative drift: start error of the last frame minus that of the first (us), which
  stays near zero because deadlines are absolute;
- overruns (frames that ended after the next one should have started) and skipped frames;
- frame work time (end - start): median and max, us;
- CPU use of the host process (user + system time / wall time, %).
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import tempfile
import time
import tty
from pathlib import Path

__all__ = ["add_arguments", "run", "measure", "summarize"]


def add_arguments(parser) -> None:
    """Arguments of `navkit bench-host`."""
    parser.add_argument("--seconds", type=float, default=10.0,
                        help="run time per rate, s (default 10)")
    parser.add_argument("--rates", default="10,100",
                        help="comma-separated frame rates, Hz (default 10,100)")
    parser.add_argument("--build", type=Path, default=None,
                        help="build folder (default: $NAVKIT_BUILD_DIR or <repo>/build)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the timing logs and host logs in this folder")


def _percentile(sorted_vals: list, q: float) -> float:
    if not sorted_vals:
        return float("nan")
    i = min(len(sorted_vals) - 1, max(0, round(q * (len(sorted_vals) - 1))))
    return sorted_vals[i]


def summarize(timing_log: Path) -> dict:
    """Figures of one --timing-log file (lines: frame, scheduled, start, end in ns since
    t0): start errors (us), drift (us), overruns, skipped frames, work times (us)."""
    rows = []
    period = None
    for line in Path(timing_log).read_text().splitlines():
        if line.startswith("#"):
            period = int(line.rsplit(" ", 1)[1])
            continue
        k, sched, start, end = (int(x) for x in line.split())
        rows.append((k, sched, start, end))
    if not rows or period is None:
        raise ValueError(f"{timing_log}: no frames")
    err = sorted((s - sch) / 1e3 for _, sch, s, _ in rows)
    work = sorted((e - s) / 1e3 for _, _, s, e in rows)
    overruns = sum(1 for k, sch, s, e in rows if e > sch + period)
    skipped = rows[-1][0] + 1 - len(rows)
    return {
        "frames": len(rows),
        "start_error_us": {"median": _percentile(err, 0.5), "p99": _percentile(err, 0.99),
                           "max": err[-1]},
        "drift_us": (rows[-1][2] - rows[-1][1] - (rows[0][2] - rows[0][1])) / 1e3,
        "overruns": overruns,
        "skipped": skipped,
        "work_us": {"median": _percentile(work, 0.5), "max": work[-1]},
    }


def measure(host: Path, config_dir: Path, rate_hz: float, seconds: float, folder: Path) -> dict:
    """Run `host` at `rate_hz` for `seconds` s in `folder` with a responding micro; the
    summary of its timing log plus cpu_percent (host user + system time / wall time)."""
    from navkit import protocol

    folder.mkdir(parents=True, exist_ok=True)
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    os.set_blocking(master, False)
    link = folder / "ttyBENCH"
    if link.is_symlink():
        link.unlink()
    os.symlink(os.ttyname(slave), link)
    timing = folder / f"timing-{rate_hz:g}hz.txt"
    shm = f"/nk-bench-{os.getpid()}-{int(rate_hz)}"
    log = open(folder / f"host-{rate_hz:g}hz.log", "wb")
    proc = subprocess.Popen(
        [str(host), "--clock", "real", "--rate", str(rate_hz), "--port", str(link),
         "--shm", shm, "--config", str(config_dir), "--log-dir", str(folder),
         "--timing-log", str(timing)],
        stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT)
    parser = protocol.Parser(protocol.DIR_TO_MICRO)
    configured: set = set()
    tag = 0
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < seconds and proc.poll() is None:
            r, _, _ = select.select([master], [], [], 0.05)
            if not r:
                continue
            try:
                data = os.read(master, 4096)
            except BlockingIOError:
                continue
            for ev in parser.feed(data):
                if not isinstance(ev, protocol.Frame):
                    continue
                if ev.name.startswith("micro_cfg"):
                    configured.add(ev.name)
                tag = (tag + 1) & 0xFFFF
                status = 1 if len(configured) == 3 else 0
                os.write(master, protocol.encode_frame(
                    "micro_data", {"status": status, "spec_hash": protocol.SPEC_HASH,
                                   "ack_time_tag": ev.fields["time_tag"]}, time_tag=tag))
    finally:
        wall = time.monotonic() - t0
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        log.close()
        os.close(master)
        os.close(slave)
        link.unlink()
    out = summarize(timing)
    out["cpu_percent"] = 100.0 * (usage.ru_utime + usage.ru_stime) / wall
    out["exit_status"] = proc.returncode
    return out


def run(args) -> int:
    """Run the benchmark and print its figures; 0 on success."""
    import platform

    from navkit.paths import build_dir, repo_root

    host = (args.build or build_dir()) / "host" / "navkit-host"
    if not host.exists():
        print(f"{host} not found: build the host first")
        return 1
    rates = [float(r) for r in args.rates.split(",") if r.strip()]
    print(f"navkit-host real-time loop, {args.seconds:g} s per rate, {platform.node()} "
          f"({platform.processor() or platform.machine()}, {os.cpu_count()} CPUs)")
    with tempfile.TemporaryDirectory(prefix="navkit-bench-host-") as tmp:
        folder = args.keep or Path(tmp)
        for rate in rates:
            s = measure(host, repo_root() / "config", rate, args.seconds, folder)
            e, w = s["start_error_us"], s["work_us"]
            print(f"{rate:6g} Hz: {s['frames']} frames; start error median {e['median']:.0f} us, "
                  f"p99 {e['p99']:.0f} us, max {e['max']:.0f} us; drift {s['drift_us']:+.0f} us; "
                  f"overruns {s['overruns']}, skipped {s['skipped']}; work median "
                  f"{w['median']:.0f} us, max {w['max']:.0f} us; CPU {s['cpu_percent']:.2f} %; "
                  f"exit {s['exit_status']}")
            if s["exit_status"] != 0:
                return 1
    return 0
