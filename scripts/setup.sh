#!/usr/bin/env bash
# navkit set-up: idempotent, and a fast no-op when everything is in place.
# - Debian packages that the landed code needs, via apt-get when run as root;
# - a .venv with the navkit package (editable) and its dependencies.
set -euo pipefail
cd "$(dirname "$0")/.."

# One package a line; what each is for is in docs/setup.md.
debs=(
  build-essential cmake ninja-build pkg-config
  libgtest-dev libinih-dev
  clang clang-format
  gcc-avr avr-libc binutils-avr simavr libsimavr-dev libelf-dev avrdude arduino-core-avr
  python3-venv libatomic1
)

# The major version N of the clang that Debian's `clang` package brings (it depends on
# clang-N): the installed one, else the one apt would install; empty if apt cannot tell.
clang_major() {
  local n
  n=$(dpkg-query -W -f='${Status} ${Depends}' clang 2>/dev/null | grep '^install ok installed' |
        grep -o 'clang-[0-9]\+' | head -n 1 | cut -d- -f2 || true)
  [[ -n $n ]] || n=$(apt-cache depends clang 2>/dev/null | grep -o 'clang-[0-9]\+' | head -n 1 | cut -d- -f2 || true)
  echo "$n"
}

missing=()
need() {
  dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q 'install ok installed' || missing+=("$1")
}
for p in "${debs[@]}"; do
  need "$p"
done
# npm fetches Foxglove's official JSON schemas for the MCAP tests (below); a node that
# brings its own npm is enough, else Debian's nodejs and npm
if ! command -v npm >/dev/null 2>&1; then
  need nodejs
  need npm
fi
root=$([[ $(id -u) -eq 0 ]] && echo 1 || echo 0)
updated=0
llvm=$(clang_major)
if [[ -z $llvm && $root -eq 1 ]]; then
  apt-get update -qq
  updated=1
  llvm=$(clang_major)
fi
if [[ -z $llvm ]]; then
  echo "setup: cannot tell which clang apt installs ('apt-cache depends clang' names no clang-N):" \
       "run as root, or install clang with its libclang-rt-N-dev and libfuzzer-N-dev" >&2
  exit 1
fi
# libFuzzer and the sanitizer runtimes of that clang (the fuzz preset builds with `clang`)
need "libclang-rt-$llvm-dev"
need "libfuzzer-$llvm-dev"
if ((${#missing[@]})); then
  if [[ $root -eq 1 ]]; then
    echo "setup: installing Debian packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    ((updated)) || apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "setup: missing Debian packages (run as root, or install them): ${missing[*]}" >&2
    exit 1
  fi
fi

py=${PYTHON:-python3}
stamp=.venv/.navkit-setup
want=$(cat pyproject.toml scripts/setup.sh | sha256sum | cut -c1-16)
if [[ ! -x .venv/bin/python ]]; then
  echo "setup: creating .venv"
  "$py" -m venv .venv
fi
if [[ ! -f $stamp || $(cat "$stamp") != "$want" ]]; then
  echo "setup: installing the navkit package into .venv"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -e '.[test]'
  echo "$want" > "$stamp"
fi

# Foxglove's published JSON schemas (npm @foxglove/schemas), which tests/test_foxglove.py
# validates run.mcap's Foxglove topics against
fox=.venv/node_modules/@foxglove/schemas/package.json
if [[ ! -f $fox ]]; then
  echo "setup: installing Foxglove's JSON schemas (npm @foxglove/schemas) into .venv"
  npm install --prefix .venv --no-save --no-audit --no-fund --loglevel=error @foxglove/schemas@2.1.0 >/dev/null
fi
