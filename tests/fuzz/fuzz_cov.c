/*
 * fuzz_cov.c - where libFuzzer's inline 8-bit coverage counters are (the linker's bounds of
 * their section), for the MAVLink harness's prefix checkpoints. This file has no coverage of
 * its own (coverage-ignore-mavlink.txt): the instrumentation declares the same bounds in
 * every file it instruments, and a declaration of them in such a file takes the place of
 * its own, which then registers no counters with libFuzzer.
 */
#include <stddef.h>
#include <stdint.h>

#include "fuzz_cov.h"

extern uint8_t __start___sancov_cntrs[] __attribute__((weak));
extern uint8_t __stop___sancov_cntrs[] __attribute__((weak));

uint8_t *fuzz_cov_counters(size_t *n)
{
	*n = (size_t)(__stop___sancov_cntrs - __start___sancov_cntrs);
	return __start___sancov_cntrs;
}
