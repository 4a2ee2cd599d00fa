# mound-survey: `make` builds into build/, `make test` runs every test, `make demo` runs
# the main job on the example data. Each target sets the machine up first (idempotent).
BUILD  ?= build
VENV   ?= .venv
PY     := $(VENV)/bin/python
JOBS   ?= 2
# Data cache: developers and CI have byte-identical copies of the public data sets in
# ../shared/data; elsewhere `mound data fetch` downloads them into ~/.cache/mound-survey.
ifeq ($(origin MOUND_DATA),undefined)
  ifneq ($(wildcard ../shared/data/statlog/sat.trn),)
    export MOUND_DATA := $(abspath ../shared/data)
  endif
endif

.PHONY: all build setup test test-cpp test-python lint demo demo-stages figures bench clean \
        fuzz fuzz-smoke fuzz-build build-asan test-asan docs test-fast format

all: build

$(VENV)/.setup-done: tools/setup.sh python/requirements.txt pyproject.toml
	bash tools/setup.sh
	touch $@

setup: $(VENV)/.setup-done

build: setup
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release
	cmake --build $(BUILD) -j $(JOBS)

test: build test-cpp test-python lint docs

test-cpp: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# pytest on JOBS workers (pytest-xdist), a test file to a worker: a file's module fixtures
# (a survey, a trained model) are made once, and the two cores stay busy while one worker
# waits on a tool, a link or a Dask cluster. PYTEST_JOBS=0 runs in this one process.
PYTEST_JOBS ?= $(JOBS)
PYTEST_PAR  := -n $(PYTEST_JOBS) --dist loadfile

# The run traces which tests start a compiled tool (tools/native_tests.py): test-asan
# runs those again under the sanitizers, and only those when the trace is current.
test-python: build
	rm -f $(BUILD)/tool-trace.txt
	MOUND_TOOL_TRACE=$(abspath $(BUILD))/tool-trace.txt $(PY) -m pytest -q $(PYTEST_PAR)
	$(PY) tools/native_tests.py write $(BUILD)/tool-trace.txt $(BUILD)/native-tests.txt

# The edit-test loop (< 1 min after the build): every ctest binary (~15 s) and the pytest
# tests not marked slow (~40 s). `make test` still runs everything.
test-fast: test-cpp
	$(PY) -m pytest -q $(PYTEST_PAR) -m "not slow"

# C++ sources of the project (the fuzz corpus and build trees excluded).
CXX_SOURCES = $(shell find cpp tools -name '*.cc' -o -name '*.h')

lint: setup
	$(VENV)/bin/ruff check python tests tools
	$(VENV)/bin/mypy
	@echo "clang-format --dry-run --Werror: $(words $(CXX_SOURCES)) C++ sources"
	@$(VENV)/bin/clang-format --dry-run --Werror $(CXX_SOURCES)

# Applies .clang-format to the C++ sources (make lint checks it).
format: setup
	$(VENV)/bin/clang-format -i $(CXX_SOURCES)

# The documentation site (docs/, mkdocs.yml) into $(BUILD)/site: strict, and the
# command-line pages generated from the tools of this build.
docs: build
	MOUND_BUILD_DIR=$(abspath $(BUILD)) $(VENV)/bin/mkdocs build --strict --quiet --site-dir $(abspath $(BUILD))/site

# Fuzzing (tools/fuzz/run.sh): the libFuzzer targets (clang, ASan + UBSan) in build-fuzz/,
# FUZZ_SECONDS per target (the sites target 2.5 times that), then the Python readers with
# Hypothesis, FUZZ_EXAMPLES examples each. fuzz-smoke is CI's short version: every
# regression and seed input once, then 10 s per target and the default examples.
FUZZ_SECONDS  ?= 180
FUZZ_EXAMPLES ?= 20000
fuzz: setup
	tools/fuzz/run.sh fuzz $(FUZZ_SECONDS)
	MOUND_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) MOUND_FUZZ_FRESH=1 $(PY) -m pytest -q tests/python/test_fuzz_readers.py

fuzz-smoke: setup
	tools/fuzz/run.sh smoke 10

fuzz-build: setup
	tools/fuzz/run.sh build

