"""Processor in the loop over CAN: `navkit sim --firmware avr --link can` runs the AVR CAN
image (navkit-mega2560-can.elf) in simavr on the simulated Mega 2560 with its MCP2515
(navkit_firmware_avr_can.fmu: the bus's frames in can_rx / can_tx), the real host on
SLCAN behind the harness's gateway; the same mission over serial PIL ends at the same pose
(docs/avr.md, CAN; docs/can.md)."""

import pytest

from navkit.paths import build_dir
from sim_helpers import STRAIGHT, run_mission

AVR_CAN_FMU = build_dir() / "fmus" / "navkit_firmware_avr_can.fmu"
pytestmark = [pytest.mark.timeout(300),
              pytest.mark.skipif(not AVR_CAN_FMU.exists(), reason=f"{AVR_CAN_FMU} not built (needs avr-gcc and libsimavr)")]

POS_MM, HDG_DEG = 5.0, 0.5


def test_pil_over_can_ends_where_pil_over_serial_ends(tmp_path_factory):
    serial = run_mission(tmp_path_factory, "straight-pil", STRAIGHT, firmware="avr")     # test_pil_sim's run
    can = run_mission(tmp_path_factory, "pil-straight-can", STRAIGHT, firmware="avr", link="can")
    a, b = serial.summary, can.summary
    assert b["firmware_fmu"].endswith("navkit_firmware_avr_can.fmu") and b["link"]["transport"] == "can"
    for key, tol in (("x_mm", POS_MM), ("y_mm", POS_MM), ("yaw_deg", HDG_DEG)):
        assert abs(a["truth"][key] - b["truth"][key]) < tol, (key, a["truth"], b["truth"])
    assert b["truth"]["x_mm"] - can.truth_at(1.4)["x_mm"] > 600      # it moved the leg
    assert b["planner"]["accepted"] == b["planner"]["commands"] and b["watchdog_stops"] == 0
    c = b["link"]["can"]
    assert c["micro_replies_skipped"] == 0 and c["adapter"]["refused"] == 0 and c["error_frames"] == 0
    rx = c["micro_iso_tp_rx"]
    assert rx["good"] > 40 and rx["wrong_sn"] == rx["timeout"] == rx["bad_frame"] == 0
    m2h = b["link"]["micro_to_host"]
    assert m2h["frames_received"] == m2h["frames_sent"] > 40 and m2h["host_link_errors"] == 0
    # the image's own profile: its ticks ran at the AVR build's 400 Hz, none reset
    prof = b["firmware_profile"]
    assert prof["prof_resets"] == 0 and abs(prof["prof_ticks"] - 400 * 5.0) <= 400 * 0.1, prof
