# trackpilot: `make sim` sails the example track in the simulator, `make test` runs every test.
# Both set up the project environment (.venv) on first use.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
TRACK ?= tracks/middelburg_loop.csv
SIM_OUT ?= sim_out
# MICROPYTHON chooses the interpreter for everything that runs firmware; default: the one installed here.
export MICROPYTHON ?= $(abspath $(BIN)/micropython)
MICROPYTHON_F32 ?= $(abspath build/micropython-f32/micropython)

.PHONY: setup test test-host test-f32 sim bench fuzz-long clean f32

setup: $(STAMP)

$(STAMP): requirements.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --disable-pip-version-check -q -r requirements.txt
	$(BIN)/pip install --disable-pip-version-check -q --no-deps -e .
	touch $(STAMP)

# The single-precision interpreter (cached; rebuilt only when its sources change).
f32: setup
	bash tools/build_micropython_f32.sh

# Every test under the chosen interpreter, then the unix-port tests again on a single-precision build.
test: setup f32
	$(BIN)/pytest -q tests
	MICROPYTHON=$(MICROPYTHON_F32) $(BIN)/pytest -q -m mpy tests

test-host: setup
	$(BIN)/pytest -q tests

sim: setup
	$(BIN)/trackpilot sim $(TRACK) --out $(SIM_OUT)

bench: setup
	$(BIN)/trackpilot bench --out bench_out
	$(BIN)/trackpilot bench --robust 10 --out bench_out/robust

fuzz-long: setup
	TRACKPILOT_FUZZ_N=2000000 $(BIN)/pytest -q -k fuzz tests

clean:
	rm -rf build $(SIM_OUT) bench_out .pytest_cache
