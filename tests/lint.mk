# tests/lint.mk: formatting checks. `make lint` runs both: `make lint-c` runs clang-format
# (pinned in requirements.txt, style in .clang-format) in check mode over every C and C++ source
# of firmware/, sim/ and tests/; `make lint-py` (host_tools/host_tools.mk) runs ruff.

CLANG_FORMAT ?= $(VENV)/bin/clang-format
LINT_C_FILES := $(shell git ls-files 'firmware/*.c' 'firmware/*.h' 'sim/*.cpp' 'sim/*.hpp' 'sim/*.h' \
                  'tests/*.c' 'tests/*.h' 'tests/*.cpp' 2>/dev/null)

.PHONY: lint lint-c
lint: lint-c lint-py

lint-c: $(VENV_STAMP)
	$(CLANG_FORMAT) --dry-run --Werror $(LINT_C_FILES)
