# TRIC for ROS 2 Jazzy. Quick start: `make demo`, then `make test`. Every target sets itself up.
SHELL := /bin/bash
.DEFAULT_GOAL := help
VENV := .venv
PY := $(VENV)/bin/python
# Run a command inside the built workspace (venv + ros_ws overlay).
IN_ENV := source ./env.sh &&

DEPS_STAMP := $(VENV)/.tric-deps
BUILD_STAMP := ros_ws/install/.tric-built
BUILD_INPUTS := $(shell find ros_ws/src -type f \( -name package.xml -o -name CMakeLists.txt -o -name setup.py \
	-o -name setup.cfg -o -name '*.cpp' -o -name '*.msg' -o -name '*.srv' -o -name '*.action' -o -path '*/resource/*' \))

.PHONY: help setup demo experiments test lint bench constraints clean

help:
	@echo "make demo         the main job: record sphere demos, train TRIC, evaluate it against the teacher"
	@echo "make experiments  the paper's experiments (EXPERIMENTS='fig9 table3' for some), results/REPORT.md"
	@echo "make setup        create .venv, install pinned ROS 2 Jazzy wheels and libraries, colcon build"
	@echo "make test         run the test suite (unit + in-process integration tests)"
	@echo "make lint         ruff check and ruff format --check over every Python file (ruff.toml), and mypy"
	@echo "                  over the ROS-free modules of tric_sim, tric_learning and tric_control (mypy.ini)"
	@echo "make bench        run the benchmarks, write results/bench.json (BENCH_ARGS=--check: against the targets)"
	@echo "make constraints  re-pin constraints.txt from the current .venv"
	@echo "make clean        remove build outputs (keeps .venv)"

setup: $(BUILD_STAMP)

$(DEPS_STAMP): requirements.txt requirements/ros-pypi.txt requirements/libs.txt constraints.txt scripts/create_venv.sh scripts/mend_cmake_exports.py
	scripts/create_venv.sh $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt -c constraints.txt
	$(PY) scripts/mend_cmake_exports.py $(VENV)
	touch $@

# The robot descriptions derived from installed ones (docs/robots.md), written before the build
# installs them.
DERIVED_PROFILES := ros_ws/src/tric_sim/tric_sim/description/panda.yaml

$(BUILD_STAMP): $(DEPS_STAMP) $(BUILD_INPUTS) $(DERIVED_PROFILES) scripts/colcon_build.sh
	for profile in $(DERIVED_PROFILES); do \
		PYTHONPATH=ros_ws/src/tric_sim $(PY) -m tric_sim.world.derived_urdf $$profile || exit 1; done
	scripts/colcon_build.sh
	touch $@

demo: setup
	$(IN_ENV) ros2 run tric_control tric-demo $(if $(ROBOT),--robot $(ROBOT)) $(DEMO_ARGS)

experiments: setup
	$(IN_ENV) ros2 run tric_control tric-experiments $(EXPERIMENTS)

test: setup
	$(IN_ENV) python -m pytest

# Every Python file of the repository: the packages and their tests, the integration tests, the
# benchmarks and the scripts. mypy checks the files mypy.ini names (the packages' ROS-free modules).
LINT_PATHS := ros_ws/src tests benchmarks scripts conftest.py

lint: setup
	$(IN_ENV) ruff check $(LINT_PATHS)
	$(IN_ENV) ruff format --check $(LINT_PATHS)
	$(IN_ENV) mypy

bench: setup
	$(IN_ENV) python benchmarks/run.py $(BENCH_ARGS)

constraints: $(DEPS_STAMP)
	scripts/pin_constraints.sh

clean:
	rm -rf ros_ws/build ros_ws/install ros_ws/log
