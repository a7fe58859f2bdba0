"""run.mcap's topics in Foxglove's well-known schemas (JSON encoding), written beside the
navkit topics so that Foxglove's 3D panel shows the robot and its Log panel the mission.

Units are SI: metres, radians (as unit quaternions about +z), the frame `world` being the
start pose (x forward, y left, z up), as /truth's. `timestamp` of every message equals its
log time: the simulated time since the start of the run (the log-time convention of the
whole file, see record.py; Foxglove shows it as a date in 1970).

Topics (each schema's title is the Foxglove schema name, its descriptions give the units):

- /foxglove/truth_pose (foxglove.PoseInFrame): the plant's true pose, TRUTH_PERIOD_NS apart;
- /foxglove/odom_pose (foxglove.PoseInFrame): the micro's odometry (micro_data x, y,
  heading), with every micro_data;
- /tf (foxglove.FrameTransform): world -> base_link (truth) with each truth pose and
  world -> odom_base_link (odometry) with each odometry pose;
- /foxglove/path (foxglove.PosesInFrame): the true path since the start (of the truth poses
  above), a pose kept every PATH_STEP_M moved or PATH_TURN_RAD turned, at most PATH_MAX
  poses (when full, every other pose is dropped and both steps double, so the path stays
  evenly spaced), published each simulated second in which it grew;
- /foxglove/log (foxglove.Log): the mission's events (keys, faults, host exit) and the
  planner's commands, at their simulated times (name `navkit-sim`), and the host's console
  (host.log) line by line at the simulated time of the frame it appeared in (name
  `navkit-host`, file `host.log` and the line's number; navkit.sim.host_console gives the
  levels and puts placeholders for the run's temporary names);
- /foxglove/scene (foxglove.SceneUpdate): the world's walls, once at t = 0, from the plant
  FMU's `walls` output (the world file as the plant parsed it): entity `walls` in frame
  `world`, a box per wall standing on the floor, WALL_THICKNESS_M thick and WALL_HEIGHT_M
  high.
"""

from __future__ import annotations

import json
import math
import struct

__all__ = ["SCHEMAS", "TOPICS", "TRUTH_PERIOD_NS", "PATH_STEP_M", "PATH_TURN_RAD",
           "PATH_MAX", "WALL_BYTES", "WALL_HEIGHT_M", "WALL_THICKNESS_M", "FoxgloveWriter"]

TRUTH_PERIOD_NS = 100_000_000    # truth poses and transforms: 10 Hz of simulated time, ns
PATH_PERIOD_NS = 1_000_000_000   # /foxglove/path at most once per simulated second, ns
PATH_STEP_M = 0.05               # a path pose per 50 mm moved, m
PATH_TURN_RAD = math.radians(10.0)   # ... or per 10 deg turned, rad
PATH_MAX = 128                   # poses in one /foxglove/path message at most
WALL_BYTES = 32                  # a wall in the plant's walls output: 4 float64 (mm)
WALL_HEIGHT_M = 0.3              # the walls' boxes: height, m (the world file is 2D)
WALL_THICKNESS_M = 0.02          # ... and thickness, m
_WALL_COLOR = {"r": 0.6, "g": 0.6, "b": 0.65, "a": 1.0}

_TIME = {"type": "object", "title": "time",
         "description": "simulated time since the start of the run (= the log time)",
         "properties": {"sec": {"type": "integer", "minimum": 0, "description": "s"},
                        "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999,
                                 "description": "ns"}},
         "required": ["sec", "nsec"]}


def _xyz(title: str, what: str, names=("x", "y", "z")) -> dict:
    return {"type": "object", "title": title, "description": what,
            "properties": {n: {"type": "number", "description": f"{n}, m"} for n in names},
            "required": list(names)}


_QUAT = {"type": "object", "title": "foxglove.Quaternion",
         "description": "orientation, a unit quaternion: a rotation by yaw (rad, "
                        "counter-clockwise looking down) about +z is (0, 0, sin(yaw/2), "
                        "cos(yaw/2))",
         "properties": {n: {"type": "number"} for n in "xyzw"},
         "required": list("xyzw")}

_POSE = {"type": "object", "title": "foxglove.Pose", "description": "pose in the frame",
         "properties": {"position": _xyz("foxglove.Vector3", "position, m"),
                        "orientation": _QUAT},
         "required": ["position", "orientation"]}

def _none(what: str) -> dict:
    """An array property this writer always leaves empty."""
    return {"type": "array", "maxItems": 0, "description": f"{what}: none (always empty)"}


