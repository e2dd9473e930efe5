/*
 * bench_mark.h - markers around the code whose instructions QEMU should count.
 *
 *   bench_mark_begin();
 *   step(&state, &in, &out);      // the one call being measured
 *   bench_mark_end();
 *
 * Run the image under QEMU with the insn-count plugin (tests/arm/insn_count.c,
 * usage in tests/arm/arm.mk): each begin/end pair prints
 * "octo-count: region N: M instructions". The markers are empty noinline
 * functions in their own file, so they cost one call each and the compiler
 * cannot move work across them; the count includes one instruction of overhead
 * (the `bl bench_mark_end`). Keep arguments of the measured call in volatile or
 * global storage so the compiler cannot compute the result ahead of the marker.
 */
#ifndef OCTO_ARM_BENCH_MARK_H
#define OCTO_ARM_BENCH_MARK_H

void bench_mark_begin(void);
void bench_mark_end(void);

#endif
