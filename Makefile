# `make install` creates .venv when it is missing, installs the pinned set (again only when pyproject.toml or
# constraints.txt change) and compiles every numba kernel into numba's cache, so that no command compiles on its
# first run (with a warm cache the warm-up only loads them: a few seconds). `make test` and `make demo` run it first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: install lint test test-slow demo bench clean

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet -c constraints.txt -e ".[rl,dev,ray]"
	touch $(STAMP)

install: $(STAMP)
	$(PY) -m triplanar.warmup

# The lint gate (ruff, configured in pyproject.toml and pinned through the `dev` extra), the layering check (no
# import circle, no upward import: tests/test_layering.py) and the function-length check (tests/test_function_length.py);
# both read the sources and import nothing. .ci/run runs it first.
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q -p no:cacheprovider tests/test_layering.py tests/test_function_length.py

# The tests run on every core (pytest-xdist; the two Ray files share one worker, so that one Ray runs at a time).
# Tests that share a costly fixture share a worker too (`xdist_group`); the costliest start first (tests/conftest.py).
# `make test` runs every test but those marked `long`, and the fuzz tests with 100 inputs each; `make test-slow`
# runs the `long` ones (study-scale training and evaluation, a 30-seed coverage rate, the Ray cluster) and the fuzz
# tests (hypothesis's own `hypothesis` marker) with 1,000 inputs each. .ci/run runs both.
# Python's bytecode cache stays on for the tests even where the environment turns it off (PYTHONDONTWRITEBYTECODE=1,
# as on this machine): the suite starts some forty interpreters (the commands' subprocess tests, the import checks)
# and two xdist workers, and without the cache each compiles the project's modules and rewrites the test modules'
# asserts again (0.7 CPU s per interpreter for the project's imports, about 7 s per worker for collection).
test test-slow: export PYTHONDONTWRITEBYTECODE =

test: install
	$(PY) -m pytest -q -n auto --dist loadgroup --durations=20 -m "not long"

test-slow: install
	$(PY) -m pytest -q -n auto --dist loadgroup --durations=15 -m "long or hypothesis" --hypothesis-profile=thorough

demo: install
	$(PY) -m triplanar.cli demo --out out/demo

bench: install
	$(PY) benchmarks/bench_core.py

clean:
	rm -rf $(VENV) out