_CUBE = {"type": "object", "title": "foxglove.CubePrimitive", "description": "a wall",
         "properties": {"pose": dict(_POSE, description="the box's centre (m) and its "
                                     "orientation: x along the wall"),
                        "size": _xyz("foxglove.Vector3", "x: the wall's length, y: "
                                     "WALL_THICKNESS_M, z: WALL_HEIGHT_M; m"),
                        "color": {"type": "object", "title": "foxglove.Color",
                                  "description": "RGBA, each 0..1",
                                  "properties": {c: {"type": "number"} for c in "rgba"},
                                  "required": list("rgba")}},
         "required": ["pose", "size", "color"]}

_ENTITY = {"type": "object", "title": "foxglove.SceneEntity",
           "description": "the walls: a box per wall of the plant's world",
           "properties": {"timestamp": _TIME, "frame_id": {"type": "string"},
                          "id": {"type": "string", "description": "walls"},
                          "lifetime": {"type": "object", "title": "duration",
                                       "description": "0: shown until replaced",
                                       "properties": {"sec": {"type": "integer"},
                                                      "nsec": {"type": "integer", "minimum": 0,
                                                               "maximum": 999_999_999}},
                                       "required": ["sec", "nsec"]},
                          "frame_locked": {"type": "boolean"},
                          "metadata": _none("metadata"), "arrows": _none("arrows"),
                          "cubes": {"type": "array", "items": _CUBE,
                                    "description": "a box per wall, in the walls output's order"},
                          "spheres": _none("spheres"), "cylinders": _none("cylinders"),
                          "lines": _none("lines"), "triangles": _none("triangles"),
                          "texts": _none("texts"), "models": _none("models")},
           "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata",
                        "arrows", "cubes", "spheres", "cylinders", "lines", "triangles",
                        "texts", "models"]}

_FRAMES = ("frame `world`: the start pose, x forward, y left, z up (as /truth); "
           "`base_link`: the robot by the plant's truth; `odom_base_link`: the robot by the "
           "micro's odometry (its own origin: the start pose until a micro reset)")

SCHEMAS = {
    "foxglove.PoseInFrame": {
        "title": "foxglove.PoseInFrame",
        "description": "A pose of the robot in frame `world` (m, quaternion). " + _FRAMES,
        "type": "object",
        "properties": {"timestamp": _TIME, "frame_id": {"type": "string"}, "pose": _POSE},
        "required": ["timestamp", "frame_id", "pose"]},
    "foxglove.FrameTransform": {
        "title": "foxglove.FrameTransform",
        "description": "The pose of a child frame in its parent frame (m, quaternion). "
                       + _FRAMES,
        "type": "object",
        "properties": {"timestamp": _TIME, "parent_frame_id": {"type": "string"},
                       "child_frame_id": {"type": "string"},
                       "translation": _xyz("foxglove.Vector3", "child origin in the parent, m"),
                       "rotation": _QUAT},
        "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation",
                     "rotation"]},
    "foxglove.PosesInFrame": {
        "title": "foxglove.PosesInFrame",
        "description": "The robot's true path since the start in frame `world` (m, "
                       "quaternion), oldest first. " + _FRAMES,
        "type": "object",
        "properties": {"timestamp": _TIME, "frame_id": {"type": "string"},
                       "poses": {"type": "array", "items": _POSE}},
        "required": ["timestamp", "frame_id", "poses"]},
    "foxglove.Log": {
        "title": "foxglove.Log",
        "description": "A mission event or planner command (name navkit-sim; level 2 info, "
                       "3 warning: faults, a host that exited), or a line of the host's "
                       "console (name navkit-host; level by the line's kind: "
                       "navkit.sim.host_console), at its simulated time",
        "type": "object",
        "properties": {"timestamp": _TIME,
                       "level": {"type": "integer", "enum": [0, 1, 2, 3, 4, 5],
                                 "description": "0 unknown, 1 debug, 2 info, 3 warning, "
                                                "4 error, 5 fatal"},
                       "message": {"type": "string"},
                       "name": {"type": "string",
                                "description": "who: navkit-sim or navkit-host"},
                       "file": {"type": "string", "description": "navkit-host: host.log; "
                                "navkit-sim: empty (the mission file's name is the "
                                "metadata's mission_file)"},
                       "line": {"type": "integer", "minimum": 0,
                                "description": "navkit-host: the line's number in host.log "
                                "(from 1); navkit-sim: 0 (the entry is named in message)"}},
        "required": ["timestamp", "level", "message", "name", "file", "line"]},
    "foxglove.SceneUpdate": {
        "title": "foxglove.SceneUpdate",
        "description": "The world's walls (the plant FMU's walls output, the world file as "
                       "the plant parsed it) in frame `world` (m): one entity `walls`, a "
                       "box per wall standing on the floor. " + _FRAMES,
        "type": "object",
        "properties": {"deletions": _none("deletions"),
                       "entities": {"type": "array", "items": _ENTITY}},
        "required": ["deletions", "entities"]},
}

