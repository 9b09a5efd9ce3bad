# Everything needs only CPython (>= 3.11) and pip: the first target that needs the
# environment creates .venv and installs the project into it.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# Two stages in one environment: the library alone (what the audit needs), then the test,
# lab and documentation tools on top (`make test` and the developer targets).
CORE   := $(VENV)/.installed-core
STAMP  := $(VENV)/.installed

.PHONY: setup audit test test-thorough example bench lint clean lab screenshot docs dist-check typecheck

$(CORE): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e .
	touch $(CORE)

$(STAMP): $(CORE)
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

setup: $(STAMP)

audit: $(CORE)           ## the main job: audit models/arm7.xml (installs the library alone)
	@# Exit status 1 means "the audit has findings": arm7 has one, its keyframe 'zero' is
	@# singular by design (stretched straight up); only 2 and above (bad input, crashes) fail.
	$(BIN)/redundancy audit models/arm7.xml || [ $$? -eq 1 ]

test: $(STAMP)           ## the default (fast) suite, as CI runs it
	@# One pytest-xdist worker per CPU (CI has two), each test file on one worker in order (a
	@# guide page's code blocks share one namespace); plain `pytest` runs it in one process.
	$(BIN)/python -m pytest -n logical --dist loadfile

test-thorough: $(STAMP)  ## >= 1000 hypothesis examples per property, plus the slow sweeps
	@# A fresh seed each run, printed in pytest's header; HYPOTHESIS_SEED=N reruns one.
	SEED=$${HYPOTHESIS_SEED:-$$(od -An -N4 -tu4 /dev/urandom | tr -d ' ')}; \
	HYPOTHESIS_PROFILE=redundancy-thorough $(BIN)/python -m pytest -n logical --dist loadfile -m "slow or not slow" --hypothesis-seed=$$SEED

example: $(CORE)         ## the worked example: arm7's six tables (lesson 5.2)
	$(BIN)/redundancy example arm7

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[bench]"
	$(BIN)/python scripts/bench.py

lab: $(STAMP)            ## the interactive lab at http://127.0.0.1:8080/
	$(BIN)/redundancy lab

screenshot: $(STAMP)     ## docs/lab.png (needs chromium)
	$(BIN)/python scripts/lab_screenshot.py

docs: $(STAMP)           ## the API reference from the docstrings, into site/ (fails on any warning)
	$(BIN)/mkdocs build --strict --site-dir site

dist-check: $(STAMP)     ## build the sdist and the wheel into dist/ and run twine check on them
	rm -rf dist
	$(BIN)/python -m build --no-isolation --outdir dist .
	$(BIN)/twine check --strict dist/*

typecheck: $(STAMP)      ## pyright's completeness score of the public API (--verifytypes)
	@# PYTHONPATH: the checkout's package, ahead of the models/ folder the editable wheel
	@# force-includes into site-packages/redundancy.
	PYTHONPATH=src $(BIN)/pyright --pythonpath $(BIN)/python --verifytypes redundancy \
		--ignoreexternal | grep -E "^Type completeness score"

lint: $(STAMP)
	$(BIN)/ruff check src tests scripts
	$(BIN)/ruff format --check src tests scripts

clean:
	rm -rf $(VENV) build dist site .pytest_cache .hypothesis
