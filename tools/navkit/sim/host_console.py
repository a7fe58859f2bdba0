"""The host's console (host.log) as run-log lines: what `navkit-host` printed, line by
line, with a level and with every name that differs from run to run replaced by a stable
placeholder, so run.mcap stays a function of (mission, config, seed).

The harness calls `read()` after each host frame (lockstep: after the frame's done, when
the host has flushed all it printed in it; real time: once per chunk) and stamps the lines
with that frame's simulated time; `rest()` at the end gives what the host printed last
(shutdown, a line without its newline).

Placeholders (the harness knows each value; PLACEHOLDERS names them):

- `<tmp>`: the run's temporary folder (the pty `<tmp>/ttyNAVKIT`, the FMUs' folders);
- `<rcomm>`: the rcomm shared-memory name (it holds the harness's pid);
- `<datalog N>`: the N-th datalog file the console names (in the output folder: the name
  has the wall-clock date), in order of first mention;
- `<out>`: the output folder (any other mention of it);
- `<config>`: the config folder.

Levels (foxglove.Log), by the line's kind: a line without the console's time stamp
(`[  t.ttt] `) is the host's stderr (a fatal error, its usage): error (4). Of the console's
lines, `status:` lines are debug (1); the counters of the shutdown (SUMMARY_KINDS) info
(2); a line that reports a fault, a loss or a refusal (one of WARNING_WORDS, or a
WARNING_KINDS start) warning (3); any other info (2). The message is the text after the
time stamp: the log time says when.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["HostConsole", "PLACEHOLDERS", "WARNING_WORDS", "WARNING_KINDS", "SUMMARY_KINDS",
           "DEBUG", "INFO", "WARNING", "ERROR", "level_of"]

DEBUG, INFO, WARNING, ERROR = 1, 2, 3, 4     # foxglove.Log levels

PLACEHOLDERS = ("<tmp>", "<rcomm>", "<datalog N>", "<out>", "<config>")

# words of the host's console lines that report a fault, a loss or a refusal
WARNING_WORDS = ("lost", "refused", "rejected", "not obeyed", "ignored", "cannot", "could not",
                 "safety stop", "silent", "not configured", "not driving", "differs",
                 "not implemented", "micro reset", "trying again", "signal", "held back",
                 "arrived within")
# the starts of the console's lines that are warnings whatever their words: a datalog
# that failed to write
WARNING_KINDS = ("datalog: ",)
# the starts of the shutdown's counter lines: info whatever they count (their counters
# are named "rejected", "dropped", ...; summary.json holds them as numbers)
SUMMARY_KINDS = ("link: ", "micro's receive counters", "micro's CAN counters", "clock: ",
                 "shut down after ")

_STAMP = re.compile(r"\[ *-?\d+\.\d{3}\] ")
_WARNING = re.compile("|".join(r"\b" + re.escape(w) + r"\b" for w in WARNING_WORDS))


def level_of(line: str) -> tuple[int, str]:
    """(foxglove.Log level, message) of one console line (without its newline)."""
    m = _STAMP.match(line)
    if m is None:
        return ERROR, line
    text = line[m.end():]
    if text.startswith("status: "):
        return DEBUG, text
    if text.startswith(SUMMARY_KINDS):
        return INFO, text
    if text.startswith(WARNING_KINDS):
        return WARNING, text
    return (WARNING if _WARNING.search(text) else INFO), text


class HostConsole:
    """Reads the host's console file `path` (host.log, which the host writes through its
    stdout and stderr) as it grows. `names`: {text: placeholder} of the run's temporary
    names (PLACEHOLDERS but `<datalog N>`); `out`: the output folder, whose .txt files the
    console names become `<datalog N>`."""

    def __init__(self, path: Path, names: dict, out: Path | None = None):
        self._fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
        self._buf = b""
        self._line = 0          # lines given so far (host.log's line number of the last)
        # longest first: a name inside another is replaced after it
        self._names = sorted(((k, v) for k, v in names.items() if k), key=lambda kv: -len(kv[0]))
        self._datalog = (re.compile(re.escape(str(out).rstrip("/")) + r"/[^/\n]*?\.txt")
                         if out is not None else None)
        self._datalogs: dict = {}   # datalog path -> its placeholder

    def _stable(self, text: str) -> str:
        """`text` with the run's temporary names as their placeholders."""
        if self._datalog is not None:
            text = self._datalog.sub(self._datalog_name, text)
        for name, placeholder in self._names:
            if name in text:
                text = text.replace(name, placeholder)
        return text

    def _datalog_name(self, m) -> str:
        """The placeholder of the datalog path matched by `m`: numbered on first sight."""
        return self._datalogs.setdefault(m.group(0), f"<datalog {len(self._datalogs) + 1}>")

    def _lines(self, data: bytes) -> list:
        """[(level, message, line number)] of `data`, lines without their newlines."""
        out = []
        for raw in data.split(b"\n"):
            self._line += 1
            level, text = level_of(raw.decode(errors="replace").rstrip("\r"))
            out.append((level, self._stable(text), self._line))
        return out

    def read(self) -> list:
        """The whole lines the host printed since the last call: [(level, message, line
        number in host.log)]; a line without its newline yet waits for it."""
        data = os.read(self._fd, 1 << 16)
        if not data:
            return []
        if len(data) == 1 << 16:            # a full read: there may be more
            parts = [data]
            while len(parts[-1]) == 1 << 16:
                parts.append(os.read(self._fd, 1 << 16))
            data = b"".join(parts)
        data = self._buf + data
        cut = data.rfind(b"\n")
        if cut < 0:
            self._buf = data
            return []
        self._buf = data[cut + 1:]
        return self._lines(data[:cut])

    def rest(self) -> list:
        """read(), then the last line even without its newline; closes the file."""
        out = self.read()
        if self._buf:
            out += self._lines(self._buf)
            self._buf = b""
        self.close()
        return out

    def close(self) -> None:
        """Closes host.log (again: nothing)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
