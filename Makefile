# pkmlib: two commands do everything (see README.md).
#   make report  - set up .venv, execute every notebook, write figures/ and data/results/,
#                  print the reproduction table, render the Quarto site if quarto is installed
#   make test    - set up .venv, run the unit tests and nbval on every notebook
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
NOTEBOOKS := $(wildcard notebooks/*.ipynb)

# CPU unless the user says otherwise; also keeps JAX's "no GPU" warning out of notebook outputs.
export JAX_PLATFORMS ?= cpu
# JAX's persistent compilation cache, in an ignored directory: a second `make test`, `make report`
# or `make rerun` loads compiled code instead of compiling it again (every entry kept, however
# quick its compilation or small its code).
export JAX_COMPILATION_CACHE_DIR ?= $(CURDIR)/.jax_cache
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS ?= 0
export JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES ?= 0

.PHONY: all venv test report rerun benchmark clean

all: test

$(BIN)/.installed: environment.lock pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --require-hashes -r environment.lock
	$(BIN)/python -m pip install --quiet --no-deps -e .
	touch $@

venv: $(BIN)/.installed

test: venv
	$(BIN)/python -m pytest --nbval --nbval-current-env

report: venv
	$(BIN)/jupyter nbconvert --to notebook --execute --inplace --ExecutePreprocessor.record_timing=False $(NOTEBOOKS)
	$(BIN)/python -m pkmlib.report
	$(BIN)/quartodoc build && rm -f objects.json
	@if command -v quarto >/dev/null 2>&1; then \
		quarto render; \
	else \
		echo "quarto not found: skipped rendering the site into _site/."; \
		echo "Install Quarto from https://quarto.org/docs/get-started/ and run 'quarto render'."; \
	fi

# Re-run one notebook with other parameters into runs/<NB>/ (the paper's run stays as it is):
#   make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 30"
rerun: venv
	@test -n "$(NB)" || (echo 'usage: make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 30"'; exit 2)
	mkdir -p runs/$(NB)
	cd notebooks && ../$(BIN)/papermill --no-progress-bar $(NB).ipynb ../runs/$(NB)/$(NB).ipynb $(PARAMS) \
		-p results_path ../runs/$(NB)/results.json -p figures_dir ../runs/$(NB)/figures
	@echo "wrote runs/$(NB)/: the executed notebook, results.json and figures/"

# Every paper's benchmark (benchmarks/results/<paper>.json); notebook timings, cold and warm
# cache: $(BIN)/python benchmarks/notebooks.py (writes benchmarks/results/notebooks.json).
benchmark: venv
	$(BIN)/python benchmarks/run_all.py

clean:
	rm -rf $(VENV) _site .quarto .pytest_cache
