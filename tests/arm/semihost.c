/*
 * semihost.c - newlib system calls over Arm semihosting, for the Cortex-M test images.
 *
 * stdout and stderr go to QEMU's ":tt" console handles; stdin reads as empty.
 * The heap is the RAM between .bss and the end of RAM (see sections.ld). On
 * exit the image prints its stack and heap high-water marks, then stops QEMU
 * with SYS_EXIT_EXTENDED so that QEMU's exit status is the program's; plain
 * SYS_EXIT can only say success or failure on 32-bit Arm.
 * The remaining calls (close, fstat, isatty, lseek, kill, getpid) are newlib's
 * nosys stubs (--specs=nosys.specs).
 */
#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "semihost.h"

extern char __heap_start[], __heap_end[];
uint32_t startup_stack_used(void);
uint32_t startup_stack_size(void);

int _write(int fd, const char *buf, int len);
int _read(int fd, char *buf, int len);
void *_sbrk(ptrdiff_t incr);
void _exit(int code) __attribute__((noreturn));

static int32_t tt_handle[3] = {-1, -1, -1};

int _write(int fd, const char *buf, int len)
{
	if (fd != 1 && fd != 2) {
		errno = EBADF;
		return -1;
	}
	if (tt_handle[fd] < 0) {
		/* mode 4 is "w" (stdout), 8 is "a" (stderr) */
		struct {
			const char *name;
			int32_t mode;
			int32_t len;
		} o = {":tt", fd == 1 ? 4 : 8, 3};
		tt_handle[fd] = semihost(SH_SYS_OPEN, &o);
		if (tt_handle[fd] < 0) {
			errno = EIO;
			return -1;
		}
	}
	struct {
		int32_t h;
		const char *buf;
		int32_t len;
	} w = {tt_handle[fd], buf, len};
	return len - semihost(SH_SYS_WRITE, &w); /* returns the bytes NOT written */
}

int _read(int fd, char *buf, int len)
{
	(void)fd, (void)buf, (void)len;
	return 0;
}

static char *heap_top = __heap_start;

void *_sbrk(ptrdiff_t incr)
{
	if (incr > __heap_end - heap_top || incr < __heap_start - heap_top) {
		errno = ENOMEM;
		return (void *)-1;
	}
	char *old = heap_top;
	heap_top += incr;
	return old;
}

/* to stdout (SYS_WRITE0 would go to QEMU's stderr) */
static void out(const char *s)
{
	int n = 0;
	while (s[n])
		n++;
	if (_write(1, s, n) != n)
		semihost_puts(s);
}

static void put_dec(uint32_t v)
{
	char s[12];
	int i = 11;
	s[i] = '\0';
	do {
		s[--i] = (char)('0' + v % 10);
		v /= 10;
	} while (v && i > 0);
	out(&s[i]);
}

void semihost_exit(int code)
{
	struct {
		uint32_t reason;
		int32_t code;
	} e = {SH_ADP_STOPPED_APPLICATION_EXIT, code};
	semihost(SH_SYS_EXIT_EXTENDED, &e);
	/* not supported: fall back to SYS_EXIT, which can only report success */
	semihost(SH_SYS_EXIT, (void *)(uintptr_t)SH_ADP_STOPPED_APPLICATION_EXIT);
	for (;;)
		;
}

/* "octo-arm: stack N of M bytes, heap N of M bytes", then stop QEMU. */
void _exit(int code)
{
	uint32_t used = startup_stack_used(), size = startup_stack_size();
	out("octo-arm: stack ");
	put_dec(used);
	out(" of ");
	put_dec(size);
	out(" bytes, heap ");
	put_dec((uint32_t)(heap_top - __heap_start));
	out(" of ");
	put_dec((uint32_t)(__heap_end - __heap_start));
	out(" bytes\n");
	if (used >= size) {
		out("octo-arm: stack exhausted\n");
		if (code == 0)
			code = 125;
	}
	semihost_exit(code);
}
