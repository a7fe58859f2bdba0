"""The AVR firmware FMU (build/fmus/navkit_firmware_avr.fmu) in fmpy: the flashed
ATmega2560 image running in simavr, coupled at its pins (processor in the loop).

Its description carries every variable of navkit_firmware.fmu unchanged (so the harness and
a user swap one for the other) plus the profile outputs; a doStep of h runs exactly h * 16 MHz
cycles; the host's config and commands go in through serial_rx at 115200 baud and micro_data
comes back in serial_tx; the plant's values reach the pins and the pins' PWM, servo pulses
and DIO levels come back as outputs.
"""

from __future__ import annotations

import zipfile
from xml.etree import ElementTree

import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from navkit import protocol  # noqa: E402
from navkit.paths import build_dir  # noqa: E402

FMU = build_dir() / "fmus" / "navkit_firmware_avr.fmu"
SIL_FMU = build_dir() / "fmus" / "navkit_firmware.fmu"
pytestmark = pytest.mark.skipif(not FMU.exists(), reason=f"{FMU} not built (needs avr-gcc and libsimavr)")

F_CPU = 16_000_000
RATE = 400  # Hz: the AVR build's control_rate ceiling (NAVKIT_AVR_RATE_MAX)


@pytest.fixture
def board(fmu3):
    """board(start=True, **params) -> an instance of the AVR firmware FMU (conftest's Fmu3)."""
    return lambda **kw: fmu3("avr", **kw)


def configs(rate=RATE, tag=1):
    """The three config frames (spec defaults, control_rate `rate` Hz)."""
    out = b""
    for i, name in enumerate(("micro_cfg_geometry", "micro_cfg_motion", "micro_cfg_io")):
        fields = protocol.defaults(name)
        if name == "micro_cfg_geometry":
            fields["control_rate"] = rate
        out += protocol.encode_frame(name, fields, time_tag=tag + i)
    return out


# ---------------------------------------------------------------- the description


def test_passes_fmpy_validation():
    assert validate_fmu(str(FMU)) == []


def test_has_every_variable_of_the_sil_firmware_fmu(md):
    """Same name, value reference, type, causality, unit and start for each variable of
    navkit_firmware.fmu; the rest are the profile outputs (UInt32/UInt64, which no plant
    input takes) and the `image` parameter."""
    sil = fmpy.read_model_description(str(SIL_FMU))

    def row(v):
        return (v.valueReference, v.type, v.causality, v.variability, v.unit, v.start)

    pil = {v.name: v for v in md.modelVariables}
    for v in sil.modelVariables:
        assert v.name in pil, v.name
        assert row(pil[v.name]) == row(v), v.name
    extra = {n: v for n, v in pil.items() if n not in {v.name for v in sil.modelVariables}}
    assert {n for n, v in extra.items() if v.type == "String"} == {"image"}
    assert extra["image"].causality == "parameter"
    outs = {n for n, v in extra.items() if v.causality == "output"}
    assert outs == {n for n in extra if n != "image"}
    assert all(extra[n].type in ("UInt32", "UInt64") for n in outs)
    assert {"prof_ticks", "prof_tick_worst_cycles", "prof_tick_mean_cycles", "prof_polls",
            "prof_poll_worst_cycles", "prof_poll_mean_cycles", "avr_cycles"} <= outs
    assert md.coSimulation.modelIdentifier == "navkit_firmware_avr"
    assert md.coSimulation.fixedInternalStepSize is None   # any step size


def test_ships_the_image_and_names_board_and_spec(unzipped):
    """The image is the build's ELF, carried in resources/; the annotation names the MCU,
    its clock and the control_rate ceiling; the spec annotation is this spec's."""
    elf = build_dir() / "firmware" / "avr" / "navkit-mega2560.elf"
    with zipfile.ZipFile(FMU) as z:
        assert z.read("resources/navkit-mega2560.elf") == elf.read_bytes()
    root = ElementTree.parse(f"{unzipped}/modelDescription.xml").getroot()
    board = root.find("./Annotations/Annotation[@type='org.navkit.board']/Board").attrib
    assert board == {"mcu": "atmega2560", "f_cpu_hz": str(F_CPU), "control_rate_max": str(RATE),
                     "image": "navkit-mega2560.elf"}
    spec = root.find("./Annotations/Annotation[@type='org.navkit.spec']/Spec").attrib
    assert spec["spec_hash"] == f"0x{protocol.SPEC_HASH:08x}"


# ---------------------------------------------------------------- time and the link


