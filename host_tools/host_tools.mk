# host_tools/: the octo_gcs Python package behind the `octo-gcs` command,
# installed into .venv in editable mode; the generated LCM Python types in
# build/gen/python are put on the venv's path by a .pth file.

GCS_STAMP := $(VENV)/.octo-gcs-stamp
$(GCS_STAMP): host_tools/pyproject.toml $(VENV_STAMP) $(B)/config.mk $(LCM_STAMP)
	$(VENV)/bin/pip install --disable-pip-version-check -q --no-build-isolation --no-deps -e host_tools
	@echo "$(abspath $(GEN)/python)" > $(SP)/octo_sil_lcmtypes.pth
	@touch $@

ALL_TARGETS += $(GCS_STAMP)

# octo-fw's parameter table and mode numbers for octo-gcs (import octo_fw_table)
FW_TABLE_PY := $(GEN)/python/octo_fw_table.py
$(FW_TABLE_PY): $(B)/octo-fw host_tools/gen_fw_table.py | $(LCM_STAMP)
	$(B)/octo-fw --dump-params | $(PYTHON) host_tools/gen_fw_table.py $@

ALL_TARGETS += $(FW_TABLE_PY)

# Python formatting and lint of host_tools/ (ruff, pinned in requirements.txt; its settings in
# host_tools/pyproject.toml).
.PHONY: lint-py
lint-py: $(VENV_STAMP)
	$(VENV)/bin/ruff check host_tools
	$(VENV)/bin/ruff format --check host_tools
