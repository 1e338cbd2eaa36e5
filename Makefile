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

.PHONY: all venv test report benchmark clean

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
	@if command -v quarto >/dev/null 2>&1; then \
		quarto render; \
	else \
		echo "quarto not found: skipped rendering the site into _site/."; \
		echo "Install Quarto from https://quarto.org/docs/get-started/ and run 'quarto render'."; \
	fi

benchmark: venv
	$(BIN)/python benchmarks/p1_velocity_map.py

clean:
	rm -rf $(VENV) _site .quarto .pytest_cache
