"""The host's configuration as the host reads it: the one reader of NavAndControl.ini and
sensors.ini is navkit-host (inih, host/src/ini.cpp); Python asks it
(`navkit-host --config PATH --print-config`) instead of parsing the files again.

`effective_config(path)` is the host's answer for a config folder (both files) or one INI
file: {"files": [path, ...], "sections": {section: {key: {"value": v, "from": "file:line"
| "--option" | "default"}}}, "headers": {section: "file:line"}}: every key the host knows
with its value after defaults and command-line overrides (values typed: numbers, strings,
booleans, the per-servo lists) and where each section's [header] is. `value`,
`origin_line` and `header_line` read it. Answers are cached per path, the files'
modification times and contents, the overrides and the host binary.

A config the host refuses raises HostConfigError with the host's one-line message
(file:line: key: reason, or --option: reason) and its exit status (1: the config, 2: an
option). The frame-vs-watchdog rule is the host's too: pass `frame_ms` and the host
judges that frame (as `navkit sim --frame-ms` runs it) against the config's watchdog.

`convert_lisp(commands)` asks the host what it makes of planner commands
(`navkit-host --convert-lisp`: Navigation::convert, the one lisp_cmd -> micro_cmd rule):
the micro_cmd of each, or why the host would drop it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import subprocess
from pathlib import Path

__all__ = ["HostConfigError", "effective_config", "value", "origin_line", "header_line", "INI_FILES",
           "host_binary", "convert_lisp", "convert_lisp_started", "ask_config", "forget_asks"]

# The files a config folder holds, read by the host in this order.
INI_FILES = ("NavAndControl.ini", "sensors.ini")

_cache: dict = {}
# ask_config's questions being answered: (config path, arguments, host) -> (the files'
# _stamp then, the answer's function from _asked)
_asking: dict = {}


class HostConfigError(ValueError):
    """A config the host refuses (or a host that cannot be asked); `status` is the host's
    exit status (1: the config, 2: an option), 0 when the host could not be run."""

    def __init__(self, message: str, status: int = 1):
        super().__init__(message)
        self.status = status


def _stamp(path: Path) -> tuple:
    """What changes when the files behind `path` change: (name, mtime ns, digest of the
    bytes) of each (the digest as well: a rewrite of the same size can keep the mtime,
    whose clock is coarse)."""
    files = [path / n for n in INI_FILES] if path.is_dir() else [path]
    out = []
    for f in files:
        try:
            out.append((f.name, f.stat().st_mtime_ns, hashlib.blake2b(f.read_bytes(), digest_size=16).digest()))
        except OSError:
            out.append((f.name, None, None))
    return tuple(out)


def host_binary(build: Path | None = None) -> Path:
    """navkit-host of build folder `build` (default: navkit.paths.build_dir())."""
    from navkit.paths import build_dir

    return Path(build or build_dir()) / "host" / "navkit-host"


def _ask(host: Path, args: list, what: str, stdin: str | None = None) -> str:
    """The stdout of `host args` (`what` names the question in errors), fed `stdin`.
    Raises HostConfigError: the host's first stderr line and exit status, or status 0 when
    it is not built or could not be run."""
    return _asked(host, args, what, stdin)()


def _asked(host: Path, args: list, what: str, stdin: str | None = None):
    """Start `host args` fed `stdin` and return at once a function that waits for it and
    returns _ask's answer or raises its HostConfigError (the same on every call)."""
    proc = error = None
    if not host.is_file():
        error = HostConfigError(f"{host}: not built (cmake --build {host.parent.parent}); "
                                f"navkit-host {what}", 0)
    else:
        try:
            proc = subprocess.Popen([str(host), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                    stdin=subprocess.PIPE if stdin is not None else subprocess.DEVNULL,
                                    text=True, errors="replace")
            if stdin is not None:
                stdin = _feed(proc, stdin)
        except (OSError, subprocess.SubprocessError) as e:
            error = HostConfigError(f"{host}: {e}", 0)

    @functools.cache
    def answer():
        return error if proc is None else _answer(proc, host, stdin)

    def result() -> str:
        out = answer()
        if isinstance(out, HostConfigError):
            raise out
        return out
    return result


def _feed(proc: subprocess.Popen, text: str) -> str | None:
    """Write `text` to the stdin of `proc` now and close it, so the host reads it and
    answers while its asker goes on, when it fits the pipe at once (its capacity, bytes);
    None then, else `text`, for communicate() to write."""
    import fcntl
    import os

    data = text.encode()
    fd = proc.stdin.fileno()
    try:
        if len(data) > fcntl.fcntl(fd, fcntl.F_GETPIPE_SZ):
            return text
    except (OSError, AttributeError):       # no F_GETPIPE_SZ here
        return text
    try:
        os.write(fd, data)
    except BrokenPipeError:                 # the host is gone: its answer says why
        pass
    proc.stdin.close()
    proc.stdin = None                       # communicate() has nothing left to write
    return None


def _answer(proc: subprocess.Popen, host: Path, stdin: str | None):
    """The stdout of host process `proc` (fed `stdin`, within 30 s), else the
    HostConfigError it makes (returned, not raised)."""
    try:
        out, err = proc.communicate(stdin, timeout=30)
    except (OSError, subprocess.SubprocessError) as e:
        proc.kill()
        proc.wait()
        return HostConfigError(f"{host}: {e}", 0)
    if proc.returncode != 0:
        said = err.splitlines()[0] if err.strip() else f"exit status {proc.returncode}"
        return HostConfigError(said.removeprefix("navkit-host: "), proc.returncode)
    return out


def _config_question(path: Path, build: Path | None, frame_ms: float | None, options: tuple):
    """What an effective_config call asks: (host binary, its arguments, the question's key
    in _asking, the files' _stamp now); _cache keeps the answer under (key, stamp)."""
    path = Path(path)
    host = host_binary(build)
    args = list(options)
    if frame_ms is not None:
        args += ["--frame-ms", f"{frame_ms:.12g}"]
    asked = (str(path.resolve()), tuple(args), str(host))
    return host, ["--config", str(path), "--print-config", *args], asked, _stamp(path)


def effective_config(path: Path, *, build: Path | None = None, frame_ms: float | None = None,
                     options: tuple = ()) -> dict:
    """The host's effective configuration of config folder (or INI file) `path` (the JSON of
    `navkit-host --print-config`, see above). `frame_ms` (ms) is the frame the caller
    runs (--frame-ms; None: the INI's frame_rate_hz), judged against the watchdog by the
    host; `options` more host options ("--port", "x", ...). `build`: the build folder of
    navkit-host (default: navkit.paths.build_dir()). Raises HostConfigError. The answer
    of an ask_config with the same arguments is taken when the files are unchanged since."""
    host, argv, asked, stamp = _config_question(path, build, frame_ms, options)
    key = (asked, stamp)
    if key in _cache:
        return _cache[key]
    early = _asking.pop(asked, None)
    if early is not None and early[0] == stamp:
        out = early[1]()
    else:
        _forget(early)
        out = _ask(host, argv, "reads the config")
    try:
        config = json.loads(out)
        config["sections"], config["headers"]
    except (ValueError, KeyError, TypeError) as e:
        raise HostConfigError(f"{host} --print-config: not its JSON ({e})", 0) from None
    _cache[key] = config
    return config


def ask_config(path: Path, *, build: Path | None = None, frame_ms: float | None = None,
               options: tuple = ()) -> None:
    """Start the host reading config `path` for effective_config (same arguments) and
    return at once, so the host answers while the caller does other work; nothing is
    started for an answer already cached. forget_asks() ends the ones not taken."""
    host, argv, asked, stamp = _config_question(path, build, frame_ms, options)
    if (asked, stamp) in _cache or asked in _asking:
        return
    _asking[asked] = (stamp, _asked(host, argv, "reads the config"))


def forget_asks() -> None:
    """Wait for the hosts of ask_config calls that no effective_config took, and drop them."""
    while _asking:
        _forget(_asking.popitem()[1])


def _forget(early) -> None:
    """Wait for an ask_config's host (`early`: its (stamp, answer), or None), ignoring what
    it says."""
    if early is not None:
        try:
            early[1]()
        except HostConfigError:
            pass


def convert_lisp(commands: list, *, build: Path | None = None) -> list:
    """The host's verdict on each planner command of `commands` (dicts of lisp_cmd fields by
    spec name, raw values, unset 0; a "heading" key is the micro's current heading, deg x
    0.1, absent: none known): one dict each, in order, the JSON of `navkit-host
    --convert-lisp` (docs/host.md): {"nav_result": "ok" | "not_implemented", "micro_cmd":
    {...}} or {"nav_result": "rejected", "refusal": ..., "lisp_field": ..., "value": ...,
    "text": ...}. One host process for the whole list; answers cached per list and host
    binary. Raises HostConfigError (status 0: the host is not built or not answering)."""
    return convert_lisp_started(commands, build=build)()


def convert_lisp_started(commands: list, *, build: Path | None = None):
    """Start the host judging `commands` for convert_lisp (same arguments) and return at
    once a function that waits for it and returns convert_lisp's answer or raises its
    HostConfigError (the same on every call): the host judges while the caller goes on."""
    host = host_binary(build)
    lines = "".join(json.dumps(c, separators=(",", ":")) + "\n" for c in commands)
    try:
        stamp = host.stat().st_mtime_ns
    except OSError:
        stamp = None
    key = ("convert_lisp", str(host), stamp, lines)
    if key in _cache:
        cached = _cache[key]
        return lambda: cached
    answer = _asked(host, ["--convert-lisp"], "converts planner commands", lines)
    n = len(commands)

    def result() -> list:
        if key in _cache:
            return _cache[key]
        out = answer().splitlines()
        try:
            verdicts = [json.loads(line) for line in out]
            if len(verdicts) != n or not all("nav_result" in v for v in verdicts):
                raise ValueError(f"{len(verdicts)} verdicts for {n} commands")
        except (ValueError, TypeError) as e:
            raise HostConfigError(f"{host} --convert-lisp: not its JSON ({e})", 0) from None
        _cache[key] = verdicts
        return verdicts
    return result


def value(config: dict, section: str, key: str):
    """The effective value of `[section] key` in `config` (effective_config's answer)."""
    return config["sections"][section][key]["value"]


def origin_line(config: dict, section: str, key: str) -> int | None:
    """The line of `[section] key` in its INI file, None when the key is not in the file
    (its default, or a command-line option's value)."""
    return _line(config["sections"][section][key]["from"])


def header_line(config: dict, section: str) -> int | None:
    """The line of `[section]`'s header in its INI file, None when the file has none."""
    return _line(config["headers"].get(section, ""))


def _line(where: str) -> int | None:
    """The line number of "file:line", None for anything else ("default", "--rate")."""
    head, _, line = where.rpartition(":")
    return int(line) if head and line.isdigit() else None
