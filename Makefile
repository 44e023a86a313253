# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
export MUJOCO_GL = egl

.PHONY: demo test test-slow quick lint figures figures-check clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# setuptools' notice that an install is editable, which pip prints as a warning on every build:
	# that one message filtered by its text (no other warning, and no error, is touched)
	PYTHONWARNINGS="ignore:Editable installation" $(BIN)/python -m pip install -q -e '.[test,lint]'
	# an editable install compiles nothing, and where PYTHONDONTWRITEBYTECODE is set every command
	# would compile each module it imports at its start
	$(BIN)/python -m compileall -q -j 0 calibench estimators scenarios scenes sim
	touch $@

demo: $(VENV)/.installed
	$(BIN)/calibench run all

# The suite over every core (pytest-xdist): `make test` in minutes, `make test-slow` the minutes of
# evidence marked slow (the README's figures regenerated and compared, the discovery suites). CI
# runs both; test-slow ends with its 25 longest tests' times, to keep tests/slow_tests.txt true.
WORKERS ?= auto

test: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n $(WORKERS) -m "not slow"

test-slow: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n $(WORKERS) -m slow --durations=25

quick: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n $(WORKERS) -m "not slow" tests/estimators tests/test_recordings.py tests/test_bad_input.py tests/scenarios/test_iso230.py

# ruff (lint, format) on everything; mypy on every product room. The rooms install as calibench.*
# through a package-dir mapping mypy cannot follow: links under build/mypy give them that name.
MYPY_ROOT = build/mypy/calibench
lint: $(VENV)/.installed
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	mkdir -p $(MYPY_ROOT)
	for f in calibench/*.py calibench/recordings estimators scenarios scenes sim; do \
		ln -sfn ../../../$$f $(MYPY_ROOT)/$$(basename $$f); done
	cd build/mypy && ../../$(BIN)/mypy --config-file ../../pyproject.toml -p calibench

# The README's tables and numbers, rerun and rewritten (FIGURES="NAME ..." for some of them;
# `$(BIN)/python -m docs.figures --list` names them); figures-check compares instead of rewriting.
# The generator is the package docs/figures/, run from the repository's root.
figures: $(VENV)/.installed
	$(BIN)/python -m docs.figures $(FIGURES)

figures-check: $(VENV)/.installed
	$(BIN)/python -m docs.figures --check $(FIGURES)

clean:
	rm -rf $(VENV) calibench-out .pytest_cache