# topic -> Foxglove schema name, in channel registration order
TOPICS = {
    "/foxglove/truth_pose": "foxglove.PoseInFrame",
    "/foxglove/odom_pose": "foxglove.PoseInFrame",
    "/tf": "foxglove.FrameTransform",
    "/foxglove/path": "foxglove.PosesInFrame",
    "/foxglove/log": "foxglove.Log",
    "/foxglove/scene": "foxglove.SceneUpdate",
}

_STAMP = b'{"timestamp":{"sec":%d,"nsec":%d},'
# A pose's numbers are formatted once for its PoseInFrame, its FrameTransform and the
# path: the position's x and y (m, 7 decimals) run from the value of "x" to the name of
# the rotation's key (_XY), the quaternion's z and w (9 decimals) from after that name
# to the end of the rotation (_QZW); the templates fill in the keys between.
_XY = b'%.7f,"y":%.7f,"z":0.0},"'
_QZW = b'":{"x":0.0,"y":0.0,"z":%.9f,"w":%.9f}}'
_POSE_TEXT = b'{"position":{"x":%sorientation%s'            # % (_XY text, _QZW text)
_POSE_IN = _STAMP + b'"frame_id":"world","pose":' + _POSE_TEXT + b'}'
_TF = _STAMP + b'"parent_frame_id":"world","child_frame_id":"%s","translation":{"x":%srotation%s'
_PATH_HEAD = _STAMP + b'"frame_id":"world","poses":['

# events that are the mission's faults, or the host's end: level warning; others info
_WARNING_KINDS = {"kill_host", "micro_reset", "unplug", "line_noise", "planner_silent",
                  "host_exited"}


