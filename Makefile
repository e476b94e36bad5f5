# Entry points for people and CI. Everything goes through scripts/setup.sh (Debian packages) and CMake.
BUILD ?= build
JOBS ?= 2
CMAKE_FLAGS ?=

.PHONY: setup build demo test acceptance test-sanitize bench study clean

setup:
	bash scripts/setup.sh

build: setup
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)
	cmake --build $(BUILD) -j$(JOBS)

# The main job. Until the design service exists: a design job run locally on the built-in arm-flexion
# scene (parametric body, sleeve over the elbow flexed from 15 to 100 degrees), about 3 minutes on two
# cores, with its history written to $(BUILD)/arm_flexion.h5 and summarized.
demo: build
	$(BUILD)/client/kgd design arm_flexion --out $(BUILD)/arm_flexion.h5
	$(BUILD)/client/kgd designs $(BUILD)/arm_flexion.h5 | tail -n 4

test: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS) -LE acceptance

# Whole design runs to the budget (issue: the design engine, acceptance 2); about half an hour.
acceptance: build
	cd $(BUILD) && ctest --output-on-failure -L acceptance

# The same suite built with AddressSanitizer and UndefinedBehaviorSanitizer.
test-sanitize:
	$(MAKE) test BUILD=build-sanitize CMAKE_FLAGS="-DKGD_SANITIZE=ON -DKGD_BUILD_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo"

bench: build
	bash bench/run.sh $(BUILD)

# The design study of docs/RESULTS.md: all seven built-in scenes to the budget (about an hour).
study: build
	bash scripts/design_study.sh $(BUILD)

clean:
	rm -rf build build-sanitize
