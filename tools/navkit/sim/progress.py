"""How far a run is, shown on stderr while it runs (`navkit sim`; SimOptions.progress)."""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """How far a run is, on `stream` (stderr): on a terminal one line redrawn in place
    (after the first second of wall time, at most 4 times a second); otherwise a line
    every `every_s` s of wall time. Says simulated s done of the duration, the real-time
    factor so far and the wall time left at that pace."""

    def __init__(self, duration_s: float, stream=None, every_s: float = 10.0):
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.duration_s, self.every_s = duration_s, every_s
        self.t0 = self.last = time.monotonic()
        self.shown = False

    def at(self, t_s: float) -> None:
        """The run has reached simulated time `t_s` (s)."""
        now = time.monotonic()
        wall = now - self.t0
        if (now - self.last < self.every_s) if not self.tty else (wall < 1.0 or now - self.last < 0.25):
            return
        self.last = now
        pace = t_s / wall if wall > 0 else 0.0
        left = f"~{(self.duration_s - t_s) / pace:.0f} s left" if pace > 0 else "starting"
        text = (f"{t_s:.0f} of {self.duration_s:g} s simulated ({100 * t_s / self.duration_s:.0f} %), "
                f"{pace:.0f}x real time, {left}; Ctrl-C stops it cleanly")
        if self.tty:
            self.stream.write(f"\r{text}\033[K")
            self.shown = True
        else:
            self.stream.write(f"navkit sim: {text}\n")
        self.stream.flush()

    def close(self) -> None:
        """Remove the terminal's progress line."""
        if self.shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self.shown = False

