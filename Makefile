# sailforce: `make demo` and `make test` set everything up from a bare python3.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
DEMO_DIR ?= out/reproduce
BUILD := build
VECTORS := $(BUILD)/vectors
#: the default calibration's header, as `sail export-c` writes it (tests/test_libsail.py checks it is current)
EXPORT_DEFAULT := c/examples/calibration.json -o c/examples/sail_calibration.h --lowpass-hz 10 --sample-rate-hz 80 --lowpass-order 2
# The sketch's multi-rate build: a simulated rig with HX711s at 80 SPS and its dynamic term, ticks at 1 kHz.
EXPORT_HX711 := c/examples/hx711/calibration.json -o c/examples/hx711/sail_calibration.h --sample-rate-hz 1000

.PHONY: bytecode install-ccx demo test lint docs c-test c-default cross cross-test arm-toolchain qemu-arm valgrind chromium live bench fuzz install clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# the compiled kernels are compiled once here, into numba's cache beside their source (about 10 s), not by the first
# test or command that needs them
$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install --quiet -e '.[dev]'
	$(PY) -m sailforce.fem.modes
	touch $(STAMP)

install: $(STAMP)

# the package's bytecode, written beside its sources: where PYTHONDONTWRITEBYTECODE is set (this machine, CI) Python
# writes none itself, and every `sail` process compiled every module it imported again (0.1 s of `sail estimate`'s
# 0.6 s of CPU); up to date, this takes a quarter of a second
bytecode: $(STAMP)
	$(PY) -m compileall -q src/sailforce

demo: $(STAMP) bytecode install-ccx
	$(VENV)/bin/sail reproduce --solid -o $(DEMO_DIR)

# the suite on every core (pytest-xdist, tests handed out one by one: measured 400 s against 425 s with each file kept
# on one worker, and 659 s in one process), the 15 slowest tests printed so that a slow one is seen when it arrives;
# PYTEST_FLAGS= runs it in one process
PYTEST_FLAGS ?= -n auto --durations=15
test: $(STAMP) bytecode lint c-test chromium install-ccx
	$(PY) -m pytest $(PYTEST_FLAGS)

# the simulated arm on the live page (sail live --simulate), calibrated as a lab would: a static session of the same
# rig, `sail calibrate` with the robot file's dynamic term; open the URL it prints
LIVE_DIR ?= $(BUILD)/live
live: $(STAMP) bytecode
	mkdir -p $(LIVE_DIR)
	$(VENV)/bin/sail simulate-motion --session static --rig 1 -o $(LIVE_DIR)/static.csv
	$(VENV)/bin/sail calibrate $(LIVE_DIR)/static.csv --model matrix --dynamics prior -q -o $(LIVE_DIR)/calibration.json
	$(VENV)/bin/sail live --calibration $(LIVE_DIR)/calibration.json --simulate --record-dir $(LIVE_DIR)/recordings

# ruff on everything Python; mypy on the public API (pyproject.toml lists the modules)
lint: $(STAMP)
	$(VENV)/bin/ruff check src tests bench docs c
	$(VENV)/bin/mypy

# the documentation site (MkDocs Material; the CLI and API pages generated from the code) into build/site
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir $(BUILD)/site

# libsail: shared test vectors from Python, then CTest in float and in double.
c-test: $(STAMP)
	$(PY) c/tests/make_vectors.py $(VECTORS)
	for real in float double; do \
	  cmake -S c -B $(BUILD)/c-$$real -DSAIL_DOUBLE=$$([ $$real = double ] && echo ON || echo OFF) \
	        -DSAIL_VECTORS_DIR=$(abspath $(VECTORS)) > /dev/null && \
	  cmake --build $(BUILD)/c-$$real -j 2 > /dev/null && \
	  ctest --test-dir $(BUILD)/c-$$real --output-on-failure || exit 1; \
	done

