# towerlink: `make demo` flies the lab scenario, `make test` runs the suite.
# Both create ./.venv on first use and install the project (editable) into it.
PY ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: demo test test-env bench sweep clients venv mavsdk3 clean help

help:
	@echo "make demo   - fly the default tower -> bridge -> drone -> rover scenario"
	@echo "make test   - run the test suite"
	@echo "make bench  - run the benchmarks (peers side by side)"
	@echo "make sweep  - install Ray (the sweep extra) and run the example sweep (examples/sweep)"
	@echo "make clients - run the client corpus (examples/clients) against towerlink sitl; writes docs/CLIENTS.md"
	@echo "make mavsdk3 - a MAVSDK-Python 3.x environment beside the venv ($(VENV)/mavsdk3), for its tests"

# setuptools warns that folders named like the packages shadow them: for this checkout's
# editable install that is the point, so the first command a person runs stays quiet
QUIET_EDITABLE := PYTHONWARNINGS='ignore:Editable installation'

# the venv itself, with a current pip (its resolver and installs are faster than the one
# python3.11's venv bundles)
$(VENV)/pyvenv.cfg:
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(VENV)/pyvenv.cfg
	$(QUIET_EDITABLE) $(BIN)/python -m pip install -q -e '.[test,plot]'
	rm -f $(VENV)/.installed-*
	touch $@

# the test suite also runs the Ray sweep tests: test and sweep add the sweep extra (Ray, pyarrow, tqdm);
# make demo does not need it. One pip call installs all of it (and so also makes STAMP's install)
SWEEP_STAMP := $(VENV)/.installed-sweep-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)
$(SWEEP_STAMP): pyproject.toml | $(VENV)/pyvenv.cfg
	$(QUIET_EDITABLE) $(BIN)/python -m pip install -q -e '.[test,plot,sweep]'
	rm -f $(VENV)/.installed-*
	touch $(STAMP) $@

venv: $(STAMP)

# MAVSDK-Python 3.x (System() with its bundled mavsdk_server) in an environment of its own:
# the test venv keeps 4.x, and examples/pytest/test_mavsdk3.py flies 3.x under MAVSDK3_PYTHON
MAVSDK3 := $(VENV)/mavsdk3
MAVSDK3_STAMP := $(MAVSDK3)/.installed
$(MAVSDK3_STAMP): | $(VENV)/pyvenv.cfg
	$(PY) -m venv $(MAVSDK3)
	$(MAVSDK3)/bin/python -m pip install -q 'mavsdk<4' pytest
	touch $@

mavsdk3: $(MAVSDK3_STAMP)

demo: $(STAMP)
	$(BIN)/towerlink fly

# what the suite needs: the project with its extras, and MAVSDK 3's environment built beside it
# (two jobs: pip spends most of its time on one core)
test-env:
	@$(MAKE) --no-print-directory -j2 $(SWEEP_STAMP) $(MAVSDK3_STAMP)

# tests/ and examples/pytest (pyproject's testpaths), in three passes (tests/conftest.py says why):
# the tests that are not full-system on four workers (they mostly wait), the full-system ones that
# fly in lockstep on two, then those marked `alone` one at a time. A module stays on one worker
# (loadfile); the conftest hands out the longest modules first and --no-loadscope-reorder keeps
# that order. The suite starts hundreds of Python processes: each compiles every module it
# imports unless the .pyc files are written once, so bytecode writing is on here even where the
# environment turns it off, and the project's own modules are compiled first, once.
# on a machine other work already loads, MAVSDK's and MAVProxy's wall-clock retries can run out
# with four workers: `make test FAST_WORKERS=2`
FAST_WORKERS ?= 4
test: export MAVSDK3_PYTHON := $(CURDIR)/$(MAVSDK3)/bin/python
test: export PYTHONDONTWRITEBYTECODE :=
test: test-env
	$(BIN)/python -m compileall -q -j 0 common vehicle gcs bridge tools
	$(BIN)/python -m pytest -q -n $(FAST_WORKERS) --dist loadfile --no-loadscope-reorder -m "not slow and not alone"
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder -m "slow and not alone"
	$(BIN)/python -m pytest -q -m alone

bench: $(STAMP)
	$(QUIET_EDITABLE) $(BIN)/python -m pip install -q -e '.[test,plot,bench]'
	$(BIN)/towerlink bench

# programs written the way MAVSDK, pymavlink, MAVProxy and autotest users write them, each against a
# fresh world, counted against what they do on ArduPilot SITL (tools/client_corpus.py)
clients: export MAVSDK3_PYTHON := $(CURDIR)/$(MAVSDK3)/bin/python
clients: $(STAMP) $(MAVSDK3_STAMP)
	$(BIN)/python -m tools.client_corpus --markdown docs/CLIENTS.md

sweep: $(SWEEP_STAMP)
	$(BIN)/towerlink sweep --grid examples/sweep/frames_loss.toml --out sweeps/frames_loss

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .hypothesis
