"""run.mcap's Foxglove topics (navkit.sim.foxglove): every message of a real short
co-simulation validates against Foxglove's official JSON schema of its schema name, and
carries the run's values in SI units (truth and odometry poses, transforms, path, log with
the host's console, the world's walls as a scene); two runs give the same bytes.

The official JSON schemas are the ones Foxglove publishes in the npm package
@foxglove/schemas (dist/jsonschema), read with node, installed into .venv/node_modules by
`npm install --prefix .venv @foxglove/schemas@2.1.0` (or set NAVKIT_FOXGLOVE_SCHEMAS to
the package's folder); without them those tests skip, saying so."""

import json
import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from sim_helpers import require_build, rewrite_fmu, run_mission

pytestmark = pytest.mark.timeout(120)

MISSION = """
duration_s = 4.0
world = "hallway.txt"
[[key]]
t = 0.5
key = "R"
[[command]]
t = 0.5
fwd_cmd = 1
speed = 300
distance = 400
turn_mode = 1
turn_rate = 600
turn_distance = -300
[[fault]]
t = 2.0
kind = "unplug"
duration_s = 0.5
"""

NEW_TOPICS = {"/foxglove/truth_pose": "foxglove.PoseInFrame",
              "/foxglove/odom_pose": "foxglove.PoseInFrame",
              "/tf": "foxglove.FrameTransform",
              "/foxglove/path": "foxglove.PosesInFrame",
              "/foxglove/log": "foxglove.Log",
              "/foxglove/scene": "foxglove.SceneUpdate"}


def _schemas_dir() -> Path:
    env = os.environ.get("NAVKIT_FOXGLOVE_SCHEMAS")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[1] / ".venv" / "node_modules" / "@foxglove" / "schemas"


@pytest.fixture(scope="module")
def official():
    """{schema name: Foxglove's official JSON schema} from @foxglove/schemas."""
    index = _schemas_dir() / "dist" / "jsonschema" / "index.js"
    node = shutil.which("node")
    if node is None or not index.exists():
        pytest.skip(f"Foxglove's JSON schemas not installed ({index}, node {node}): "
                    "npm install --prefix .venv @foxglove/schemas@2.1.0")
    out = subprocess.run([node, "-e", "process.stdout.write(JSON.stringify("
                          "require(process.argv[1])))", str(index)],
                         capture_output=True, check=True, timeout=30).stdout
    return {s["title"]: s for s in json.loads(out).values() if "title" in s}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return run_mission(tmp_path_factory, "foxglove", MISSION)


def _yaw(q: dict) -> float:
    """Yaw (rad, CCW) of a rotation about +z; x and y must be 0."""
    assert q["x"] == 0 and q["y"] == 0
    assert q["z"] ** 2 + q["w"] ** 2 == pytest.approx(1.0, abs=1e-8)
    return 2.0 * math.atan2(q["z"], q["w"])


def _same_angle(a: float, b: float, tol: float) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) <= tol


