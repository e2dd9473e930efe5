# tests/arm/: cross-build of the core and its unit tests for Cortex-M4F and M0 under QEMU.
.PHONY: arm
arm:
	@echo "make arm: not built yet"; exit 1
