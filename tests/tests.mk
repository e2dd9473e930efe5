# tests/: C unit tests of the core (tests/core/test_*.c, one file per core module)
# through the project's runner, in three builds, then pytest over tests/.
#
# A test is `UNIT_TEST(name) { ... }` in tests/core/test_*.c; the registry
# build/gen/unit_list.h is generated from those lines, so adding a test needs no
# edit anywhere else. Test code is not firmware: it may use double and libc.

UNIT_SRC   := $(sort $(wildcard tests/core/test_*.c))
UNIT_LIST  := $(GEN)/unit_list.h
UNIT_CFLAGS := -std=c11 $(OPT) -Wall -Wextra -Werror -Itests/core -Ifirmware/core -I$(GEN) -MMD -MP

$(UNIT_LIST): $(UNIT_SRC) tests/tests.mk
	@mkdir -p $(@D)
	@{ echo "/* generated from tests/core/test_*.c: do not edit */"; \
	   for f in $(UNIT_SRC); do sed -n 's/^UNIT_TEST(\([A-Za-z0-9_]*\)).*/UNIT_ENTRY(\1)/p' $$f; done; } > $@.tmp
	@cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@

UNIT_ALL_SRC := tests/core/unit.c $(UNIT_SRC)

$(B)/unit-tests: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore.a
	$(CC) $(UNIT_CFLAGS) -MF $@.d -o $@ $(UNIT_ALL_SRC) $(B)/libcore.a -lm
$(B)/unit-tests-fixed: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore-fixed.a
	$(CC) $(UNIT_CFLAGS) -DOCTO_FIXED=1 -MF $@.d -o $@ $(UNIT_ALL_SRC) $(B)/libcore-fixed.a -lm
$(B)/unit-tests-asan: $(UNIT_ALL_SRC) $(UNIT_LIST) $(B)/libcore-asan.a
	$(CC) $(UNIT_CFLAGS) $(SAN) -MF $@.d -o $@ $(UNIT_ALL_SRC) $(B)/libcore-asan.a -lm

UNIT_BINS := $(B)/unit-tests $(B)/unit-tests-fixed $(B)/unit-tests-asan
ALL_TARGETS += $(UNIT_BINS)

PYTEST_ARGS ?=
.PHONY: test-unit test-py
test-unit: $(UNIT_BINS)
	@rc=0; for t in $(UNIT_BINS); do echo "== $$t"; $$t || rc=1; done; exit $$rc

test-py: all
	$(VPY) -m pytest -c tests/pytest.ini tests $(PYTEST_ARGS)
