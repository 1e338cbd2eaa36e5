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

# Re-run one notebook with other parameters into runs/<NB>/ (the paper's run stays as it is);
# unknown names and bad values fail before anything runs; prints the path of runs/<NB>/changes.md:
#   make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 25"
#   make rerun NB=p2_three_rrr_singularity_proximity PARAMS='-y "branch: [1, -1, 1]"'
rerun: venv
	@test -n "$(NB)" || (echo 'usage: make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 25"'; exit 2)
	$(BIN)/python -m pkmlib.rerun $(NB) $(PARAMS)

benchmark: venv
	$(BIN)/python benchmarks/p1_velocity_map.py

clean:
	rm -rf $(VENV) _site .quarto .pytest_cache
