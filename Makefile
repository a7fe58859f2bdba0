# navkit: the two commands a user needs are `make sim` and `make test`.
# Everything else here is a step of theirs, or an opt-in long run.
BUILD ?= build
PY    := .venv/bin/python
CMAKE_PRESET ?= default

.PHONY: setup build test test-c test-py sim bench fuzz-long clean

setup:
	@scripts/setup.sh

build: setup
	@cmake --preset $(CMAKE_PRESET) >/dev/null
	@cmake --build --preset $(CMAKE_PRESET)

test-c: build
	@ctest --preset $(CMAKE_PRESET)

test-py: build
	@$(PY) -m pytest

test: build
	@ctest --preset $(CMAKE_PRESET)
	@$(PY) -m pytest

clean:
	rm -rf $(BUILD)
