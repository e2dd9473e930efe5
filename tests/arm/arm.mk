# tests/arm/: the core and its C unit tests on emulated Cortex-M, and instruction counts.
#
#   make arm         cross-compile firmware/core/*.c for each target below with the host
#                    firmware flags (CFLAGS_FW: FW_WARN, -fno-math-errno), link the unit tests
#                    (tests/core, UNIT_CFLAGS) with the start-up code here into two images per
#                    target (ref-tests: ARM_REF_SRC; unit-tests: the rest), run them under QEMU
#                    with semihosting (the images in parallel), print the core's sizes per
#                    target and check the instruction-counting plugin on its demo.
#                    Then the app's C suite (tests/app: firmware/app on the stub HAL) on the
#                    targets where it fits (ARM_APP_VARIANTS, below).
#                    Fails if any test fails on any target.
#                    ARM_FILTER="mixer rls" runs only tests whose names contain a word.
#   make arm-nofloat the fixed build's 90 Hz objects (ARM_FIXED_90HZ) call no soft-float or
#                    float libm routine: `arm-none-eabi-nm -u` of each m0-fixed object
#                    (part of `make arm`). Work that runs only when parameters change
#                    lives in *_setup.c and is not listed.
#   make arm-size    .text/.data/.bss per core module and target
#   make arm-stack   stack high-water mark of each test alone on M0
#   make arm-count   build the counting plugin and print the demo's counts (4x8 float
#                    matrix-vector product: about 190 instructions on M4F, 5,700 on M0)
#
# Targets (ARM_VARIANTS):
#   m4f        Cortex-M4F, hard float (fpv4-sp-d16), float build    QEMU mps2-an386
#   m0         Cortex-M0, soft float, float build                   QEMU microbit
#   m0-fixed   Cortex-M0, Q16.16 build (OCTO_FIXED=1)               QEMU microbit
# Optimisation of the core per target (ARM_CORE_OPT_<v>, after $(OPT)): -Os on every target,
# as flash-bound flight controllers are built (the core's budget is 32 KB of flash). Measured
# on m4f with `make bench` items 2 and 3 against $(OPT) (-O2), 2026-11-24: flash 39,927 ->
# 34,937 B before the mixer's reduction; the 90 Hz step 3-5 % more instructions (median HOLD
# 4,172 -> 4,397, experiment 1 5,714 -> 5,897). `make ARM_CORE_OPT_m4f= ...` builds -O2.
# Set-up objects (*_setup.o: work that runs only when parameters change, never in the 90 Hz
# step) and motor_id_solve.o (the rotor-model estimator's work between frames, a few times
# per experiment) are built ARM_SETUP_OPT (-Os) on every target, as firmware builds its cold code:
# on m4f mixer_setup.o 5,244 -> 4,728 B and rls_setup.o 1,624 -> 1,206 B (2026-11-24), with
# the same results (the unit tests on every target, and the step's outputs, unchanged).
# On M0 the test code (not the core) is built with -Os too, to leave room in microbit's
# 256 KB of flash.
#
# The app's suite (ARM_APP_VARIANTS): firmware/app/*.c and firmware/hal/hal.c built like
# the core for the target (CFLAGS_FW, ARM_CORE_OPT_<v>), the tests and the stub HAL like
# the core's tests, linked with the target's core library. Only m4f: its test rig holds a
# struct app (9 KB) and the stub HAL's 8 KB parameter "file", more than microbit's 16 KB
# of RAM, so the M0 targets run the core's tests only. tests/app/test_mav.c stays on the
# host (ARM_APP_HOST_ONLY): its two ground-station rigs keep 512 decoded messages each,
# 300 KB, beyond the 256 KB of RAM the m4f images use.
#
# Memory (sections.ld): the stack sits at the bottom of RAM (64 KB on m4f, 8 KB of
# microbit's 16 KB on M0: __stack_size in m4f.ld, m0.ld), then .data and
# .bss, then the heap (newlib's stdio) up to the end of RAM. An overflow runs off the
# start of RAM and faults. Each image ends with its high-water marks:
# "octo-arm: stack N of M bytes, heap N of M bytes".
#
# Image exit status (QEMU's, through semihosting SYS_EXIT_EXTENDED): the number of
# failed tests; 124 timeout (ARM_TIMEOUT s); 125 stack exhausted; 126 fault.
#
# Sizes: "core objects" is all of libcore.a (text includes .rodata); "linked" is what
# an image grows by when it keeps every global core function, with what they pull
# from libgcc and libm (soft float, sinf...); the core has no globals, so its RAM is
# the caller-owned structs, whose sizeof is printed per target.
#
# Files: startup.c (vector table, reset, faults), semihost.c/.h (newlib system calls,
# exit), sections.ld + m4f.ld/m0.ld (memory), bench_mark.c/.h (markers),
# insn_count.c (QEMU plugin), insn-count.sh (runs it), bench_demo.c (its reference),
# size_main.c (the empty program behind the "linked" sizes).
#
# Instruction counts for `make bench`: put bench_mark_begin()/bench_mark_end() from
# tests/arm/bench_mark.h around the one call to measure (several pairs are fine: one
# count each), build an image with
#     $(eval $(call arm_program,m4f,$(B)/bench/step-m4f.elf,bench/step.c,EXTRA_CFLAGS))
# (in a fragment included after this one; compiled with CFLAGS_FW for the target,
# linked with the start-up code, the markers and the target's core library), depend
# on $(ARM_COUNT_PLUGIN), then run
#     tests/arm/insn-count.sh mps2-an386 $(B)/bench/step-m4f.elf
# which prints the image's output, then "octo-count: region N: M instructions" for each
# begin/end pair (exact guest instructions; one of them is the `bl bench_mark_end`).
# Note: -std=c11 implies -ffp-contract=off, so GCC emits no fused multiply-add; the demo
# shows the cost on M4F (226 instructions, 194 with -ffp-contract=fast).
#
# The toolchain is Debian's: if it is missing, root installs it with apt-get; anyone
# else is told the command.

