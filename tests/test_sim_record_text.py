"""The log worker's fast paths give what the slow ones give, byte for byte: the
Recorder's own MCAP writer (_McapFile) writes the file mcap's Writer writes, and the native
row formatter (fmu/record) writes /truth as Python's % formats its template."""

import random
import struct

import pytest

from navkit.sim import record


class _WriterFile:
    """mcap's Writer (add_message, flush, finish) behind record._McapFile's interface: the
    reference the Recorder's own writer is held to, put in its place by monkeypatch."""

    def __init__(self, stream, chunk_size: int):
        from mcap.writer import CompressionType, Writer

        self.w = w = Writer(stream, chunk_size=chunk_size, compression=CompressionType.LZ4)
        self.start, self.register_schema, self.register_channel, self.add_metadata = \
            w.start, w.register_schema, w.register_channel, w.add_metadata
        self.flush = w.flush

    def writer(self, chan: int, n: list, keep=None):
        def write(t_ns: int, data: bytes) -> None:
            n[0] += 1
            self.w.add_message(chan, t_ns, data, t_ns, n[0])
        return write

    def rows_writer(self, chan: int, n: list, fmt, stop_every_ns: int, keep_run=None):
        write = self.writer(chan, n)

        def write_rows(raw: bytes, first: int, last: int) -> tuple:
            k, data, where = fmt.records(raw, first, last, 0, 0, 0, 1 << 62, stop_every_ns)
            ends = where[3::2] + [len(data)]
            for i in range(k):
                write(where[2 * i], data[where[2 * i + 1] + 31:ends[i]])
            return k, where[-2]
        return write_rows

    def finish(self, counts: dict) -> None:
        self.w.finish()


def _recorder(monkeypatch, fast: bool, path, metadata: dict):
    """A Recorder writing through its own _McapFile (`fast`) or through mcap's Writer."""
    with monkeypatch.context() as m:
        if not fast:
            m.setattr(record, "_McapFile", _WriterFile)
        rec = record.Recorder(path, metadata)
    assert isinstance(rec._w, record._McapFile if fast else _WriterFile)
    return rec


def test_own_mcap_writer_writes_the_file_mcaps_writer_writes(tmp_path, monkeypatch):
    """The same messages through _McapFile and through mcap's Writer.add_message: the
    same file, header, schemas, channels, metadata, chunk ends (span and 8 MiB size),
    message indexes, chunk indexes, statistics, summary offsets and footer included; and
    the same for a log without any message."""
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
        rec = _recorder(monkeypatch, fast, path, {"seed": 1})
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
    empty = []
    for fast in (True, False):
        rec = _recorder(monkeypatch, fast, tmp_path / f"empty-{fast}.mcap", {"seed": 2})
        rec.close()
        empty.append((tmp_path / f"empty-{fast}.mcap").read_bytes())
    assert empty[0] == empty[1]


def _python_fixed(x: float, decimals: int) -> bytes:
    """The reference: Python's '%.<decimals>f'."""
    return b"%.*f" % (decimals, x)


def _native_fixed(lib, x: float, decimals: int) -> bytes:
    import ctypes

    buf = ctypes.create_string_buffer(400)
    n = lib.rowtext_fixed(buf, x, decimals)
    return buf.raw[:n]


def test_native_fixed_point_text_is_pythons(tmp_path):
    """rowtext_fixed prints every double as Python's '%.<d>f' does: halfway cases between
    two last digits (ties to even by the exact binary value) and their neighbours one ulp
    away, signed zeros, tiny, huge and non-finite values, and random ones."""
    import math

    from sim_helpers import require_build

    require_build()
    lib = record._row_lib()
    rng = random.Random(11)
    values = [0.0, -0.0, 5e-324, -5e-324, 1e-300, 1e300, -1e300, 2.0 ** 52, 2.0 ** 53 + 2,
              4.5e11, -4.5e15, float("inf"), float("-inf"), float("nan"), -float("nan"),
              359.99995, 0.1 + 0.2, 123.45675, -2.5e-4, 0.5, 1.5, 2.5, -0.5]
    for _ in range(4000):
        d = rng.randrange(10)
        k = rng.randrange(-10 ** rng.randrange(1, 12), 10 ** rng.randrange(1, 12))
        half = (k + 0.5) / 10 ** d          # the double nearest a halfway point
        values += [half, math.nextafter(half, math.inf), math.nextafter(half, -math.inf),
                   rng.uniform(-1e4, 1e4), rng.uniform(-1, 1) * 10 ** rng.randrange(-8, 16)]
    for x in values:
        for d in (0, 4, 6, 7, 9) if rng.random() < 0.9 else range(10):
            assert _native_fixed(lib, x, d) == _python_fixed(x, d), (x, d)


def _template(rt) -> bytes:
    """Row program `rt` as a Python % template (decimals as %.<d>f, integers %d), the wrap
    and the mask left to the caller: the reference of its native text."""
    return ("".join(lit + ("%d" if d == record.ROW_INT else f"%.{d}f") for lit, _, d in rt.fields)
            + rt.tail).encode()


