# ballbot-casadi: every target creates/uses its own virtual environment in .venv.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: all venv codegen test demo bench fmu sil firmware clean distclean

all: codegen

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,fmi-extra]'
	@touch $(STAMP)

venv: $(STAMP)

## Generate C for the model (and controllers) under build/ and compile shared + static libraries.
codegen: $(STAMP)
	$(PY) -m ballbot_casadi.cli codegen

## Run the test suite (the 15 slowest tests and this run's C compiles, from the build log, at the end).
## Slow tests included; TEST_WORKERS processes (pytest-xdist), whole test files per process.
TEST_WORKERS ?= 2
test: $(STAMP)
	BALLBOT_BUILD_LOG=$(CURDIR)/build/test_builds.jsonl $(PY) -m pytest -q --durations=15 \
		-n $(TEST_WORKERS) --dist loadfile

## Main job: build, analyse, simulate the default robot, write report and plots under build/demo.
demo: $(STAMP)
	$(PY) -m ballbot_casadi.cli demo --out build/demo

## Benchmarks: results in build/bench.json.
bench: $(STAMP)
	$(PY) -m ballbot_casadi.cli bench --out build/bench.json

## Build the plant FMU into build/fmu/.
fmu: $(STAMP)
	$(PY) -m ballbot_casadi.cli fmu build --out build/fmu

## Software in the loop: plant + controller FMUs of the roll sine (noise, QUKF + VUKF) as
## build/fmu/BallbotSIL.ssp; run it with: ballbot fmu cosim build/fmu/BallbotSIL.ssp --out DIR
sil: $(STAMP)
	$(PY) -m ballbot_casadi.cli fmu ssp --scenario full_sine --out build/fmu/BallbotSIL.ssp

## Cortex-M7 firmware library of the embedded software (FLC + QUKF + VUKF; and with the path MPC), verified in QEMU
## (needs gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm).
firmware: $(STAMP)
	$(PY) -m ballbot_casadi.cli firmware --precision double --verify 200
	$(PY) -m ballbot_casadi.cli firmware --precision single --verify 200
	$(PY) -m ballbot_casadi.cli firmware --precision double --guidance mpc --verify 200

clean:
	rm -rf build

distclean: clean
	rm -rf $(VENV) *.egg-info
