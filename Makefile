# navkit: the two commands a user needs are `make sim` and `make test`.
# Everything else here is a step of theirs, or an opt-in long run.
BUILD ?= build
PY    := .venv/bin/python
CMAKE_PRESET ?= default

.PHONY: setup build sim test test-c test-py fuzz-build fuzz-short fuzz-long bench clean

setup:
	@scripts/setup.sh

build: setup
	@cmake --preset $(CMAKE_PRESET) >/dev/null
	@cmake --build --preset $(CMAKE_PRESET)

# The main job: co-simulate the default mission (config/missions/demo.toml) with the real
# host over a pty, the firmware FMU and the plant FMU; prints outputs, final pose, speed.
sim: build
	@$(PY) -m navkit sim --mission config/missions/demo.toml

test-c: build
	@ctest --preset $(CMAKE_PRESET)

test-py: build
	@$(PY) -m pytest

test: build fuzz-short
	@ctest --preset $(CMAKE_PRESET)
	@$(PY) -m pytest

# libFuzzer on the C frame parser (clang, ASan+UBSan, its own build folder).
FUZZER := $(BUILD)/fuzz/tests/c/protocol/fuzz_proto_parser
fuzz-build: setup
	@cmake --preset fuzz >/dev/null
	@cmake --build --preset fuzz --target fuzz_proto_parser

fuzz-short: fuzz-build
	@mkdir -p $(BUILD)/fuzz/corpus
	@$(FUZZER) -seed=1 -runs=200000 $(BUILD)/fuzz/corpus 2>&1 | tail -1

# Opt-in long runs: 10 minutes of libFuzzer, then 10 minutes of differential fuzz.
fuzz-long: fuzz-build build
	$(FUZZER) -max_total_time=600 $(BUILD)/fuzz/corpus
	$(PY) -m navkit fuzz-proto --seconds 600

bench: build
	$(PY) -m navkit bench-proto
	$(PY) -m navkit bench-host
	$(PY) -m navkit bench-sim

clean:
	rm -rf $(BUILD)