def test_every_message_fits_the_official_schema(run, official):
    import jsonschema
    from mcap.reader import make_reader

    validators = {name: jsonschema.Draft202012Validator(official[name])
                  for name in set(NEW_TOPICS.values())}
    seen = dict.fromkeys(NEW_TOPICS, 0)
    with open(run.out / "run.mcap", "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            name = NEW_TOPICS.get(channel.topic)
            if name is None:
                continue
            assert (schema.name, schema.encoding, channel.message_encoding) == \
                (name, "jsonschema", "json"), channel.topic
            msg = json.loads(message.data)
            validators[name].validate(msg)
            ts = msg["entities"][0]["timestamp"] if name == "foxglove.SceneUpdate" \
                else msg["timestamp"]
            assert ts["sec"] * 1_000_000_000 + ts["nsec"] == message.log_time, \
                "timestamp = log time = simulated time"
            seen[channel.topic] += 1
    assert all(seen.values()), seen
    assert run.summary["messages"]["/foxglove/truth_pose"] == seen["/foxglove/truth_pose"]


def test_our_schemas_name_the_official_fields(official):
    """The schemas run.mcap carries (ours: they give the units) have the official ones'
    names, types and properties, and require at least what they require, down through
    nested objects and arrays (but the items of an array ours keeps empty)."""
    from navkit.sim.foxglove import SCHEMAS, TOPICS

    def walk(ours, theirs, where):
        if "type" in theirs:
            assert ours.get("type") == theirs["type"], where
        if "properties" in theirs:
            assert set(ours["properties"]) == set(theirs["properties"]), where
            assert set(ours.get("required", ())) >= set(theirs.get("required", ())), where
            for k, v in ours["properties"].items():
                walk(v, theirs["properties"][k], f"{where}.{k}")
        if "items" in theirs and ours.get("maxItems") != 0:
            walk(ours["items"], theirs["items"], where + "[]")

    for name in set(TOPICS.values()):
        walk(SCHEMAS[name], official[name], name)


def test_a_message_off_the_official_schema_is_refused(official):
    """The validation above can fail: a pose in mm with a missing w, or a Log level name."""
    import jsonschema

    bad_pose = {"timestamp": {"sec": 0, "nsec": 0}, "frame_id": "world",
                "pose": {"position": {"x": 1, "y": 2, "z": 0},
                         "orientation": {"x": 0, "y": 0, "z": 0}}}
    bad_log = {"timestamp": {"sec": 0, "nsec": 0}, "level": "INFO", "message": "m",
               "name": "n", "file": "", "line": 0}
    for name, msg in (("foxglove.PoseInFrame", bad_pose), ("foxglove.Log", bad_log)):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(msg, official[name])


def test_truth_and_odometry_poses_in_metres_and_quaternions(run):
    from navkit.sim.foxglove import TRUTH_PERIOD_NS

    truth = {round(t, 3): m for t, m in run.messages("/truth")}
    poses = run.messages("/foxglove/truth_pose")
    ts = [t for t, _ in poses]
    assert ts[0] == 0 and ts[-1] == pytest.approx(4.0)
    assert all(b - a == pytest.approx(TRUTH_PERIOD_NS / 1e9) for a, b in zip(ts, ts[1:]))
    moved = 0.0
    for t, m in poses:
        tr = truth[round(t, 3)]
        p = m["pose"]["position"]
        assert m["frame_id"] == "world"
        assert (p["x"], p["y"], p["z"]) == pytest.approx((tr["x_mm"] / 1e3, tr["y_mm"] / 1e3, 0),
                                                        abs=1e-6)
        assert _same_angle(_yaw(m["pose"]["orientation"]), math.radians(tr["yaw_deg"]), 1e-6)
        moved = max(moved, p["x"])
    assert moved > 0.3, "the command drove the robot about 400 mm forward"

    micro = run.messages("/micro/data")
    odom = run.messages("/foxglove/odom_pose")
    assert len(odom) == len(micro) > 0
    for (t, m), (tm, d) in zip(odom, micro):
        assert t == tm
        p = m["pose"]["position"]
        assert (p["x"], p["y"]) == pytest.approx((d["x"] / 1e3, d["y"] / 1e3), abs=1e-9)
        # the micro's heading is clockwise (deg x 10), the pose's yaw counter-clockwise
        assert _same_angle(_yaw(m["pose"]["orientation"]), -math.radians(d["heading"] / 10), 1e-7)
    # the odometry follows the truth (within a few cm and degrees after the move)
    last_t, last = odom[-1]
    tr = run.truth_at(last_t)
    assert last["pose"]["position"]["x"] == pytest.approx(tr["x_mm"] / 1e3, abs=0.05)
    assert _same_angle(_yaw(last["pose"]["orientation"]), math.radians(tr["yaw_deg"]), 0.1)
    assert abs(tr["yaw_deg"]) > 10, "the command turned the robot"


def test_transforms_carry_both_poses(run):
    tf = run.messages("/tf")
    by_child = {}
    for t, m in tf:
        assert m["parent_frame_id"] == "world"
        by_child.setdefault(m["child_frame_id"], []).append((t, m))
    assert set(by_child) == {"base_link", "odom_base_link"}
    for child, topic in (("base_link", "/foxglove/truth_pose"),
                         ("odom_base_link", "/foxglove/odom_pose")):
        poses = run.messages(topic)
        assert len(by_child[child]) == len(poses)
        for (t, m), (tp, p) in zip(by_child[child], poses):
            assert t == tp
            assert m["translation"] == p["pose"]["position"]
            assert m["rotation"] == p["pose"]["orientation"]


def test_path_grows_and_ends_at_the_robot(run):
    from navkit.sim.foxglove import PATH_MAX, PATH_STEP_M

    paths = run.messages("/foxglove/path")
    ts = [t for t, _ in paths]
    assert len(set(int(t) for t in ts)) == len(ts), "at most one per simulated second"
    lengths = [len(m["poses"]) for _, m in paths]
    assert lengths == sorted(lengths) and lengths[-1] <= PATH_MAX
    first = paths[-1][1]["poses"][0]["position"]
    assert (first["x"], first["y"]) == (0.0, 0.0), "the path starts at the start pose"
    t, last = paths[-1]
    end = last["poses"][-1]["position"]
    tr = run.truth_at(t)
    assert math.hypot(end["x"] - tr["x_mm"] / 1e3, end["y"] - tr["y_mm"] / 1e3) < PATH_STEP_M


def test_path_stays_bounded_on_a_long_drive(tmp_path, official):
    """Thousands of path poses (a 100 m drive) through the real Recorder: at most PATH_MAX
    in a message, the first pose kept, the latest last, evenly thinned."""
    import jsonschema

    from navkit.sim.foxglove import PATH_MAX, FoxgloveWriter
    from navkit.sim.record import Recorder
    from navkit.sim.results import read_mcap

    rec = Recorder(tmp_path / "run.mcap", {})
    fox = FoxgloveWriter(rec.writer)
    for k in range(5000):          # 0.2 m/s, truth rows at 50 Hz, 100 s: 400 path steps
        t_ns = k * 20_000_000
        rec.reserve(t_ns, t_ns)
        fox.truth(t_ns, k * 4.0, 0.0, 0.0)
    rec.close()
    paths = [json.loads(d) for _, topic, d in read_mcap(tmp_path / "run.mcap").messages
             if topic == "/foxglove/path"]
    secs = [p["timestamp"]["sec"] for p in paths]
    assert len(set(secs)) == len(secs) >= 90, "about once per simulated second"
    last = paths[-1]
    jsonschema.validate(last, official["foxglove.PosesInFrame"])
    xs = [p["position"]["x"] for p in last["poses"]]
    assert PATH_MAX // 2 <= len(xs) <= PATH_MAX
    t = last["timestamp"]["sec"] + last["timestamp"]["nsec"] / 1e9
    assert t >= 98.0, "published while it grows"
    assert xs[0] == 0.0 and xs[-1] == pytest.approx(0.2 * t, abs=0.05), "0.2 m/s"
    steps = [b - a for a, b in zip(xs, xs[1:])]
    assert max(steps) < 2.5 * min(steps), "thinned evenly, not just cut"


def test_log_has_events_and_commands_at_their_times(run):
    logs = run.messages("/foxglove/log")
    got = [(round(t, 3), m["level"], m["message"].split(" ")[0]) for t, m in logs]
    assert (0.5, 2, "key") in got
    assert (0.5, 2, "planner:") in got
    assert (2.0, 3, "unplug") in got, "a fault is a warning"
    assert (2.5, 2, "plug") in got
    cmd = next(m["message"] for _, m in logs if m["message"].startswith("planner:"))
    assert "[[command]] #1" in cmd and "speed=300" in cmd and "distance=400" in cmd
    ours = [m for _, m in logs if m["name"] == "navkit-sim"]
    assert all((m["file"], m["line"]) == ("", 0) for m in ours)
    events = run.messages("/events")
    assert len(ours) == len(events) + run.summary["planner"]["commands"]
    assert {m["name"] for _, m in logs} == {"navkit-sim", "navkit-host"}


# ---------------------------------------------------------------- the host's console


def test_host_console_line_by_line_with_placeholders(run):
    """Every line of host.log is a foxglove.Log of navkit-host, in order, numbered as in
    the file, at the time of the frame it appeared in (the host stamps its lines with its
    clock: in lockstep the frame's time), those of its shutdown at the run's end, with the
    run's temporary names replaced by the harness's placeholders."""
    text = (run.out / "host.log").read_text().splitlines()
    host = [(t, m) for t, m in run.messages("/foxglove/log") if m["name"] == "navkit-host"]
    assert [m["line"] for _, m in host] == list(range(1, len(text) + 1))
    assert all(m["file"] == "host.log" for _, m in host)
    last_frame = run.messages("/host/frame")[-1][0]
    assert host[-1][0] == run.summary["sim_time_s"] > last_frame
    for (t, m), line in zip(host, text):
        stamp, _, rest = line.partition("] ")
        assert float(stamp.lstrip("[ ")) == pytest.approx(min(t, last_frame), abs=1e-9), line
        for name in (str(run.out), "/tmp/navkit-sim-", "/navkit-sim-", "Data "):
            assert name not in m["message"], m["message"]
        # the same text but for the placeholders
        parts = re.split(r"<(?:tmp|rcomm|out|config|datalog \d+)>", m["message"])
        assert re.fullmatch(".+".join(map(re.escape, parts)), rest), (m["message"], rest)
    messages = [m["message"] for _, m in host]
    assert any(re.fullmatch(r"micro port <tmp>/ttyNAVKIT open \(.*\)", x) for x in messages)
    assert any(x.startswith("navkit-host: ") and x.endswith("rcomm <rcomm>") for x in messages)
    assert "recording to <datalog 1>" in messages, "key R started the datalog"
    levels = {m["message"].split(" ")[0]: m["level"] for _, m in host}
    assert levels["status:"] == 1 and levels["recording"] == 2 and levels["link:"] == 2
    lost = [(t, m["level"]) for t, m in host if " lost " in m["message"]]
    assert lost and 2.0 <= lost[0][0] <= 2.2 and lost[0][1] == 3, "the unplug: a warning"


def test_console_levels_and_placeholders(tmp_path):
    """navkit.sim.host_console on a file that grows as the host writes it: whole lines
    only, their numbers, levels by kind, every temporary name a placeholder (the longest
    first), datalogs numbered in order of first mention."""
    from navkit.sim.host_console import HostConsole

    out, tmp = tmp_path / "out", "/tmp/navkit-sim-ab12"
    log = tmp_path / "host.log"
    log.write_bytes(b"")
    con = HostConsole(log, {tmp: "<tmp>", f"{tmp}/config": "<config>",
                            "/navkit-sim-7-99": "<rcomm>", str(out): "<out>"}, out)
    with open(log, "ab", buffering=0) as f:
        f.write(f"[    0.000] micro port {tmp}/ttyNAVKIT open (115200 baud)\n"
                f"[    0.100] recording to {out}/Data 11-25-26 15;20;01.txt\n[    0.2".encode())
        assert con.read() == [(2, "micro port <tmp>/ttyNAVKIT open (115200 baud)", 1),
                              (2, "recording to <datalog 1>", 2)]
        f.write(f"00] status: frame 2\n[    0.300] micro port {tmp}/ttyNAVKIT lost (EIO)\n"
                f"[    0.400] cannot record: {out}/Data 11-25-26 15;20;02.txt: denied\n"
                f"[    0.500] recording stopped: {out}/Data 11-25-26 15;20;01.txt\n"
                f"[    0.600] config {tmp}/config/NavAndControl.ini, log dir {out}\n".encode())
        assert con.read() == [(1, "status: frame 2", 3),
                              (3, "micro port <tmp>/ttyNAVKIT lost (EIO)", 4),
                              (3, "cannot record: <datalog 2>: denied", 5),
                              (2, "recording stopped: <datalog 1>", 6),
                              (2, "config <config>/NavAndControl.ini, log dir <out>", 7)]
        assert con.read() == []
        f.write(b"[    0.700] link: 0 rejected frames\nnavkit-host: --rate 0: not a rate")
    assert con.rest() == [(2, "link: 0 rejected frames", 8),
                          (4, "navkit-host: --rate 0: not a rate", 9)]


# ---------------------------------------------------------------- the world's walls


def test_walls_scene_once_at_the_start(run, official):
    """/foxglove/scene: one SceneUpdate at t = 0 whose boxes are the world's walls (the
    plant FMU's walls output) in frame world, in m: hallway.txt, the robot 1 m in."""
    import jsonschema

    from navkit.sim.foxglove import WALL_HEIGHT_M, WALL_THICKNESS_M

    scenes = run.messages("/foxglove/scene")
    assert [t for t, _ in scenes] == [0.0]
    msg = scenes[0][1]
    jsonschema.validate(msg, official["foxglove.SceneUpdate"])
    (entity,) = msg["entities"]
    assert (entity["id"], entity["frame_id"], entity["lifetime"]) == \
        ("walls", "world", {"sec": 0, "nsec": 0})
    cubes = entity["cubes"]
    assert len(cubes) == 14, "hallway.txt: 3 + 2 + 2 + 3 walls and a box's 4 sides"
    ends = []
    for c in cubes:
        p, size = c["pose"]["position"], c["size"]
        assert (size["y"], size["z"], p["z"]) == (WALL_THICKNESS_M, WALL_HEIGHT_M, WALL_HEIGHT_M / 2)
        yaw = _yaw(c["pose"]["orientation"])
        half = 0.5 * size["x"]
        ends.append(tuple(round(v, 9) for v in (p["x"] - half * math.cos(yaw), p["y"] - half * math.sin(yaw),
                                                p["x"] + half * math.cos(yaw), p["y"] + half * math.sin(yaw))))
    # the file's mm, 1 m behind the start: the right wall, then the bin's four sides
    assert ends[7] == (-1.0, -0.9, 11.0, -0.9)
    assert ends[10:] == [(4.0, -0.9, 4.4, -0.9), (4.4, -0.9, 4.4, -0.5), (4.4, -0.5, 4.0, -0.5),
                         (4.0, -0.5, 4.0, -0.9)]


def test_a_plant_without_walls_runs_without_a_scene_and_a_mistyped_one_is_refused(tmp_path):
    """The walls output is optional (a plant of the user's): without it the run has no
    scene; a plant whose walls is not a Binary output is refused up front, by name."""
    from fmpy import read_model_description

    from navkit.paths import build_dir
    from navkit.sim.harness import SimError, SimOptions, fmu_paths
    from navkit.sim.harness import run as sim_run
    from navkit.sim.mission import loads
    from navkit.sim.results import read_mcap

    require_build()
    plant = fmu_paths(build_dir())[1]
    vr = {v.name: v.valueReference for v in read_model_description(str(plant)).modelVariables}

    def without_walls(xml):
        xml, n = re.subn(r'\n\s*<Binary name="walls"[^>]*/>', "", xml)
        xml, m = re.subn(rf'\n\s*<(?:Output|InitialUnknown) valueReference="{vr["walls"]}"/>',
                         "", xml)
        assert (n, m) == (1, 2)
        return xml

    lean = rewrite_fmu(plant, tmp_path / "lean.fmu", without_walls)
    mission = loads('duration_s = 0.5\nworld = "hallway.txt"\n', tmp_path / "m.toml")
    sim_run(SimOptions(mission=mission, out=tmp_path / "out", plant_fmu=lean, plot=False))
    topics = {topic for _, topic, _ in read_mcap(tmp_path / "out" / "run.mcap").messages}
    assert "/foxglove/truth_pose" in topics and "/foxglove/scene" not in topics
    odd = rewrite_fmu(plant, tmp_path / "odd.fmu",
                      lambda xml: xml.replace('<Binary name="walls"', '<String name="walls"'))
    with pytest.raises(SimError) as e:
        sim_run(SimOptions(mission=mission, out=tmp_path / "odd", plant_fmu=odd, plot=False))
    assert str(e.value).startswith(f"{odd}: ") and \
        "walls is String output, expected Binary output" in str(e.value), str(e.value)


# ---------------------------------------------------------------- determinism


def test_two_runs_give_the_same_bytes(run, tmp_path):
    """A second run of the mission (a file of the same name), into another folder at
    another wall-clock time (so another pty folder, rcomm name and datalog name), writes a
    byte-identical run.mcap."""
    from navkit.sim.harness import SimOptions
    from navkit.sim.harness import run as sim_run
    from navkit.sim.mission import loads

    mission = loads(MISSION, tmp_path / run.metadata["mission_file"])
    sim_run(SimOptions(mission=mission, out=tmp_path, seed=1, plot=False))
    assert (tmp_path / "host.log").read_text() != (run.out / "host.log").read_text()
    assert (tmp_path / "run.mcap").read_bytes() == (run.out / "run.mcap").read_bytes()
