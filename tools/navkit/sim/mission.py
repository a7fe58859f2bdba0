"""Mission files: what the scripted planner does during a co-simulation run.

A mission is a TOML file::

    duration_s = 12.0              # simulated seconds
    world = "room.txt"             # optional, in config/worlds/ or beside the mission
    [plant]                        # optional plant FMU parameter overrides (by FMU name)
    battery_ocv_v = 12.6           # (not seed or world_file: --seed and `world` set those)
    [[command]]                    # the planner writes this whole lisp_cmd at t
    t = 1.0                        # s of simulated time
    fwd_cmd = 1                    # any lisp_cmd field by its spec name; unset fields 0
    speed = 300
    distance = 1000
    [[key]]                        # typed at the host's console (stdin)
    t = 0.5
    key = "R"
    [[fault]]
    t = 5.0
    kind = "unplug"                # kill_host | micro_reset | unplug | line_noise | planner_silent
    duration_s = 1.0               # unplug, line_noise, planner_silent (optional)
    ber = 1e-3                     # line_noise: bit error rate per bit
    [expect]                       # optional: where the robot should end (final /truth row);
    x_mm = 500.0                   # `navkit sweep` reports each run's error from these
    heading_deg = 90.0             # (keys of EXPECT_KEYS)

Every error (unknown key, bad value, a time or a fault's end past the duration) is a
MissionError naming the file, the entry and the key; a file that is not UTF-8 text (or
over MAX_MISSION_BYTES, or nested deeper than TOML readers go) is one naming the file and
the line. Entries of a table listed out of time order are run in time order, and
`Mission.warnings` says so. A bad value is also one the host would refuse while
converting the command to a micro_cmd (e.g. speed = 99999999 with fwd_cmd 1 fits
lisp_cmd's int32 but not micro_cmd's int16): the built host judges the commands
(`navkit-host --convert-lisp`), so a mission with commands loads only where navkit-host
is built (else a MissionError says so). Events take effect at the first host frame that
starts at or after their t (the harness checks that this frame is in the run).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["MissionError", "Command", "Key", "Fault", "Mission", "load", "loads",
           "FAULT_KINDS", "COMMAND_FIELDS", "RESERVED_PLANT_KEYS", "EXPECT_KEYS",
           "MAX_MISSION_BYTES", "max_duration_s"]

# A mission file larger than this is refused (bytes): missions are a few kB; the bound
# keeps a link to an endless file (/dev/zero) from being read for ever.
MAX_MISSION_BYTES = 1 << 20


def max_duration_s() -> float:
    """The longest duration_s (s): the planner stamps lisp_cmd.time_tag with the simulated
    time in ms, so a run ends before that field's maximum (the spec's int32)."""
    from navkit import protocol

    return protocol.SPEC.messages["lisp_cmd"].field("time_tag").max / 1000.0

# lisp_cmd fields a mission may set (time_tag and msg_type are the planner's own).
COMMAND_FIELDS = ("fwd_cmd", "accel", "speed", "distance", "turn_mode", "turn_accel",
                  "turn_rate", "turn_distance", "rc_servo_num", "rc_param0", "rc_param1",
                  "rc_param2", "dio_active", "dio_command", "mc_datalog_cmd", "excite_mode",
                  "excite_wheels", "excite_amplitude", "excite_offset", "excite_duration",
                  "excite_period", "excite_f0", "excite_f1", "excite_seed")

# fault kind -> (required parameters, optional parameters)
FAULT_KINDS = {
    "kill_host": ((), ()),
    "micro_reset": ((), ()),
    "unplug": (("duration_s",), ()),
    "line_noise": (("ber", "duration_s"), ()),
    "planner_silent": ((), ("duration_s",)),
}


# plant parameters the harness sets itself: [plant] key -> where a mission sets it instead
RESERVED_PLANT_KEYS = {
    "seed": "the run's seed: `navkit sim --seed N` (SimOptions.seed), recorded in the metadata",
    "world_file": "the mission's top-level `world = \"NAME.txt\"` key (config/worlds/ or "
                  "beside the mission)",
}


# [expect] key -> what it is: the final /truth row's value the mission expects
EXPECT_KEYS = {
    "x_mm": "x, mm (start pose frame, x forward)",
    "y_mm": "y, mm (left)",
    "heading_deg": "heading, deg clockwise from the start heading, 0..360",
    "distance_mm": "signed path length along the body axis, mm",
}


class MissionError(ValueError):
    """A mission file that cannot be run; the text names file, entry and key."""


@dataclass(frozen=True)
class Command:
    """A lisp_cmd written at simulated time `t` (s); `fields` by spec name, raw values;
    `where` names the entry in errors ("file: [[command]] #2")."""

    t: float
    fields: dict
    where: str = field(default="", compare=False)


@dataclass(frozen=True)
class Key:
    """Characters typed at the host console at simulated time `t` (s); `where` as in
    Command."""

    t: float
    key: str
    where: str = field(default="", compare=False)


@dataclass(frozen=True)
class Fault:
    """A fault injected at simulated time `t` (s): `kind` with its `params`
    (duration_s in s, ber in errors per bit); `where` as in Command."""

    t: float
    kind: str
    params: dict
    where: str = field(default="", compare=False)

    @property
    def duration_s(self) -> float | None:
        """How long the fault lasts (s), or None (to the end of the run / instant)."""
        return self.params.get("duration_s")


@dataclass
class Mission:
    """A loaded, checked mission (loaded with judge_later: the host's verdict on its
    commands pending until judged()). Times in s of simulated time."""

    path: Path
    text: str
    duration_s: float
    world: Path | None = None
    plant: dict = field(default_factory=dict)
    commands: list = field(default_factory=list)
    keys: list = field(default_factory=list)
    faults: list = field(default_factory=list)
    expect: dict = field(default_factory=dict)     # EXPECT_KEYS key -> value (mm, deg)
    warnings: list = field(default_factory=list)   # what a run should say once (text lines)
    # the host's verdict on the commands until judged() takes it (loads(judge_later=True))
    _verdict: object = field(default=None, init=False, repr=False, compare=False)

    def judged(self) -> None:
        """Take the host's verdict on the commands if it is still pending: MissionError as
        loads raises it. Nothing once taken."""
        verdict, self._verdict = self._verdict, None
        if verdict is not None:
            verdict()

    @property
    def name(self) -> str:
        """The mission file's stem, e.g. 'demo'."""
        return self.path.stem


