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

# pytest: two workers (pytest-xdist), a line per test, the slowest listed at the end.
PYTEST_OPTS ?= -n 2 -v --durations=15

.PHONY: setup test test-host test-quick test-f32 sim bench fuzz-long clean distclean f32

setup: $(STAMP)

# .venv is rebuilt from scratch when the Python changed (version or path) or the last install
# failed (no stamp), so a broken or foreign environment never lingers.
PY_ID := $(shell $(PYTHON) -c 'import sys; print("%d.%d.%d-%s" % (sys.version_info[:3] + (sys.executable,)))' 2>/dev/null)
ifneq ($(PY_ID),$(shell cat $(VENV)/.python-id 2>/dev/null))
$(shell rm -f $(STAMP))
endif

$(STAMP): requirements.txt pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "trackpilot needs Python 3.11 or newer (the pinned matplotlib and numpy do); this is %s. Try: make PYTHON=python3.11" % sys.version.split()[0])'
	rm -rf $(VENV)
	$(PYTHON) -m venv $(VENV)
	@$(BIN)/pip install --disable-pip-version-check -q -r requirements.txt \
	  && $(BIN)/pip install --disable-pip-version-check -q --no-deps -e . \
	  || { rm -rf $(VENV); echo "make: installing the environment failed; .venv removed (the next make starts afresh)"; exit 1; }
	echo '$(PY_ID)' > $(VENV)/.python-id
	touch $(STAMP)

# The 32-bit single-precision interpreter, as the ESP32 (cached; rebuilt only when its sources change).
f32: setup
	bash tools/build_micropython_f32.sh

# Every test under the chosen interpreter, then every test that runs firmware (marker mpy: tests/mpy,
# the simulator and the other firmware-running host tests) again on the 32-bit single-precision build.
test: setup f32
	$(BIN)/pytest $(PYTEST_OPTS) tests
	MICROPYTHON=$(MICROPYTHON_F32) $(BIN)/pytest $(PYTEST_OPTS) -m mpy tests

test-host: setup
	$(BIN)/pytest $(PYTEST_OPTS) tests

# The inner loop: everything but the full-track sims, the benchmark and the f32 build, with 10x
# fewer fuzz inputs (207 tests; 3 min on a 2-core machine under a load of 8, less when idle).
test-quick: setup
	TRACKPILOT_FUZZ_N=10000 $(BIN)/pytest -n 2 -q --durations=5 \
	  --ignore=tests/host/test_sim_example.py --ignore=tests/host/test_bench_quick.py \
	  --ignore=tests/host/test_f32_interpreter.py tests

sim: setup
	$(BIN)/trackpilot sim $(TRACK) --out $(SIM_OUT)

bench: setup
	$(BIN)/trackpilot bench --out bench_out
	$(BIN)/trackpilot bench --robust 10 --out bench_out/robust

fuzz-long: setup
	TRACKPILOT_FUZZ_N=2000000 $(BIN)/pytest -q -k fuzz tests

clean:
	rm -rf build $(SIM_OUT) $(SIM_OUT).partial .$(SIM_OUT).tmp-* bench_out bench_out.partial .bench_out.tmp-* board_sim .pytest_cache
	@echo "make clean: kept .venv (the Python environment) and everything in git; make distclean removes .venv too"

distclean: clean
	rm -rf $(VENV)