ARM_PKGS    := gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm
ARM_B       := $(B)/arm
ARM_CC      := arm-none-eabi-gcc
ARM_AR      := arm-none-eabi-ar
ARM_SIZE    := arm-none-eabi-size
ARM_NM      := arm-none-eabi-nm
ARM_COMMA   := ,
ARM_SPACE   := $(ARM_COMMA:,=) $(ARM_COMMA:,=)
ARM_QEMU    := qemu-system-arm
# Per image: a hang ends here. The M0 images take about 2 minutes on an idle core (their
# fixed-vs-float64 and long-run tests); several QEMU images beside other work take longer.
ARM_TIMEOUT ?= 900
ARM_FILTER  ?=

ARM_VARIANTS      := m4f m0 m0-fixed
ARM_APP_VARIANTS  := m4f
ARM_ARCH_m4f      := -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
ARM_ARCH_m0       := -mcpu=cortex-m0 -mthumb -mfloat-abi=soft
ARM_ARCH_m0-fixed := $(ARM_ARCH_m0)
ARM_DEFS_m0-fixed := -DOCTO_FIXED=1
# The test code (not the core) is built with -Os on M0: microbit has 256 KB of flash.
ARM_UNIT_OPT_m0       := -Os
ARM_UNIT_OPT_m0-fixed := -Os
# The core's optimisation per target (after $(OPT), so it wins): ARM_CORE_OPT_<v>.
ARM_CORE_OPT_m4f      ?= -Os
ARM_CORE_OPT_m0       ?= -Os
ARM_CORE_OPT_m0-fixed ?= -Os
# The set-up objects' optimisation on every target (after ARM_CORE_OPT_<v>, so it wins).
ARM_SETUP_OPT ?= -Os
ARM_LD_m4f        := tests/arm/m4f.ld
ARM_LD_m0         := tests/arm/m0.ld
ARM_LD_m0-fixed   := tests/arm/m0.ld
# ARM_M0_MACHINE="lm3s6965evb -cpu cortex-m0" runs the M0 images on the same QEMU
# Cortex-M0 CPU model on another board (256 KB flash, 64 KB RAM; the images still use
# only microbit's 16 KB), which ignores accesses to unmapped addresses that microbit
# faults on.
ARM_M0_MACHINE ?= microbit
ARM_MACHINE_m4f      := mps2-an386
ARM_MACHINE_m0       := $(ARM_M0_MACHINE)
ARM_MACHINE_m0-fixed := $(ARM_M0_MACHINE)

