# tests/soak.mk: `make soak`, a day in the air (tests/py/test_soak.py).
#
# 24 h of plant time in octo-sil, octo-sil-fixed and octo-sil-asan, an identification
# every hour while k_f drifts by 30 % over the day; progress printed as it flies.
# SOAK_HOURS shortens or lengthens it. `make test` flies the short form (2 h, 3 identifications, float and
# Q16.16 builds).

SOAK_HOURS ?= 24

.PHONY: soak
soak: all $(B)/octo-sil-asan
	OCTO_SOAK_HOURS=$(SOAK_HOURS) OCTO_SOAK_ASAN=1 $(VPY) -m pytest -c tests/pytest.ini -s -q \
	  tests/py/test_soak.py $(PYTEST_ARGS)
