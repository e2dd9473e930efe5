/*
 * startup.c - the project's start-up code for the Cortex-M test images (M0 and M4F).
 *
 * Reset: enable the FPU when the image uses it (CPACR, then DSB/ISB, before any
 * float instruction), paint the stack so its high-water mark can be measured,
 * copy .data from flash, zero .bss, run the C library's constructors, then
 * exit(main(argc, argv)) with argv taken from the semihosting command line
 * (QEMU's `-semihosting-config ...,arg=NAME,arg=FILTER`). Any fault ends the run
 * through semihosting with exit status 126, so a crash can never look like a pass.
 *
 * Memory (see sections.ld): the stack sits at the bottom of RAM, so an overflow
 * runs off the start of RAM and faults instead of silently corrupting data.
 */
#include <stdint.h>
#include <stdlib.h>

#include "semihost.h"

extern uint32_t __data_load[], __data_start[], __data_end[];
extern uint32_t __bss_start__[], __bss_end__[];
extern uint32_t __stack_bottom[], __stack_top[];

int main(int argc, char **argv);
void __libc_init_array(void);
void reset_handler(void) __attribute__((noreturn));
void fault_handler(void);

#define STACK_PAINT 0x5ca1ab1eu

/* newlib's __libc_init_array calls _init; -nostartfiles leaves it undefined. */
void _init(void) {}
void _fini(void) {}

static char cmdline[256];
static char *argv_buf[16];

static int parse_cmdline(void)
{
	struct {
		char *buf;
		int32_t len;
	} blk = {cmdline, (int32_t)sizeof cmdline - 1};
	int argc = 0;
	if (semihost(SH_SYS_GET_CMDLINE, &blk) != 0)
		blk.len = 0;
	cmdline[blk.len] = '\0';
	for (char *p = cmdline; *p && argc < 15;) {
		while (*p == ' ')
			*p++ = '\0';
		if (!*p)
			break;
		argv_buf[argc++] = p;
		while (*p && *p != ' ')
			p++;
	}
	if (argc == 0)
		argv_buf[argc++] = (char *)"unit-tests";
	argv_buf[argc] = 0;
	return argc;
}

static void __attribute__((noinline, noreturn)) start_c(void)
{
	/* paint the unused part of the stack (below this frame) for the high-water mark */
	uintptr_t sp;
	__asm__ volatile("mov %0, sp" : "=r"(sp));
	for (uint32_t *p = __stack_bottom; (uintptr_t)p < sp - 128; p++)
		*p = STACK_PAINT;
	for (uint32_t *s = __data_load, *d = __data_start; d < __data_end;)
		*d++ = *s++;
	for (uint32_t *d = __bss_start__; d < __bss_end__;)
		*d++ = 0;
	__libc_init_array();
	int argc = parse_cmdline();
	exit(main(argc, argv_buf));
}

void reset_handler(void)
{
#if defined(__ARM_FP)
	/* CPACR: full access to CP10 and CP11 (the FPU) */
	*(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
	__asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
	start_c();
}

/* Bytes of stack ever used: the painted words still intact are the unused part. */
uint32_t startup_stack_used(void)
{
	const uint32_t *p = __stack_bottom;
	while (p < __stack_top && *p == STACK_PAINT)
		p++;
	return (uint32_t)((uintptr_t)__stack_top - (uintptr_t)p);
}

uint32_t startup_stack_size(void) { return (uint32_t)((uintptr_t)__stack_top - (uintptr_t)__stack_bottom); }

static void put_hex(const char *label, uint32_t v)
{
	char s[11] = "0x";
	for (int i = 0; i < 8; i++)
		s[2 + i] = "0123456789abcdef"[(v >> (28 - 4 * i)) & 0xFu];
	s[10] = '\0';
	semihost_puts(label);
	semihost_puts(s);
}

/* Every exception but reset ends the run: report the exception number and pc. */
void fault_report(const uint32_t *frame, uint32_t ipsr) __attribute__((noreturn, used));
void fault_report(const uint32_t *frame, uint32_t ipsr)
{
	put_hex("\nocto-arm: unexpected exception ", ipsr & 0x1FFu);
	if ((uintptr_t)frame >= (uintptr_t)__stack_bottom && (uintptr_t)frame + 32 <= (uintptr_t)__stack_top)
		put_hex(" at pc ", frame[6]);
	else
		put_hex(" with sp outside the stack (overflow?) ", (uint32_t)(uintptr_t)frame);
	semihost_puts("\n");
	semihost_exit(126);
}

/* Reset the stack pointer first: the fault may be a stack overflow. */
__attribute__((naked)) void fault_handler(void)
{
	__asm__ volatile("mrs r0, msp\n\t"
			 "mrs r1, ipsr\n\t"
			 "ldr r2, =__stack_top\n\t"
			 "mov sp, r2\n\t"
			 "ldr r2, =fault_report\n\t"
			 "bx r2\n\t"
			 ".ltorg");
}

/* ARMv6-M and ARMv7-M vector table: initial sp, reset, 14 system exceptions,
   then device interrupts (none enabled here). */
__attribute__((section(".vectors"), used)) static void (*const vectors[16 + 32])(void) = {
	[0] = (void (*)(void))(uintptr_t)__stack_top,
	[1] = reset_handler,
	[2 ... 16 + 31] = fault_handler,
};
