/* bench_mark.c - the two marker functions the insn-count plugin watches; see bench_mark.h. */
#include "bench_mark.h"

__attribute__((noinline)) void bench_mark_begin(void) { __asm__ volatile("" ::: "memory"); }
__attribute__((noinline)) void bench_mark_end(void) { __asm__ volatile("" ::: "memory"); }
