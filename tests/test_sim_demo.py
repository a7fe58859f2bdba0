"""The default mission (config/missions/demo.toml, what `make sim` runs) shows what its
comments say: one lockstep run through the real host and FMUs, checked on the plant's
ground truth (mm, deg, mm/s) and on the host's datalog.
"""

import pytest

from sim_helpers import require_build

pytestmark = pytest.mark.timeout(120)

LATENCY = 0.35      # s: host frame + UART + control tick, generous
# the demo's command times (s): drive 1 m, heading select 90, turning leg, reverse across
# north, DIO release; the datalog runs from the "R" key to the "S" key
DRIVE, HDG, TURN, REVERSE, RELEASE = 1.0, 6.0, 10.0, 15.0, 21.0
RECORD, STOP_RECORD = 0.5, 23.0


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    from navkit.paths import repo_root
    from navkit.sim.harness import SimOptions, run
    from navkit.sim.mission import load
    from navkit.sim.results import load as load_run

    require_build()
    m = load(repo_root() / "config" / "missions" / "demo.toml")
    assert [c.t for c in m.commands] == [DRIVE, HDG, TURN, REVERSE, RELEASE]
    assert [(k.t, k.key) for k in m.keys] == [(RECORD, "R"), (STOP_RECORD, "S")]
    out = tmp_path_factory.mktemp("sim-demo")
    run(SimOptions(mission=m, out=out, plot=False))
    return load_run(out)


def _turned(a: float, b: float) -> float:
    """Heading change (deg) from a to b, wrapped to -180..180 (+ clockwise)."""
    return (b - a + 180) % 360 - 180


def test_the_1_m_leg_ends_near_1000_mm_straight_ahead(demo):
    end = demo.truth_at(HDG)
    assert abs(end["distance_mm"] - 1000) <= 15, end
    assert abs(end["x_mm"] - 1000) <= 20 and abs(end["y_mm"]) <= 20, end
    leg = demo.truth_between(DRIVE, HDG)
    assert 285 <= max(m["v_mm_s"] for m in leg) <= 315
    assert all(abs(_turned(0, m["heading_deg"])) < 1 for m in leg), "straight ahead"


def test_heading_select_turns_clockwise_to_90_in_place(demo):
    end = demo.truth_at(TURN)
    assert abs(end["heading_deg"] - 90) <= 2, end
    leg = demo.truth_between(HDG, TURN)
    assert min(m["w_deg_s"] for m in leg) < -30 and max(m["w_deg_s"] for m in leg) < 1
    start = demo.truth_at(HDG)
    assert abs(end["x_mm"] - start["x_mm"]) < 10 and abs(end["y_mm"] - start["y_mm"]) < 10


def test_servo_0_scans_plus_minus_45_then_goes_to_0(demo):
    assert all(m["servo_deg"][0] == 0 for m in demo.truth_between(0, DRIVE))
    scan = [m["servo_deg"][0] for m in demo.truth_between(DRIVE + 1.0, TURN)]
    assert max(scan) == pytest.approx(45, abs=1.0) and min(scan) == pytest.approx(-45, abs=1.0)
    bounces = sum(1 for a, b, c in zip(scan, scan[1:], scan[2:]) if (b - a) * (c - b) < 0)
    assert bounces >= 4, "90 deg at 60 deg/s: a sweep every 1.5 s"
    # GoTo 0 at 90 deg/s: at most 45 deg away, 0.5 s
    rest = [m["servo_deg"][0] for m in demo.truth_between(TURN + 0.5 + LATENCY, 24.0)]
    assert rest and all(abs(a) < 0.5 for a in rest), (min(rest), max(rest))
    assert all(m["servo_deg"][k] == 0 for m in demo.truth for k in range(1, 8))


@pytest.mark.parametrize("t0, t1, dio", [
    (0.0, DRIVE, 0x000),
    (DRIVE + LATENCY, HDG, 0x001),             # bit 0: a leg drives
    (HDG + LATENCY, TURN, 0x008),              # bit 3: it turns
    (TURN + LATENCY, REVERSE, 0x009),
    (REVERSE + LATENCY, RELEASE, 0x009),
    (RELEASE + LATENCY, 24.0, 0x000),          # no dio_active: back to the console's 0
])
def test_dio_out_as_the_mission_drives_it(demo, t0, t1, dio):
    rows = demo.truth_between(t0, t1)
    assert rows and {m["dio_out"] for m in rows} == {dio}


def test_turning_leg_turns_45_deg_left_over_600_mm(demo):
    a, b = demo.truth_at(TURN), demo.truth_at(REVERSE)
    assert abs(_turned(a["heading_deg"], b["heading_deg"]) + 45) <= 2.5, (a, b)
    assert abs(b["distance_mm"] - a["distance_mm"] - 600) <= 15, (a, b)
    leg = demo.truth_between(TURN, REVERSE)
    assert max(m["w_deg_s"] for m in leg) > 20 and min(m["v_mm_s"] for m in leg) > -2


def test_reverse_leg_backs_300_mm_and_heading_select_crosses_north_to_350(demo):
    a, b = demo.truth_at(REVERSE), demo.truth_at(RELEASE)
    assert abs(b["distance_mm"] - a["distance_mm"] + 300) <= 15, (a, b)
    leg = demo.truth_between(REVERSE, RELEASE)
    assert min(m["v_mm_s"] for m in leg) < -150 and max(m["v_mm_s"] for m in leg) < 2
    # 45 -> 350 the short way: counter-clockwise through 0, never through 180
    assert min(m["w_deg_s"] for m in leg) > -1 and max(m["w_deg_s"] for m in leg) > 20
    hdg = [m["heading_deg"] for m in leg]
    assert all(h <= 47 or h >= 348 for h in hdg)
    assert any(h < 10 for h in hdg) and any(h > 350.5 for h in hdg)
    for m in (b, demo.truth[-1]):
        assert abs(_turned(350, m["heading_deg"])) <= 2, m


def test_datalog_written_from_r_to_s(demo):
    logs = demo.summary["datalogs"]
    assert len(logs) == 1, logs
    lines = (demo.out / logs[0]).read_text().splitlines()
    n = int(lines[0])
    names = [ln.split()[0] for ln in lines[1:1 + n]]
    rows = [[float(v) for v in ln.split("\t")] for ln in lines[1 + n:]]
    assert rows and all(len(r) == n for r in rows)
    col = {name: i for i, name in enumerate(names)}
    times = [r[col["time_s"]] for r in rows]
    assert times[0] == pytest.approx(RECORD, abs=0.01)
    assert STOP_RECORD - 0.2 <= times[-1] < STOP_RECORD + 0.05, "S stops it"
    assert len(rows) == pytest.approx((times[-1] - times[0]) / 0.1 + 1, abs=1), "every frame"
    last = rows[-1]
    assert abs(_turned(350, last[col["heading_deg"]])) <= 2
    assert abs(last[col["distance_mm"]] + 300) <= 15, "mm since the last fwd_cmd 1"
    legs = [r for r in rows if TURN + LATENCY <= r[col["time_s"]] < RELEASE]
    assert {r[col["dio"]] for r in legs} == {0x009}
    scan = [r[col["servo0_deg"]] for r in rows if DRIVE + 1.0 <= r[col["time_s"]] <= TURN]
    assert max(scan) > 35 and min(scan) < -35
