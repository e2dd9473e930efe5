/*
 * semihost.h - Arm semihosting calls used by the Cortex-M test images.
 *
 * A semihosting call is `bkpt 0xab` with the operation in r0 and a pointer to
 * its argument block in r1; QEMU (-semihosting-config enable=on) performs it on
 * the host and returns the result in r0. Only what the tests need is here.
 */
#ifndef OCTO_ARM_SEMIHOST_H
#define OCTO_ARM_SEMIHOST_H

#include <stdint.h>

#define SH_SYS_OPEN 0x01
#define SH_SYS_WRITE0 0x04
#define SH_SYS_WRITE 0x05
#define SH_SYS_GET_CMDLINE 0x15
#define SH_SYS_EXIT 0x18
#define SH_SYS_EXIT_EXTENDED 0x20
#define SH_ADP_STOPPED_APPLICATION_EXIT 0x20026

static inline int32_t semihost(uint32_t op, void *arg)
{
	register uint32_t r0 __asm__("r0") = op;
	register void *r1 __asm__("r1") = arg;
	__asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
	return (int32_t)r0;
}

/* Write a NUL-terminated string to QEMU's semihosting console. */
static inline void semihost_puts(const char *s) { semihost(SH_SYS_WRITE0, (void *)(uintptr_t)s); }

/* Stop QEMU with `code` as its exit status (SYS_EXIT_EXTENDED). */
void semihost_exit(int code) __attribute__((noreturn));

#endif
