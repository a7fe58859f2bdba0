"""The native coupler (fmu/cosim) with the real FMUs, without the host: connections by
name, 1 kHz stepping, serial bytes both ways, truth rows, a firmware reset."""

import array
from pathlib import Path

import pytest

from navkit import protocol as P
from navkit.paths import build_dir
from spec_helpers import bit

INPUTS_OF_FIRMWARE = ["enc_left", "enc_right", "gyro_raw", "compass_raw", "ir_voltage_0",
                      "ir_voltage_1", "ir_voltage_2", "ir_voltage_3", "battery_voltage",
                      "sonar_echo_0", "sonar_echo_1", "sonar_echo_2", "sonar_echo_3", "dio_in"]
OUTPUTS_OF_FIRMWARE = ["motor_left_duty", "motor_right_duty", "dio_out", "dio_dir"] + \
    [f"servo_pulse_{i}" for i in range(8)]


@pytest.fixture
def coupled(tmp_path: Path):
    from navkit.sim.coupler import Coupler, library_path
    from navkit.sim.fmus import FmuPair
    from navkit.sim.harness import fmu_paths
    from navkit.sim.mission import loads

    b = build_dir()
    fw, plant = fmu_paths(b)
    if not (fw.exists() and plant.exists() and library_path(b).exists()):
        pytest.skip("FMUs or the coupler not built")
    fmus = FmuPair(fw, plant, tmp_path, {"seed": 3}, loads("duration_s = 1.0", tmp_path / "m.toml"))
    c = Coupler(fmus.fw, fmus.fw_md, fmus.plant, fmus.plant_md, record_every=20, build=b)
    yield fmus, c
    c.close()
    fmus.close()


def _configs() -> bytes:
    return b"".join(P.encode_frame(n, P.defaults(n), time_tag=i) for i, n in
                    enumerate(("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io")))


def _micro_data(tx: bytes) -> list:
    return [e.fields for e in P.Parser(P.DIR_TO_HOST).feed(tx) if isinstance(e, P.Frame)]


def test_connected_by_name_and_truth_columns(coupled):
    _, c = coupled
    assert sorted(n for src, n in c.links if src == "plant") == sorted(INPUTS_OF_FIRMWARE)
    assert sorted(n for src, n in c.links if src == "firmware") == sorted(OUTPUTS_OF_FIRMWARE)
    assert c.columns[:7] == ["x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm",
                             "v_mm_s", "w_deg_s"]
    assert c.columns[-1] == "dio_out" and len(c.columns) == 16


def test_steps_serial_and_truth_rows(coupled):
    _, c = coupled
    tx, rows = c.run(200, _configs())
    assert c.steps == 200 and c.time_s == pytest.approx(0.2)
    assert len(rows) == 10 and rows[0][0] == pytest.approx(0.02) and rows[-1][0] == pytest.approx(0.2)
    data = _micro_data(tx)
    assert len(data) == 3, "one micro_data per received frame"
    assert data[-1]["status"] & bit("micro_status", "configured")
    # drive: the plant's truth moves
    cmd = P.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 300, "distance": 300}, time_tag=1)
    tx, rows = c.run(100, cmd)
    assert _micro_data(tx)[0]["ack_time_tag"] == 1
    for _ in range(30):      # the host repeats its command every 100 ms (the watchdog)
        tx, rows = c.run(100, cmd)
    assert rows[-1][1] == pytest.approx(300, abs=15), "x_mm at the end of the move"


def test_run_raw_after_run_grew_the_row_buffer(coupled):
    """run() past the truth row buffer's capacity (4096 rows) grows it for run_raw() too:
    run_raw's rows are the ones of the steps it just did, none refused."""
    _, c = coupled
    c.run(4100)
    _, raw = c.run_raw(100)
    t = array.array("d", raw)[::c.width]
    assert list(t) == pytest.approx([4.12, 4.14, 4.16, 4.18, 4.2])


def test_firmware_reset_unconfigures_and_keeps_the_plant(coupled):
    fmus, c = coupled
    c.run(100, _configs())
    cmd = P.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200, "distance": 2000}, time_tag=1)
    for _ in range(15):
        c.run(100, cmd)
    x_before = c.sample()[1]
    fmus.reset_firmware(c.time_s)
    c.firmware_restart(c.time_s)
    c.exchange()
    tx, rows = c.run(100, P.encode_frame("micro_cmd", {"fwd_cmd": 1, "speed": 200,
                                                         "distance": 2000}, time_tag=2))
    d = _micro_data(tx)[-1]
    assert not d["status"] & bit("micro_status", "configured") and d["cmd_rejected"] == 1, "the command is refused"
    assert rows[-1][1] >= x_before, "the plant keeps its state"
