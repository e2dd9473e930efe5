# tests/fuzz/: libFuzzer harnesses under AddressSanitizer + UBSan (clang).
#
#   make fuzz         each harness for FUZZ_SECONDS (60) with the committed seed
#                     corpus tests/fuzz/corpus/NAME; new inputs go to
#                     build/fuzz/corpus/NAME (never into git), crashes to
#                     build/fuzz/artifacts/; figures in build/fuzz/summary.txt
#   make fuzz-smoke   the same for FUZZ_SMOKE_SECONDS (10) each (CI)
#   make fuzz-build   the harnesses only
# Both first replay tests/fuzz/regress/NAME/* (inputs that once failed); for the MAVLink
# harnesses, reset_check.sh then shows that each seed and regression input leaves the same
# state whatever ran before it (the harness resets by copying a snapshot).
# fuzz-mavlink compiles many sources in one command: if a firmware header changes
# meanwhile (another editor), its translation units could disagree on struct
# layouts and report false errors, so the build is refused and must be rerun.
# clang and its runtime come from Debian's packages: installed with apt-get when
# missing and running as root, otherwise the command is printed and make fails.

FUZZ_CC       ?= clang
FUZZ_CXX      ?= clang++
FUZZ_SECONDS  ?= 60
FUZZ_SMOKE_SECONDS ?= 10
FUZZ_APT      := clang libclang-rt-14-dev
FZ            := $(B)/fuzz
FUZZ_SAN      := -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
                 -fno-omit-frame-pointer -fsanitize-coverage-ignorelist=tests/fuzz/coverage-ignore.txt
# params.c checks its table with _Static_assert on float comparisons, which GCC
# folds and clang refuses in C: the GCC builds keep those checks, the fuzz
# builds drop them.
# Every automatic variable starts from one fixed pattern, its padding included: a struct built
# on the stack and copied into the state (a configuration, a status line's unused arguments)
# then carries the same bytes whatever ran before, so the MAVLink harnesses' state hashes
# (reset_check.sh, OCTO_FUZZ_VERIFY) compare what the firmware did, not stack garbage
# (the MAVLink harnesses leave out FUZZ_MAV_NO_FILL, below).
FUZZ_SAN      += -ftrivial-auto-var-init=pattern
FUZZ_CFLAGS   := -std=c11 $(FUZZ_SAN) -Wall -Wextra -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE \
                 '-D_Static_assert(c,m)=struct fuzz_static_assert_dropped'
# NAME_fixed: the harness NAME built with the core in fixed point (OCTO_FIXED=1); it shares
# NAME's seed corpus, regression inputs and dictionary
FUZZ_NAMES    := xp_client sim_input mavlink mavlink_fixed experiment experiment_fixed params plant
FUZZ_BINS     := $(FUZZ_NAMES:%=$(FZ)/fuzz-%)
# libFuzzer flags of the MAVLink harnesses beside the common ones (-reload=0: one
# process writes the corpus, nothing to reread). The MAVLink harness's inputs cost from a few
# microseconds to milliseconds (flight, experiments): the power schedule weighs each input's
# energy by its speed.
FUZZ_FLAGS_mavlink := -entropic_scale_per_exec_time=1
# mutated inputs the MAVLink harnesses run with OCTO_FUZZ_VERIFY before fuzzing: every one
# resumed from a prefix checkpoint runs again whole, and the run fails unless both agree
FUZZ_VERIFY_RUNS ?= 20000
FUZZ_TC_STAMP := $(FZ)/.toolchain

# clang with a working libFuzzer + sanitizer runtime, or install it (root only).
$(FUZZ_TC_STAMP):
	@mkdir -p $(@D)
	@probe() { echo 'int LLVMFuzzerTestOneInput(const char *d, unsigned long n){(void)d;(void)n;return 0;}' \
	    | $(FUZZ_CC) -x c $(FUZZ_SAN) -o $(FZ)/.probe - >/dev/null 2>&1; }; \
	if ! probe; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "== installing $(FUZZ_APT) (Debian packages) for libFuzzer"; \
	    { DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(FUZZ_APT) || \
	      { apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(FUZZ_APT); }; } \
	      >$(FZ)/apt.log 2>&1 || { tail -20 $(FZ)/apt.log; exit 1; }; \
	  else \
	    echo "error: '$(FUZZ_CC)' cannot build libFuzzer harnesses. Install clang as root:"; \
	    echo "  apt-get install -y --no-install-recommends $(FUZZ_APT)"; exit 1; \
	  fi; \
	  probe || { echo "error: $(FUZZ_CC) still cannot link -fsanitize=fuzzer"; exit 1; }; \
	fi
	@rm -f $(FZ)/.probe; touch $@

