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
  clang libclang-rt-14-dev libfuzzer-14-dev
  gcc-avr avr-libc binutils-avr avrdude simavr
  python3-venv libatomic1
)

missing=()
for p in "${debs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  if [[ $(id -u) -eq 0 ]]; then
    echo "setup: installing Debian packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
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
