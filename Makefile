# Entry points for people and CI. Everything goes through scripts/setup.sh (Debian packages) and CMake.
BUILD ?= build
JOBS ?= 2
CMAKE_FLAGS ?=


.PHONY: faults
.PHONY: setup build demo test images test-images acceptance stability test-sanitize bench study study-roles study-accuracy study-makehuman study-bodies fuzz clean

setup:
	bash scripts/setup.sh

build: setup
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)
	cmake --build $(BUILD) -j$(JOBS)

# The main job on the embedded default: `kgd serve` (server + in-process worker, SQLite and HDF5 in
# $(BUILD)/demo-data), the built-in arm-flexion design job submitted and watched live through the CLI
# (a first run also builds the scene cache and measures the machine), then where its result is; the
# service stays on the CLI's and the browser's default addresses until Ctrl-C.
demo: build
	bash scripts/demo.sh $(BUILD)

# --timeout: a test that hangs fails with its name after 20 minutes (the longest takes about one)
# instead of holding the whole run. The tests' design jobs keep their scene cache and their machine
# factor (cost_calibration.json) in the build folder: jobs of a few iterations on small scenes would
# teach the user's own cache a factor that predicts real jobs badly. setup.sh --browser runs before the
# build: where it installs Node.js 20, that is the node CMake finds for the browser test.
# OMP_WAIT_POLICY=passive: two tests at a time on two cores run more OpenMP threads than cores, and
# libgomp's default busy-wait at every barrier then burns the cores the other threads wait for (`kgd
# study accuracy --quick` on the pull test: 220 CPU s instead of 14 on a loaded 2-core machine). It
# changes no result, only how idle threads wait.
TEST_ENV = KGD_CACHE_DIR=$(abspath $(BUILD))/test-cache OMP_WAIT_POLICY=passive
test:
	bash scripts/setup.sh --browser
	$(MAKE) build
	cd $(BUILD) && $(TEST_ENV) ctest --output-on-failure -j$(JOBS) -LE 'acceptance|long' --timeout 1200

# The images of deploy/docker/Dockerfile (kgd-server, kgd-worker, kgd-cli) built with buildah, no daemon
# or registry: the base images debian:12 and debian:12-slim come from debootstrap when absent
# (deploy/images.sh; sizes and build times in $(BUILD)/images.txt).
images:
	bash scripts/setup.sh --images
	bash deploy/images.sh

# The images run (deploy/test_images.py): the server and two workers over TLS with tokens, a job from the
# cli image with its worker killed mid-job, bit for bit as `kgd design` of this build; twenty jobs of four
# users while a worker is killed. Builds only kgd here when the build folder has none.
test-images:
	test -x $(BUILD)/client/kgd || { cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) && cmake --build $(BUILD) -j$(JOBS) --target kgd; }
	python3 deploy/test_images.py --kgd $(BUILD)/client/kgd

# The whole-body scenes' frames (slouch, crouch, lunge), a few minutes; the whole BESO designs of
# acceptance 2 (tests/beso_acceptance_test.cpp) are part of `make test`.
acceptance: build
	cd $(BUILD) && $(TEST_ENV) ctest --output-on-failure -L acceptance

# The stability suite with its long cases (a 100k-vertex garment: time and memory printed).
stability: build
	cd $(BUILD) && $(TEST_ENV) ctest --output-on-failure -L stability --timeout 3600

# The same suite built with AddressSanitizer and UndefinedBehaviorSanitizer.
SANITIZE_BUILD = build-sanitize
SANITIZE_FLAGS = -DKGD_SANITIZE=ON -DKGD_BUILD_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo
test-sanitize:
	$(MAKE) test BUILD=$(SANITIZE_BUILD) CMAKE_FLAGS="$(SANITIZE_FLAGS)"

# The mutation harness over kgd's inputs (scene files and the body scenes' exported files, job specs
# and records, design files, the HTTP door with tokens and a finished job), built with the sanitizers
# in $(SANITIZE_BUILD) (only the programs it runs): FUZZ_CASES per target from FUZZ_SEED, every case
# checked for crash, hang, sanitizer report (UBSan halts on its first) or internal error. `make test`
# runs 300 cases per target of it, 1000 of the scene target (the test fuzz_smoke).
FUZZ_CASES ?= 2000
FUZZ_SEED ?= 1
fuzz: setup
	cmake -S . -B $(SANITIZE_BUILD) $(SANITIZE_FLAGS)
	cmake --build $(SANITIZE_BUILD) -j$(JOBS) --target kgd kgd-server kgd-worker kgd_fuzz
	cd $(SANITIZE_BUILD) && KGD_CACHE_DIR=$(abspath $(SANITIZE_BUILD))/test-cache UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	  tests/kgd_fuzz --source $(CURDIR) --kgd client/kgd --server server/kgd-server --worker worker/kgd-worker \
	  --cases $(FUZZ_CASES) --seed $(FUZZ_SEED)

