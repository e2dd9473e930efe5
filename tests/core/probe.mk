# tests/core/probe.mk: probe programs that expose core modules over stdin/stdout for the
# numpy reference tests (tests/py/test_core_reference.py). Not firmware, not unit tests.
PROBE_CFLAGS := -std=c11 $(OPT) -Wall -Wextra -Werror -Ifirmware/core -MMD -MP

$(B)/probe-mixer: tests/core/probe_mixer.c $(B)/libcore.a
	$(CC) $(PROBE_CFLAGS) -MF $@.d -o $@ $< $(B)/libcore.a -lm
$(B)/probe-mixer-fixed: tests/core/probe_mixer.c $(B)/libcore-fixed.a
	$(CC) $(PROBE_CFLAGS) -DOCTO_FIXED=1 -MF $@.d -o $@ $< $(B)/libcore-fixed.a -lm

ALL_TARGETS += $(B)/probe-mixer $(B)/probe-mixer-fixed