def _num(where: str, key: str, v, *, positive=False, lo=None, hi=None) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MissionError(f"{where}: key {key!r}: {v!r} is not a finite number")
    if positive and v <= 0:
        raise MissionError(f"{where}: key {key!r}: {v!r} must be > 0")
    if lo is not None and v < lo:
        raise MissionError(f"{where}: key {key!r}: {v!r} must be >= {lo}")
    if hi is not None and v > hi:
        raise MissionError(f"{where}: key {key!r}: {v!r} must be <= {hi}")
    return float(v)


def _time(where: str, entry: dict, duration: float) -> float:
    if "t" not in entry:
        raise MissionError(f"{where}: key 't' is missing (seconds of simulated time)")
    t = _num(where, "t", entry["t"], lo=0.0)
    if t > duration:
        raise MissionError(f"{where}: key 't': {t} s is past duration_s = {duration} s")
    return t


def _command(where: str, entry: dict, duration: float) -> Command:
    from navkit import protocol

    t = _time(where, entry, duration)
    fields = {}
    for k, v in entry.items():
        if k == "t":
            continue
        if k not in COMMAND_FIELDS:
            raise MissionError(f"{where}: unknown key {k!r} (a command takes t and lisp_cmd "
                               f"fields: {', '.join(COMMAND_FIELDS)})")
        enum = protocol.SPEC.messages["lisp_cmd"].field(k).enum
        values = protocol.SPEC.enums[enum].values if enum else {}
        if isinstance(v, str) and v in values:
            v = values[v]       # an enum value by its spec name, e.g. fwd_cmd = "start"
        if isinstance(v, bool) or not isinstance(v, int):
            raise MissionError(f"{where}: key {k!r}: {v!r} is not an integer (raw lisp_cmd "
                               f"value{', or one of ' + ', '.join(values) if values else ''})")
        if values and v not in values.values():
            codes = ", ".join(f"{n}={c}" for n, c in values.items())
            raise MissionError(f"{where}: key {k!r}: {v} is not a {enum} code ({codes})")
        fields[k] = v
    try:
        protocol.to_bytes("lisp_cmd", fields, strict=False)
        for k, v in fields.items():
            protocol.check("lisp_cmd", {k: v})
    except protocol.ProtocolError as e:
        key = next((k for k in fields if f".{k}:" in str(e)), "?")
        raise MissionError(f"{where}: key {key!r}: {e}") from None
    return Command(t, fields, where)


