# Octo-SIL: one Makefile for the whole project.
#
#   make          bootstrap .venv (pinned requirements.txt), generate MAVLink and LCM code,
#                 build build/octo-sim, build/octo-fw, the unit tests and octo-gcs
#   make test     C unit tests (float, Q16.16 and sanitizer builds), then pytest over tests/
#   make run      the main job: octo-gcs mission with the paper's vehicle, output in out/
#   make bench    performance figures (build/bench.json)
#   make campaign a Monte Carlo campaign of random vehicles and faults on a local Dask cluster
#                 (host_tools/campaigns/default.json; output in campaign/; goes on where it stopped)
#   make arm      cross-build the core and run its unit tests on emulated Cortex-M4F and M0,
#                 and the app's C suite on Cortex-M4F
#   make pil      processor-in-the-loop: make run's mission on an emulated Cortex-M4F board
#                 (QEMU mps2-an386), float and Q16.16 images (docs/pil.md)
#   make soak     a day in the air: 24 h of plant time in octo-sil (float, Q16.16, sanitizers)
#   make fuzz     libFuzzer on every parser (make fuzz-smoke: a few seconds each, for CI)
#   make clean    remove build/ (keeps .venv); make distclean removes .venv too
#
# Each part keeps its own rules in a fragment included below (firmware/firmware.mk,
# sim/sim.mk, host_tools/host_tools.mk, tests/*.mk, tests/*/*.mk).
# No root is needed, except by `make arm` / `make fuzz` when their toolchain is missing.

SHELL       := /bin/bash
.DEFAULT_GOAL := all
.DELETE_ON_ERROR:
.SUFFIXES:

PYTHON      ?= python3
VENV        := .venv
VPY         := $(VENV)/bin/python
B           := build
GEN         := $(B)/gen
VENV_STAMP  := $(VENV)/.requirements-stamp
# MAVProxy, a headless real ground station for the interoperability tests: only
# its MAVLink core is used, so it is installed without its ~1 GB of GUI and map
# dependencies (pymavlink and pyserial, pinned in requirements.txt, are enough).
MAVPROXY_PIN := mavproxy==1.8.75

# Warning flags (issue 2): firmware C11, simulator C++17; generated and
# third-party headers always through -isystem.
FW_WARN     := -Wall -Wextra -Werror -Wconversion -Wdouble-promotion -Wshadow -Wvla
OPT         ?= -O2 -g
CC          ?= cc
CXX         ?= c++
CFLAGS_FW   := -std=c11 $(OPT) $(FW_WARN) -fno-math-errno -MMD -MP
CXXFLAGS_SIM := -std=c++17 $(OPT) -Wall -Wextra -Werror -MMD -MP
SAN         := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all

# ---------------------------------------------------------------- bootstrap
$(VENV_STAMP): requirements.txt
	@echo "== creating $(VENV) with pinned requirements"
	@test -x $(VPY) || $(PYTHON) -m venv $(VENV) || \
	  { echo "error: '$(PYTHON) -m venv' failed: install python3-venv"; exit 1; }
	$(VENV)/bin/pip install --disable-pip-version-check -q -r requirements.txt
	$(VENV)/bin/pip install --disable-pip-version-check -q --no-deps $(MAVPROXY_PIN)
	@touch $@