# The whole test suite once more with every tool and test built under AddressSanitizer +
# UndefinedBehaviorSanitizer (build-asan/): every ctest binary, and the Python tests that
# start a compiled tool (all of them when `make test` has not traced the current sources).
ASAN_BUILD ?= build-asan
build-asan: setup
	cmake -S . -B $(ASAN_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMOUND_SANITIZE=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS)

test-asan: build-asan
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j $(JOBS)
	MOUND_BUILD_DIR=$(abspath $(ASAN_BUILD)) ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 $(PY) -m pytest -q $(PYTEST_PAR) \
	  $$($(PY) tools/native_tests.py args $(BUILD)/native-tests.txt)

# The main job: the whole survey in one command (python/mission.py re-executes itself
# under .venv): train the classifier, make standard field 0 at 250 m spacing, plan the tour,
# build the MAVLink mission, simulate and reconstruct every visited site in 3-D on a local
# Dask cluster, judge it, and write runs/survey/{summary.json,report.html,report.md}.
# A rerun skips what is done. Then the mission goes to a stand-in MAVSDK autopilot, since
# no aircraft is attached.
demo: build
	python3 python/mission.py
	$(PY) tools/demo_upload.py runs/survey/mission.plan

# The stages one by one with their own CLIs, as the driver runs them (runs/demo/).
demo-stages: build
	@mkdir -p runs/demo
	$(VENV)/bin/mound data fetch
	$(VENV)/bin/mound classify train --out runs/demo/model.json
	$(VENV)/bin/mound classify eval runs/demo/model.json
	$(VENV)/bin/mound field make --seed 0 --model runs/demo/model.json --out runs/demo/sites.json
	./$(BUILD)/mound_plan runs/demo/sites.json 120 --algo newalg --out runs/demo/plan_newalg.json
	./$(BUILD)/mound_plan runs/demo/sites.json 120 --algo newalg-ls --out runs/demo/plan_newalg_ls.json
	./$(BUILD)/mound_plan runs/demo/sites.json 120 --out runs/demo/plan_default.json
	$(PY) tools/plan_summary.py runs/demo/plan_newalg.json runs/demo/plan_newalg_ls.json runs/demo/plan_default.json
	$(VENV)/bin/mound field make --seed 0 --model runs/demo/model.json --spacing 250 --scan-pattern raster --out runs/demo/sites_flight.json
	./$(BUILD)/mound_plan runs/demo/sites_flight.json --out runs/demo/plan_flight.json
	$(VENV)/bin/mound mission build runs/demo/plan_flight.json --out runs/demo/mission.plan --wpl runs/demo/mission.waypoints --geojson runs/demo/mission.geojson
	$(PY) tools/demo_upload.py runs/demo/mission.plan
	$(VENV)/bin/mound sim site --mound tumulus --seed 1 --out runs/demo/site_tumulus --figures
	$(VENV)/bin/mound sim site --mound none --seed 1 --out runs/demo/site_flat
	./$(BUILD)/mound_recon reconstruct runs/demo/site_tumulus/images --out runs/demo/recon_tumulus --camera runs/demo/site_tumulus/camera.json --gps runs/demo/site_tumulus/poses.json
	$(VENV)/bin/mound recon figure runs/demo/recon_tumulus --out runs/demo/recon_tumulus.png
	./$(BUILD)/mound_recon verdict runs/demo/recon_tumulus --out runs/demo/recon_tumulus/verdict.json
	./$(BUILD)/mound_recon verdict runs/demo/recon_tumulus --reference runs/demo/site_tumulus/reference.ply --out runs/demo/recon_tumulus/verdict_paper.json

# The figures of the docs (docs/figures/): the site simulator and the 3-D stage.
figures: build
	$(VENV)/bin/mound sim site --mound tumulus --seed 1 --out runs/figures/site_tumulus
	$(VENV)/bin/mound sim site --mound none --seed 1 --out runs/figures/site_flat
	$(VENV)/bin/mound sim figures runs/figures/site_tumulus --out-dir docs/figures --dpi-scale 0.6

bench: build figures
	./$(BUILD)/tools/bench/mound_bench_plan
	$(PY) tools/bench/bench_tsp.py
	$(PY) tools/bench/bench_render.py
	$(PY) tools/bench/bench_mission.py
	$(PY) tools/bench/bench_recon.py --colmap
	$(PY) tools/bench/bench_icp.py
	$(PY) tools/bench/bench_verdict.py --paper --grid

clean:
	rm -rf $(BUILD)