# Random system faults (libfiu: write, fsync, open, mmap, allocation) during `kgd design`, FAULT_RUNS
# runs from FAULT_SEED, every run judged against the uninterrupted design (tests/faults/fault_injection.py,
# docs/RELIABILITY.md, whose table it writes). About 6 s a run on two cores. Then the same faults in the
# design service, SERVICE_FAULT_RUNS runs of `kgd serve` (tests/faults/service_faults.py, the second
# table), about 7 s a run. Both run; the target fails when either finds a defect.
FAULT_RUNS ?= 300
SERVICE_FAULT_RUNS ?= 100
FAULT_SEED ?= 1
faults: build
	status=0; \
	KGD_CACHE_DIR=$(abspath $(BUILD))/test-cache python3 tests/faults/fault_injection.py --kgd $(BUILD)/client/kgd --runs $(FAULT_RUNS) \
	  --seed $(FAULT_SEED) --write-docs docs/RELIABILITY.md || status=1; \
	KGD_CACHE_DIR=$(abspath $(BUILD))/test-cache python3 tests/faults/service_faults.py --kgd $(BUILD)/client/kgd --runs $(SERVICE_FAULT_RUNS) \
	  --seed $(FAULT_SEED) --write-docs docs/RELIABILITY.md || status=1; \
	exit $$status

# Every benchmark once (about 20 minutes on two cores); every table they measure is written into
# docs/PERFORMANCE.md and docs/SCALING.md between its markers (bench/tables.py, scripts/generated_block.py),
# headed by its command, date and `kgd machine`.
bench: build
	bash bench/run.sh $(BUILD)

# The design study of docs/RESULTS.md (scripts/design_study.sh): the paper's seven built-in scenes to the
# budget (about ten minutes on two cores), then the three scenes with roles, each also resist-only, and
# the symmetric shirt (estimated 30-50 minutes more from short runs, the shirt's three runs most of it:
# two motions of 33k faces whose solves take tens of Newton iterations per BESO step);
# it writes Table 1, the curves and the roles' results into docs/RESULTS.md and the job times into
# docs/PERFORMANCE.md between their markers (scripts/study_tables.py). STUDY picks runs: `make study
# STUDY=paper` (the seven, about ten minutes), `make study STUDY="knee_flexion knee_brace+resist-only"`;
# a block is written only when its runs were all made by this study.
STUDY ?= paper roles
STUDY_COMMAND = make study$(if $(filter command line,$(origin STUDY)), STUDY="$(STUDY)")
study: build
	STUDY_COMMAND='$(STUDY_COMMAND)' bash scripts/design_study.sh $(BUILD) $(BUILD)/study $(STUDY)

# The scenes with roles alone, with the single-motion jobs their time is compared with (the roles' time
# above and about three minutes).
study-roles: build
	STUDY_COMMAND='make study-roles' bash scripts/design_study.sh $(BUILD) $(BUILD)/study roles arm_flexion knee_flexion slouch

# What accuracy costs in time (docs/ACCURACY.md and its plots, generated): the arm-flexion design at seven
# solver tolerances, two model variants, `precise` repeated, garment and body resolutions, three solver
# methods, and the frames a design is evaluated over (about fifty minutes on two cores); its header gives
# the date and machine as `kgd machine` prints them.
study-accuracy: build
	$(BUILD)/client/kgd study accuracy arm_flexion --out $(BUILD)/study-accuracy --image-prefix images/accuracy/
	mkdir -p docs/images/accuracy
	cp $(BUILD)/study-accuracy/*.svg docs/images/accuracy/
	cp $(BUILD)/study-accuracy/ACCURACY.md docs/ACCURACY.md

# The same study on the MakeHuman bodies of ../shared/bodies (about fifteen minutes).
study-makehuman: build
	bash scripts/makehuman_study.sh $(BUILD)

# One design for sizes S-L (scripts/bodies_study.sh): knee flexion designed for M alone, for the worst and
# for the mean of S, M and L, each worn by the three bodies; writes docs/RESULTS.md's results-bodies block
# and docs/images/bodies/ (about five minutes on two quiet cores).
study-bodies: build
	bash scripts/bodies_study.sh $(BUILD)

clean:
	rm -rf build build-sanitize