# Paths inside the venv (site-packages differs by Python version): computed once
# into build/config.mk, which make includes and, if stale, rebuilds and restarts.
$(B)/config.mk: $(VENV_STAMP) Makefile
	@mkdir -p $(B)
	@sp=$$($(VPY) -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'); \
	{ echo "SP := $$sp"; \
	  echo "EIGEN_INC := $$sp/cmeel.prefix/include/eigen3"; \
	  echo "LCM_INC := $$sp/include"; \
	  echo "LCM_LIB := $$sp/lib"; \
	  echo "LCM_GEN := $$sp/bin/lcm-gen"; \
	  echo "MAVLINK_XML := $$sp/pymavlink/dialects/v20/common.xml"; } > $@.tmp && mv $@.tmp $@

NO_CONFIG_GOALS := clean distclean help
ifeq ($(filter $(NO_CONFIG_GOALS),$(MAKECMDGOALS)),)
-include $(B)/config.mk
endif

LCM_LDFLAGS := -L$(LCM_LIB) -Wl,-rpath,$(LCM_LIB) -llcm

# ---------------------------------------------------------------- generated code
# The project's dialect firmware/mavlink/octo.xml includes pymavlink's common.xml:
# both are put side by side, mavgen makes the C headers (build/gen/mavlink/octo/)
# and the Python module, which goes into the venv's pymavlink as dialect "octo"
# (octo-gcs, MAVProxy --dialect=octo and MAVLINK_DIALECT=octo load it from there).
MAVLINK_DIALECT_XML := firmware/mavlink/octo.xml
MAVLINK_STAMP := $(GEN)/mavlink/.stamp
$(MAVLINK_STAMP): $(MAVLINK_DIALECT_XML) $(VENV_STAMP) $(B)/config.mk
	@echo "== mavgen: MAVLink 2 C headers and pymavlink dialect from $(MAVLINK_DIALECT_XML)"
	@rm -rf $(GEN)/mavlink $(GEN)/mavlink-xml && mkdir -p $(GEN)/mavlink $(GEN)/mavlink-xml
	cp $(dir $(MAVLINK_XML))common.xml $(dir $(MAVLINK_XML))standard.xml $(dir $(MAVLINK_XML))minimal.xml \
	  $(MAVLINK_DIALECT_XML) $(GEN)/mavlink-xml/
	$(VPY) -m pymavlink.tools.mavgen --lang=C --wire-protocol=2.0 -o $(GEN)/mavlink $(GEN)/mavlink-xml/octo.xml >/dev/null
	$(VPY) -m pymavlink.tools.mavgen --lang=Python3 --wire-protocol=2.0 -o $(GEN)/mavlink-xml/octo.py \
	  $(GEN)/mavlink-xml/octo.xml >/dev/null
	cp $(GEN)/mavlink-xml/octo.py $(dir $(MAVLINK_XML))octo.py.tmp && mv $(dir $(MAVLINK_XML))octo.py.tmp $(dir $(MAVLINK_XML))octo.py
	cp $(MAVLINK_DIALECT_XML) $(dir $(MAVLINK_XML))octo.xml
	@touch $@

LCM_TYPES := $(sort $(wildcard firmware/lcm/*.lcm))
LCM_STAMP := $(GEN)/lcm/.stamp
$(LCM_STAMP): $(LCM_TYPES) $(VENV_STAMP) $(B)/config.mk
	@echo "== lcm-gen: C, C++ and Python types"
	@rm -rf $(GEN)/lcm $(GEN)/python && mkdir -p $(GEN)/lcm $(GEN)/python
	$(if $(LCM_TYPES),$(LCM_GEN) -c --c-cpath $(GEN)/lcm --c-hpath $(GEN)/lcm $(LCM_TYPES))
	$(if $(LCM_TYPES),$(LCM_GEN) -x --cpp-std c++11 --cpp-hpath $(GEN)/lcm $(LCM_TYPES))
	$(if $(LCM_TYPES),$(LCM_GEN) -p --ppath $(GEN)/python $(LCM_TYPES))
	@touch $@

# ---------------------------------------------------------------- parts
include firmware/firmware.mk
include sim/sim.mk
include firmware/hal/sil/sil.mk
include host_tools/host_tools.mk
include tests/tests.mk
include tests/core/probe.mk
include tests/arm/arm.mk
include tests/bench/bench.mk
include tests/fuzz/fuzz.mk
include tests/soak.mk
include tests/lint.mk
include firmware/hal/mps2/pil.mk

# ---------------------------------------------------------------- top-level goals
.PHONY: all test run campaign bench arm pil soak clean distclean help
all: $(ALL_TARGETS)

test: all
	@$(MAKE) --no-print-directory test-unit test-py

# MISSION_ARGS: more options for octo-gcs mission, e.g. MISSION_ARGS="--seed 7 --vehicle v.json"
MISSION_ARGS ?=
run: all
	$(VENV)/bin/octo-gcs mission --out out $(MISSION_ARGS)

# CAMPAIGN_SPEC: the spec; CAMPAIGN_ARGS: more options, e.g. CAMPAIGN_ARGS="--workers 1".
# --resume: a campaign/ started with the same spec goes on (a finished one only gets its report
# again); one started with another spec is refused (remove campaign/ first).
CAMPAIGN_SPEC ?= host_tools/campaigns/default.json
CAMPAIGN_ARGS ?=
campaign: all
	$(VENV)/bin/octo-gcs campaign $(CAMPAIGN_SPEC) --out campaign --resume $(CAMPAIGN_ARGS)

help:
	@sed -n '2,20p' Makefile | sed 's/^# \{0,1\}//'

clean:
	rm -rf $(B)

distclean: clean
	rm -rf $(VENV)

-include $(shell find $(B) -name '*.d' 2>/dev/null)
