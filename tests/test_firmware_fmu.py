"""The firmware FMU (build/fmus/navkit_firmware.fmu) in fmpy.

The model description is checked against the C variable table it was generated from and
against docs/internals.md; then micro_cmd frames from the Python codec go into serial_rx
(after the three config frames), a simple wheel model in the test closes the loop, and
the micro_data frames from serial_tx must report the motion the wheels really made.
"""

from __future__ import annotations

import math
import re
from xml.etree import ElementTree

import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from navkit import protocol  # noqa: E402
from navkit.paths import build_dir, repo_root, spec_path  # noqa: E402
from firmware_helpers import Wheels, cmd, config_frames  # noqa: E402
from spec_helpers import FWD_CMD, TURN_CMD  # noqa: E402

FMU = build_dir() / "fmus" / "navkit_firmware.fmu"
MODEL_H = repo_root() / "fmu" / "firmware" / "fw_fmu_model.h"
pytestmark = pytest.mark.skipif(not FMU.exists(), reason=f"{FMU} not built")


def run(micro, wheels: Wheels | None, seconds: float, frame: bytes = b"",
        frame_period: float = 0.1) -> list[dict]:
    """Co-simulate in 1 ms steps; the host repeats `frame` every frame_period. Returns the
    micro_data frames received."""
    return micro.frames(seconds, frame, 0.001, frame_period,
                        before=wheels and wheels.drive, after=wheels and wheels.advance)


# ---------------------------------------------------------------- the description


def test_passes_fmpy_validation():
    assert validate_fmu(str(FMU)) == []


def _c_table():
    """{name: (vr, type, causality, unit, start)} from fw_fmu_model.h; unit None for the
    integer and Binary rows (no unit attribute), start None for outputs (not described)."""
    text = MODEL_H.read_text()
    macros = dict(re.findall(r"#define (FW_FMU_\w+) (\S+)", text))
    table = {}
    for block, typ in (("FLOAT64", "Float64"), ("INT32", "Int32"), ("UINT32", "UInt32"), ("BINARY", "Binary")):
        body = re.search(rf"#define FW_FMU_{block}_VARS\(X\)(.*?)\n\n", text, re.S).group(1)
        if typ == "Binary":
            for vr, name, caus in re.findall(r"X\((\d+), (\w+), (\w+)", body):
                table[name] = (int(vr), typ, caus, None, "" if caus == "input" else None)
            continue
        rows = re.findall(r'X\((\d+), (\w+), (\w+), \w+, "([^"]*)", ([^,]+),', body)
        assert rows, block
        for vr, name, caus, unit, start in rows:
            start = macros.get(start, start).rstrip("u")
            has_start = caus in ("input", "parameter")
            table[name] = (int(vr), typ, caus, unit if typ == "Float64" else None,
                           float(start) if has_start else None)
    return table


def test_description_matches_the_c_table(md):
    """Every variable of the C table (fw_fmu_model.h) is in modelDescription.xml with the
    same value reference, type, causality, unit and start value, and nothing else is."""
    def start(v):
        if v.start is None or v.type == "Binary":
            return v.start if v.start is None else ""
        return float(v.start)
    described = {v.name: (v.valueReference, v.type, v.causality, v.unit if v.type == "Float64" else None, start(v))
                 for v in md.modelVariables}
    assert described == _c_table()
    assert described["battery_voltage"][3:] == ("V", 12.0) and described["baud"][4] == 115200.0


def test_description_names_the_spec(unzipped, md):
    """The description names the protocol spec the firmware was built from: its file, in
    the description attribute and in the org.navkit.spec annotation, with the spec hash of
    this checkout's spec (a stale FMU built from another spec fails here)."""
    spec_file = spec_path().relative_to(repo_root()).as_posix()
    root = ElementTree.parse(f"{unzipped}/modelDescription.xml").getroot()
    specs = root.findall("./Annotations/Annotation[@type='org.navkit.spec']/Spec")
    assert [s.attrib for s in specs] == [{"file": spec_file, "spec_hash": f"0x{protocol.SPEC_HASH:08x}",
                                          "sha256": protocol.SPEC.hash_hex}]
    assert md.description.endswith(f"; protocol spec {spec_file}, spec_hash 0x{protocol.SPEC_HASH:08x}")