def _host_conversion(commands: list, build: Path | None):
    """Start the host judging `commands` and return a function that waits for its verdict:
    MissionError naming the entry and key of the first command the host would drop while
    making its micro_cmd: the host itself judges them (`navkit-host --convert-lisp`,
    Navigation::convert, docs/host.md), all in one process. A heading hold is judged with
    a heading: at run time the micro's reports give it one (without them the host says
    so on its console). `build`: the build folder of navkit-host (None: navkit.paths.
    build_dir()). Without a built host: a MissionError saying so."""
    from navkit.hostconfig import HostConfigError, convert_lisp_started

    commands = list(commands)       # in file order, as the verdicts come
    if not commands:
        return lambda: None
    answer = convert_lisp_started([{**c.fields, "heading": 0} for c in commands], build=build)

    def verdict() -> None:
        try:
            verdicts = answer()
        except HostConfigError as e:
            raise MissionError(f"{commands[0].where}: the host judges the commands and cannot: {e}") from None
        for c, v in zip(commands, verdicts):
            if v["nav_result"] == "rejected":
                raise MissionError(f"{c.where}: key {v['lisp_field']!r}: {v['text']}: the host would drop "
                                   f"the command")
    return verdict


def _key(where: str, entry: dict, duration: float) -> Key:
    t = _time(where, entry, duration)
    for k in entry:
        if k not in ("t", "key"):
            raise MissionError(f"{where}: unknown key {k!r} (a key entry takes t and key)")
    if "key" not in entry:
        raise MissionError(f"{where}: key 'key' is missing (the character to type, e.g. \"R\")")
    v = entry["key"]
    if not isinstance(v, str) or not v or not v.isprintable():
        raise MissionError(f"{where}: key 'key': {v!r} must be printable text, e.g. \"R\"")
    return Key(t, v, where)


def _fault(where: str, entry: dict, duration: float) -> Fault:
    t = _time(where, entry, duration)
    kind = entry.get("kind")
    if kind is None:
        raise MissionError(f"{where}: key 'kind' is missing (one of {', '.join(FAULT_KINDS)})")
    if kind not in FAULT_KINDS:
        raise MissionError(f"{where}: key 'kind': {kind!r} is not a fault kind "
                           f"(one of {', '.join(FAULT_KINDS)})")
    required, optional = FAULT_KINDS[kind]
    params = {}
    for k, v in entry.items():
        if k in ("t", "kind"):
            continue
        if k not in required and k not in optional:
            allowed = ", ".join(("t", "kind") + required + optional)
            raise MissionError(f"{where}: unknown key {k!r} for kind {kind!r} (takes {allowed})")
        if k == "duration_s":
            params[k] = _num(where, k, v, positive=True)
            if t + params[k] > duration + 1e-9:
                raise MissionError(f"{where}: key 'duration_s': the fault ends at "
                                   f"{t + params[k]} s, past duration_s = {duration} s")
        elif k == "ber":
            params[k] = _num(where, k, v, lo=0.0, hi=0.5)
    for k in required:
        if k not in params:
            raise MissionError(f"{where}: key {k!r} is missing (kind {kind!r} needs "
                               f"{', '.join(required)})")
    return Fault(t, kind, params, where)


def _world(path: Path, name) -> Path:
    from navkit.paths import repo_root

    if not isinstance(name, str) or not name:
        raise MissionError(f"{path}: key 'world': {name!r} must be a file name")
    for cand in (path.parent / name, repo_root() / "config" / "worlds" / name, Path(name)):
        if cand.is_file():
            return cand.resolve()
        if cand.exists():
            raise MissionError(f"{path}: key 'world': {cand} is not a regular file (a world is a "
                               f"text file of walls)")
    raise MissionError(f"{path}: key 'world': {name!r} not found beside the mission "
                       f"or in config/worlds/")


