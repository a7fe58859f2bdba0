"""The `navkit` command line.

Each subcommand lives in its own module, imported only when that subcommand runs, so
`navkit proto decode` does not pay for fmpy or matplotlib. A module provides
`add_arguments(parser)` and `run(args) -> int` (the exit status), and may say
EXIT_AT_ONCE = True and HOLDS_COLLECTOR = True (see main). argparse is imported where it
is used: this module's own import is then only built-in modules, so a Ctrl-C during
start-up meets main's handler, not a traceback.
"""

import gc
import importlib
import math
import signal
import sys

__all__ = ["main", "SUBCOMMANDS", "positive_int", "count_int", "positive_float", "fraction",
           "hold_collector", "release_collector"]

# name -> (module, one-line help)
SUBCOMMANDS = {
    "gen": ("navkit.gen", "generate C headers/sources and docs from the protocol spec"),
    "proto": ("navkit.proto_cli", "encode, decode and sniff protocol frames"),
    "bench-proto": ("navkit.proto_bench", "benchmark the C and Python codecs (frames/s)"),
    "fuzz-proto": ("navkit.proto_fuzz", "differential fuzz of the Python and C frame parsers"),
    "sim": ("navkit.sim.cli", "co-simulate a mission: the real host, the firmware FMU and the plant FMU"),
    "plot": ("navkit.plot", "plot an MCAP run or a seed-format datalog"),
    "bench-host": ("navkit.host_bench", "benchmark the host's real-time frame loop (start error, drift, CPU)"),
    "bench-sim": ("navkit.sim_bench", "benchmark the co-simulation (real-time factor, time shares, memory)"),
    "bench-pil": ("navkit.pil_bench", "benchmark processor in the loop: the AVR image's tick and link-poll cycles, CPU share, real-time factor"),
    "flash": ("navkit.flash", "flash the firmware image to an Arduino Mega 2560 with avrdude"),
    "simboard": ("navkit.simboard", "a simulated Arduino Mega 2560 (simavr) with its bootloader on a pty"),
    "compare": ("navkit.compare", "compare two co-simulation runs (pose, speed, heading over time)"),
    "tune": ("navkit.tune", "identify, design, verify and write wheel and heading loop gains"),
    "sweep": ("navkit.sweep", "run a mission over plant parameters and seeds on Dask"),
    "can": ("navkit.can_cli", "decode the micro link's CAN traffic with the spec (a log, an SLCAN adapter)"),
}


def _int_at_least(text: str, least: int) -> int:
    """An integer (decimal or 0x) of at least `least`, else argparse's one-line error."""
    import argparse

    try:
        n = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if n < least:
        raise argparse.ArgumentTypeError(f"must be at least {least}, not {n}")
    return n


def positive_int(text: str) -> int:
    """argparse type of a count option: an integer of at least 1 (decimal or 0x)."""
    return _int_at_least(text, 1)


def count_int(text: str) -> int:
    """argparse type of a count option that may be 0: an integer of at least 0 (decimal or 0x)."""
    return _int_at_least(text, 0)


def positive_float(text: str) -> float:
    """argparse type of a positive, finite number (in the option's unit)."""
    import argparse

    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, not {text}")
    return v


def fraction(text: str) -> float:
    """argparse type of a fraction: a number above 0 and below 1."""
    import argparse

    v = positive_float(text)
    if v >= 1:
        raise argparse.ArgumentTypeError(f"must be below 1, not {text}")
    return v


_held = False       # hold_collector() turned the collector off, release_collector() not yet on


def hold_collector() -> None:
    """Hold Python's cyclic garbage collector off (gc.disable) until release_collector():
    a command's imports and set-up make objects that live as long as the process (modules,
    the spec, FMU descriptions), which every collection would walk again for nothing.
    Nothing if the collector is already off."""
    global _held
    if gc.isenabled():
        gc.disable()
        _held = True


def release_collector() -> None:
    """End hold_collector()'s hold: the objects made so far are frozen (gc.freeze: never
    walked again, and a child forked later shares their pages) and the collector is on.
    Nothing without a hold."""
    global _held
    if _held:
        _held = False
        gc.freeze()
        gc.enable()


def _exit_at_once(status: int) -> None:
    """End the process with `status` once stdout and stderr are flushed (a closed pipe
    there is ignored, as at a normal exit), skipping atexit handlers and teardown."""
    import os

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(status)


def _stdout_gone() -> bool:
    """Whether stdout's reader has closed it (a pipe to `head`: poll says POLLERR); then
    stdout is pointed at /dev/null, so what is left in its buffer goes nowhere at exit
    instead of failing again."""
    import os
    import select

    try:
        fd = sys.stdout.fileno()
        poll = select.poll()
        poll.register(fd, select.POLLOUT)
        gone = any(ev & select.POLLERR for _, ev in poll.poll(0))
    except (OSError, ValueError, AttributeError):
        return False
    if gone:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, fd)
        os.close(null)
    return gone


def _top_parser():
    """The `navkit` argparse parser listing the subcommands (for its help and its errors; a command
    line naming a subcommand goes to that subcommand's own parser)."""
    import argparse

    parser = argparse.ArgumentParser(prog="navkit", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv=None) -> int:
    """Parse `argv` (default: sys.argv[1:]) and run the chosen subcommand. Without `argv` the
    caller is the navkit command itself (the console script, `python -m navkit`): the
    collector is held off through the imports and the parsing (hold_collector), and
    through the subcommand's run() until that releases it when the module says
    HOLDS_COLLECTOR = True (its set-up ends the hold); a subcommand module with
    EXIT_AT_ONCE = True (its run() has ended every child and closed every file it made)
    then ends the process as soon as it returns, its output flushed, without the
    interpreter's teardown of every module and object (os._exit)."""
    own_process = argv is None
    if own_process:
        hold_collector()
    argv = sys.argv[1:] if argv is None else argv
    try:
        return _main(argv, own_process)
    except KeyboardInterrupt:   # Ctrl-C where the subcommand does not stop by it itself: its
        if not own_process:     # imports, its parsing, before a run's outputs exist
            raise
        name = argv[0] if argv and argv[0] in SUBCOMMANDS else ""
        print(f"navkit{' ' + name if name else ''}: stopped by SIGINT", file=sys.stderr)
        return 128 + signal.SIGINT


def _main(argv: list, own_process: bool) -> int:
    """main() once the collector is held, for `argv` (a command line without the program)."""
    import argparse

    if not argv or argv[0] in ("-h", "--help"):
        _top_parser().print_help()
        return 0 if argv else 2
    name = argv[0]
    if name not in SUBCOMMANDS:
        _top_parser().error(f"unknown command {name!r} (choose from {', '.join(SUBCOMMANDS)})")
    from navkit.spec import SpecError
    try:
        module = importlib.import_module(SUBCOMMANDS[name][0])
        sub_parser = argparse.ArgumentParser(prog=f"navkit {name}", description=SUBCOMMANDS[name][1])
        module.add_arguments(sub_parser)
        args = sub_parser.parse_args(argv[1:])
        if not getattr(module, "HOLDS_COLLECTOR", False):
            release_collector()
        status = int(module.run(args) or 0)
        if own_process and getattr(module, "EXIT_AT_ONCE", False):
            _exit_at_once(status)
        return status
    except SpecError as e:  # a broken spec (navkit.protocol loads it at import): file:line, no traceback
        print(f"navkit {name}: {e}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        if not (own_process and _stdout_gone()):
            raise
        print(f"navkit {name}: stdout: its reader closed it (output cut short)", file=sys.stderr)
        return 1
