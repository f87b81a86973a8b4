# tognet: every target creates its own virtual environment with python -m venv + pip.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test lint install clean system-deps

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,ray,serve,ros,rerun]'
	# The robot extra for the arm tests: robosuite only for its model files (tognet never imports it, so not
	# its own ~500 MB of dependencies) and mink for inverse kinematics.
	$(BIN)/python -m pip install --quiet --no-deps robosuite==1.5.1
	$(BIN)/python -m pip install --quiet mink==1.3.0
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

## Debian/Ubuntu libraries for MuJoCo's headless renderer (the --gif animations): Mesa's EGL and GL; and
## Chromium, which the service's test uses to render its /docs page headless. Needs root (or sudo);
## nothing else in tognet needs system packages.
SYSTEM_PACKAGES := libegl1 libgl1 libgles2 chromium
system-deps:
	@export PATH="$$PATH:/usr/sbin:/sbin"; \
	if ldconfig -p | grep -q libEGL.so.1 && ldconfig -p | grep -q libGL.so.1 && command -v chromium >/dev/null; then \
	  echo "system-deps: EGL and GL libraries and Chromium already present"; \
	else \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(SYSTEM_PACKAGES); \
	fi

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache
