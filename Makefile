# A fresh clone: `make demo`, `make test-fast` (lint and the core of every package, under 2 minutes on
# 2 cores) and `make test` (lint and the whole suite; a test that needs a missing system tool is skipped and
# the run ends with a summary of the skips: tools/system-packages installs the tools).
# Each creates .venv if missing and installs the package with what it needs.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
# The fast tier: everything but the markers registered in pyproject.toml for long or tool-bound tests.
FAST   := not (slow or cross or browser or valgrind or cluster)

.PHONY: demo lint test test-fast bench clean distclean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(VENV)/bin/python
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/manip demo

lint: $(VENV)/.installed
	$(PY) -m ruff check --no-cache .

test-fast: lint
	$(PY) -m pytest -q -n 2 --dist loadfile -m "$(FAST)"

test: lint
	$(PY) -m pytest -q

bench: $(VENV)/.installed
	$(PY) -m benchmarks

# What the build, the tests, the demo and the tools write into the tree (.gitignore lists the same);
# the venv stays (distclean removes it too).
clean:
	rm -rf build dist out .cache .pytest_cache .ruff_cache *.egg-info
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +
	find . -path ./$(VENV) -prune -o -name '*.fmu' -type f -exec rm -f {} +

distclean: clean
	rm -rf $(VENV)
