# Pac-Man Pete: every entry point. On a fresh machine `make test` and `make demo` install what they
# need themselves: a .venv with the project, and Debian packages for the C++ build when missing.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
BUILD := build/host
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
export PIP_DISABLE_PIP_VERSION_CHECK := 1

# Debian packages the host build needs: (file that proves it is installed, package).
DEB_CHECKS := /usr/include/gtest/gtest.h:libgtest-dev \
              /usr/bin/cmake:cmake \
              /usr/bin/g++:g++

.PHONY: firmware-check arm-deps
# The V5's toolchain, for proving the Brain core builds for the target.
ARM_CHECKS := /usr/bin/arm-none-eabi-g++:gcc-arm-none-eabi \
              /usr/lib/arm-none-eabi/newlib/libc.a:libnewlib-arm-none-eabi \
              /usr/lib/arm-none-eabi/include/c++:libstdc++-arm-none-eabi-newlib

# Headless Chromium for the dashboard's browser test and benchmark (driven by Selenium through
# Debian's own chromedriver: no browser download).
BROWSER_CHECKS := /usr/bin/chromium:chromium \
                  /usr/bin/chromedriver:chromium-driver

.PHONY: browser-deps
browser-deps:  ## apt-get Debian's chromium and chromium-driver (the dashboard's checks), if missing
	@missing=""; for pair in $(BROWSER_CHECKS); do \
	  [ -e "$${pair%%:*}" ] || missing="$$missing $${pair##*:}"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

.PHONY: help venv system-deps build test test-python test-cpp lint format generate check demo bench results clean wheel-check

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | expand -t 16

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

venv: $(BIN)/.installed  ## create .venv and install the project with every extra

system-deps:  ## apt-get the Debian packages the C++ build needs, if missing
	@missing=""; for pair in $(DEB_CHECKS); do \
	  [ -e "$${pair%%:*}" ] || missing="$$missing $${pair##*:}"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

arm-deps:  ## apt-get the arm-none-eabi toolchain, if missing
	@missing=""; for pair in $(ARM_CHECKS); do \
	  [ -e "$${pair%%:*}" ] || missing="$$missing $${pair##*:}"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

firmware-check: arm-deps  ## compile every Brain core source for the V5's Cortex-A9
	bash brain/tools/firmware_check.sh

build: system-deps  ## configure and build the C++ host tree (tests run under ASan + UBSan)
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Debug -DPETE_SANITIZE=ON > /dev/null
	cmake --build $(BUILD) -j $(JOBS)

generate: venv  ## rewrite the generated codecs from protocol/schema.toml
	$(BIN)/pete-protocol generate

# The Jetson side runs on Python 3.10 (JetPack 6); CI has 3.11 only, so vermin checks it statically.
JETSON_SIDE := protocol jetson

check: venv  ## lint, format check, Python 3.10 check of the Jetson side, generated-file check
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/vermin --quiet --target=3.10- --no-tips --violations --eval-annotations $(JETSON_SIDE)
	$(BIN)/pete-protocol check
	$(BIN)/python -m bench.report --check

lint: check

format: venv  ## apply ruff's formatting and fixable lints
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

test: venv build browser-deps check firmware-check wheel-check  ## everything: lint, C++ build, firmware check, wheel check, all tests
	$(BIN)/pytest

wheel-check: venv  ## build the wheel, install it with .[jetson] in a fresh venv, run detect and run elsewhere
	PYTHON=$(PYTHON) BUILD_PYTHON=$(BIN)/python bash .ci/wheel-check

demo: venv build  ## a whole 2v2 VEX AI match, both red robots on the full stack (Brain core + wire + daemon), linked by VEXlink
	$(BIN)/python -m protocol.demo --tool $(BUILD)/bin/pete_codec_tool
	$(BIN)/pete-sim match --stack full --world tipping_point_2v2 --opponent alliance --partner stack --seed 0 \
	  --brain-host $(BUILD)/bin/brain_host --out runs/demo

bench: venv build browser-deps  ## run every benchmark; results land in bench/results/
	@for b in bench/*.py; do \
	  name=$$(basename $$b .py); [ "$$name" = "__init__" ] && continue; \
	  [ "$$name" = "common" ] && continue; [ "$$name" = "report" ] && continue; \
	  echo "== bench.$$name"; $(BIN)/python -m bench.$$name || exit 1; done

results: venv  ## regenerate RESULTS.md and README's headline table from bench/results/*.json
	$(BIN)/python -m bench.report

clean:  ## remove build outputs (keeps .venv)
	rm -rf build .pytest_cache .ruff_cache
