# towerlink: `make demo` flies the lab scenario, `make test` runs the suite.
# Both create ./.venv on first use and install the project (editable) into it.
PY ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: demo test bench venv clean help

help:
	@echo "make demo   - fly the default tower -> bridge -> drone -> rover scenario"
	@echo "make test   - run the test suite"
	@echo "make bench  - run the benchmarks (peers side by side)"

# setuptools warns that folders named like the packages shadow them: for this checkout's
# editable install that is the point, so the first command a person runs stays quiet
QUIET_EDITABLE := PYTHONWARNINGS='ignore:Editable installation'

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(QUIET_EDITABLE) $(BIN)/python -m pip install -q -e '.[test,plot]'
	rm -f $(VENV)/.installed-*
	touch $@

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/towerlink fly

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile -m "not slow"
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	$(QUIET_EDITABLE) $(BIN)/python -m pip install -q -e '.[test,plot,bench]'
	$(BIN)/towerlink bench

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .hypothesis
