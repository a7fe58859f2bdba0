"""The run log: an MCAP file of JSON messages with JSON-schema schemas.

Log time (and publish time) of every message is the simulated time in ns, never the wall
clock, so two runs of the same (mission, config, seed) give identical message contents.
Chunks are closed at least every `flush_every_s` of simulated time so a run that is killed
keeps everything before its last second.
"""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["Recorder", "message_schema", "TRUTH_SCHEMA", "FRAME_SCHEMA", "TOPICS"]

TRUTH_SCHEMA = {
    "title": "navkit.truth",
    "description": "Ground truth of the plant FMU (start pose is the origin, x forward, y left).",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "simulated time, s"},
        "x_mm": {"type": "number", "description": "x, mm"},
        "y_mm": {"type": "number", "description": "y (left), mm"},
        "yaw_deg": {"type": "number", "description": "yaw, deg, counter-clockwise positive, unwrapped"},
        "heading_deg": {"type": "number", "description": "heading, deg, clockwise, 0..360"},
        "distance_mm": {"type": "number", "description": "signed path length along the body axis, mm"},
        "v_mm_s": {"type": "number", "description": "forward speed, mm/s"},
        "w_deg_s": {"type": "number", "description": "yaw rate, deg/s, counter-clockwise positive"},
        "servo_deg": {"type": "array", "items": {"type": "number"}, "description": "servo angles, deg"},
        "dio_out": {"type": "integer", "description": "DIO output levels, 12-bit mask"},
    },
}

FRAME_SCHEMA = {
    "title": "navkit.host_frame",
    "description": "One lockstep host frame: tick sent, done received.",
    "type": "object",
    "properties": {
        "frame": {"type": "integer"},
        "t": {"type": "number", "description": "simulated time of the frame, s"},
        "rx_bytes": {"type": "integer", "description": "bytes written to the host's port before the tick"},
        "tx_bytes": {"type": "integer", "description": "bytes the host wrote in the frame"},
        "flags": {"type": "integer", "description": "bit 0 quitting, bit 1 port closed"},
        "host": {"type": "string", "description": "running, killed, exited or unplugged"},
    },
}

EVENT_SCHEMA = {
    "title": "navkit.event",
    "description": "A mission event applied by the harness (key typed, fault injected or ended).",
    "type": "object",
    "properties": {"t": {"type": "number"}, "kind": {"type": "string"}, "detail": {"type": "object"}},
}

# topic -> spec message whose fields it carries (None: a schema above)
TOPICS = {
    "/truth": None,
    "/micro/cmd": "micro_cmd",
    "/micro/config": None,
    "/micro/data": "micro_data",
    "/planner/cmd": "lisp_cmd",
    "/planner/data": "lisp_data",
    "/host/frame": None,
    "/events": None,
}


def message_schema(name: str) -> dict:
    """JSON schema of spec message `name`: one property per field (raw integer values,
    units and scale in the description), plus `t` (simulated time, s)."""
    from navkit import protocol

    m = protocol.SPEC.messages[name]
    props = {"t": {"type": "number", "description": "simulated time, s"}}
    for f in m.fields:
        desc = f.doc
        if f.units:
            desc += f" Units: {f.units}" + (f" (raw x {f.scale})" if f.scale != 1 else "") + "."
        item = {"type": "integer"}
        props[f.name] = ({"type": "array", "items": item, "minItems": f.count,
                          "maxItems": f.count, "description": desc}
                         if f.count > 1 else dict(item, description=desc))
    return {"title": f"navkit.{name}", "description": m.doc, "type": "object",
            "properties": props}


def _config_schema() -> dict:
    return {"title": "navkit.micro_config",
            "description": "A config message sent to the micro (micro_cfg_geometry, "
                           "micro_cfg_motion or micro_cfg_io) with its decoded fields.",
            "type": "object",
            "properties": {"t": {"type": "number"}, "message": {"type": "string"},
                           "fields": {"type": "object"}}}


class Recorder:
    """Writes `run.mcap`. Call `write(topic, t_ns, obj)` with JSON-able objects, `flush_if`
    once per frame, and `close()` at the end."""

    def __init__(self, path: Path, metadata: dict, flush_every_s: float = 1.0):
        from mcap.writer import CompressionType, Writer

        self._file = open(path, "wb")
        self._w = Writer(self._file, chunk_size=8 << 20, compression=CompressionType.LZ4)
        self._w.start(profile="", library="navkit")
        schemas = {"/truth": TRUTH_SCHEMA, "/micro/config": _config_schema(),
                   "/host/frame": FRAME_SCHEMA, "/events": EVENT_SCHEMA}
        self._chan = {}
        for topic, msg in TOPICS.items():
            schema = schemas[topic] if msg is None else message_schema(msg)
            sid = self._w.register_schema(schema["title"], "jsonschema",
                                          json.dumps(schema, sort_keys=True).encode())
            self._chan[topic] = self._w.register_channel(topic, "json", sid)
        self._w.add_metadata("navkit", {k: str(v) for k, v in metadata.items()})
        self._seq = dict.fromkeys(self._chan, 0)
        self._flush_ns = int(flush_every_s * 1e9)
        self._next_flush = self._flush_ns
        self.counts = dict.fromkeys(self._chan, 0)
        self._dumps = json.JSONEncoder(separators=(",", ":")).encode

    def write(self, topic: str, t_ns: int, obj) -> None:
        """One message on `topic` at simulated time `t_ns` (ns)."""
        self.write_raw(topic, t_ns, self._dumps(obj).encode())

    def write_raw(self, topic: str, t_ns: int, data: bytes) -> None:
        """One message whose JSON text is already encoded."""
        seq = self._seq[topic] = self._seq[topic] + 1
        self._w.add_message(self._chan[topic], t_ns, data, t_ns, seq)
        self.counts[topic] += 1

    def flush_if(self, t_ns: int) -> None:
        """Close the chunk when `t_ns` reaches the next flush point."""
        if t_ns >= self._next_flush:
            self._w.flush()
            self._next_flush = (t_ns // self._flush_ns + 1) * self._flush_ns

    def close(self) -> None:
        """Write the summary section and close the file."""
        if self._file is not None:
            self._w.finish()
            self._file.close()
            self._file = None
