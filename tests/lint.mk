# tests/lint.mk: formatting checks. `make lint-c` runs clang-format (pinned in requirements.txt,
# style in .clang-format) in check mode over LINT_C_FILES: a file listed here is kept formatted;
# a file joins the list when it is written or rewritten, not by reformatting the tree at once.

CLANG_FORMAT ?= $(VENV)/bin/clang-format
LINT_C_FILES := firmware/hal/host/host_report.h \
                firmware/hal/sil/cmdline.c \
                firmware/hal/sil/script.c \
                firmware/hal/sil/script.h

.PHONY: lint-c
lint-c: $(VENV_STAMP)
	$(CLANG_FORMAT) --dry-run --Werror $(LINT_C_FILES)
