/*
 * cmsdk.h - the peripherals of the MPS2 AN386 board (Cortex-M4F) that the platform uses,
 * as QEMU's mps2-an386 machine emulates them: the Arm CMSDK APB UART and timer.
 *
 *   UART0 0x40004000  plant link (X-Plane datagrams in SLIP frames with a CRC-32)
 *   UART1 0x40005000  ground link (MAVLink 2, its own framing)
 *   UART2 0x40006000  log link (the firmware log as records in SLIP frames with a CRC-32)
 *   TIMER0 0x40000000 free-running 32-bit down-counter at the board's 25 MHz peripheral clock
 *
 * Everything is polled: no interrupt is enabled, so that the instruction counts of a step
 * (docs/pil.md) hold that step's work alone.
 */
#ifndef OCTO_MPS2_CMSDK_H
#define OCTO_MPS2_CMSDK_H

#include <stdbool.h>
#include <stdint.h>

#define MPS2_PCLK_HZ 25000000u

struct cmsdk_uart {
	volatile uint32_t data;       /* a byte received (read) or to send (write) */
	volatile uint32_t state;      /* bit 0 TX buffer full, bit 1 RX buffer full */
	volatile uint32_t ctrl;       /* bit 0 TX enable, bit 1 RX enable */
	volatile uint32_t intstatus;
	volatile uint32_t bauddiv;    /* at least 16, else the UART neither sends nor receives */
};

struct cmsdk_timer {
	volatile uint32_t ctrl;       /* bit 0 enable */
	volatile uint32_t value;      /* counts down at PCLK, reloads from reload at zero */
	volatile uint32_t reload;
	volatile uint32_t intstatus;
};

#define MPS2_UART(n) ((struct cmsdk_uart *)(uintptr_t)(0x40004000u + 0x1000u * (uint32_t)(n)))
#define MPS2_TIMER0 ((struct cmsdk_timer *)(uintptr_t)0x40000000u)

/* 921,600 baud: the divider a board would use; QEMU moves bytes as fast as its host does. */
#define MPS2_UART_BAUDDIV (MPS2_PCLK_HZ / 921600u)

static inline void cmsdk_uart_init(struct cmsdk_uart *u)
{
	u->bauddiv = MPS2_UART_BAUDDIV;
	u->ctrl = 0x3u;
}

/* One received byte into *b: true, or false when there is none. */
static inline bool cmsdk_uart_getc(struct cmsdk_uart *u, uint8_t *b)
{
	if (!(u->state & 0x2u))
		return false;
	*b = (uint8_t)u->data;
	return true;
}

/* Sends one byte, waiting while the transmit buffer is full. */
static inline void cmsdk_uart_putc(struct cmsdk_uart *u, uint8_t b)
{
	while (u->state & 0x1u)
		;
	u->data = b;
}

static inline void cmsdk_timer_start(struct cmsdk_timer *t)
{
	t->ctrl = 0;
	t->reload = 0xFFFFFFFFu;
	t->value = 0xFFFFFFFFu;
	t->ctrl = 0x1u;
}

#endif /* OCTO_MPS2_CMSDK_H */
