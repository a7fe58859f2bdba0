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
  planner's commands, at their simulated times.

The host's console (host.log) is not among them: its text names wall-clock and temporary
things (the datalog's date, the pty's folder, the rcomm name), and the run log is a
function of (mission, config, seed) only.
"""

from __future__ import annotations

import json
import math

__all__ = ["SCHEMAS", "TOPICS", "TRUTH_PERIOD_NS", "PATH_STEP_M", "PATH_TURN_RAD",
           "PATH_MAX", "FoxgloveWriter"]

TRUTH_PERIOD_NS = 100_000_000    # truth poses and transforms: 10 Hz of simulated time, ns
PATH_PERIOD_NS = 1_000_000_000   # /foxglove/path at most once per simulated second, ns
PATH_STEP_M = 0.05               # a path pose per 50 mm moved, m
PATH_TURN_RAD = math.radians(10.0)   # ... or per 10 deg turned, rad
PATH_MAX = 128                   # poses in one /foxglove/path message at most

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
        "description": "A mission event or planner command (navkit sim), at its simulated "
                       "time. level: 2 info, 3 warning (faults, a host that exited)",
        "type": "object",
        "properties": {"timestamp": _TIME,
                       "level": {"type": "integer", "enum": [0, 1, 2, 3, 4, 5],
                                 "description": "0 unknown, 1 debug, 2 info, 3 warning, "
                                                "4 error, 5 fatal"},
                       "message": {"type": "string"},
                       "name": {"type": "string", "description": "who: navkit-sim"},
                       "file": {"type": "string", "description": "empty (the mission "
                                "file's name is the metadata's mission_file)"},
                       "line": {"type": "integer", "minimum": 0,
                                "description": "0 (the entry is named in message)"}},
        "required": ["timestamp", "level", "message", "name", "file", "line"]},
}

# topic -> Foxglove schema name, in channel registration order
TOPICS = {
    "/foxglove/truth_pose": "foxglove.PoseInFrame",
    "/foxglove/odom_pose": "foxglove.PoseInFrame",
    "/tf": "foxglove.FrameTransform",
    "/foxglove/path": "foxglove.PosesInFrame",
    "/foxglove/log": "foxglove.Log",
}

_STAMP = b'{"timestamp":{"sec":%d,"nsec":%d},'
_POSE_TEXT = (b'{"position":{"x":%.7f,"y":%.7f,"z":0.0},'
              b'"orientation":{"x":0.0,"y":0.0,"z":%.9f,"w":%.9f}}')
_POSE_IN = _STAMP + b'"frame_id":"world","pose":' + _POSE_TEXT + b'}'
_TF = (_STAMP + b'"parent_frame_id":"world","child_frame_id":"%s","translation":'
       b'{"x":%.7f,"y":%.7f,"z":0.0},"rotation":{"x":0.0,"y":0.0,"z":%.9f,"w":%.9f}}')
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
        self._path: list = []           # pose texts of the path, oldest first
        self._kept = None               # (x m, y m, yaw rad) of the last path pose
        self._steps = (PATH_STEP_M, PATH_TURN_RAD)   # now (m, rad): doubled at each thinning
        self._path_due = 0              # next time (ns) the path may be published
        self._path_grew = False
        self._dumps = json.JSONEncoder(separators=(",", ":"), ensure_ascii=False).encode

    def truth(self, t_ns: int, x_mm: float, y_mm: float, yaw_deg: float) -> None:
        """A truth row at `t_ns` (ns): x, y (mm), yaw (deg, counter-clockwise); written
        when t_ns is a multiple of TRUTH_PERIOD_NS."""
        if t_ns % TRUTH_PERIOD_NS:
            return
        sec, nsec = divmod(t_ns, 1_000_000_000)
        x, y, yaw = x_mm * 1e-3, y_mm * 1e-3, math.radians(yaw_deg)
        qz, qw = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        self._truth_pose(t_ns, _POSE_IN % (sec, nsec, x, y, qz, qw))
        self._tf(t_ns, _TF % (sec, nsec, b"base_link", x, y, qz, qw))
        kept = self._kept
        step, turn = self._steps
        if (kept is None or math.hypot(x - kept[0], y - kept[1]) >= step
                or abs(yaw - kept[2]) >= turn):
            self._kept = (x, y, yaw)
            path = self._path
            if len(path) >= PATH_MAX:
                path[:] = path[::2]     # keeps the first pose; the latest is appended next
                self._steps = (2 * step, 2 * turn)
            path.append(_POSE_TEXT % (x, y, qz, qw))
            self._path_grew = True
        if self._path_grew and t_ns >= self._path_due:
            self._path_w(t_ns, _PATH_HEAD % (sec, nsec) + b",".join(self._path) + b"]}")
            self._path_grew = False
            self._path_due = t_ns - t_ns % PATH_PERIOD_NS + PATH_PERIOD_NS

    def odom(self, t_ns: int, x_mm: int, y_mm: int, heading_ddeg: int) -> None:
        """micro_data's odometry at `t_ns` (ns): x, y (mm, the truth's axes) and the gyro
        heading (deg x 10, clockwise)."""
        sec, nsec = divmod(t_ns, 1_000_000_000)
        x, y, yaw = x_mm * 1e-3, y_mm * 1e-3, -math.radians(heading_ddeg * 0.1)
        qz, qw = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        self._odom_pose(t_ns, _POSE_IN % (sec, nsec, x, y, qz, qw))
        self._tf(t_ns, _TF % (sec, nsec, b"odom_base_link", x, y, qz, qw))

    def log(self, t_ns: int, level: int, message: str) -> None:
        """A foxglove.Log at `t_ns` (ns): `level` (2 info, 3 warning), `message`."""
        sec, nsec = divmod(t_ns, 1_000_000_000)
        self._log(t_ns, self._dumps({"timestamp": {"sec": sec, "nsec": nsec}, "level": level,
                                     "message": message, "name": "navkit-sim",
                                     "file": "", "line": 0}).encode())

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
