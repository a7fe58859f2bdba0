"""A run's summary (summary.json): what ran, how fast, what the log worker counted, what
became of the host, the link, the planner's commands and the faults, from the parts of a
stopped navkit.sim.rig.SimRig and its navkit.sim.faults.Faults. Times in s, memory in MiB."""

from __future__ import annotations

import resource

from navkit.sim.options import fmu_paths
from navkit.sim.rig import datalogs

__all__ = ["summary", "planner_summary", "refusal"]


def summary(rig, faults, wall_s: float) -> dict:
    """summary.json of `rig` (stopped: its log's results are in) after `wall_s` s of wall
    time; ends the line noise in force (adding its counts)."""
    res = rig.results or {}
    micro = res.get("last_micro") or {}
    lisp = res.get("last_lisp") or {}
    link = res.get("link", {})
    h2m, m2h = link.get("h2m", {}), link.get("m2h", {})
    faults.end_noise()
    out = {
        "mission": str(rig.m.path),
        "seed": rig.opts.seed,
        "plant_fmu": str(rig.plant_fmu),
        "firmware": rig.opts.firmware,
        "firmware_fmu": str(rig.fw_fmu or fmu_paths(rig.build, rig.opts.firmware)[0]),
        "control_rate_hz": rig.control_rate,
        "mode": "realtime" if rig.opts.realtime else "lockstep",
        "sim_time_s": round(rig.sim_time_s, 6),
        "wall_time_s": round(wall_s, 3),
        "realtime_factor": round(rig.sim_time_s / wall_s, 1) if wall_s > 0 else None,
        "frames": rig.frames,
        "frame_s": rig.frame_s,
        "truth": res.get("last_truth"),
        "micro": micro,
        "planner_data": lisp,
        "link": {
            "host_to_micro": dict(h2m, micro_counters={
                k: micro.get(k) for k in micro if k.startswith("rx_")}),
            "micro_to_host": dict(m2h, host_link_errors=lisp.get("link_errors")),
            "crc_errors": h2m.get("crc_errors", 0) + m2h.get("crc_errors", 0),
            "resyncs": h2m.get("resyncs", 0) + m2h.get("resyncs", 0),
            "line_noise": dict(faults.noise_stats),
            "bytes_dropped_at_port": rig.port.dropped if rig.port else 0,
            "transport": rig.opts.link,
        },
        "memory_peak_mib": {
            "harness": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "log_worker": round(res["peak_rss_kib"] / 1024, 1) if res.get("peak_rss_kib") else None,
            "host": round(rig.host_peak_kib / 1024, 1) if rig.host_peak_kib else None},
        "host": {"state": rig.host_state, "exit_status": rig.host_exit,
                 "overruns": lisp.get("overruns"),
                 "config_downloads": res.get("config_downloads"),
                 "host_status": lisp.get("host_status")},
        "watchdog_stops": res.get("watchdog_stops"),
        "planner": planner_summary(res.get("planner")),
        "datalogs": sorted(name for name, mtime in datalogs(rig.out).items()
                           if rig.old_datalogs.get(name) != mtime),
        "messages": res.get("counts", {}),
        "time_share_s": {k: round(v, 3) for k, v in rig.times.items()},
        "log_worker_cpu_s": res.get("cpu_s"),
    }
    if rig.gateway is not None:  # --link can: the simulated bus (can.log holds its frames)
        g = rig.gateway
        out["link"]["can"] = {"frames": g.frames, "error_frames": g.error_frames,
                              "micro_replies_skipped": g.skipped, "adapter": dict(g.adapter.stats),
                              "micro_iso_tp_rx": dict(g.micro.rx.stats), "micro_iso_tp_tx": g.micro_tx_stats()}
    if rig.fmu_split:
        out["fmu_split_s"] = [round(x, 3) for x in rig.fmu_split]
    if rig.rate_note:
        out["control_rate_note"] = rig.rate_note
    if rig.fw_profile:
        out["firmware_profile"] = rig.fw_profile
    return out


def refusal(cmd: dict, result: str) -> str:
    """Why the host refused planner command `cmd` (lisp_cmd fields) with lisp_data
    nav_result `result` (host/src/navigation.cpp, Navigation::convert)."""
    from navkit import protocol

    enums = protocol.SPEC.enums
    if result == "not_implemented":
        fwd = cmd["fwd_cmd"]
        name = {c: n for n, c in enums["fwd_cmd"].values.items()}.get(fwd, "?")
        return f"fwd_cmd {fwd} ({name}) is a high-level code; the rest of the command applies"
    if result == "rejected" and cmd["turn_mode"] == enums["turn_mode"].values["heading_hold"]:
        return ("heading hold (turn_mode 11) needs the micro's current heading and the host "
                "had none (no fresh micro_data: micro offline); the command was dropped")
    if result == "rejected":
        return ("the command was dropped: a value does not fit the micro command the host makes "
                "of it, or a console stop key (space) came in the same frame (see host.log)")
    return f"lisp_data.nav_result = {result}"


def planner_summary(planner: dict | None) -> dict:
    """summary.json `planner` from the log's verdicts: commands written, how many the host
    accepted, rejected, did not implement or never acknowledged, and `refused`, one entry
    per command not accepted ([[command]] index, t in s, nav_result, reason). Each
    nav_result of the spec but ok has its count (rejected, not_implemented,
    planner_timeout)."""
    from navkit import protocol

    names = {c: n for n, c in protocol.SPEC.enums["nav_result"].values.items()}
    out = {"commands": 0, "accepted": 0, **{n: 0 for n in names.values() if n != "ok"},
           "unacknowledged": 0, "refused": []}
    if not planner:
        return out
    out["commands"] = planner["commands"]
    out["unacknowledged"] = len(planner["unacknowledged"])
    for (index, t, where), cmd, code in planner["verdicts"]:
        result = names.get(code, str(code))
        if result == "ok":
            out["accepted"] += 1
            continue
        out[result] = out.get(result, 0) + 1   # a code the spec does not name: under its number
        out["refused"].append({"command": index, "t": t, "where": where,
                               "nav_result": result, "reason": refusal(cmd, result)})
    return out
