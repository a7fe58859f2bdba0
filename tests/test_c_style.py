"""The C style (.clang-format, docs/internals.md "C style") holds in the folders formatted
with it (their C and C++ files): clang-format leaves their files as they are, and every if/else/for/while body is a
braced block (clang-format 14 cannot add braces, so that rule is checked here)."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from navkit.paths import repo_root

# Folders whose C and C++ files (in them and below) are formatted with .clang-format
# (docs/internals.md, C style).
FORMATTED = ["fmu/plant", "planner", "firmware/core", "protocol/runtime", "fmu/fmi", "fmu/firmware",
             "fmu/firmware_avr", "tests/c/firmware", "tests/c/protocol", "host", "firmware/avr", "tests/c/avr",
             "fmu/cosim", "fmu/record", "tests/c/host"]
_SOURCES = (".c", ".h", ".cpp", ".hpp")

_HEAD = re.compile(r"^\s*(\} )?(if \(|else if \(|for \(|while \()")
_ELSE = re.compile(r"^\s*(\} )?else\b(?! if \()")


def _files():
    root = repo_root()
    return sorted(p for d in FORMATTED for p in (root / d).rglob("*") if p.suffix in _SOURCES)


def _code(line: str) -> str:
    """`line` without string and character literals and comments."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])*'", "''", line)
    line = re.sub(r"/\*.*?\*/", "", line)
    return line.split("//")[0].rstrip().rstrip("\\").rstrip()


def unbraced(text: str) -> list:
    """Line numbers (1-based) of if/else/for/while statements whose body is not a braced
    block, in clang-formatted C `text` (a `} while (...)` or `while (...);` ends a do-while
    and is not one)."""
    lines = text.split("\n")
    bad = []
    for i, line in enumerate(lines):
        m = _HEAD.match(line)
        if m and not (m.group(1) and m.group(2) == "while ("):
            j, depth = i, 0
            while True:
                code = _code(lines[j])
                depth += code.count("(") - code.count(")")
                if depth <= 0:
                    break
                j += 1
            if not _code(lines[j]).endswith(("{", ";")) or re.search(r"\)\s*[^\s{;)][^;]*;$", _code(lines[j])):
                bad.append(i + 1)
        elif _ELSE.match(line) and not _code(line).endswith("{"):
            bad.append(i + 1)
    return bad


def test_unbraced_finds_bodies_without_braces():
    text = "void f(int a)\n{\n    if (a)\n        g();\n    if (a) {\n        g();\n    } else\n        h();\n" \
           "    for (;;) g();\n    do {\n    } while (a);\n    do {\n    } while (0)\n    if (a &&\n        b) {\n    }\n}\n"
    assert unbraced(text) == [3, 7, 9]


def test_formatted_folders_are_as_clang_format_writes_them():
    exe = shutil.which("clang-format")
    assert exe, "clang-format is missing: run scripts/setup.sh (Debian package clang-format)"
    files = _files()
    assert files
    for path in files:
        text = path.read_text()
        out = subprocess.run([exe, "--style=file", f"--assume-filename={path}"], input=text,
                             capture_output=True, text=True, check=True).stdout
        assert out == text, f"{path}: not as clang-format writes it (run clang-format -i {path})"
        assert unbraced(text) == [], f"{path}: lines {unbraced(text)}: a body without braces"


def test_every_c_file_of_the_tree_is_in_a_formatted_folder():
    """A new C or C++ folder is held to the style too: every source outside build folders
    (a folder holding CMakeCache.txt), dot folders and node_modules lies under FORMATTED."""
    root = repo_root()
    outside = []
    for p in root.rglob("*"):
        rel = p.relative_to(root)
        if p.suffix not in _SOURCES or any(part.startswith(".") or part == "node_modules"
                                           for part in rel.parts):
            continue
        if any((root / Path(*rel.parts[:k]) / "CMakeCache.txt").exists() for k in range(1, len(rel.parts))):
            continue
        if not any(rel.as_posix().startswith(d + "/") for d in FORMATTED):
            outside.append(rel.as_posix())
    assert outside == []