def test_truth_text_is_the_python_template(tmp_path, monkeypatch):
    """/truth rows through the native row program: the text Python's % gives with the
    program's template (heading wrap and the 12-bit dio_out mask applied), tricky values
    included, and the same MCAP records row by row as in one run."""
    from sim_helpers import require_build

    require_build()
    columns = ["x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm", "v_mm_s", "w_deg_s"] \
        + [f"servo_deg_{i}" for i in range(8)] + ["dio_out"]
    dec = record._Decoder(tmp_path / "run.mcap", {}, columns, len(columns) + 1)
    rt = dec.truth_text
    tpl = _template(rt)
    tricky = [0.0, -0.0, 1e-5, -4.99995e-5, 0.00005, 123.45675, -2.5e-4, 1e300, -1e-300,
              float("inf"), float("-inf"), float("nan"), 0.1 + 0.2, 359.99995, 359.99996]
    rng = random.Random(5)
    rows = []
    for _ in range(300):
        row = [rng.uniform(0, 600)] + [rng.choice(tricky) if rng.random() < 0.5
                                       else rng.uniform(-1e4, 1e4) for _ in columns[:-1]] \
            + [rng.choice((-1.0, 4097.9, 1e20, -3.5, float(rng.randrange(4096))))]
        vals = []
        for lit, col, d in rt.fields:
            x = 0.0 if col is None else row[col]
            if d == record.ROW_INT:
                vals.append(int(x) & 0xFFF)
            else:
                vals.append(0.0 if record._HEADING_ROUNDS_TO_360 <= x < 360.0
                            and lit.endswith('"heading_deg":') else x)
        raw = struct.pack(f"={len(row)}d", *row)
        assert rt.text(raw) == tpl % tuple(vals), row
        rows.append(raw)
    raw = b"".join(rows)
    k, data, where = rt.records(raw, 0, len(rows), 7, 40, 1000, 1 << 40, 0)
    assert k == len(rows) and len(where) == 2 * k
    at = 0
    for i, one in enumerate(rows):
        _, rec, pair = rt.records(one, 0, 1, 7, 40 + i, 1000 + at, 1 << 40, 0)
        assert pair == where[2 * i:2 * i + 2] and data[at:at + len(rec)] == rec
        assert struct.unpack_from("<BQHIQQ", rec) == (5, len(rec) - 9, 7, 41 + i, pair[0], pair[0])
        at += len(rec)
    # stops: after a row on the period, and after the record that passes the chunk size
    t_rows = [struct.pack(f"={len(row)}d", t, *([0.0] * (len(row) - 1)))
              for t in (0.098, 0.099, 0.1, 0.101)]
    assert rt.records(b"".join(t_rows), 0, 4, 7, 0, 0, 1 << 40, 100_000_000)[0] == 3
    assert rt.records(b"".join(t_rows), 0, 4, 7, 0, 100, 101, 0)[0] == 1
    bad = struct.pack(f"={len(row)}d", *([1.0] * (len(row) - 1) + [float("nan")]))
    with pytest.raises(ValueError, match="not finite"):
        rt.text(bad)
    dec.handle((record.TRUTH_ROWS, struct.pack(f"={len(columns) + 1}d", 1.0, *range(len(columns)))))
    assert dec.finish()["counts"]["/truth"] == 1
    # the rows through the Recorder's own writer and through mcap's Writer: the same file
    files = []
    for fast in (True, False):
        rec = _recorder(monkeypatch, fast, tmp_path / f"rows-{fast}.mcap", {})
        write = rec.rows_writer("/truth", rt, 100_000_000)
        at = 0
        while at < len(t_rows):
            at += write(b"".join(t_rows), at, len(t_rows))[0]
        rec.close()
        files.append((tmp_path / f"rows-{fast}.mcap").read_bytes())
    assert files[0] == files[1]


def test_a_truth_time_without_a_log_time_is_refused(tmp_path):
    """A truth row whose time (s) has no log time in int64 ns (not finite, or past
    rowtext.h's ROWTEXT_MAX_TIME_S) is a ValueError of the row formatter, wherever it is
    in the rows, not a cast C leaves undefined."""
    from sim_helpers import require_build

    require_build()
    rt = record.RowText(None, 2, [('{"t":', 0, 6), (',"x":', 1, 4)], "}")
    for t in (float("nan"), float("inf"), -float("inf"), 1e10, -9.3e9):
        raw = struct.pack("=6d", 0.001, 1.0, t, 2.0, 0.003, 3.0)
        with pytest.raises(ValueError, match="truth rows 0..2: a time"):
            rt.records(raw, 0, 3, 1, 0, 0, 1 << 40, 0)
    raw = struct.pack("=2d", 9.1e9, 1.0)
    assert rt.records(raw, 0, 1, 1, 0, 0, 1 << 40, 0)[2][0] == 9_100_000_000_000_000_000


def test_native_message_text_is_the_generated_template(tmp_path):
    """Every spec message through the native field program (FieldText, from the generated
    navkit_json's template and slots): the text its template % its unpack gives, for
    random bytes (every sign and width of value) and at an offset."""
    from navkit import protocol
    from sim_helpers import require_build

    require_build()
    rng = random.Random(3)
    texts = protocol.json_texts()
    for name, mt in texts.BY_NAME.items():
        text = record.FieldText(None, mt).text
        for _ in range(50):
            data = bytes(rng.choice((0, 255, 128, 127, rng.randrange(256))) for _ in range(mt.size))
            assert text(data) == mt.json % mt.unpack(data), name
            assert text(b"xyz" + data, 3) == mt.json % mt.unpack(data), name


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