ARM_SECTIONS := -ffunction-sections -fdata-sections
ARM_LDFLAGS  := -nostartfiles --specs=nano.specs --specs=nosys.specs -u _printf_float \
                -Wl,--gc-sections -Ltests/arm
ARM_QEMU_FLAGS := -nographic -monitor none -serial none
ARM_RT_SRC   := tests/arm/startup.c tests/arm/semihost.c
ARM_COUNT_PLUGIN := $(ARM_B)/insn-count.so

# ---------------------------------------------------------------- toolchain
.PHONY: arm-toolchain
arm-toolchain:
	@if command -v $(ARM_CC) >/dev/null && command -v $(ARM_QEMU) >/dev/null && \
	    [ -e "$$($(ARM_CC) -print-file-name=libc_nano.a)" ]; then exit 0; fi; \
	if [ "$$(id -u)" != 0 ]; then \
	  echo "make arm: the ARM cross toolchain or QEMU is missing. Install it (as root) with:"; \
	  echo "  apt-get install -y --no-install-recommends $(ARM_PKGS)"; exit 1; fi; \
	echo "== installing $(ARM_PKGS)"; mkdir -p $(ARM_B); \
	if apt-cache policy $(ARM_PKGS) 2>/dev/null | grep -q 'Candidate: (none)' || \
	   [ "$$(apt-cache policy $(ARM_PKGS) 2>/dev/null | grep -c 'Candidate:')" != 3 ]; then \
	  apt-get update -q >$(ARM_B)/apt.log 2>&1 || { cat $(ARM_B)/apt.log; exit 1; }; fi; \
	DEBIAN_FRONTEND=noninteractive apt-get install -y -q -o DPkg::Lock::Timeout=300 \
	    --no-install-recommends $(ARM_PKGS) \
	  >>$(ARM_B)/apt.log 2>&1 || { cat $(ARM_B)/apt.log; exit 1; }

# ---------------------------------------------------------------- per target
# $(1) = variant. Objects: build/arm/<v>/{core,unit,rt}/; library build/arm/<v>/libcore.a.
define arm_variant
ARM_CORE_OBJ_$(1) := $$(CORE_SRC:firmware/core/%.c=$(ARM_B)/$(1)/core/%.o)
ARM_RT_OBJ_$(1)   := $$(ARM_RT_SRC:tests/arm/%.c=$(ARM_B)/$(1)/rt/%.o)
ARM_MARK_OBJ_$(1) := $(ARM_B)/$(1)/rt/bench_mark.o
ARM_CFLAGS_$(1)   := $$(ARM_ARCH_$(1)) $$(ARM_DEFS_$(1)) $$(ARM_SECTIONS)

$(ARM_B)/$(1)/core/%.o: firmware/core/%.c | arm-toolchain
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(CFLAGS_FW) $$(ARM_CORE_OPT_$(1)) $$(ARM_OBJ_OPT) $$(CORE_INC) -c $$< -o $$@
$(ARM_B)/$(1)/core/%_setup.o: ARM_OBJ_OPT = $$(ARM_SETUP_OPT)
$(ARM_B)/$(1)/core/motor_id_solve.o: ARM_OBJ_OPT = $$(ARM_SETUP_OPT)
$(ARM_B)/$(1)/unit/%.o: tests/core/%.c | arm-toolchain
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(UNIT_CFLAGS) $$(ARM_UNIT_OPT_$(1)) -c $$< -o $$@
$(ARM_B)/$(1)/rt/%.o: tests/arm/%.c | arm-toolchain
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(CFLAGS_FW) -Itests/arm -c $$< -o $$@

$(ARM_B)/$(1)/libcore.a: $$(ARM_CORE_OBJ_$(1)) | arm-toolchain
	@rm -f $$@; $$(ARM_AR) rcs $$@ $$(ARM_CORE_OBJ_$(1))