def test_step_size_is_the_default_control_tick(md):
    """fixedInternalStepSize is one tick at the spec's default control_rate (the FMU after
    reset); test_control_rate_from_config shows it stepping at a configured rate."""
    rate = protocol.defaults("micro_cfg_geometry")["control_rate"]
    assert float(md.coSimulation.fixedInternalStepSize) == pytest.approx(1.0 / rate)
    assert float(md.defaultExperiment.stepSize) == pytest.approx(1.0 / rate)


def test_description_has_the_internals_contract(md):
    """The names, types and causalities docs/internals.md fixes for the firmware FMU."""
    want = {"motor_left_duty": ("Float64", "output"), "motor_right_duty": ("Float64", "output"),
            "dio_out": ("Int32", "output"), "dio_dir": ("Int32", "output"),
            "enc_left": ("Int32", "input"), "enc_right": ("Int32", "input"),
            "gyro_raw": ("Int32", "input"), "compass_raw": ("Int32", "input"),
            "battery_voltage": ("Float64", "input"), "dio_in": ("Int32", "input"),
            "serial_rx": ("Binary", "input"), "serial_tx": ("Binary", "output")}
    want.update({f"servo_pulse_{i}": ("Float64", "output") for i in range(8)})
    want.update({f"ir_voltage_{i}": ("Float64", "input") for i in range(4)})
    want.update({f"sonar_echo_{i}": ("Float64", "input") for i in range(4)})
    got = {v.name: (v.type, v.causality) for v in md.modelVariables}
    for name, tc in want.items():
        assert got.get(name) == tc, name
    units = {v.name: v.unit for v in md.modelVariables if v.type == "Float64"}
    assert units["battery_voltage"] == "V" and units["servo_pulse_3"] == "us"
    assert md.coSimulation.modelIdentifier == "navkit_firmware"


def test_every_described_variable_is_served_by_the_code(micro, md):
    """Each variable of the description can be read through its type's getter, and a
    value reference the description does not have is refused."""
    m = micro()
    getters = {"Float64": m.fmu.getFloat64, "Int32": m.fmu.getInt32, "UInt32": m.fmu.getUInt32,
               "Binary": m.fmu.getBinary}
    for v in md.modelVariables:
        getters[v.type]([v.valueReference])
    with pytest.raises(FMICallException):
        m.fmu.getFloat64([999])
    with pytest.raises(FMICallException):
        m.fmu.getInt32([m.vr["motor_left_duty"]])  # right number, wrong type
    with pytest.raises(FMICallException):
        m.set(motor_left_duty=0.5)  # outputs cannot be set


def test_simulates_in_fmpy():
    r = fmpy.simulate_fmu(str(FMU), stop_time=0.3, output_interval=0.001)
    assert len(r) == 301
    assert max(abs(r["motor_left_duty"])) == 0.0  # unconfigured: motors off


# ---------------------------------------------------------------- FMI behaviour


def test_state_table_and_step_sizes(micro):
    m = micro(start=False)
    with pytest.raises(FMICallException):
        m.fmu.doStep(0.0, 0.001)  # not in step mode yet
    m.start()
    m.fmu.setDebugLogging(True, ["logEvents", "logStatusError"])
    with pytest.raises(FMICallException):
        m.fmu.setDebugLogging(True, ["logEverything"])  # no such category
    with pytest.raises(FMICallException):
        m.fmu.setUInt32([m.vr["baud"]], [9600])  # fixed parameter, step mode
    m.step(0.001)
    m.step(0.1)  # 100 control ticks
    assert m.fmu.getFloat64([m.vr["time"]])[0] == pytest.approx(0.101)
    m.step(0.0015)  # not a whole number of 1 ms ticks: runs the ticks due in it
    assert m.fmu.getFloat64([m.vr["time"]])[0] == pytest.approx(0.1025)
    with pytest.raises(FMICallException):
        m.fmu.doStep(m.t + 0.5, 0.001)  # not the current time
    m.fmu.terminate()
    with pytest.raises(FMICallException):
        m.fmu.doStep(m.t, 0.001)
    m.fmu.reset()
    m.start()
    m.step(0.001)


