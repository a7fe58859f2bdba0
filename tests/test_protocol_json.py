"""The codec's fast path to JSON text: the generated navkit_json (`navkit gen --py-out`,
loaded by protocol.json_texts) gives the codec's decoding dumped as JSON, byte for byte;
frame_crc_ok and split_frames agree with crc16 and decode_frame."""

import json
import random
import struct

import pytest

from navkit import protocol

DUMPS = json.JSONEncoder(separators=(",", ":")).encode


def _random_frame(rng, m, good_crc=True):
    body = bytearray(rng.randrange(256) for _ in range(m.size - 2))
    struct.pack_into("<HHHH", body, 0, protocol.SPEC.framing["start_word"],
                     rng.randrange(1 << 16), m.id, m.words)
    crc = protocol.crc16(body)
    return bytes(body) + struct.pack("<H", crc if good_crc else crc ^ (1 << rng.randrange(16)))


def test_generated_texts_are_the_codecs_json():
    texts = protocol.json_texts()
    assert texts.SPEC_HASH == protocol.SPEC_HASH
    assert set(texts.BY_NAME) == set(protocol.SPEC.messages)
    assert {m.id: m.name for m in protocol.SPEC.serial_messages()} == \
        {k: t.name for k, t in texts.BY_TYPE.items()}
    rng = random.Random(11)
    for name, t in texts.BY_NAME.items():
        m = protocol.SPEC.messages[name]
        assert (t.id, t.size) == (m.id, m.size)
        for _ in range(100):
            if m.framed:
                data = _random_frame(rng, m)
                fields = protocol.decode_frame(data)[1]
            else:
                data = bytes(rng.randrange(256) for _ in range(m.size))
                fields = protocol.from_bytes(name, data)
            values = t.unpack(data)
            assert t.json % values == DUMPS(fields).encode(), name
            for f in m.fields:       # `at`: each field's first value
                first = fields[f.name][0] if f.count > 1 else fields[f.name]
                assert values[t.at[f.name]] == first, (name, f.name)


def test_frame_crc_ok_is_crc16():
    rng = random.Random(5)
    for m in protocol.SPEC.serial_messages():
        for _ in range(100):
            good, bad = _random_frame(rng, m), _random_frame(rng, m, good_crc=False)
            assert protocol.frame_crc_ok(good)
            assert not protocol.frame_crc_ok(bad)
            with pytest.raises(protocol.ProtocolError, match="bad CRC"):
                protocol.decode_frame(bad)
    assert protocol.frame_crc_ok(b"123456789" + struct.pack("<H", 0x6F91))


def test_split_frames_takes_whole_frames_back_to_back():
    rng = random.Random(3)
    frames = [_random_frame(rng, m) for m in protocol.SPEC.serial_messages()]
    stream = b"".join(frames)
    ids = [m.id for m in protocol.SPEC.serial_messages()]
    assert protocol.split_frames(stream) == (list(zip(ids, frames)), len(stream), False)
    # the last frame cut short (in its header, in its payload): wait for the rest
    for cut in (3, 9):
        got, end, short = protocol.split_frames(stream[:len(stream) - len(frames[-1]) + cut])
        assert (got, end, short) == (list(zip(ids, frames))[:-1], len(stream) - len(frames[-1]), True)
    # garbage after the first frame: not a frame cut short (the Parser resyncs)
    got, end, short = protocol.split_frames(frames[0] + b"\x00" * 20 + frames[1])
    assert (got, end, short) == ([(ids[0], frames[0])], len(frames[0]), False)
    # a length word below a header and CRC word
    tiny = bytearray(frames[0])
    tiny[6:8] = struct.pack("<H", 4)
    assert protocol.split_frames(bytes(tiny)) == ([], 0, False)


def test_json_texts_missing_or_stale_is_an_oserror_naming_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="build it") as e:
        protocol.json_texts(tmp_path)
    assert e.value.filename == str(tmp_path / "gen" / "python" / "navkit_json.py")
    from navkit.gen import emit_python
    from navkit.spec import load

    stale = tmp_path / "stale"
    (stale / "gen" / "python").mkdir(parents=True)
    text = emit_python(load(protocol.SPEC.path)).replace(
        f"SPEC_HASH = 0x{protocol.SPEC_HASH:08x}", "SPEC_HASH = 0x00000001")
    (stale / "gen" / "python" / "navkit_json.py").write_text(text)
    with pytest.raises(OSError, match="generated from spec hash 0x00000001") as e:
        protocol.json_texts(stale)
    assert e.value.filename.endswith("navkit_json.py")
