/* fuzz_cov.h - libFuzzer's inline 8-bit coverage counters (fuzz_cov.c). */
#ifndef OCTO_FUZZ_COV_H
#define OCTO_FUZZ_COV_H

#include <stddef.h>
#include <stdint.h>

/* The counters of the whole program and their number in *n (NULL and 0 without them). */
uint8_t *fuzz_cov_counters(size_t *n);

#endif