FUZZ_FW_INC := -Ifirmware -Ifirmware/core -Ifirmware/app -Ifirmware/hal -Ifirmware/hal/host -Itests/app -Itests/fuzz \
               -isystem $(GEN)/mavlink -isystem $(GEN)/mavlink/common
FUZZ_APP_SRC := $(sort $(wildcard firmware/app/*.c firmware/core/*.c)) $(PARAM_META_C) firmware/hal/hal.c \
                tests/app/stub_hal.c

$(FZ)/fuzz-xp_client: tests/fuzz/fuzz_xp_client.c tests/fuzz/records.h firmware/hal/host/xp_client.c firmware/hal/host/xp_proto.c \
		firmware/hal/host/xp_client.h firmware/hal/host/xp_proto.h firmware/hal/hal.h | $(FUZZ_TC_STAMP)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -Drecvfrom=fuzz_recvfrom -Dsendto=fuzz_sendto $(FUZZ_FW_INC) \
	  -o $@ tests/fuzz/fuzz_xp_client.c firmware/hal/host/xp_client.c firmware/hal/host/xp_proto.c -lm

$(FZ)/fuzz-params: tests/fuzz/fuzz_params.c firmware/app/params.c $(wildcard firmware/app/*.h) | $(FUZZ_TC_STAMP)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(FUZZ_FW_INC) -o $@ tests/fuzz/fuzz_params.c firmware/app/params.c -lm

# $(call fuzz_app_build,HARNESS,EXTRA_CFLAGS[,APART]): a harness linked with the whole app and
# core (FUZZ_APP_SRC) into $@; each file F of APART is compiled apart (object $@.NAME.o) with
# the flags FUZZ_APART_FLAGS_NAME added (NAME: F's name without directory and .c)
fuzz_apart_name = $(basename $(notdir $(1)))
define fuzz_app_build
	@sum() { cat firmware/app/*.h firmware/core/*.h | cksum; }; before=$$(sum); \
	$(foreach f,$(3),echo "$(FUZZ_CC) $(FUZZ_CFLAGS) $(2) $(FUZZ_APART_FLAGS_$(call fuzz_apart_name,$f)) $(FUZZ_FW_INC) -c -o $@.$(call fuzz_apart_name,$f).o $f"; \
	  $(FUZZ_CC) $(FUZZ_CFLAGS) $(2) $(FUZZ_APART_FLAGS_$(call fuzz_apart_name,$f)) $(FUZZ_FW_INC) -c -o $@.$(call fuzz_apart_name,$f).o $f || exit 1; ) \
	objs="$(foreach f,$(3),$@.$(call fuzz_apart_name,$f).o)"; \
	echo "$(FUZZ_CC) $(FUZZ_CFLAGS) $(2) $(FUZZ_FW_INC) -o $@ $(1) $(filter-out $(3),$(FUZZ_APP_SRC)) $$objs -lm"; \
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(2) $(FUZZ_FW_INC) -o $@ $(1) $(filter-out $(3),$(FUZZ_APP_SRC)) $$objs -lm && \
	if [ "$$(sum)" != "$$before" ]; then rm -f $@; \
	  echo "error: firmware headers changed during the build (struct layouts may differ): run again"; exit 1; fi
endef
FUZZ_APP_DEP := tests/app/stub_hal.h $(FUZZ_APP_SRC) $(wildcard firmware/app/*.h firmware/core/*.h)

# fuzz-mavlink: coverage and comparison tracing only where the receive path decides
# (coverage-ignore-mavlink.txt); MAVLink's SHA-256 is fuzz_sha256.c's (fuzz_sha256.h, included
# first in every file), outside the sanitizers (sanitize-ignore.txt)
FUZZ_MAV_FLAGS := -fsanitize-coverage-ignorelist=tests/fuzz/coverage-ignore-mavlink.txt \
                  -fsanitize-ignorelist=tests/fuzz/sanitize-ignore.txt -include tests/fuzz/fuzz_sha256.h
FUZZ_MAV_SRC  := tests/fuzz/fuzz_mavlink.c tests/fuzz/fuzz_sha256.c tests/fuzz/fuzz_cov.c
# fuzz-mavlink's files with coverage but without comparison tracing (the same edges and
# counters, so the same features). The app's own logic (modes, commands, experiments, its
# status lines and event ring, its limits): its integer comparisons are on the app's state
# (modes, phases, ring indices, counters) and on UBSan's checks of the pointers it follows,
# not on bytes of the input; the messages' fields reach it as floats, which comparison
# tracing does not see. Traced, these took about a fifth of an execution. The MAVLink
# endpoint's parser and dispatch (mav.c): libFuzzer's mutations draw only on 4- and 8-byte
# comparisons (and switches over values above 255); 1- and 2-byte ones feed only its value
# profile, which `make fuzz` leaves off. mav.c's byte-wise parser compares bytes (its
# states, the magic, the flags), its commands are 2-byte ids, the fields its handlers read
# are floats or bytes, its 8-byte comparisons are its loops' indices and UBSan's checks of
# the pointers it advances, and a message id of a raw datagram counts only behind a CRC
# that only the harness's framing gets right. Traced, mav.c took a seventh to a fifth of an
# execution. mav_ftp.c stays traced: its 4-byte offsets and sizes are compared with the
# file's.
FUZZ_MAV_NO_CMP := firmware/app/app.c firmware/app/experiment.c firmware/app/outbox.c firmware/app/line.c \
                   firmware/app/id_result.c firmware/app/env_limits.c firmware/app/mav.c
$(foreach f,$(FUZZ_MAV_NO_CMP),$(eval FUZZ_APART_FLAGS_$(call fuzz_apart_name,$f) += -fno-sanitize-coverage=trace-cmp))
# fuzz-mavlink's files without the pattern fill of automatic variables: the MAVLink endpoint
# (mav.c, mav_telem.c, mav_ftp.c) fills every buffer and message it sends and keeps no struct
# from its stack in the state, so the fill changes no state hash (a byte left to the stack
# would show in reset_check.sh and OCTO_FUZZ_VERIFY as a difference); on its message buffers
# it cost a few percent of an execution.
FUZZ_MAV_NO_FILL := firmware/app/mav.c firmware/app/mav_telem.c firmware/app/mav_ftp.c
$(foreach f,$(FUZZ_MAV_NO_FILL),$(eval FUZZ_APART_FLAGS_$(call fuzz_apart_name,$f) += -ftrivial-auto-var-init=uninitialized))
# the files compiled apart, each once
FUZZ_MAV_APART := $(sort $(FUZZ_MAV_NO_CMP) $(FUZZ_MAV_NO_FILL))
FUZZ_MAV_DEP  := $(FUZZ_MAV_SRC) tests/fuzz/fuzz_sha256.h tests/fuzz/fuzz_cov.h $(FUZZ_APP_DEP) tests/fuzz/coverage-ignore.txt \
                 tests/fuzz/coverage-ignore-mavlink.txt tests/fuzz/sanitize-ignore.txt
$(FZ)/fuzz-mavlink: $(FUZZ_MAV_DEP) | $(FUZZ_TC_STAMP) $(MAVLINK_STAMP)
	$(call fuzz_app_build,$(FUZZ_MAV_SRC),$(FUZZ_MAV_FLAGS),$(FUZZ_MAV_APART))
$(FZ)/fuzz-mavlink_fixed: $(FUZZ_MAV_DEP) | $(FUZZ_TC_STAMP) $(MAVLINK_STAMP)
	$(call fuzz_app_build,$(FUZZ_MAV_SRC),-DOCTO_FIXED=1 $(FUZZ_MAV_FLAGS),$(FUZZ_MAV_APART))
$(FZ)/fuzz-experiment: tests/fuzz/fuzz_experiment.c $(FUZZ_APP_DEP) | $(FUZZ_TC_STAMP) $(MAVLINK_STAMP)
	$(call fuzz_app_build,tests/fuzz/fuzz_experiment.c,)
$(FZ)/fuzz-experiment_fixed: tests/fuzz/fuzz_experiment.c $(FUZZ_APP_DEP) | $(FUZZ_TC_STAMP) $(MAVLINK_STAMP)
	$(call fuzz_app_build,tests/fuzz/fuzz_experiment.c,-DOCTO_FIXED=1)

FUZZ_SIM_SRC := sim/xplane_input.cpp sim/xplane_proto.cpp sim/counters.cpp
$(FZ)/fuzz-sim_input: tests/fuzz/fuzz_sim_input.cpp tests/fuzz/records.h $(FUZZ_SIM_SRC) $(wildcard sim/*.hpp) | $(FUZZ_TC_STAMP)
	$(FUZZ_CXX) -std=c++17 $(FUZZ_SAN) -Wall -Wextra -Isim -o $@ tests/fuzz/fuzz_sim_input.cpp $(FUZZ_SIM_SRC)

# the plant as octo-sil links it (sim/plant.h): everything of sim/ but main() and the server
FUZZ_PLANT_SRC := $(filter-out sim/main.cpp sim/server.cpp,$(sort $(wildcard sim/*.cpp)))
$(FZ)/fuzz-plant: tests/fuzz/fuzz_plant.cpp tests/fuzz/records.h $(FUZZ_PLANT_SRC) firmware/hal/host/xp_proto.c $(wildcard sim/*.hpp sim/*.h) \
		| $(FUZZ_TC_STAMP) $(LCM_STAMP)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -Ifirmware/hal/host -c firmware/hal/host/xp_proto.c -o $(FZ)/plant_xp_proto.o
	$(FUZZ_CXX) -std=c++17 $(FUZZ_SAN) -Wall -Wextra -Isim -Ifirmware/hal/host -isystem $(EIGEN_INC) \
	  -isystem $(GEN)/lcm -isystem $(LCM_INC) -o $@ tests/fuzz/fuzz_plant.cpp $(FUZZ_PLANT_SRC) \
	  $(FZ)/plant_xp_proto.o $(LCM_LDFLAGS) -lm

# $(call fuzz_run,SECONDS): regressions, then every harness for SECONDS; a
# summary line per harness (executions, executions per second) in summary.txt.
define fuzz_run
	@mkdir -p $(FZ)/artifacts; rm -f $(FZ)/summary.txt; rc=0; \
	for h in $(FUZZ_NAMES); do \
	  bin=$(FZ)/fuzz-$$h; src=$${h%_fixed}; reg=tests/fuzz/regress/$$src; \
	  if [ -d $$reg ] && [ -n "$$(ls -A $$reg)" ]; then \
	    echo "== fuzz-$$h: replaying $$(ls $$reg | wc -l) regression input(s)"; \
	    $$bin $$reg/* >$(FZ)/$$h.regress.log 2>&1 || { tail -30 $(FZ)/$$h.regress.log; rc=1; continue; }; \
	  fi; \
	  mkdir -p $(FZ)/corpus/$$h; \
	  flags=; case $$src in mavlink) flags="$(FUZZ_FLAGS_mavlink)";; esac; \
	  case $$h in mavlink*) echo "== fuzz-$$h: each seed and regression input from the same state"; \
	    sh tests/fuzz/reset_check.sh $$bin tests/fuzz/corpus/$$src $$reg || { rc=1; continue; }; \
	    echo "== fuzz-$$h: $(FUZZ_VERIFY_RUNS) mutated inputs, those resumed from a checkpoint as if run whole"; \
	    rm -rf $(FZ)/verify; mkdir -p $(FZ)/verify; \
	    OCTO_FUZZ_VERIFY=1 $$bin -runs=$(FUZZ_VERIFY_RUNS) -seed=1 -max_len=4096 -timeout=10 $$flags \
	      -artifact_prefix=$(FZ)/artifacts/$$h-verify- $(FZ)/verify $(FZ)/corpus/$$h tests/fuzz/corpus/$$src \
	      >$(FZ)/$$h.verify.log 2>&1 || { tail -30 $(FZ)/$$h.verify.log; rc=1; continue; }; \
	    rm -rf $(FZ)/verify;; esac; \
	  echo "== fuzz-$$h: $(1) s"; \
	  dict=; [ -f tests/fuzz/$$src.dict ] && dict=-dict=tests/fuzz/$$src.dict; \
	  $$bin -max_total_time=$(1) -print_final_stats=1 -max_len=4096 -timeout=10 -rss_limit_mb=2048 -reload=0 \
	    $$flags $$dict \
	    -artifact_prefix=$(FZ)/artifacts/$$h- $(FZ)/corpus/$$h tests/fuzz/corpus/$$src \
	    >$(FZ)/$$h.log 2>&1 || { tail -40 $(FZ)/$$h.log; echo "FAIL: fuzz-$$h (input in $(FZ)/artifacts/)"; rc=1; }; \
	  execs=$$(sed -n 's/^stat::number_of_executed_units: *//p' $(FZ)/$$h.log); \
	  eps=$$(sed -n 's/^stat::average_exec_per_sec: *//p' $(FZ)/$$h.log); \
	  cov=$$(grep -o 'cov: [0-9]*' $(FZ)/$$h.log | tail -1); \
	  printf '%-10s %4s s  %10s execs  %7s execs/s  %s  corpus %s\n' $$h $(1) "$$execs" "$$eps" "$$cov" \
	    "$$(ls $(FZ)/corpus/$$h | wc -l)" | tee -a $(FZ)/summary.txt; \
	done; exit $$rc
endef

.PHONY: fuzz fuzz-smoke fuzz-build
fuzz-build: $(FUZZ_BINS)
fuzz: $(FUZZ_BINS)
	$(call fuzz_run,$(FUZZ_SECONDS))
fuzz-smoke: $(FUZZ_BINS)
	$(call fuzz_run,$(FUZZ_SMOKE_SECONDS))
