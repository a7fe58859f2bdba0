"""`navkit sim --link can`: the real host on `[micro] link = slcan`, the harness as its
USB-CAN adapter (navkit.can_gateway), the firmware FMU behind. The demo mission ends where
it ends over serial, every planner command accepted, no watchdog stop; the bus's frames in
can.log decode with `navkit can dump`; line noise becomes error frames, and CAN resends;
what the micro's ISO-TP aborts reaches the host in micro_data's can_* counters."""

import json

from navkit.paths import repo_root
from sim_helpers import can_dump, require_build, run_mission

DEMO = (repo_root() / "config" / "missions" / "demo.toml").read_text()


def test_the_demo_over_can_ends_where_it_ends_over_serial(tmp_path_factory):
    serial = run_mission(tmp_path_factory, "demo-serial", DEMO)
    can = run_mission(tmp_path_factory, "demo-can", DEMO, link="can")
    a, b = serial.summary, can.summary
    for key in ("x_mm", "y_mm", "yaw_deg"):
        assert abs(a["truth"][key] - b["truth"][key]) < 5, (key, a["truth"], b["truth"])
    assert b["planner"]["accepted"] == b["planner"]["commands"] == a["planner"]["commands"]
    assert b["watchdog_stops"] == 0 and b["link"]["transport"] == "can" and a["link"]["transport"] == "serial"
    c = b["link"]["can"]
    # the micro is the firmware FMU's CAN build: its ISO-TP in C behind can_rx / can_tx
    assert b["firmware_fmu"].endswith("navkit_firmware_can.fmu") and a["firmware_fmu"].endswith("navkit_firmware.fmu")
    rx = c["micro_iso_tp_rx"]
    # a reply asked while the last is still going out (each command's last frames come with
    # the flow control for the last reply) waits until the sender is free: none is skipped
    # in the run; at its end the shutdown's stop follows the last command within ms
    # (navkit.sim.playout), and the micro answers both with one micro_data
    assert c["adapter"]["refused"] == 0
    assert c["micro_replies_skipped"] == 1
    assert rx["good"] - c["micro_iso_tp_tx"]["sent"] == 1 + 1  # that one, and the last under way
    assert rx["good"] > 200 and rx["wrong_sn"] == rx["timeout"] == rx["bad_frame"] == 0
    # the host's micro_data arrive as over serial: one per message, none lost
    m2h = b["link"]["micro_to_host"]
    assert m2h["frames_received"] == m2h["frames_sent"] and m2h["host_link_errors"] == 0
    # the bus log decodes with the spec, both ways, nothing refused
    r = can_dump(can.out / "can.log")
    assert r.returncode == 0, r.stderr[-2000:]
    names = [json.loads(ln)["message"] for ln in r.stdout.splitlines()]
    assert len(names) - names.count("micro_data") == rx["good"], "every message the micro got, in the log"
    assert names.count("micro_data") == c["micro_iso_tp_tx"]["sent"], "every micro_data it sent whole"
    assert [n for n in names if n != "micro_data"][:3] == ["micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io"]
    assert f"{c['frames']} frames" in r.stderr


