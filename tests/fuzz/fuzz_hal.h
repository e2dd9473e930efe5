/* fuzz_hal.h - controls of the fuzzing HAL (fuzz_hal.c). */
#ifndef OCTO_FUZZ_HAL_H
#define OCTO_FUZZ_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "hal.h"

extern uint64_t fuzz_now_us;
extern bool fuzz_have_key;
extern uint8_t fuzz_key[32];
extern size_t fuzz_sent_bytes;
void fuzz_hal_reset(void);

#endif