# sizeof of every struct the core's headers define, as symbol sizes (nm -S)
$(ARM_B)/$(1)/structs.o: $(ARM_B)/structs.c | arm-toolchain
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(filter-out -MMD -MP,$$(CFLAGS_FW)) $$(CORE_INC) -c $$< -o $$@

# the empty program alone and with every global core function kept (see size_main.c)
$(ARM_B)/$(1)/size-base.elf: $(ARM_B)/$(1)/rt/size_main.o $$(ARM_RT_OBJ_$(1)) $$(ARM_LD_$(1)) tests/arm/sections.ld
	$$(ARM_CC) $$(ARM_ARCH_$(1)) $$(ARM_LDFLAGS) -T$$(ARM_LD_$(1)) -o $$@ $$(filter %.o,$$^) -lm
$(ARM_B)/$(1)/size-core.elf: $(ARM_B)/$(1)/size-base.elf $(ARM_B)/$(1)/libcore.a
	$$(ARM_CC) $$(ARM_ARCH_$(1)) $$(ARM_LDFLAGS) -T$$(ARM_LD_$(1)) -o $$@ \
	  $$(addprefix -Wl$$(ARM_COMMA)--undefined=,$$(shell $$(ARM_NM) -g --defined-only $(ARM_B)/$(1)/libcore.a | awk '$$$$2 == "T" { print $$$$3 }')) \
	  $(ARM_B)/$(1)/rt/size_main.o $$(ARM_RT_OBJ_$(1)) $(ARM_B)/$(1)/libcore.a -lm
endef
$(foreach v,$(ARM_VARIANTS),$(eval $(call arm_variant,$(v))))

# $(call arm_test_elf,VARIANT,IMAGE,OBJECTS): build/arm/<v>/<image>.elf, a test image of
# OBJECTS with the start-up code and the variant's core library.
define arm_test_elf
$(ARM_B)/$(1)/$(2).elf: $$(ARM_RT_OBJ_$(1)) $(3) $(ARM_B)/$(1)/libcore.a $$(ARM_LD_$(1)) tests/arm/sections.ld
	$$(ARM_CC) $$(ARM_ARCH_$(1)) $$(ARM_LDFLAGS) -T$$(ARM_LD_$(1)) -Wl,-Map,$$@.map -o $$@ \
	  $$(ARM_RT_OBJ_$(1)) $(3) $(ARM_B)/$(1)/libcore.a -lm
endef
# The core's tests in two images per target, each with its own registry: microbit's 256 KB
# of flash no longer hold them all in the M0 builds. ref-tests: the numerics against
# references (float64 twins of the estimators, exact integer definitions); unit-tests: the rest.
ARM_REF_SRC  := $(filter $(addprefix tests/core/,test_ident_ref.c test_motor_id_ref.c test_motor_id_ref64.c \
                  test_rls_ref.c test_scalar.c test_qfmt.c),$(UNIT_SRC))
ARM_UNIT_IMG_unit-tests := $(filter-out $(ARM_REF_SRC),$(UNIT_SRC))
ARM_UNIT_IMG_ref-tests  := $(ARM_REF_SRC)
ARM_UNIT_IMAGES := unit-tests ref-tests
$(ARM_B)/lists/%/unit_list.h: $(UNIT_SRC) tests/arm/arm.mk
	@mkdir -p $(@D)
	@{ echo "/* generated: the core tests of the Cortex-M image $*: do not edit */"; \
	   for f in $(ARM_UNIT_IMG_$*); do sed -n 's/^UNIT_TEST(\([A-Za-z0-9_]*\)).*/UNIT_ENTRY(\1)/p' $$f; done; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@
# $(call arm_unit_image,VARIANT,IMAGE): its runner (unit.c on the image's registry) and image
define arm_unit_image
$(ARM_B)/$(1)/unit/runner-$(2).o: tests/core/unit.c $(ARM_B)/lists/$(2)/unit_list.h | arm-toolchain
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) -I$(ARM_B)/lists/$(2) $$(UNIT_CFLAGS) $$(ARM_UNIT_OPT_$(1)) -c $$< -o $$@
$(call arm_test_elf,$(1),$(2),$(ARM_B)/$(1)/unit/runner-$(2).o $(ARM_UNIT_IMG_$(2):tests/core/%.c=$(ARM_B)/$(1)/unit/%.o))
endef
$(foreach v,$(ARM_VARIANTS),$(foreach i,$(ARM_UNIT_IMAGES),$(eval $(call arm_unit_image,$(v),$(i)))))

