"""The log worker's fast paths give what the slow ones give, byte for byte: the
Recorder's _ChunkMessages writes the file mcap's Writer.add_message writes, and /truth's
bytes template formats as the str template."""

import random
import struct

from navkit.sim import record


def test_chunk_messages_write_the_file_add_message_writes(tmp_path):
    """The same messages through _ChunkMessages and through Writer.add_message: the same
    file, chunk ends (span and 8 MiB size), message indexes and statistics included."""
    rng = random.Random(9)
    topics = list(record.TOPICS)
    script = []
    t = 0
    for i in range(3000):
        t += rng.choice((0, 1_000_000, 7_000_000, 400_000_000))
        topic = rng.choice(topics[:6] if i < 1500 else topics)
        size = 9_000_000 if i == 2000 else rng.randrange(1, 300)
        script.append((topic, t, bytes(rng.randrange(256) for _ in range(8)) * (size // 8 + 1)))
    files = []
    for fast in (True, False):
        path = tmp_path / f"run-{fast}.mcap"
        rec = record.Recorder(path, {"seed": 1}, fast=fast)
        assert (rec._chunk is not None) is fast, "the fast path was refused (mcap changed?)"
        for k, (topic, t_ns, data) in enumerate(script):
            rec.reserve(t_ns, t_ns)
            rec.write_raw(topic, t_ns, data)
            if k % 10 == 9:
                rec.flush_before(t_ns + 100_000_000)
        counts = rec.counts
        rec.close()
        files.append(path.read_bytes())
    assert files[0] == files[1]
    assert sum(counts.values()) == len(script)
    assert record._ChunkMessages.make(object()) is None     # not an mcap Writer: add_message


def test_truth_bytes_template_formats_as_str(tmp_path):
    """The worker formats /truth with a bytes template; the text must be what the str
    template and encode() gave (same float conversion), tricky values included."""
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
    dec.handle((record.TRUTH_ROWS, struct.pack(f"={len(columns) + 1}d", 1.0, *range(len(columns)))))
    assert dec.finish()["counts"]["/truth"] == 1


def test_the_log_worker_socket_holds_megabytes_before_the_loop_waits(tmp_path):
    """RunLog's connection to its worker has a send buffer of _SEND_BUFFER_BYTES (or the
    kernel's cap, net.core.wmem_max), not the default ~200 KiB: a worker that falls behind
    holds up the loop only after that much."""
    import socket
    from pathlib import Path

    from sim_helpers import require_build

    require_build()
    cap = int(Path("/proc/sys/net/core/wmem_max").read_text())
    log = record.RunLog(tmp_path / "run.mcap", {"seed": 1}, ["x_mm"], 2)
    try:
        s = socket.socket(fileno=log._conn.fileno())
        try:
            got = s.getsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF)   # the kernel doubles it
        finally:
            s.detach()
        assert got >= min(record._SEND_BUFFER_BYTES, cap)
    finally:
        assert log.close()["counts"]["/truth"] == 0
