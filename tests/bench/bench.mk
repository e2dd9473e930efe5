# tests/bench/: `make bench`, the project's performance figures.
#
#   make bench        builds the harnesses below, then runs tests/bench/bench.py: one table on
#                     stdout (each figure: median of repeated runs with min and max, beside its
#                     reference and target, with the command that produced it) and
#                     build/bench.json. Takes about twenty minutes on two cores, most of it item 9
#                     (5,000 identification flights: about 0.4 s of a core each).
#   make bench-tools  only the harnesses (the host ones are part of `make`;
#                     tests/py/test_bench_smoke.py runs them tiny)
#   BENCH_ARGS="--repeats 3 --only speed,step"  passed to bench.py (see bench.py --help)
#   BENCH_ARGS=--readme  also writes the table into docs/performance.md, between its markers
#
# Harnesses (build/bench/):
#   pingpong       bare UDP ping-pong over loopback between two processes with octo-sim's and
#                  octo-fw's datagram sizes per frame (the design's limit), and the tightest
#                  X-Plane client of octo-sim --lockstep (the simulator alone)
#   peakrss        a child's own peak RSS and CPU time (ru_maxrss read from Python includes
#                  Python's own size)
#   bench-physics  sim::Model (build/sim/*.o, the simulator's flags) stepped as fast as it goes
#   bench-step     octo-fw's 90 Hz step (firmware/app + core, stub HAL) under callgrind;
#                  step-<v>.elf: the same on Cortex-M under QEMU with tests/arm's counting
#                  plugin, v = m4f, m4f-fixed, m0 (soft float), m0-fixed (needs the ARM
#                  toolchain: `make arm` installs it as root)
#                  estim-<v>.elf: the identification's RLS updates and one rotor's
#                  ident_rotor_update alone (tests/bench/estim_step.c), per build
#   bench-alloc    allocation quality: priority allocator vs pseudo-inverse + clipping
#   bench-estim    Monte Carlo of the k_f estimators (lag-aware, paper's plain) vs the CRLB
#   bench-motor    Monte Carlo of the joint rotor-model estimator (motor_id.h) on random vehicles
#   bench-motor-fixed  the same, the core built fixed point (OCTO_FIXED=1)
# Sizes of the core on Cortex-M4F/M0 come from tests/arm's images (build/arm/<v>/).