# The app's suite: build/arm/<v>/app/{firmware,tests}/ hold its objects.
ARM_APP_FW_SRC := $(sort $(wildcard firmware/app/*.c)) firmware/hal/hal.c
ARM_APP_HOST_ONLY := tests/app/test_mav.c
ARM_APP_TEST_SRC := $(filter-out $(ARM_APP_HOST_ONLY),$(APP_TEST_SRC))
ARM_APP_TEST_ALL := tests/core/unit.c $(ARM_APP_TEST_SRC) tests/app/stub_hal.c
ARM_APP_LIST := $(ARM_B)/app_tests/unit_list.h
$(ARM_APP_LIST): $(ARM_APP_TEST_SRC) tests/arm/arm.mk
	@mkdir -p $(@D)
	@{ echo "/* generated from the app tests built for Cortex-M: do not edit */"; \
	   for f in $(ARM_APP_TEST_SRC); do sed -n 's/^UNIT_TEST(\([A-Za-z0-9_]*\)).*/UNIT_ENTRY(\1)/p' $$f; done; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@
ARM_APP_INC := -D_POSIX_C_SOURCE=200809L -Ifirmware -Ifirmware/core -Ifirmware/app -Ifirmware/hal \
               -isystem $(GEN)/mavlink -isystem $(GEN)/mavlink/common
define arm_app_variant
ARM_APP_OBJ_$(1) := $$(ARM_APP_FW_SRC:%.c=$(ARM_B)/$(1)/app/%.o) $$(ARM_APP_TEST_ALL:%.c=$(ARM_B)/$(1)/app/%.o) \
                    $(ARM_B)/$(1)/app/gen/param_metadata.o

$(ARM_B)/$(1)/app/firmware/%.o: firmware/%.c | arm-toolchain $(MAVLINK_STAMP)
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(CFLAGS_FW) $$(ARM_CORE_OPT_$(1)) $$(ARM_APP_INC) -c $$< -o $$@
$(ARM_B)/$(1)/app/gen/param_metadata.o: $(PARAM_META_C) | arm-toolchain
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(CFLAGS_FW) $$(ARM_CORE_OPT_$(1)) $$(ARM_APP_INC) -c $$< -o $$@
$(ARM_B)/$(1)/app/tests/%.o: tests/%.c | arm-toolchain $(MAVLINK_STAMP)
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) -I$(ARM_B)/app_tests $$(APP_TEST_CFLAGS) $$(ARM_UNIT_OPT_$(1)) -c $$< -o $$@
$(ARM_B)/$(1)/app/tests/core/unit.o: $(ARM_APP_LIST)
endef
$(foreach v,$(ARM_APP_VARIANTS),$(eval $(call arm_app_variant,$(v))))
$(foreach v,$(ARM_APP_VARIANTS),$(eval $(call arm_test_elf,$(v),app-tests,$(ARM_APP_OBJ_$(v)))))

# $(call arm_program,VARIANT,ELF,SOURCES[,EXTRA_CFLAGS]): a rule for an image of
# SOURCES (firmware flags, -Ifirmware/core -Itests/arm) with the start-up code, the
# bench markers and the variant's core library; for instruction counts.
define arm_program
$(2): $(3) $$(ARM_RT_OBJ_$(1)) $$(ARM_MARK_OBJ_$(1)) $(ARM_B)/$(1)/libcore.a $$(ARM_LD_$(1)) tests/arm/sections.ld \
      $$(wildcard firmware/core/*.h) tests/arm/bench_mark.h
	@mkdir -p $$(@D)
	$$(ARM_CC) $$(ARM_CFLAGS_$(1)) $$(filter-out -MMD -MP,$$(CFLAGS_FW)) $(4) $$(CORE_INC) -Itests/arm \
	  $$(ARM_LDFLAGS) -T$$(ARM_LD_$(1)) -Wl,-Map,$$@.map -o $$@ $(3) $$(ARM_RT_OBJ_$(1)) $$(ARM_MARK_OBJ_$(1)) \
	  $(ARM_B)/$(1)/libcore.a -lm
endef

# ---------------------------------------------------------------- instruction counting
$(ARM_COUNT_PLUGIN): tests/arm/insn_count.c
	@mkdir -p $(@D)
	$(CC) -shared -fPIC -O2 -Wall -Wextra -Werror -fvisibility=hidden -o $@ $<

# The demo: m4f as the firmware is built (-std=c11 implies -ffp-contract=off),
# m4f with fused multiply-add allowed, and m0.
$(eval $(call arm_program,m4f,$(ARM_B)/demo/matvec-m4f.elf,tests/arm/bench_demo.c))
$(eval $(call arm_program,m4f,$(ARM_B)/demo/matvec-m4f-fma.elf,tests/arm/bench_demo.c,-ffp-contract=fast))
$(eval $(call arm_program,m0,$(ARM_B)/demo/matvec-m0.elf,tests/arm/bench_demo.c))
# name:machine:lo:hi, the plausible range of the count (a check of the plugin, not a benchmark)
ARM_DEMO := m4f:mps2-an386:150:300 m4f-fma:mps2-an386:150:300 m0:microbit:4000:8000

ARM_DEMO_ELFS := $(foreach d,$(ARM_DEMO),$(ARM_B)/demo/matvec-$(firstword $(subst :, ,$(d))).elf)
arm_count_demo = echo "== instruction counts, 4x8 float matrix-vector product (reference: ~190 M4F, ~5,700 M0)"; \
  for d in $(ARM_DEMO); do IFS=: read -r n m lo hi <<< "$$d"; \
    out=$$(tests/arm/insn-count.sh $$m $(ARM_B)/demo/matvec-$$n.elf $(ARM_COUNT_PLUGIN)) || rc=1; \
    c=$$(echo "$$out" | sed -n 's/^octo-count: region 1: \([0-9]*\) instructions$$/\1/p'); \
    printf '   %-9s %-11s %s instructions\n' $$n $$m "$${c:-?}"; \
    if [ -z "$$c" ] || [ "$$c" -lt $$lo ] || [ "$$c" -gt $$hi ]; then echo "$$out"; rc=1; \
      failed="$$failed insn-count($$n: $${c:-no count}, expected $$lo..$$hi)"; fi; \
  done;

.PHONY: arm-count
arm-count: $(ARM_COUNT_PLUGIN) $(ARM_DEMO_ELFS)
	@rc=0; $(arm_count_demo) exit $$rc

# ---------------------------------------------------------------- sizes and tests
# The core keeps no globals: its RAM is the state its callers own. structs.c
# declares char octo_sizeof_NAME[sizeof(struct NAME)] for each struct in the headers.
$(ARM_B)/structs.c: $(wildcard firmware/core/*.h)
	@mkdir -p $(@D)
	@{ echo "/* generated by tests/arm/arm.mk from the headers of firmware/core */"; \
	   for h in $(notdir $^); do echo "#include \"$$h\""; done; \
	   sed -n 's/^struct \([a-z0-9_]*\) {.*/\1/p' $^ | sort -u | \
	     sed 's/.*/char octo_sizeof_&[sizeof(struct &)];/'; } > $@

ARM_ELFS := $(foreach v,$(ARM_VARIANTS),$(foreach i,$(ARM_UNIT_IMAGES),$(ARM_B)/$(v)/$(i).elf)) \
            $(foreach v,$(ARM_APP_VARIANTS),$(ARM_B)/$(v)/app-tests.elf)
# the images `make arm` runs: variant:image (build/arm/<variant>/<image>.elf)
ARM_RUNS := $(foreach v,$(ARM_VARIANTS),$(foreach i,$(ARM_UNIT_IMAGES),$(v):$(i))) $(foreach v,$(ARM_APP_VARIANTS),$(v):app-tests)
ARM_LIBS := $(foreach v,$(ARM_VARIANTS),$(ARM_B)/$(v)/libcore.a)

# text includes .rodata; flash = text + data, RAM = data + bss (no heap, no stack).
# "core objects": the core's own code and data (all of libcore.a); "linked": what an
# image grows by when it keeps every global core function, libgcc and libm included.
ARM_SIZE_ELFS := $(foreach v,$(ARM_VARIANTS),$(ARM_B)/$(v)/size-base.elf $(ARM_B)/$(v)/size-core.elf $(ARM_B)/$(v)/structs.o)
.PHONY: arm-size-total arm-size
arm-size-total: $(ARM_LIBS) $(ARM_SIZE_ELFS)
	@echo "== firmware/core size per target, bytes (bench targets: flash < 32 KB, RAM < 8 KB)"
	@echo "   (core objects: all of libcore.a; linked: + libgcc/libm, see size_main.c)"
	@printf '   %-9s %6s %6s %6s %7s %6s   %14s %6s\n' target .text .data .bss flash RAM "linked: flash" RAM
	@for v in $(ARM_VARIANTS); do \
	  lib=$$($(ARM_SIZE) -t $(ARM_B)/$$v/libcore.a 2>/dev/null | awk '$$NF == "(TOTALS)" { print $$1, $$2, $$3 }'); \
	  base=$$($(ARM_SIZE) $(ARM_B)/$$v/size-base.elf | awk 'NR == 2 { print $$1, $$2, $$3 }'); \
	  core=$$($(ARM_SIZE) $(ARM_B)/$$v/size-core.elf | awk 'NR == 2 { print $$1, $$2, $$3 }'); \
	  echo $$v $${lib:-0 0 0} $$base $$core | awk '{ printf "   %-9s %6d %6d %6d %7d %6d   %14d %6d\n", \
	    $$1, $$2, $$3, $$4, $$2 + $$3, $$3 + $$4, ($$8 + $$9) - ($$5 + $$6), ($$9 + $$10) - ($$6 + $$7) }'; \
	done
	@echo "== caller-owned core structs (the core's RAM), sizeof in bytes: $(ARM_VARIANTS)"
	@for v in $(ARM_VARIANTS); do $(ARM_NM) -S -t d $(ARM_B)/$$v/structs.o | \
	   awk -v v=$$v '$$4 ~ /^octo_sizeof_/ { sub(/^octo_sizeof_/, "", $$4); print $$4, v, $$2 + 0 }'; done | \
	 awk '{ n[$$1] = n[$$1] sprintf(" %6d", $$3) } END { for (k in n) printf "   %-22s%s\n", k, n[k] }' | sort | \
	 paste -d' ' - - | sed 's/^/ /'

arm-size: $(ARM_LIBS)
	@for v in $(ARM_VARIANTS); do echo "== $$v"; $(ARM_SIZE) -t $(ARM_B)/$$v/libcore.a; done

# Stack high-water mark of each test alone on M0 (one QEMU run per test name; a name
# also selects the tests whose names contain it), largest first.
.PHONY: arm-stack
arm-stack: $(ARM_UNIT_IMAGES:%=$(ARM_B)/m0/%.elf)
	@echo "== stack used per test on m0 ($(ARM_MACHINE_m0)), bytes of $$(($$($(ARM_NM) $< | \
	   awk '$$3 == "__stack_top" { t = $$1 } $$3 == "__stack_bottom" { b = $$1 } END { print "0x" t " - 0x" b }')))"
	@for i in $(ARM_UNIT_IMAGES); do \
	  for t in $$(sed -n 's/^UNIT_ENTRY(\(.*\))$$/\1/p' $(ARM_B)/lists/$$i/unit_list.h); do \
	    timeout $(ARM_TIMEOUT) $(ARM_QEMU) -M $(ARM_MACHINE_m0) $(ARM_QEMU_FLAGS) \
	      -semihosting-config enable=on,target=native,arg=$$i,arg=$$t -kernel $(ARM_B)/m0/$$i.elf </dev/null 2>&1 | \
	    sed -n "s/^octo-arm: stack \([0-9]*\) of.*/\1 $$t/p"; done; done | sort -rn | awk '{ printf "   %6d  %s\n", $$1, $$2 }'

# The images run in parallel (logs in build/arm/<v>/<image>.log), every one even when
# another fails; their output is then printed in order with a summary of failures.
# $(1) = variant, $(2) = image (unit-tests, ref-tests: the core's tests; app-tests: the app's).
arm_start = (timeout $(ARM_TIMEOUT) $(ARM_QEMU) -M $(ARM_MACHINE_$(1)) $(ARM_QEMU_FLAGS) \
    -semihosting-config enable=on,target=native,arg=$(2)$(subst $(ARM_SPACE),,$(foreach f,$(ARM_FILTER),$(ARM_COMMA)arg=$(f))) \
    -kernel $(ARM_B)/$(1)/$(2).elf </dev/null >$(ARM_B)/$(1)/$(2).log 2>&1; \
  echo $$? >$(ARM_B)/$(1)/$(2).status) &
arm_report = echo "== $(if $(filter app-tests,$(2)),app tests,core $(2)): $(1) on QEMU $(ARM_MACHINE_$(1))"; \
  cat $(ARM_B)/$(1)/$(2).log; \
  s=$$(cat $(ARM_B)/$(1)/$(2).status); if [ "$$s" != 0 ]; then rc=1; case $$s in \
    124) why="timed out after $(ARM_TIMEOUT) s";; 125) why="stack exhausted";; 126) why="fault";; \
    *) why="exit status $$s"; grep -q '^[0-9]* passed, ' $(ARM_B)/$(1)/$(2).log && why="$$s failed tests";; \
  esac; failed="$$failed $(1)/$(2) ($$why)"; fi;
