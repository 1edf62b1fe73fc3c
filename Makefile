# Two commands on a fresh machine: `make run` (the app, simulated robot) and `make test` (the whole suite).
# Each sets up what it needs: Debian packages (apt-get, when missing and root), .venv, the package.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
HOST ?= 127.0.0.1
PORT ?= 8000
export HOST PORT

RUN_DEBS := libgl1 libegl1 libportaudio2 espeak-ng
TEST_DEBS := $(RUN_DEBS) chromium postgresql iproute2 ethtool

.PHONY: run test lint bench setup setup-test deps-run deps-test clean

run: setup
	$(BIN)/humanoid db upgrade
	$(BIN)/humanoid serve --host $(HOST) --port $(PORT)

test: setup-test
	$(BIN)/ruff check app robot tests
	$(BIN)/ruff format --check app robot tests
	$(BIN)/python -m pytest -q

lint: setup-test
	$(BIN)/ruff check app robot tests
	$(BIN)/ruff format --check app robot tests

bench: setup-test
	$(BIN)/humanoid bench core --output bench-results/core.json --json

setup: deps-run $(VENV)/.installed-run
setup-test: deps-test $(VENV)/.installed-test

deps-run:
	@bash scripts/ensure-debs.sh $(RUN_DEBS)
deps-test:
	@bash scripts/ensure-debs.sh $(TEST_DEBS)

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed-run: $(VENV)/bin/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: $(VENV)/bin/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(VENV)/.installed-run $@

clean:
	rm -rf $(VENV) data .pytest_cache .ruff_cache *.egg-info