def test_run_mcap_has_the_bus_frames_of_can_log_on_its_can_topic(tmp_path_factory):
    """/can holds every frame of can.log (both ways, flow controls), with the same id, data
    and direction, in a CAN run's run.mcap and only there; its schema names units."""
    import mcap.reader

    serial = run_mission(tmp_path_factory, "demo-serial", DEMO)
    can = run_mission(tmp_path_factory, "demo-can", DEMO, link="can")
    assert "/can" not in serial.topics and "/can" not in serial.summary["messages"]
    frames = can.messages("/can")
    lines = (can.out / "can.log").read_text().splitlines()
    assert len(frames) == len(lines) == can.summary["messages"]["/can"] == can.summary["link"]["can"]["frames"]
    for (t, m), line in zip(frames, lines):       # "(t) can0 ID#DATA R|T"
        stamp, _, frame, *rx = line.split()
        can_id, data = frame.split("#")
        assert (m["id"], m["data"], m["dlc"]) == (int(can_id, 16), data.lower(), len(data) // 2), line
        assert m["direction"] == ("to_host" if rx == ["R"] else "to_micro") and not m["error_frame"]
        assert abs(t - float(stamp[1:-1])) < 1e-6 and m["t"] == t
    ids = {m["id"] for _, m in frames}
    assert {0x110, 0x111, 0x120, 0x180, 0x181} <= ids
    with open(can.out / "run.mcap", "rb") as f:
        schema = next(s for s in mcap.reader.make_reader(f).get_summary().schemas.values()
                      if s.name == "navkit.can_frame")
    assert "simulated time, s" in schema.data.decode() and "to_host" in schema.data.decode()


def _line_noise(duration_s: float, ber: float) -> str:
    """A mission of `duration_s` s: a 1000 mm leg at 300 mm/s from 0.5 s, the line noisy at
    bit error rate `ber` from 1 s until 1 s before the end."""
    return f"""
duration_s = {duration_s}
[[fault]]
t = 1.0
kind = "line_noise"
ber = {ber}
duration_s = {duration_s - 2.0}
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 1000
"""


def test_line_noise_over_can_is_error_frames_and_nothing_lost(tmp_path_factory):
    r = run_mission(tmp_path_factory, "noise-can", _line_noise(6.0, 2e-4), link="can")
    s = r.summary
    c = s["link"]["can"]
    assert c["error_frames"] > 10, c          # ~2 % of the frames meet a bit error at 2e-4
    assert c["micro_iso_tp_rx"]["wrong_sn"] == 0 and s["link"]["micro_to_host"]["host_link_errors"] == 0
    assert s["link"]["line_noise"]["flips"] == 0, "no byte is corrupted: CAN resends"
    assert abs(s["truth"]["distance_mm"] - 1000) <= 15 and s["watchdog_stops"] == 0
    # can.log holds the error frames; navkit can dump counts them and finds nothing refused
    d = can_dump(r.out / "can.log")
    assert d.returncode == 0 and f"{c['error_frames']} error frames" in d.stderr, d.stderr[-1000:]
    # run.mcap's /can has them too, each before the try it destroyed (same identifier)
    frames = [m for _, m in r.messages("/can")]
    assert len(frames) == len((r.out / "can.log").read_text().splitlines())
    errors = [i for i, m in enumerate(frames) if m["error_frame"]]
    assert len(errors) == c["error_frames"]
    assert all(frames[i]["dlc"] == 0 and frames[i]["id"] == frames[i + 1]["id"] for i in errors)


def test_line_noise_duplicates_move_the_micros_counters(tmp_path_factory):
    """18 s of a bad bus (bit error rate 1e-3: one frame in ten meets an error frame): a few
    frames are taken twice (an error in the transmitter's last end-of-frame bit), a
    duplicated consecutive frame aborts its message, a duplicated first frame restarts it.
    The micro's own counters in micro_data (0 before the noise) are what a bus analyser's
    ISO-TP counts from the same frames (the gateway listening, navkit can dump); the
    repeats of the command make it good."""
    r = run_mission(tmp_path_factory, "noise-dup-can", _line_noise(20.0, 1e-3), link="can")
    s = r.summary
    frames = [m for _, m in r.messages("/can")]

    def key(m):
        return m["id"], m["data"], m["direction"]
    dups = 0          # a frame, error frames, the same frame: the receivers took both
    for i, m in enumerate(frames[:-1]):
        if not m["error_frame"] and frames[i + 1]["error_frame"]:
            nxt = next(f for f in frames[i + 1:] if not f["error_frame"])
            dups += key(nxt) == key(m)
    assert dups >= 2, dups
    # can_rx_lost is the controller's count, before ISO-TP (none lost here)
    own = {k: v for k, v in s["micro"].items() if k.startswith("can_rx_") and k != "can_rx_lost"}
    analyser = {f"can_rx_{k}": v for k, v in s["link"]["can"]["micro_iso_tp_rx"].items() if k != "good"}
    assert s["micro"]["can_rx_lost"] == 0
    assert own == analyser and own["can_rx_wrong_sn"] + own["can_rx_restarted"] >= 1, (own, analyser)
    data = r.messages("/micro/data")
    assert all(not any(m[k] for k in own) for t, m in data if t < 1.0)
    assert {k: data[-1][1][k] for k in own} == own
    assert abs(s["truth"]["distance_mm"] - 1000) <= 15 and s["watchdog_stops"] == 0
    d = can_dump(r.out / "can.log")
    assert f"rx_wrong_sn {own['can_rx_wrong_sn']}" in d.stderr.split("the micro's own")[1], d.stderr[-1000:]
    assert f"wrong_sn {own['can_rx_wrong_sn']}" in d.stderr.split("host to micro:")[1].split(";")[0]


UNPLUG = """
duration_s = 9.0
[[command]]
t = 1.5
fwd_cmd = 1
speed = 200
distance = 5000
[[fault]]
t = 3.0
kind = "unplug"
duration_s = 1.0
[[command]]
t = 6.0
fwd_cmd = 1
speed = 200
distance = 400
"""


def test_an_unplugged_adapter_comes_back_and_commands_flow_again(tmp_path_factory):
    """The host reopens the port and sets the adapter up again (C, Sn, O); the next command
    goes through."""
    r = run_mission(tmp_path_factory, "unplug-can", UNPLUG, link="can")
    assert r.truth_at(3.0)["v_mm_s"] > 180
    assert all(abs(m["v_mm_s"]) < 2 for m in r.truth_between(4.5, 6.0)), "watchdog stop"
    d6 = r.truth_at(6.0)["distance_mm"]
    assert abs(r.truth[-1]["distance_mm"] - (d6 + 400)) <= 15, "commands flow again"
    assert r.summary["link"]["can"]["adapter"]["commands"] > 0
    assert (r.out / "host.log").read_text().count("SLCAN adapter, CAN at 500000 bit/s") == 2


def test_the_micros_can_counters_reach_the_host_and_run_mcap(tmp_path_factory):
    """The adapter unplugged for 1 s cuts one message each way: the micro's reception of a
    micro_cmd misses its consecutive frames (N_Cr), its micro_data misses the host's flow
    control (N_Bs). The firmware's own counters say so in micro_data: 0 before, 1 each
    after, the rest 0, in run.mcap's /micro/data, summary.json and the host's closing line;
    the bus analyser (the gateway listening) saw the same N_Cr abort."""
    r = run_mission(tmp_path_factory, "unplug-can", UNPLUG, link="can")
    data = r.messages("/micro/data")
    zero = {k: 0 for k in data[0][1] if k.startswith("can_")}
    assert len(zero) == 11
    before = [m for t, m in data if t < 3.0]
    after = [m for t, m in data if t > 4.5]
    assert before and after
    assert all({k: m[k] for k in zero} == zero for m in before)
    want = dict(zero, can_rx_timeout=1, can_tx_timeout=1)
    assert all({k: m[k] for k in zero} == want for m in after), after[-1]
    assert {k: r.summary["micro"][k] for k in zero} == want
    assert r.summary["link"]["can"]["micro_iso_tp_rx"]["timeout"] == 1
    assert ("micro's CAN counters (its last micro_data): 0 frames refused, 0 stray consecutive frames; "
            "messages to it aborted: 0 out of sequence, 0 restarted, 1 N_Cr timeouts, 0 overflows; micro_data "
            "abandoned: 1 N_Bs timeouts") in (r.out / "host.log").read_text()


def test_real_time_over_can(tmp_path_factory):
    r = run_mission(tmp_path_factory, "realtime-can", """
duration_s = 2.5
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 300
""", link="can", realtime=True)
    s = r.summary
    assert s["mode"] == "realtime" and abs(s["truth"]["distance_mm"] - 300) <= 15
    m2h = s["link"]["micro_to_host"]
    assert m2h["frames_received"] == m2h["frames_sent"] > 10 and m2h["crc_errors"] == 0


def test_bench_sim_over_can_prints_its_figures(capsys):
    import argparse

    from navkit import sim_bench

    require_build()
    parser = argparse.ArgumentParser()
    sim_bench.add_arguments(parser)
    assert sim_bench.run(parser.parse_args(["--minutes", "0.5", "--link", "can"])) == 0
    out = capsys.readouterr().out
    assert "real-time factor" in out and "can link: " in out and " CAN frames)" in out