class FoxgloveWriter:
    """Writes the Foxglove topics through a `Recorder`'s per-topic writers (`writer(topic)`
    -> fn(t_ns, JSON bytes)); the caller keeps the Recorder's chunk spans (reserve) as for
    the items it derives them from."""

    def __init__(self, writer):
        self._truth_pose = writer("/foxglove/truth_pose")
        self._odom_pose = writer("/foxglove/odom_pose")
        self._tf = writer("/tf")
        self._path_w = writer("/foxglove/path")
        self._log = writer("/foxglove/log")
        self._scene = writer("/foxglove/scene")
        self._path: list = []           # pose texts of the path, oldest first
        self._kept = None               # (x m, y m, yaw rad) of the last path pose
        self._steps = (PATH_STEP_M, PATH_TURN_RAD)   # now (m, rad): doubled at each thinning
        self._path_due = 0              # next time (ns) the path may be published
        self._path_grew = False
        self._odom = (None, b"", b"")   # the last odometry (mm, mm, deg x 10) and its texts
        self._dumps = json.JSONEncoder(separators=(",", ":"), ensure_ascii=False).encode

    def truth(self, t_ns: int, x_mm: float, y_mm: float, yaw_deg: float) -> None:
        """A truth row at `t_ns` (ns): x, y (mm), yaw (deg, counter-clockwise); written
        when t_ns is a multiple of TRUTH_PERIOD_NS."""
        if t_ns % TRUTH_PERIOD_NS:
            return
        sec, nsec = divmod(t_ns, 1_000_000_000)
        x, y, yaw = x_mm * 1e-3, y_mm * 1e-3, math.radians(yaw_deg)
        xy, qzw = _XY % (x, y), _QZW % (math.sin(0.5 * yaw), math.cos(0.5 * yaw))
        self._truth_pose(t_ns, _POSE_IN % (sec, nsec, xy, qzw))
        self._tf(t_ns, _TF % (sec, nsec, b"base_link", xy, qzw))
        kept = self._kept
        step, turn = self._steps
        if (kept is None or math.hypot(x - kept[0], y - kept[1]) >= step
                or abs(yaw - kept[2]) >= turn):
            self._kept = (x, y, yaw)
            path = self._path
            if len(path) >= PATH_MAX:
                path[:] = path[::2]     # keeps the first pose; the latest is appended next
                self._steps = (2 * step, 2 * turn)
            path.append(_POSE_TEXT % (xy, qzw))
            self._path_grew = True
        if self._path_grew and t_ns >= self._path_due:
            self._path_w(t_ns, _PATH_HEAD % (sec, nsec) + b",".join(self._path) + b"]}")
            self._path_grew = False
            self._path_due = t_ns - t_ns % PATH_PERIOD_NS + PATH_PERIOD_NS

    def odom(self, t_ns: int, x_mm: int, y_mm: int, heading_ddeg: int) -> None:
        """micro_data's odometry at `t_ns` (ns): x, y (mm, the truth's axes) and the gyro
        heading (deg x 10, clockwise)."""
        sec, nsec = divmod(t_ns, 1_000_000_000)
        odom = (x_mm, y_mm, heading_ddeg)
        if odom != self._odom[0]:       # integers: the same values, the same text
            yaw = -math.radians(heading_ddeg * 0.1)
            self._odom = (odom, _XY % (x_mm * 1e-3, y_mm * 1e-3),
                          _QZW % (math.sin(0.5 * yaw), math.cos(0.5 * yaw)))
        _, xy, qzw = self._odom
        self._odom_pose(t_ns, _POSE_IN % (sec, nsec, xy, qzw))
        self._tf(t_ns, _TF % (sec, nsec, b"odom_base_link", xy, qzw))

    def log(self, t_ns: int, level: int, message: str, name: str = "navkit-sim",
            file: str = "", line: int = 0) -> None:
        """A foxglove.Log at `t_ns` (ns): `level` (1 debug, 2 info, 3 warning, 4 error),
        `message`, from `name` (file and line: where it was written, if anywhere)."""
        sec, nsec = divmod(t_ns, 1_000_000_000)
        self._log(t_ns, self._dumps({"timestamp": {"sec": sec, "nsec": nsec}, "level": level,
                                     "message": message, "name": name,
                                     "file": file, "line": line}).encode())

    def console(self, t_ns: int, level: int, message: str, line: int) -> None:
        """Line number `line` of the host's console (host.log), with placeholders, at the
        simulated time `t_ns` (ns) of the frame it appeared in."""
        self.log(t_ns, level, message, "navkit-host", "host.log", line)

    def walls(self, t_ns: int, data: bytes) -> None:
        """The world's walls as a foxglove.SceneUpdate at `t_ns` (ns). `data`: the plant
        FMU's walls output as navkit.sim.fmus.FmuPair.walls checked it, whole walls of
        WALL_BYTES (ax, ay, bx, by: little-endian float64, mm, in the start pose frame =
        frame `world`)."""
        sec, nsec = divmod(t_ns, 1_000_000_000)
        cubes = []
        for ax, ay, bx, by in struct.iter_unpack("<4d", data):
            dx, dy = (bx - ax) * 1e-3, (by - ay) * 1e-3
            half = 0.5 * math.atan2(dy, dx)
            cubes.append({"pose": {"position": {"x": (ax + bx) * 5e-4, "y": (ay + by) * 5e-4,
                                                "z": 0.5 * WALL_HEIGHT_M},
                                   "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(half),
                                                   "w": math.cos(half)}},
                          "size": {"x": math.hypot(dx, dy), "y": WALL_THICKNESS_M,
                                   "z": WALL_HEIGHT_M},
                          "color": _WALL_COLOR})
        stamp = {"sec": sec, "nsec": nsec}
        entity = {"timestamp": stamp, "frame_id": "world", "id": "walls",
                  "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "metadata": [],
                  "arrows": [], "cubes": cubes, "spheres": [], "cylinders": [], "lines": [],
                  "triangles": [], "texts": [], "models": []}
        self._scene(t_ns, self._dumps({"deletions": [], "entities": [entity]}).encode())

    def event(self, t_ns: int, kind: str, detail: dict) -> None:
        """A mission event (as /events): its kind and details, a warning for a fault or
        the host's exit."""
        text = kind + "".join(f" {k}={v}" for k, v in detail.items())
        self.log(t_ns, 3 if kind in _WARNING_KINDS else 2, text)

    def command(self, t_ns: int, cmd: dict, entry) -> None:
        """A planner command (lisp_cmd `cmd`, raw values) for mission entry `entry`
        ((number, t, where) as the harness gives it): the entry's number and the command's
        non-zero fields (not `where`: it names the mission file, which may be anywhere)."""
        where = (f"[[command]] #{entry[0]}" if isinstance(entry, tuple) and entry
                 else "command")
        fields = " ".join(f"{k}={v}" for k, v in cmd.items() if v and k != "msg_type")
        self.log(t_ns, 2, f"planner: {where}: lisp_cmd {fields}")