def loads(text: str, path: str | Path = "<mission>", *, build: Path | None = None,
          judge_later: bool = False) -> Mission:
    """Parse and check mission TOML `text` (`path` names it in errors and resolves the
    world file); `build` is the build folder whose navkit-host judges the commands (None:
    navkit.paths.build_dir()). Raises MissionError. `judge_later`: the host's verdict on
    the commands is left for Mission.judged() (navkit.sim.rig.SimRig takes it), so the
    host judges them while the caller goes on."""
    path = Path(path)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise MissionError(f"{path}: not valid TOML: {e}") from None
    except RecursionError:
        raise MissionError(f"{path}: not valid TOML: arrays or tables nested too deeply") from None
    known = ("duration_s", "world", "plant", "command", "key", "fault", "expect")
    for k in doc:
        if k not in known:
            raise MissionError(f"{path}: unknown top-level key {k!r} (known: {', '.join(known)})")
    if "duration_s" not in doc:
        raise MissionError(f"{path}: key 'duration_s' is missing (simulated seconds to run)")
    duration = _num(f"{path}", "duration_s", doc["duration_s"], positive=True, hi=max_duration_s())
    m = Mission(path=path, text=text, duration_s=duration)
    if "world" in doc:
        m.world = _world(path, doc["world"])
    plant = doc.get("plant", {})
    if not isinstance(plant, dict):
        raise MissionError(f"{path}: key 'plant' must be a table of FMU parameters")
    for k, v in plant.items():
        if k in RESERVED_PLANT_KEYS:
            raise MissionError(f"{path}: [plant]: key {k!r} is set by the harness, not here: "
                               f"use {RESERVED_PLANT_KEYS[k]}")
        if isinstance(v, (dict, list)):
            raise MissionError(f"{path}: [plant]: key {k!r}: {v!r} must be a number, "
                               f"boolean or string")
        if isinstance(v, float) and not math.isfinite(v):
            raise MissionError(f"{path}: [plant]: key {k!r}: {v!r} is not finite")
    m.plant = dict(plant)
    expect = doc.get("expect", {})
    if not isinstance(expect, dict):
        raise MissionError(f"{path}: key 'expect' must be a table of final /truth values "
                           f"({', '.join(EXPECT_KEYS)})")
    for k, v in expect.items():
        if k not in EXPECT_KEYS:
            raise MissionError(f"{path}: [expect]: unknown key {k!r} (one of "
                               f"{', '.join(EXPECT_KEYS)})")
        m.expect[k] = _num(f"{path}: [expect]", k, v)
    try:
        _entries(m, doc, path, duration, build, judge_later)
    except MissionError:
        m.judged()      # a pending verdict on the commands comes first, as without judge_later
        raise
    return m


def _entries(m: Mission, doc: dict, path: Path, duration: float, build: Path | None,
             judge_later: bool) -> None:
    """loads' [[command]], [[key]] and [[fault]] tables of `doc` into `m` (sorted by time,
    with a warning for each entry out of order in the file). Raises MissionError."""
    for table, parse, out in (("command", _command, m.commands), ("key", _key, m.keys),
                              ("fault", _fault, m.faults)):
        entries = doc.get(table, [])
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise MissionError(f"{path}: {table!r} must be an array of tables ([[{table}]])")
        for i, entry in enumerate(entries):
            out.append(parse(f"{path}: [[{table}]] #{i + 1}", entry, duration))
        if table == "command":
            m._verdict = _host_conversion(out, build)
            if not judge_later:
                m.judged()
        for a, b in zip(out, out[1:]):
            if b.t < a.t:
                m.warnings.append(f"{b.where} (t = {b.t:g} s) comes after {a.where.rsplit(': ', 1)[1]} "
                                  f"(t = {a.t:g} s) in the file: entries run in time order")
        out.sort(key=lambda e: e.t)   # stable: same-time entries keep file order


def load(path: str | Path, *, build: Path | None = None, judge_later: bool = False) -> Mission:
    """Load and check the mission file at `path` (`build`, `judge_later` as in loads).
    Raises MissionError."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_MISSION_BYTES + 1)
    except OSError as e:
        raise MissionError(f"{path}: cannot read: {e.strerror}") from None
    if len(data) > MAX_MISSION_BYTES:
        raise MissionError(f"{path}: longer than {MAX_MISSION_BYTES} bytes: not a mission file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise MissionError(f"{path}:{line}: byte offset {e.start}: 0x{data[e.start]:02X} is not UTF-8 "
                           f"text (save the file as UTF-8)") from None
    return loads(text, path, build=build, judge_later=judge_later)
