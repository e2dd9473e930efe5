# tests/bench/: `make bench`, the project's performance figures (build/bench.json).
.PHONY: bench
bench:
	@echo "make bench: not built yet"; exit 1