arm_run_word = $(call $(1),$(word 1,$(subst :, ,$(2))),$(word 2,$(subst :, ,$(2))))

# The fixed build's objects on the 90 Hz path: no float arithmetic (soft float on M0)
ARM_FIXED_90HZ := alt_ctrl att_ctrl excite filt guidance hover_est ident imu_id kf_track mixer motor_id pos_ctrl quat rls scalar thrmap
# __aeabi_f*/d* (float and double arithmetic, compare, convert), *2f/*2d (int to float),
# libgcc's __*sf*/__*df* names, and libm's functions
ARM_FLOAT_SYMS := ^(__aeabi_[fd]|__aeabi_[a-z0-9]*2[fd]$$|__[a-z]+[sd]f[0-9]?$$|(sqrt|exp|log|pow|sin|cos|tan|asin|acos|atan|atan2|fmax|fmin|fabs|floor|ceil|round|ldexp|frexp|fmod|cbrt|hypot)f?$$)
.PHONY: arm-nofloat
arm-nofloat: $(ARM_FIXED_90HZ:%=$(ARM_B)/m0-fixed/core/%.o)
	@echo "== soft-float calls in the fixed build's 90 Hz objects (m0-fixed, arm-none-eabi-nm -u)"; \
	rc=0; for o in $^; do \
	  bad=$$($(ARM_NM) -u $$o | awk '{ print $$NF }' | grep -E '$(ARM_FLOAT_SYMS)' | tr '\n' ' '); \
	  if [ -n "$$bad" ]; then echo "   $$(basename $$o): calls $$bad"; rc=1; fi; \
	done; \
	if [ $$rc = 0 ]; then echo "   none in: $(ARM_FIXED_90HZ)"; \
	else echo "== make arm-nofloat: FAILED (float on the 90 Hz path of the fixed build)"; fi; exit $$rc

.PHONY: arm
arm: arm-nofloat arm-size-total $(ARM_ELFS) $(ARM_COUNT_PLUGIN) $(ARM_DEMO_ELFS)
	@rc=0; failed=; rm -f $(foreach r,$(ARM_RUNS),$(ARM_B)/$(subst :,/,$(r)).status); \
	$(foreach r,$(ARM_RUNS),$(call arm_run_word,arm_start,$(r))) wait; \
	$(foreach r,$(ARM_RUNS),$(call arm_run_word,arm_report,$(r))) $(arm_count_demo) \
	if [ $$rc = 0 ]; then echo "== make arm: all passed on $(ARM_VARIANTS) (app tests: $(ARM_APP_VARIANTS))"; \
	else echo "== make arm: FAILED:$$failed"; fi; exit $$rc