@pytest.mark.parametrize("rate", [500, 400])
def test_control_rate_from_config(micro, rate):
    """control_rate 500 or 400 Hz: a 2 or 2.5 ms tick under the harness's 1 ms steps runs
    at its own rate (a tick in the steps that hold its time), so the micro's clock keeps
    simulated time; the step that carries the config still ends on time."""
    m = micro()
    geo = protocol.defaults("micro_cfg_geometry")
    geo["control_rate"] = rate
    m.step(0.1, protocol.encode_frame("micro_cfg_geometry", geo, time_tag=1))
    assert m.fmu.getFloat64([m.vr["time"]])[0] == pytest.approx(0.1)
    parser = protocol.Parser(protocol.DIR_TO_HOST)

    def micro_time_after(tag: int) -> int:
        """micro_time (ms) of the reply to a config sent now, after 20 ms of 1 ms steps."""
        tx = m.step(0.001, protocol.encode_frame("micro_cfg_geometry", geo, time_tag=tag))
        for _ in range(19):
            tx += m.step(0.001)
        return [e.fields for e in parser.feed(tx)][-1]["micro_time"]

    t0 = micro_time_after(2)
    for _ in range(80):
        m.step(0.001)
    t1 = micro_time_after(3)
    assert t1 - t0 == 100  # 100 ms of 1 ms steps: 50 ticks of 2 ms or 40 of 2.5 ms


def test_unconfigured_until_three_configs_and_again_after_reset(micro, status_bit):
    m = micro()
    w = Wheels()
    configured = status_bit("configured")
    data = run(m, w, 0.3, cmd(5, fwd_cmd=1, speed=200, distance=500))
    assert len(data) == 3 and not data[-1]["status"] & configured
    assert data[-1]["cmd_rejected"] == 1 and data[-1]["last_reject"] == FWD_CMD["start"]
    assert w.dist == 0.0
    # a config built from another spec is refused and counted
    data = run(m, w, 0.05, config_frames(hash_override=protocol.SPEC_HASH ^ 1))
    assert data[-1]["rx_schema_mismatch"] == 3 and not data[-1]["status"] & configured
    data = run(m, w, 0.05, config_frames())
    assert len(data) == 3  # one micro_data per host frame
    assert data[-1]["status"] & configured
    assert data[-1]["spec_hash"] == protocol.SPEC_HASH
    # fmi3Reset = micro reset: unconfigured again
    m.fmu.reset()
    m.start()
    data = run(m, w, 0.05, cmd(6, fwd_cmd=1, speed=200, distance=500))
    assert not data[-1]["status"] & configured and data[-1]["rx_schema_mismatch"] == 0


def test_forward_move_closed_loop(micro, status_bit):
    m = micro()
    w = Wheels()
    run(m, w, 1.2)  # gyro calibration
    run(m, w, 0.05, config_frames())
    frame = cmd(10, fwd_cmd=1, speed=250, distance=800, mc_datalog_cmd=3)
    data = run(m, w, 5.0, frame)
    assert len(data) == 50  # one reply per frame the host sent
    peak = max(d["fwd_speed"] for d in data)
    assert 230 <= peak <= 265
    assert max(d["mc_datalog"][0] for d in data) == pytest.approx(250, abs=2)  # reference speed
    last = data[-1]
    assert w.dist == pytest.approx(800, abs=5)
    assert last["distance"] == pytest.approx(800, abs=5)
    assert last["x"] == pytest.approx(800, abs=6) and abs(last["y"]) <= 3
    assert last["status"] & status_bit("fwd_done")
    assert last["ack_time_tag"] == 10
    assert abs(last["enc_left"] - round(w.enc[0])) <= 1


def test_pivot_and_heading_select_across_north(micro, status_bit):
    m = micro()
    w = Wheels(gyro_bias=40)
    run(m, w, 1.2)
    run(m, w, 0.05, config_frames())
    data = run(m, w, 4.0, cmd(20, turn_cmd=1, turn_rate=450, turn_distance=-900))  # 90 deg left
    assert w.yaw_cw == pytest.approx(-90, abs=2)
    assert data[-1]["heading"] == pytest.approx(2700, abs=20)
    assert data[-1]["turn_progress"] == pytest.approx(-900, abs=20)
    # HdgSel from 270 to 30: shortest way is 120 deg clockwise, through north
    data = run(m, w, 6.0, cmd(21, turn_cmd=10, turn_rate=450, turn_distance=300))
    assert w.yaw_cw == pytest.approx(30, abs=1.5)
    assert data[-1]["heading"] == pytest.approx(300, abs=10)
    assert data[-1]["status"] & status_bit("hdg_active")
    # an unimplemented turn code is refused and counted
    data = run(m, w, 0.2, cmd(22, turn_cmd=20, turn_distance=100))
    assert data[-1]["last_reject"] == TURN_CMD["radius"] and data[-1]["cmd_rejected"] == 1


