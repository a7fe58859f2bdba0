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


def _random_frame(rng, m, good_crc):
    import struct

    body = bytearray(rng.randrange(256) for _ in range(m.size - 2))
    struct.pack_into("<HHHH", body, 0, protocol.SPEC.framing["start_word"],
                     rng.randrange(1 << 16), m.id, m.words)
    crc = protocol.crc16(body)
    return bytes(body) + struct.pack("<H", crc if good_crc else crc ^ (1 << rng.randrange(16)))


def test_frame_texts_are_the_codecs_json_and_crc():
    from navkit.sim.record import _frame_texts

    fast = _frame_texts(protocol)
    crc_ok = fast.pop(None)
    names = {name for name, _, _ in fast.values()}
    assert {"micro_data", "micro_cmd"} <= names, "the fast path refused a per-frame message"
    dumps = json.JSONEncoder(separators=(",", ":")).encode
    rng = random.Random(11)
    for msg_id, (name, size, text) in fast.items():
        m = protocol.SPEC.messages[name]
        assert (m.id, m.size) == (msg_id, size)
        for _ in range(100):
            frame = _random_frame(rng, m, good_crc=True)
            assert crc_ok(frame)
            assert text(frame) == dumps(protocol.decode_frame(frame)[1]).encode()
            bad = _random_frame(rng, m, good_crc=False)
            assert not crc_ok(bad)
            try:
                protocol.decode_frame(bad)
            except protocol.ProtocolError:
                pass
            else:
                raise AssertionError(f"{name}: the codec took a frame crc_ok refused")


def test_truth_bytes_template_formats_as_str(tmp_path):
    """The worker formats /truth with a bytes template; the text must be what the str
    template and encode() gave (same float conversion), tricky values included."""
    import struct

    from navkit.sim.record import _HEADING_ROUNDS_TO_360, _Decoder, _heading_wrapped

    columns = ["x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm", "v_mm_s", "w_deg_s"] \
        + [f"servo_deg_{i}" for i in range(8)] + ["dio_out"]
    dec = _Decoder(tmp_path / "run.mcap", {}, columns, len(columns) + 1)
    tricky = [0.0, -0.0, 1e-5, -4.99995e-5, 0.00005, 123.45675, -2.5e-4, 1e300, -1e-300,
              float("inf"), float("-inf"), float("nan"), 0.1 + 0.2, 359.99995]
    rng = random.Random(5)
    str_fmt = dec.truth_fmt.decode()
    for _ in range(300):
        row = tuple([rng.uniform(0, 600)] + [rng.choice(tricky) if rng.random() < 0.5
                                             else rng.uniform(-1e4, 1e4) for _ in columns[:-1]]
                    + [float(rng.randrange(4096))]) + (0.0,)
        dio = int(row[dec.dio_col]) & 0xFFF
        vals = dec.truth_get(row)
        if vals[dec.heading_at] >= _HEADING_ROUNDS_TO_360:
            vals = _heading_wrapped(vals, dec.heading_at)
        want = (str_fmt % (vals + (dio,))).encode()
        assert dec._truth_text(row) == want
    # a heading that would print as 360.0000 is written as 0 (0 <= heading_deg < 360)
    for h, text in ((359.99996, b'"heading_deg":0.0000'), (359.99994, b'"heading_deg":359.9999')):
        row = (1.0, 0.0, 0.0, 0.0, h) + (0.0,) * (len(columns) - 4) + (0.0,)
        assert text in dec._truth_text(row)
    dec.handle(("T", struct.pack(f"={len(columns) + 1}d", 1.0, *range(len(columns)))))
    assert dec.finish()["counts"]["/truth"] == 1
