"""Stop signals (navkit.sim.options.STOP_SIGNALS) held off while the harness's work must not
be cut in two (a lockstep frame, a message to the log worker), with no system call per
piece of work.

`DeferredStops` installs, in the main thread, a Python handler for each stop signal that
only records it. CPython's C-level handler only sets a flag and runs the Python handler in
the main thread between bytecodes, so a recorded signal never cuts the holder's work: a
system call it interrupts is retried (PEP 475), nothing is raised. The holder acts on the
signal with deliver() where a stop may land (between frames); the block's end delivers what
is left, and puts the previous handlers back. The handlers are swapped with the stop signals
blocked in the kernel (a few system calls at a block's start and end, none within it).
Python runs signal handlers only in the main thread, so in any other thread (a Dask task)
no stop can land in the work and nothing is installed.
"""

from __future__ import annotations

import signal
import threading

from navkit.sim.options import STOP_SIGNALS

__all__ = ["DeferredStops"]


class DeferredStops:
    """A context manager holding off the stop signals: `pending` lists those recorded (signal
    numbers, in order of arrival) and not delivered yet. Blocks nest: an inner block while
    another holds the signals does nothing (the outer one delivers)."""

    _holding = None         # the DeferredStops whose handlers are installed, if any

    def __init__(self):
        self.pending: list = []
        self._saved: dict = {}      # signal number -> the handler before ours

    def __enter__(self) -> "DeferredStops":
        if DeferredStops._holding is None and threading.current_thread() is threading.main_thread():
            with _masked():
                DeferredStops._holding = self
                for signum in sorted(STOP_SIGNALS):
                    before = signal.getsignal(signum)
                    if before is not None:      # None: a handler not set from Python, kept as it is
                        self._saved[signum] = before
                        signal.signal(signum, self._record)
        return self

    def _record(self, signum: int, _frame) -> None:
        self.pending.append(signum)

    def deliver(self) -> None:
        """Act on the first recorded stop signal as the handler before ours does (the harness's
        raises KeyboardInterrupt; SIG_DFL ends the process as the signal would; SIG_IGN
        nothing); others recorded with it are dropped, the first one's stop being under way."""
        if not self.pending:
            return
        signum = self.pending[0]
        self.pending.clear()
        before = self._saved.get(signum, signal.SIG_DFL)
        if callable(before):
            before(signum, None)
        elif before != signal.SIG_IGN:
            self._restore()
            signal.raise_signal(signum)

    def _restore(self) -> None:
        if DeferredStops._holding is self:
            with _masked():
                DeferredStops._holding = None
                for signum, before in self._saved.items():
                    signal.signal(signum, before)

    def __exit__(self, _exc_type, _exc, _tb) -> bool:
        if DeferredStops._holding is self:
            self._restore()
            self.deliver()      # even while an error unwinds: a stop asked for is not lost
        return False


class _masked:
    """The stop signals blocked in the kernel while the handlers are swapped (at a block's
    start and end only): a signal taken half way through would run the handler before ours,
    which raises, and leave the swap half done. One that comes meanwhile is taken when the
    mask is put back, by the handlers then in place. The mask to put back is read before it
    changes, and put back if anything is raised on the way in."""

    def __enter__(self) -> None:
        self._mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())
        try:
            signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        except BaseException:
            signal.pthread_sigmask(signal.SIG_SETMASK, self._mask)
            raise

    def __exit__(self, *_exc) -> bool:
        signal.pthread_sigmask(signal.SIG_SETMASK, self._mask)
        return False
