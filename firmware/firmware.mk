# firmware/: the portable core (three builds: float, Q16.16, sanitizers) and octo-fw
# (float, and octo-fw-fixed on the Q16.16 core).
#
# core/  pure C11, no heap, no globals, no I/O; compiled with the strict FW_WARN set.
# app/   the autopilot (90 Hz step, modes, parameters, telemetry, commands).
# hal/   hal.h and hal/host/ (UDP, X-Plane client, MAVLink, parameter file, LCM log).
# lcm/   LCM message types of the project (generated into build/gen by lcm-gen).

CORE_SRC   := $(sort $(wildcard firmware/core/*.c))
CORE_INC   := -Ifirmware/core

CORE_OBJ        := $(CORE_SRC:firmware/core/%.c=$(B)/core/%.o)
CORE_FIXED_OBJ  := $(CORE_SRC:firmware/core/%.c=$(B)/core-fixed/%.o)
CORE_ASAN_OBJ   := $(CORE_SRC:firmware/core/%.c=$(B)/core-asan/%.o)

$(B)/core/%.o: firmware/core/%.c $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) $(CORE_INC) -c $< -o $@
$(B)/core-fixed/%.o: firmware/core/%.c $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -DOCTO_FIXED=1 $(CORE_INC) -c $< -o $@
$(B)/core-asan/%.o: firmware/core/%.c $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) $(SAN) $(CORE_INC) -c $< -o $@

$(B)/libcore.a: $(CORE_OBJ)
	@rm -f $@; $(AR) rcs $@ $^
$(B)/libcore-fixed.a: $(CORE_FIXED_OBJ)
	@rm -f $@; $(AR) rcs $@ $^
$(B)/libcore-asan.a: $(CORE_ASAN_OBJ)
	@rm -f $@; $(AR) rcs $@ $^

# ---- the component metadata mav_ftp.c serves, as constant data (build/gen/param_metadata.c):
#   firmware/tools/param_meta.c, linked with the parameter table on the host, prints the
#   parameter metadata JSON; gen_param_metadata.py compresses it (xz) and adds the general
#   metadata file. Every build that links mav_ftp.c compiles PARAM_META_C with its own flags.
PARAM_META_TOOL := $(B)/tools/param-meta
PARAM_META_C    := $(GEN)/param_metadata.c

$(PARAM_META_TOOL): firmware/tools/param_meta.c firmware/app/params.c $(wildcard firmware/app/*.h firmware/core/*.h) \
                    $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(filter-out -MMD -MP,$(CFLAGS_FW)) -D_POSIX_C_SOURCE=200809L -Ifirmware/app -Ifirmware/core \
	  -o $@ firmware/tools/param_meta.c firmware/app/params.c -lm
$(PARAM_META_C): $(PARAM_META_TOOL) firmware/tools/gen_param_metadata.py | $(VENV_STAMP)
	$(VPY) firmware/tools/gen_param_metadata.py $(PARAM_META_TOOL) $@

# ---- octo-fw: app + host HAL + core + generated MAVLink/LCM code and metadata
FW_SRC    := $(sort $(wildcard firmware/app/*.c firmware/hal/*.c firmware/hal/host/*.c))
FW_OBJ    := $(FW_SRC:firmware/%.c=$(B)/fw/%.o) $(B)/fw/app/param_metadata.o
FW_INC    := -Ifirmware -Ifirmware/core -Ifirmware/app -Ifirmware/hal \
             -isystem $(GEN)/mavlink -isystem $(GEN)/mavlink/common -isystem $(GEN)/lcm -isystem $(LCM_INC)

$(B)/fw/%.o: firmware/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@
$(B)/fw/app/param_metadata.o: $(PARAM_META_C) $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@

# lcm-gen's C output is third-party style code: compiled without -Wconversion,
# all at once whenever the types change.
$(B)/liblcmtypes.a: $(LCM_STAMP)
	@rm -rf $(B)/lcmtypes && mkdir -p $(B)/lcmtypes
	@for f in $(GEN)/lcm/*.c; do [ -e "$$f" ] || continue; \
	  $(CC) -std=c11 $(OPT) -Wall -Werror -isystem $(GEN)/lcm -isystem $(LCM_INC) \
	    -c "$$f" -o $(B)/lcmtypes/$$(basename "$${f%.c}").o || exit 1; done
	@rm -f $@; $(AR) rcs $@ $$(ls $(B)/lcmtypes/*.o 2>/dev/null)

$(B)/octo-fw: $(FW_OBJ) $(B)/libcore.a $(B)/liblcmtypes.a
	$(CC) $(OPT) -o $@ $(FW_OBJ) $(B)/libcore.a $(B)/liblcmtypes.a $(LCM_LDFLAGS) -lm

ALL_TARGETS += $(B)/octo-fw

# ---- octo-fw-fixed: the same program on the Q16.16 core (OCTO_FIXED: the app's scalars and
#   struct app change with it, so every object is compiled again, into build/fw-fixed/).
FW_FIXED_OBJ := $(FW_OBJ:$(B)/fw/%=$(B)/fw-fixed/%)

$(B)/fw-fixed/%.o: firmware/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -DOCTO_FIXED=1 -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@
$(B)/fw-fixed/app/param_metadata.o: $(PARAM_META_C) $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -DOCTO_FIXED=1 -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@

$(B)/octo-fw-fixed: $(FW_FIXED_OBJ) $(B)/libcore-fixed.a $(B)/liblcmtypes.a
	$(CC) $(OPT) -o $@ $(FW_FIXED_OBJ) $(B)/libcore-fixed.a $(B)/liblcmtypes.a $(LCM_LDFLAGS) -lm

ALL_TARGETS += $(B)/octo-fw-fixed

# ---- octo-fw-asan: the same program under AddressSanitizer and UBSan (not part of `all`):
#   make build/octo-fw-asan, then e.g. copy it as octo-fw into a directory with octo-sim
#   and run the pytest suite with OCTO_BUILD pointing there.
FW_ASAN_OBJ := $(FW_OBJ:$(B)/fw/%=$(B)/fw-asan/%)

$(B)/fw-asan/%.o: firmware/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) $(SAN) -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@
$(B)/fw-asan/app/param_metadata.o: $(PARAM_META_C) $(B)/config.mk
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) $(SAN) -D_POSIX_C_SOURCE=200809L $(FW_INC) -c $< -o $@

$(B)/octo-fw-asan: $(FW_ASAN_OBJ) $(B)/libcore-asan.a $(B)/liblcmtypes.a
	$(CC) $(OPT) $(SAN) -o $@ $(FW_ASAN_OBJ) $(B)/libcore-asan.a $(B)/liblcmtypes.a $(LCM_LDFLAGS) -lm