def test_watchdog_stop(micro, status_bit):
    m = micro()
    w = Wheels()
    run(m, w, 1.2)
    run(m, w, 0.05, config_frames())
    run(m, w, 2.0, cmd(30, fwd_cmd=1, speed=300, distance=2000000000))
    assert sum(w.v) / 2 == pytest.approx(300, abs=20)
    run(m, w, 1.5)  # the host goes quiet
    assert abs(w.v[0]) < 1 and abs(w.v[1]) < 1
    data = run(m, w, 0.1, cmd(30, fwd_cmd=1, speed=300, distance=2000000000))  # repeat: no resume
    assert data[-1]["status"] & status_bit("watchdog_stop")
    assert data[-1]["watchdog_stops"] == 1
    run(m, w, 1.0, cmd(31, fwd_cmd=1, speed=300, distance=2000000000))  # new start
    assert sum(w.v) / 2 == pytest.approx(300, abs=20)


def test_uart_runs_at_the_baud_rate(micro):
    """At 9600 baud a 36-byte config frame needs 37.5 ms on the line, and the micro_data
    reply (n bytes) n * 1.04 ms: the reply starts after the frame arrived and ends that
    much later."""
    m = micro(baud=9600)
    frame = protocol.encode_frame("micro_cfg_geometry", protocol.defaults("micro_cfg_geometry"), time_tag=1)
    n = len(protocol.encode_frame("micro_data", protocol.defaults("micro_data"), time_tag=1))
    reply_ms = n * 10 / 9.6
    got = []
    for k in range(300):
        tx = m.step(0.001, frame if k == 0 else b"")
        got.extend((k, b) for b in tx)
    first, last = got[0][0], got[-1][0]
    assert len(got) == n
    assert 36 <= first <= 40
    assert 36 + math.floor(reply_ms) - 1 <= last <= 40 + math.ceil(reply_ms) + 1
    assert protocol.decode_frame(bytes(b for _, b in got))[0] == "micro_data"
    # one 100 ms step at 115200 baud carries frame and reply in the same step
    m.fmu.reset()
    m.start(baud=115200)
    assert protocol.decode_frame(m.step(0.1, frame))[0] == "micro_data"


def test_instances_are_independent(micro, status_bit):
    a, b = micro("a"), micro("b")
    wa, wb = Wheels(), Wheels()
    run(a, wa, 0.05, config_frames())
    da = run(a, wa, 1.0, cmd(3, fwd_cmd=1, speed=200, distance=100))
    db = run(b, wb, 1.0, cmd(3, fwd_cmd=1, speed=200, distance=100))
    assert da[-1]["status"] & status_bit("configured")
    assert not db[-1]["status"] & status_bit("configured")
    assert wa.dist == pytest.approx(100, abs=5) and wb.dist == 0.0


def test_servo_dio_and_sensors(micro, md):
    m = micro()
    run(m, None, 0.05, config_frames())
    m.set(dio_in=0x0A00, compass_raw=1234)
    m.set(ir_voltage_0=2.5, battery_voltage=12.0, sonar_echo_1=5800.0)
    data = run(m, None, 0.6, cmd(4, rc2_param0=1000, rc2_param1=300, rc2_param2=9999,
                                 dio_command=0x0FF9))
    assert m.get("servo_pulse_2") == 1800.0 and m.get("servo_pulse_0") == 0.0
    assert m.get("dio_dir") == 0x00FF and m.get("dio_out") == 0x00F9
    d = data[-1]
    assert d["servo_pos"][2] == 300
    assert d["dio_state"] == 0x0AF9
    assert d["adc"][0] == 512 and d["adc"][4] == 819  # 12 V / 3 on a 5 V, 10-bit ADC
    # the board has ch0-4 only: the spare words are 0, and no FMU input feeds them
    assert d["adc"][5:] == [0, 0, 0]
    adc_inputs = [v.name for v in md.modelVariables if v.causality == "input" and "ADC ch" in v.description]
    assert sorted(adc_inputs) == ["battery_voltage"] + [f"ir_voltage_{i}" for i in range(4)]
    assert d["sonar_echo"][1] == 5800 and d["compass"] == 1234