# Debian packages for the Cortex-M builds, installed when missing (as root, or through sudo).
APT := $$([ "$$(id -u)" = 0 ] || echo sudo) env DEBIAN_FRONTEND=noninteractive apt-get
arm-toolchain:
	@command -v arm-none-eabi-gcc > /dev/null || { \
	  echo "installing gcc-arm-none-eabi and libnewlib-arm-none-eabi (Debian)"; \
	  $(APT) update -qq && $(APT) install -y -qq gcc-arm-none-eabi libnewlib-arm-none-eabi > /dev/null; }

qemu-arm:
	@command -v qemu-system-arm > /dev/null || { \
	  echo "installing qemu-system-arm (Debian)"; \
	  $(APT) update -qq && $(APT) install -y -qq qemu-system-arm > /dev/null; }

# Debian's chromium for the live page's browser tests (Playwright drives it; it downloads no browser)
chromium:
	@command -v chromium > /dev/null || { \
	  echo "installing chromium (Debian), for the live page's browser tests"; \
	  $(APT) update -qq && $(APT) install -y -qq chromium > /dev/null; }

# CalculiX for the solid model (sail solid, solid-sweep, cell-fit; its tests)
install-ccx:
	@command -v ccx > /dev/null || { \
	  echo "installing calculix-ccx (Debian), for the solid model"; \
	  $(APT) update -qq && $(APT) install -y -qq calculix-ccx > /dev/null; }

valgrind:
	@command -v valgrind > /dev/null || { \
	  echo "installing valgrind (Debian)"; \
	  $(APT) update -qq && $(APT) install -y -qq valgrind > /dev/null; }

# libsail and the sketch for Cortex-M4F (-Os), installing Debian's toolchain if missing; prints the code size.
cross: arm-toolchain
	cmake -S c -B $(BUILD)/cross -DCMAKE_TOOLCHAIN_FILE=cmake/cortex-m4f.cmake -DCMAKE_BUILD_TYPE=MinSizeRel \
	      -DSAIL_BUILD_TESTS=OFF -DSAIL_BUILD_EXAMPLES=OFF -DSAIL_BUILD_FIRMWARE=ON > /dev/null
	cmake --build $(BUILD)/cross -j 2 > /dev/null
	python3 c/firmware/report_size.py $(BUILD)/cross

# libsail's tests on an emulated Cortex-M4F (QEMU's mps2-an386), built as `make cross` builds (-Os, hard float,
# newlib-nano): the shared vectors and the API and sketch-logic tests, each killed after 120 s.
cross-test: $(STAMP) arm-toolchain qemu-arm
	$(PY) c/tests/make_vectors.py $(VECTORS)
	cmake -S c -B $(BUILD)/cross-test -DCMAKE_TOOLCHAIN_FILE=cmake/cortex-m4f-qemu.cmake -DCMAKE_BUILD_TYPE=MinSizeRel \
	      -DSAIL_BUILD_EXAMPLES=OFF -DSAIL_VECTORS_DIR=$(abspath $(VECTORS)) > /dev/null
	cmake --build $(BUILD)/cross-test -j 2 > /dev/null
	ctest --test-dir $(BUILD)/cross-test --output-on-failure

# every benchmark; callgrind counts x86-64 instructions, QEMU Thumb-2 ones (both installed when missing)
bench: $(STAMP) bytecode valgrind arm-toolchain qemu-arm chromium install-ccx
	$(PY) bench/run.py

# Random and mutated files through every reader (tables in file and stream mode, fit-poly tables, robot and
# calibration files): no crash, no lost row.  FUZZ_CASES=100000 by default, about six minutes.
FUZZ_CASES ?= 100000
fuzz: $(STAMP)
	$(PY) bench/fuzz_readers.py $(FUZZ_CASES)

clean:
	rm -rf $(VENV) $(BUILD) src/*.egg-info .pytest_cache .hypothesis

# Regenerate the example calibration headers after changing their calibration.json or export-c.  The HX711 one
# comes from `sail simulate-motion --adc hx711-80` (static and free sessions) and `sail calibrate --free-motion`.
c-default: $(STAMP)
	$(VENV)/bin/sail export-c $(EXPORT_DEFAULT)
	$(VENV)/bin/sail export-c $(EXPORT_HX711)
