"""The log worker's fast /planner/data text (navkit.sim.record._fields_text) is the
codec's decoding dumped as JSON, byte for byte."""

import json
import random

from navkit import protocol
from navkit.sim.record import _fields_text


def test_lisp_data_text_is_the_codecs_json():
    text = _fields_text(protocol, "lisp_data")
    assert text is not None, "the fast path refused lisp_data (bench-sim gets slower)"
    dumps = json.JSONEncoder(separators=(",", ":")).encode
    rng = random.Random(7)
    size = protocol.SPEC.messages["lisp_data"].size
    for _ in range(200):
        data = bytes(rng.randrange(256) for _ in range(size))
        assert text(data) == dumps(protocol.from_bytes("lisp_data", data)).encode()
