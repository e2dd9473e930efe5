# tests/: C unit tests of the core (tests/core/test_*.c, one file per core module)
# through the project's runner, in three builds, then pytest over tests/.
#
# A test is `UNIT_TEST(name) { ... }` in tests/core/test_*.c; the registry
# build/gen/unit_list.h is generated from those lines, so adding a test needs no
# edit anywhere else. Test code is not firmware: it may use double and libc.

UNIT_SRC   := $(sort $(wildcard tests/core/test_*.c))
UNIT_LIST  := $(GEN)/unit_list.h
UNIT_CFLAGS := -std=c11 $(OPT) -Wall -Wextra -Werror -Itests/core -Ifirmware/core -I$(GEN) -MMD -MP
# Each host suite is one compiler call over many sources, whose dependency file would list
# only the last source's headers: the suites depend on every header they may include instead.
UNIT_HDR := $(wildcard firmware/core/*.h tests/core/*.h)
SUITE_CFLAGS = $(filter-out -MMD -MP,$(1))

$(UNIT_LIST): $(UNIT_SRC) tests/tests.mk
	@mkdir -p $(@D)
	@{ echo "/* generated from tests/core/test_*.c: do not edit */"; \
	   for f in $(UNIT_SRC); do sed -n 's/^UNIT_TEST(\([A-Za-z0-9_]*\)).*/UNIT_ENTRY(\1)/p' $$f; done; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@

UNIT_ALL_SRC := tests/core/unit.c $(UNIT_SRC) $(UNIT_HDR)

$(B)/unit-tests: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore.a
	$(CC) $(call SUITE_CFLAGS,$(UNIT_CFLAGS)) -o $@ $(filter %.c,$(UNIT_ALL_SRC)) $(B)/libcore.a -lm
$(B)/unit-tests-fixed: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore-fixed.a
	$(CC) $(call SUITE_CFLAGS,$(UNIT_CFLAGS)) -DOCTO_FIXED=1 -o $@ $(filter %.c,$(UNIT_ALL_SRC)) $(B)/libcore-fixed.a -lm
$(B)/unit-tests-asan: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore-asan.a
	$(CC) $(call SUITE_CFLAGS,$(UNIT_CFLAGS)) $(SAN) -o $@ $(filter %.c,$(UNIT_ALL_SRC)) $(B)/libcore-asan.a -lm

# The app's suite (tests/app/test_*.c): the firmware's app sources on the stub HAL,
# the same runner with its own registry, in the same three builds.
APP_TEST_SRC  := $(sort $(wildcard tests/app/test_*.c))
APP_TEST_LIST := $(GEN)/app_tests/unit_list.h
APP_TEST_ALL  := tests/core/unit.c $(APP_TEST_SRC) tests/app/stub_hal.c firmware/hal/hal.c \
                 $(sort $(wildcard firmware/app/*.c)) $(PARAM_META_C)
APP_TEST_CFLAGS := -std=c11 $(OPT) -Wall -Wextra -Werror -D_POSIX_C_SOURCE=200809L -I$(GEN)/app_tests \
                 -Itests/core -Itests/app -Ifirmware -Ifirmware/core -Ifirmware/app -Ifirmware/hal \
                 -isystem $(GEN)/mavlink -isystem $(GEN)/mavlink/common -MMD -MP
APP_TEST_HDR := $(UNIT_HDR) $(wildcard firmware/app/*.h firmware/hal/*.h tests/app/*.h)

$(APP_TEST_LIST): $(APP_TEST_SRC) tests/tests.mk
	@mkdir -p $(@D)
	@{ echo "/* generated from tests/app/test_*.c: do not edit */"; \
	   for f in $(APP_TEST_SRC); do sed -n 's/^UNIT_TEST(\([A-Za-z0-9_]*\)).*/UNIT_ENTRY(\1)/p' $$f; done; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@

$(B)/app-tests: $(APP_TEST_ALL) $(APP_TEST_HDR) $(APP_TEST_LIST) $(B)/libcore.a | $(MAVLINK_STAMP)
	$(CC) $(call SUITE_CFLAGS,$(APP_TEST_CFLAGS)) -o $@ $(APP_TEST_ALL) $(B)/libcore.a -lm
$(B)/app-tests-fixed: $(APP_TEST_ALL) $(APP_TEST_HDR) $(APP_TEST_LIST) $(B)/libcore-fixed.a | $(MAVLINK_STAMP)
	$(CC) $(call SUITE_CFLAGS,$(APP_TEST_CFLAGS)) -DOCTO_FIXED=1 -o $@ $(APP_TEST_ALL) $(B)/libcore-fixed.a -lm
$(B)/app-tests-asan: $(APP_TEST_ALL) $(APP_TEST_HDR) $(APP_TEST_LIST) $(B)/libcore-asan.a | $(MAVLINK_STAMP)
	$(CC) $(call SUITE_CFLAGS,$(APP_TEST_CFLAGS)) $(SAN) -o $@ $(APP_TEST_ALL) $(B)/libcore-asan.a -lm

UNIT_BINS := $(B)/unit-tests $(B)/unit-tests-fixed $(B)/unit-tests-asan \
             $(B)/app-tests $(B)/app-tests-fixed $(B)/app-tests-asan
ALL_TARGETS += $(UNIT_BINS)

PYTEST_ARGS ?=
.PHONY: test-unit test-py
test-unit: $(UNIT_BINS)
	@rc=0; for t in $(UNIT_BINS); do echo "== $$t"; $$t || rc=1; done; exit $$rc

test-py: all
	$(VPY) -m pytest -c tests/pytest.ini tests $(PYTEST_ARGS)
