"""scripts/setup.sh's choice of Debian packages, run for real against stand-in
dpkg-query, apt-cache, apt-get and id commands (first on PATH), so nothing is installed:
each case ends before the .venv step (a missing package as non-root, or a stand-in
apt-get install that fails)."""

import os
import subprocess
from pathlib import Path

import pytest

from navkit.paths import repo_root

SETUP = repo_root() / "scripts" / "setup.sh"


def _tool(folder: Path, name: str, body: str) -> None:
    path = folder / name
    path.write_text("#!/bin/sh\n" + body)
    path.chmod(0o755)


def _run(tmp_path: Path, *, uid: int, installed: set, clang_dep: str | None, apt_dep: str | None,
         clang_status: str = "install ok installed"):
    """Run setup.sh with dpkg-query knowing `installed` (and the installed `clang`
    depending on `clang_dep`, its dpkg status `clang_status`), apt-cache knowing `apt_dep` as clang's dependency;
    returns (returncode, stderr + stdout, apt-get calls)."""
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    log = tmp_path / "apt-get.log"
    cases = "".join(f"  *' {p}') echo 'install ok installed'; exit 0;;\n" for p in sorted(installed))
    depends = (f"case \"$*\" in *Depends*' clang') echo '{clang_status} {clang_dep} (>= 1~)'; exit 0;; esac\n"
               if clang_dep else "")
    _tool(bin_, "dpkg-query", depends + 'case " $*" in\n' + cases + "esac\nexit 1\n")
    _tool(bin_, "apt-cache", f"echo clang\necho '  Depends: {apt_dep}'\n" if apt_dep else "exit 100\n")
    _tool(bin_, "apt-get", f'echo "$*" >> {log}\ncase "$1" in update) exit 0;; esac\nexit 3\n')
    _tool(bin_, "id", f"echo {uid}\n")
    env = dict(os.environ, PATH=f"{bin_}:{os.environ['PATH']}")
    r = subprocess.run(["bash", str(SETUP)], capture_output=True, text=True, env=env, timeout=30)
    calls = log.read_text().splitlines() if log.exists() else []
    return r.returncode, r.stderr + r.stdout, calls


def _listed_debs() -> set:
    """The packages of setup.sh's `debs=( ... )` list (one place states them), minus clang,
    whose presence each case sets itself."""
    text = SETUP.read_text()
    body = text.split("debs=(", 1)[1].split(")", 1)[0]
    words = {w for line in body.splitlines() for w in line.split("#", 1)[0].split()}
    assert {"cmake", "simavr"} <= words, "setup.sh's debs=( ... ) list not found"
    return words - {"clang"}


BASE = _listed_debs()


def test_fuzzer_packages_follow_the_installed_clang(tmp_path):
    rc, out, calls = _run(tmp_path, uid=1000, installed=BASE | {"clang"}, clang_dep="clang-19",
                          apt_dep="clang-14")
    assert rc == 1 and calls == []
    missing = out.split("missing Debian packages (run as root, or install them):")[1].split()
    assert missing == ["libclang-rt-19-dev", "libfuzzer-19-dev"]


def test_a_removed_clangs_dpkg_record_does_not_decide(tmp_path):
    """dpkg still knows a removed clang (config files left) depending on clang-13: apt's
    candidate decides, as when dpkg knows none."""
    rc, out, calls = _run(tmp_path, uid=1000, installed=BASE, clang_dep="clang-13", apt_dep="clang-16",
                          clang_status="deinstall ok config-files")
    assert rc == 1 and calls == []
    missing = out.split("missing Debian packages (run as root, or install them):")[1].split()
    assert missing == ["clang", "libclang-rt-16-dev", "libfuzzer-16-dev"]


def test_without_clang_the_candidate_decides_and_root_installs_once(tmp_path):
    rc, out, calls = _run(tmp_path, uid=0, installed=BASE - {"simavr"}, clang_dep=None, apt_dep="clang-21")
    assert rc == 3, out   # the stand-in apt-get install fails: the script stops there
    assert calls == ["update -qq",
                     "install -y -qq --no-install-recommends clang simavr libclang-rt-21-dev libfuzzer-21-dev"]


def test_root_updates_the_lists_when_apt_does_not_know_clang(tmp_path):
    rc, out, calls = _run(tmp_path, uid=0, installed=BASE, clang_dep=None, apt_dep=None)
    assert rc == 1 and calls == ["update -qq"]
    assert "cannot tell which clang apt installs" in out


@pytest.mark.parametrize("word", ["libfuzzer-14", "libclang-rt-14"])
def test_no_pinned_package_is_named(word):
    assert word not in SETUP.read_text()

