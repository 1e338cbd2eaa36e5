# pkmlib: two commands do everything (see README.md).
#   make report  - set up .venv, execute every notebook, write figures/ and data/results/,
#                  print the scorecard, render the Quarto site if Quarto is available
#   make test    - set up .venv, lint, render the site (if Quarto is available) beside the unit tests,
#                  the site and scorecard tests, nbval on every notebook and every benchmark's smoke
#                  run, in $(PYTEST_WORKERS) processes: the complete check CI runs (.ci/run)
#   make quick   - while working: lint and the unit tests not marked slow, in parallel, no render,
#                  no nbval
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
# The same science bits on every x86-64 machine (tests/test_regenerate.py): XLA's CPU code at most
# AVX2 and its matrix products on one thread (vector width and thread count change the order of
# sums), NumPy's and SciPy's OpenBLAS with the Haswell kernels on one thread (its kernels are
# chosen per CPU: P5's singular values differed in their last digits). The design page stores its
# optima at 4 significant digits besides (pkmlib/design/studies.py, stored_design).
export XLA_FLAGS ?= --xla_cpu_max_isa=AVX2 --xla_cpu_multi_thread_eigen=false
export OPENBLAS_CORETYPE ?= Haswell
export OPENBLAS_NUM_THREADS ?= 1

# Test processes (pytest-xdist): each test file and each notebook stays in one process
# (--dist loadfile: a notebook's cells share one kernel; module fixtures are computed once), the
# test files longest first as benchmarks/results/tests.json measured them (tests/conftest.py; not
# xdist's order by test count). Three processes on two cores: the browser tests, the kernels and
# the subprocesses leave a core idle while they wait (unit step 513 s with 2, 418 s with 3 and
# this order, warm cache, on 2026-12-07).
PYTEST_WORKERS ?= 3
PYTEST_PARALLEL := -n $(PYTEST_WORKERS) --dist loadfile --no-loadscope-reorder
LINTED := pkmlib tests benchmarks scripts

.PHONY: all venv test quick lint report rerun benchmark clean

all: test

$(BIN)/.installed: environment.lock pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --require-hashes -r environment.lock
	$(BIN)/python -m pip install --quiet --no-deps -e .
	touch $@

venv: $(BIN)/.installed

# The site renders beside the unit tests (scripts/tests_beside_render.sh runs scripts/render_site.sh:
# Quarto from ../shared/quarto or PATH, stored outputs, any Quarto warning fails), and the tests
# that read _site/ wait for it (tests/_site.py); a failed render fails the step. Without Quarto the
# site tests skip and say why. The unit tests run before nbval, not beside it: the notebooks
# rewrite data/results/ while they run, which the scorecard and site tests read.
test: venv lint
	bash scripts/tests_beside_render.sh $(PYTEST_PARALLEL) tests
	$(BIN)/python -m pytest --nbval --nbval-current-env $(PYTEST_PARALLEL) notebooks

# The unit tests without the slow ones (re-runs, kernels, benchmark smoke runs), no render, no nbval.
quick: venv lint
	$(BIN)/python -m pytest $(PYTEST_PARALLEL) -m "not slow" tests

lint: venv
	$(BIN)/ruff check $(LINTED)
	$(BIN)/ruff format --check $(LINTED)

# Notebooks are executed into .nbexec/ and then installed over notebooks/ by pkmlib.tools.report
# (normalized: no timing metadata, split stream outputs merged; atomic), so a second
# `make report` leaves `git status` clean and an interrupted one leaves notebooks/ as they were.
# pkmlib.tools.report fails, naming the file, on a missing or corrupt results file and writes nothing.
report: venv
	rm -rf .nbexec
	$(BIN)/jupyter nbconvert --to notebook --execute --ExecutePreprocessor.record_timing=False --output-dir .nbexec $(NOTEBOOKS)
	$(BIN)/python -m pkmlib.tools.report --notebooks-from .nbexec
	rm -rf .nbexec
	$(BIN)/python -m pkmlib.explore --out site/explore/data
	$(BIN)/quartodoc build && rm -f objects.json
	@bash scripts/render_site.sh || { rc=$$?; [ $$rc -eq 3 ] || exit $$rc; echo "Quarto not found: skipped rendering the site into _site/ (see README)."; }

# Re-run one notebook with other parameters into runs/<NB>/ (the paper's run stays as it is);
# unknown names and bad values fail before anything runs; prints the path of runs/<NB>/changes.md:
#   make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 25"
#   make rerun NB=p2_three_rrr_singularity_proximity PARAMS='-y "branch: [1, -1, 1]"'
rerun: venv
	@test -n "$(NB)" || (echo 'usage: make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 25"'; exit 2)
	$(BIN)/python -m pkmlib.tools.rerun $(NB) $(PARAMS)

# Every paper's benchmark (benchmarks/results/<paper>.json); notebook timings, cold and warm
# cache: $(BIN)/python benchmarks/notebooks.py (writes benchmarks/results/notebooks.json).
benchmark: venv
	$(BIN)/python benchmarks/run_all.py
# (CI runs each benchmark once at its smallest size: tests/test_benchmarks_smoke.py, part of make test.)

clean:
	rm -rf $(VENV) _site .quarto .pytest_cache