def test_steps_run_exact_cycles_for_any_step_size(board):
    """Each step ends at the first instruction boundary at or after its end cycle, counted
    from the start: at most one instruction or interrupt entry (5 cycles) late, never
    drifting over many steps."""
    b = board()
    end = 0
    for h in (0.001, 0.0013, 0.0025, 0.0001):
        b.step(h)
        end += round(h * F_CPU)
        assert 0 <= b.get("avr_cycles") - end <= 5, h
    for _ in range(997):
        b.step(0.0001)
    assert 0 <= b.get("avr_cycles") - round(0.1046 * F_CPU) <= 5
    assert b.get("time") == pytest.approx(b.t)


def test_configured_over_uart_at_the_ceiling_rate_and_refused_above(board, status_bit):
    """control_rate 401 Hz is refused (unconfigured, as on the real board); 400 Hz is taken
    and the tick timer then runs at 400 Hz (prof_ticks over 0.25 s)."""
    b = board()
    data = b.frames(0.1, configs(rate=RATE + 1))
    assert data and not data[-1]["status"] & status_bit("configured")
    assert data[-1]["spec_hash"] == protocol.SPEC_HASH
    data = b.frames(0.1, configs(rate=RATE, tag=10))
    assert data[-1]["status"] & status_bit("configured")
    ticks0, t0 = b.get("prof_ticks"), b.t
    b.frames(0.25)
    assert b.get("prof_ticks") - ticks0 == pytest.approx(RATE * (b.t - t0), abs=1)
    assert 0 < b.get("prof_tick_mean_cycles") <= b.get("prof_tick_worst_cycles") < F_CPU // RATE
    assert 0 < b.get("prof_poll_mean_cycles") <= b.get("prof_poll_worst_cycles")
    assert b.get("prof_tick_total_cycles") <= b.get("avr_cycles")


def test_pins_carry_the_plant_and_the_micro(board):
    """ADC voltages, sonar echo, DIO inputs in; servo pulse and DIO levels measured at the
    pins out; the same values the SIL firmware FMU reports for the same inputs."""
    b = board()
    b.frames(0.1, configs())
    b.set(dio_in=0x0A00, compass_raw=1234)
    b.set(ir_voltage_0=2.5, battery_voltage=12.0, sonar_echo_1=5800.0)
    frame = protocol.encode_frame("micro_cmd", {"rc2_param0": 1000, "rc2_param1": 300, "rc2_param2": 9999,
                                                "dio_command": 0x0FF9}, time_tag=4)
    data = b.frames(0.6, frame)  # the servo reaches 30 deg (1800 us) by then, as in the SIL test
    # the width the image makes, as timed at the pin (its compare interrupt's latency in it)
    assert b.get("servo_pulse_2") == pytest.approx(1800.0, abs=5) and b.get("servo_pulse_0") == 0.0
    assert b.get("dio_dir") == 0x00FF and b.get("dio_out") == 0x00F9
    d = data[-1]
    assert d["servo_pos"][2] == 300 and d["dio_state"] == 0x0AF9
    assert abs(d["adc"][0] - 512) <= 1 and abs(d["adc"][4] - 819) <= 1
    assert d["sonar_echo"][1] == pytest.approx(5800, abs=10)  # timed by the image: its latency in it
    assert d["compass"] == 1234


def test_reset_is_a_power_cycle(board, status_bit):
    b = board()
    b.frames(0.1, configs())
    assert 0 <= b.get("avr_cycles") - round(0.1 * F_CPU) <= 5
    b.fmu.reset()
    b.start()
    data = b.frames(0.1, protocol.encode_frame("micro_cmd", {}, time_tag=7))
    assert 0 <= b.get("avr_cycles") - round(0.1 * F_CPU) <= 5
    assert not data[-1]["status"] & status_bit("configured")


# ---------------------------------------------------------------- errors


def test_a_missing_image_is_named(board, tmp_path):
    missing = tmp_path / "nope.elf"
    b = board(start=False)
    b.fmu.enterInitializationMode(startTime=0.0)
    b.fmu.setString([b.vr["image"]], [str(missing)])
    with pytest.raises(FMICallException):
        b.fmu.exitInitializationMode()
    assert any(str(missing) in m for m in b.log), b.log


def test_another_baud_is_refused(board):
    b = board(start=False)
    b.fmu.enterInitializationMode(startTime=0.0)
    b.fmu.setUInt32([b.vr["baud"]], [9600])
    with pytest.raises(FMICallException):
        b.fmu.exitInitializationMode()
    assert any("115200" in m for m in b.log), b.log