BENCH_B      := $(B)/bench
BENCH_CFLAGS := $(filter-out -MMD -MP,$(CFLAGS_FW))
BENCH_APP_SRC := $(sort $(wildcard firmware/app/*.c firmware/hal/*.c)) $(PARAM_META_C) tests/app/stub_hal.c
BENCH_APP_INC := -D_POSIX_C_SOURCE=200809L -Ifirmware -Ifirmware/core -Ifirmware/app -Ifirmware/hal \
                 -Itests/app -Itests/arm -isystem $(GEN)/mavlink -isystem $(GEN)/mavlink/common
BENCH_FW_HDR := $(wildcard firmware/core/*.h firmware/app/*.h firmware/hal/hal.h tests/app/stub_hal.h)
BENCH_SIM_OBJ := $(addprefix $(B)/sim/,model.o actuator.o vehicle.o json.o)

$(BENCH_B)/pingpong: tests/bench/pingpong.c
	@mkdir -p $(@D)
	$(CC) -std=c11 -O2 -Wall -Wextra -Werror -o $@ $<

$(BENCH_B)/peakrss: tests/bench/peakrss.c
	@mkdir -p $(@D)
	$(CC) -std=c11 -O2 -Wall -Wextra -Werror -o $@ $<

$(BENCH_B)/bench-physics: tests/bench/physics.cpp $(BENCH_SIM_OBJ) $(wildcard sim/*.hpp)
	@mkdir -p $(@D)
	$(CXX) $(filter-out -MMD -MP,$(CXXFLAGS_SIM)) $(SIM_INC) -o $@ $< $(BENCH_SIM_OBJ) -lm

$(BENCH_B)/bench-alloc: tests/bench/alloc.c $(B)/libcore.a $(BENCH_FW_HDR)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) $(CORE_INC) -o $@ $< $(B)/libcore.a -lm

$(BENCH_B)/bench-estim: tests/bench/estim.c $(B)/libcore.a $(BENCH_FW_HDR)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) $(CORE_INC) -o $@ $< $(B)/libcore.a -lm

$(BENCH_B)/bench-motor: tests/bench/motor.c $(B)/libcore.a $(BENCH_FW_HDR)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) $(CORE_INC) -o $@ $< $(B)/libcore.a -lm

# the same Monte Carlo on the fixed build (OCTO_FIXED=1: integer per-frame part, float solve)
$(BENCH_B)/bench-motor-fixed: tests/bench/motor.c $(B)/libcore-fixed.a $(BENCH_FW_HDR)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) -DOCTO_FIXED=1 $(CORE_INC) -o $@ $< $(B)/libcore-fixed.a -lm

# the app step: the firmware's own app sources, compiled here with the firmware's flags, and
# the tests' stub HAL (tests/app/stub_hal.c)
BENCH_STEP_SRC := tests/bench/step.c $(BENCH_APP_SRC)
$(BENCH_B)/bench-step: $(BENCH_STEP_SRC) tests/arm/bench_mark.c $(B)/libcore.a \
                       $(BENCH_FW_HDR) | $(MAVLINK_STAMP)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) $(BENCH_APP_INC) -o $@ $(BENCH_STEP_SRC) tests/arm/bench_mark.c $(B)/libcore.a -lm
$(BENCH_B)/bench-step-quick: $(BENCH_STEP_SRC) tests/arm/bench_mark.c $(B)/libcore.a \
                       $(BENCH_FW_HDR) | $(MAVLINK_STAMP)
	@mkdir -p $(@D)
	$(CC) $(BENCH_CFLAGS) -DBENCH_QUICK $(BENCH_APP_INC) -o $@ $(BENCH_STEP_SRC) tests/arm/bench_mark.c \
	  $(B)/libcore.a -lm

BENCH_HOST := $(BENCH_B)/pingpong $(BENCH_B)/peakrss $(BENCH_B)/bench-physics $(BENCH_B)/bench-alloc \
              $(BENCH_B)/bench-estim $(BENCH_B)/bench-motor $(BENCH_B)/bench-motor-fixed $(BENCH_B)/bench-step \
              $(BENCH_B)/bench-step-quick
# built by `make` too (host only, a few seconds): tests/py/test_bench_smoke.py runs them
ALL_TARGETS += $(BENCH_HOST)

# ---- Cortex-M (only when the cross toolchain and QEMU are installed; else the table says so)
BENCH_ARM_OK := $(shell command -v $(ARM_CC) >/dev/null 2>&1 && command -v $(ARM_QEMU) >/dev/null 2>&1 && echo 1)
# The step per build: m4f (hard float), m4f-fixed, m0 (soft float), m0-fixed. The M0 images
# hold the whole app and the test harness, more than microbit's RAM: they are Cortex-M0
# code (ARMv6-M, soft float) linked with m4f.ld and counted on mps2-an386, whose Cortex-M4
# executes the same Thumb instructions; an instruction count depends on the code, not on
# the core that runs it.
BENCH_STEP_VARIANTS := m4f m4f-fixed m0 m0-fixed
ARM_ARCH_m4f-fixed     := $(ARM_ARCH_m4f)
ARM_DEFS_m4f-fixed     := -DOCTO_FIXED=1
ARM_CORE_OPT_m4f-fixed ?= $(ARM_CORE_OPT_m4f)
ARM_LD_m4f-fixed       := tests/arm/m4f.ld
ifeq ($(BENCH_ARM_OK),1)
$(eval $(call arm_variant,m4f-fixed))
$(foreach v,$(BENCH_STEP_VARIANTS),$(eval $(call arm_program,$(v),$(BENCH_B)/step-$(v).elf,$(BENCH_STEP_SRC),$(BENCH_APP_INC))))
$(BENCH_STEP_VARIANTS:%=$(BENCH_B)/step-%.elf): $(BENCH_FW_HDR) | $(MAVLINK_STAMP)
$(BENCH_B)/step-m0.elf: ARM_LD_m0 := tests/arm/m4f.ld
$(BENCH_B)/step-m0-fixed.elf: ARM_LD_m0-fixed := tests/arm/m4f.ld
$(foreach v,$(BENCH_STEP_VARIANTS),$(eval $(call arm_program,$(v),$(BENCH_B)/estim-$(v).elf,tests/bench/estim_step.c)))
$(BENCH_B)/estim-m0.elf: ARM_LD_m0 := tests/arm/m4f.ld
$(BENCH_B)/estim-m0-fixed.elf: ARM_LD_m0-fixed := tests/arm/m4f.ld
BENCH_ARM := $(BENCH_STEP_VARIANTS:%=$(BENCH_B)/step-%.elf) $(BENCH_STEP_VARIANTS:%=$(BENCH_B)/estim-%.elf) \
             $(ARM_COUNT_PLUGIN) $(ARM_LIBS) $(ARM_SIZE_ELFS)
endif

.PHONY: bench bench-tools
bench-tools: $(BENCH_HOST) $(BENCH_ARM)

bench: $(B)/octo-sim $(B)/octo-fw $(B)/octo-sil bench-tools
	$(VPY) tests/bench/bench.py $(if $(BENCH_ARM_OK),,--no-arm) $(BENCH_ARGS)
