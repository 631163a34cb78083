# mcvo: the commands a user runs. See README.md.
#
#   make deps    install every build and test dependency from Debian packages
#   make         build (Release) into build/
#   make test    build and run the test suite (ctest)
#   make demo    build and run the default job on the built-in example
#   make install install the Python module mcvo into the system python3 (cmake --install)
#   make format  clang-format all sources in place
#   make lint    clang-tidy over src/ and tools/ (uses build/compile_commands.json)
#   make fuzz    libFuzzer targets of the input readers, FUZZ_SECONDS each (docs/fuzzing.md)

BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
FUZZ_SECONDS ?= 600
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

# Debian 12 package names. colmap is the real binary that later checks our
# COLMAP exports; chromium renders reports in tests. libopenblas0-serial
# becomes the system BLAS (Debian's alternatives) that CHOLMOD factorises
# the global BA with: about 4x faster than ATLAS, one thread (mcvo/util/blas.h).
# slurm-wlm and munge: the cluster test starts a one-node Slurm (tests/cluster/).
# linux-perf: perf, for the CPU profile of tools/bench_profile.sh (results/profile.md).
# librosbag-storage-dev and the ROS message headers read ROS1 bags (--format
# rosbag); no ROS installation is needed.
# pybind11-dev and python3-dev build the Python module (docs/python.md);
# numpy, pytest and matplotlib are what it, its tests and examples/python use.
DEB_PACKAGES := build-essential cmake pkg-config git ca-certificates \
  libeigen3-dev libceres-dev libsuitesparse-dev libopenblas0-serial libssl-dev libgoogle-glog-dev libgflags-dev \
  libopencv-dev libopencv-contrib-dev libdeflate-dev nlohmann-json3-dev libyaml-cpp-dev \
  librosbag-storage-dev libsensor-msgs-dev libgeometry-msgs-dev libnav-msgs-dev \
  libgtest-dev libgmock-dev libopengv-dev colmap chromium \
  clang-format clang-tidy clang libclang-rt-14-dev slurm-wlm munge linux-perf \
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib

SOURCES := $(shell find src include tools tests -name '*.cc' -o -name '*.h' 2>/dev/null)

.PHONY: all build deps configure test demo install format lint fuzz clean

all: build

deps:
	$(SUDO) apt-get update
	DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y --no-install-recommends $(DEB_PACKAGES)

$(BUILD_DIR)/CMakeCache.txt:
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE)

configure: $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

demo: build
	./tools/demo.sh $(BUILD_DIR)/mcvo

# The Python module mcvo, into the system python3's site-packages (docs/python.md).
install: build
	$(SUDO) cmake --install $(BUILD_DIR)

format:
	clang-format -i $(SOURCES)

lint: configure
	run-clang-tidy -quiet -p $(BUILD_DIR) '$(CURDIR)/(src|tools)/.*\.cc$$'

# Builds the fuzz targets with clang in build-fuzz/ (never build/), runs each
# for FUZZ_SECONDS and writes results/fuzz.md and results/fuzz.csv.
fuzz:
	FUZZ_SECONDS=$(FUZZ_SECONDS) JOBS=$(JOBS) ./tools/run_fuzz.sh

clean:
	rm -rf $(BUILD_DIR)
