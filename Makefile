# navkit: the two commands a user needs are `make sim` and `make test`.
# Everything else here is a step of theirs, or an opt-in long run.
BUILD ?= build
PY    := .venv/bin/python
CMAKE_PRESET ?= default

.PHONY: setup build sim test test-c test-py fuzz-build fuzz-corpus fuzz-short fuzz-long prop-long bench bench-sweep clean

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
	@cmake --preset fuzz -B $(BUILD)/fuzz >/dev/null
	@cmake --build $(BUILD)/fuzz --target fuzz_proto_parser

# The corpus is seeded from the golden streams (tests/vectors). The log goes to a file and
# only its last line is shown; the fuzzer's exit status is kept (a crash fails the target).
FUZZ_CORPUS := $(BUILD)/fuzz/corpus
fuzz-corpus: setup
	@PYTHONPATH=tools $(PY) -m navkit.vectors --fuzz-corpus $(FUZZ_CORPUS) >/dev/null

fuzz-short: fuzz-build fuzz-corpus
	@$(FUZZER) -seed=1 -runs=200000 $(FUZZ_CORPUS) >$(BUILD)/fuzz/fuzz-short.log 2>&1; \
	  status=$$?; tail -1 $(BUILD)/fuzz/fuzz-short.log; \
	  if [ $$status -ne 0 ]; then echo "fuzz-short: libFuzzer failed ($$status); see $(BUILD)/fuzz/fuzz-short.log"; \
	    tail -30 $(BUILD)/fuzz/fuzz-short.log; fi; exit $$status

# Opt-in long runs: 10 minutes of libFuzzer, then 10 minutes of differential fuzz.
fuzz-long: fuzz-build fuzz-corpus build
	$(FUZZER) -max_total_time=600 $(FUZZ_CORPUS)
	$(PY) -m navkit fuzz-proto --seconds 600

# Opt-in long property run of the motion profile generator (random moves with random
# modifications, stops and forever targets; about 2.5 min of CPU per 2 million moves).
PROP_SEED ?= 777
PROP_COUNT ?= 2000000
prop-long: build
	$(BUILD)/tests/c/firmware/fw_test_profile --seed $(PROP_SEED) --count $(PROP_COUNT)

bench: build
	$(PY) -m navkit bench-proto
	$(PY) -m navkit bench-host
	$(PY) -m navkit bench-sim
	$(PY) -m navkit bench-pil
	$(PY) -m navkit flash --bench

# Opt-in: `navkit sweep` runs per minute on a LocalCluster of 1 and of 2 workers (the demo
# mission, 24 runs each), their ratio, and that both gave the same table.
bench-sweep: build
	$(PY) -m navkit sweep --bench

clean:
	rm -rf $(BUILD)
