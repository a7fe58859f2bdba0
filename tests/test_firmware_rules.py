"""The firmware core's structural rules (issue 3), checked on the build and the sources.

- No file-level mutable state: `nm` (the build's CMAKE_NM) on the core library
  (navkit_fw_core) lists no data, bss or common symbol, so every variable lives in the one
  `fw_t` (several firmware instances per process) and `static const` tables are the only
  statics (read-only data, `r`/`R`).
- Includes: firmware/core/*.c and *.h include only `hal.h`, the generated
  `navkit/navkit_proto.h`, the core's own headers and <stdint.h>, <stddef.h>, <math.h>:
  no hardware register headers, no stdio or stdlib.

Each rule is also run on a small broken example, which it must reject, so a checker that
stopped seeing anything could not pass.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from navkit.paths import build_dir, repo_root

CORE = repo_root() / "firmware" / "core"
LIB = build_dir() / "firmware" / "libnavkit_fw_core.a"
CACHE = build_dir() / "CMakeCache.txt"
pytestmark = pytest.mark.skipif(not LIB.exists(), reason=f"{LIB} not built")

# nm symbol classes of writable storage: initialised data (d/D), zeroed data (b/B), common
# (C), and the small-data and small-bss sections some targets use (g/G, s/S)
MUTABLE_CLASSES = "bBdDCgGsS"
ALLOWED_STD = {"stdint.h", "stddef.h", "math.h"}
ALLOWED_QUOTED = {"hal.h", "navkit/navkit_proto.h"}
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def cache_entry(name: str) -> str:
    """The value of `name` in the build's CMakeCache.txt (a tool's path)."""
    for line in CACHE.read_text().splitlines():
        m = re.match(rf"{name}:[A-Z]+=(.*)$", line)
        if m and m.group(1):
            return m.group(1)
    raise AssertionError(f"{CACHE}: no {name}")


def symbols(path: Path) -> list[tuple[str, str, str]]:
    """(object, class, name) of every symbol `nm` lists in the archive or object `path`."""
    out = subprocess.run([cache_entry("CMAKE_NM"), str(path)], check=True, capture_output=True,
                         text=True).stdout
    obj = path.name
    found = []
    for line in out.splitlines():
        if line.endswith(":"):
            obj = line[:-1]
        elif m := re.match(r"^[0-9a-fA-F ]*\s([A-Za-z?-])\s(\S+)$", line):
            found.append((obj, m.group(1), m.group(2)))
    return found


def mutable_state(path: Path) -> list[str]:
    """'object: symbol (class)' for every data/bss/common symbol in `path`."""
    return [f"{obj}: {name} ({cls})" for obj, cls, name in symbols(path) if cls in MUTABLE_CLASSES]


def include_violations(files: list[Path], core_headers: set[str]) -> list[str]:
    """'file:line: include X: reason' for every include outside the allowed set."""
    bad = []
    for f in files:
        for n, line in enumerate(f.read_text().splitlines(), 1):
            m = INCLUDE_RE.match(line)
            if not m:
                continue
            kind, name = m.groups()
            if kind == "<" and name not in ALLOWED_STD:
                bad.append(f"{f}:{n}: include <{name}>: not one of {sorted(ALLOWED_STD)}")
            elif kind == '"' and name not in ALLOWED_QUOTED | core_headers:
                bad.append(f'{f}:{n}: include "{name}": not hal.h, the generated header or a core header')
    return bad


def core_files() -> list[Path]:
    return sorted(CORE.glob("*.c")) + sorted(CORE.glob("*.h"))


def test_core_library_has_no_mutable_state():
    defined = {name for _, cls, name in symbols(LIB) if cls == "T"}
    assert {"fw_tick", "fw_link_poll", "profile_step", "heading_update"} <= defined, \
        f"{LIB} does not hold the firmware core"
    assert mutable_state(LIB) == []


def test_mutable_state_check_rejects_a_static(tmp_path):
    """A file-scope static, a global and a function-local static are caught; a static
    const table is not."""
    src = tmp_path / "bad.c"
    src.write_text("static int count;\nint total = 1;\nstatic const int table[2] = {1, 2};\n"
                   "int bump(int i) { static int calls; calls++; count += table[i & 1]; return calls + total; }\n")
    obj = tmp_path / "bad.o"
    subprocess.run([cache_entry("CMAKE_C_COMPILER"), "-O2", "-c", str(src), "-o", str(obj)], check=True)
    found = mutable_state(obj)
    # a function-local static is named like calls.0
    assert sorted(s.split(": ")[1].split(" ")[0].split(".")[0] for s in found) == ["calls", "count", "total"], found


def test_core_includes_only_allowed_headers():
    files = core_files()
    assert len(files) >= 20, f"{CORE}: {len(files)} files"
    headers = {f.name for f in CORE.glob("*.h")}
    assert include_violations(files, headers) == []
    # the standard headers the core uses today: exactly the allowed three
    used = {m.group(2) for f in files for line in f.read_text().splitlines()
            if (m := INCLUDE_RE.match(line)) and m.group(1) == "<"}
    assert used == ALLOWED_STD


def test_include_check_rejects_register_and_stdio_headers(tmp_path):
    src = tmp_path / "bad.c"
    src.write_text('#include "hal.h"\n#include <avr/io.h>\n  # include <stdio.h>\n#include "board.h"\n'
                   '#include "navkit/navkit_proto.h"\n')
    assert include_violations([src], {"fw.h"}) == [
        f"{src}:2: include <avr/io.h>: not one of ['math.h', 'stddef.h', 'stdint.h']",
        f"{src}:3: include <stdio.h>: not one of ['math.h', 'stddef.h', 'stdint.h']",
        f'{src}:4: include "board.h": not hal.h, the generated header or a core header',
    ]
