# tognet: every target creates its own virtual environment with python -m venv + pip.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test lint install clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

## The main job: the end-to-end demo (grows with the project).
run: $(STAMP)
	$(BIN)/tognet demo --out runs/demo

## The test suite, plus the linter.
test: $(STAMP)
	$(BIN)/ruff check tognet tests benchmarks
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check tognet tests benchmarks

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache
