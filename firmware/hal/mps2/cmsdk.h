/*
 * cmsdk.h - the peripherals of the MPS2 AN386 board (Cortex-M4F) that the platform uses,
 * as QEMU's mps2-an386 machine emulates them: the Arm CMSDK APB UART and timer.
 *
 *   UART0 0x40004000  plant link (X-Plane datagrams in SLIP frames with a CRC-32)
 *   UART1 0x40005000  ground link (MAVLink 2, its own framing)
 *   UART2 0x40006000  log link (the firmware log as records in SLIP frames with a CRC-32);
 *                     its receiver, UART3's (0x40007000) and UART4's (0x40009000) are the
 *                     plant link's lanes 1 to 3 towards the board
 *   TIMER0 0x40000000 free-running 32-bit down-counter at the board's 25 MHz peripheral clock
 *   TIMER1 0x40001000 the idle wake-up: a periodic interrupt request
 *
 * Everything is polled: PRIMASK stays set, so no interrupt is ever taken and the instruction
 * counts of a step (docs/pil.md) hold that step's work alone. The UART receive and TIMER1
 * requests are enabled in the NVIC only so that they stay pending and end a WFI: an idle
 * board sleeps until a byte or the next tick arrives instead of polling.
 */
#ifndef OCTO_MPS2_CMSDK_H
#define OCTO_MPS2_CMSDK_H

#include <stdbool.h>
#include <stdint.h>

#define MPS2_PCLK_HZ 25000000u

struct cmsdk_uart {
	volatile uint32_t data;      /* a byte received (read) or to send (write) */
	volatile uint32_t state;     /* bit 0 TX buffer full, bit 1 RX buffer full */
	volatile uint32_t ctrl;      /* bit 0 TX enable, bit 1 RX enable, bit 3 RX interrupt enable */
	volatile uint32_t intstatus; /* bit 1 RX: set by a received byte, cleared by writing 1 */
	volatile uint32_t bauddiv;   /* at least 16, else the UART neither sends nor receives */
};

struct cmsdk_timer {
	volatile uint32_t ctrl;  /* bit 0 enable, bit 3 interrupt enable */
	volatile uint32_t value; /* counts down at PCLK, reloads from reload at zero */
	volatile uint32_t reload;
	volatile uint32_t intstatus; /* bit 0: reached zero; cleared by writing 1 */
};

/* UART0..UART2 at 0x40004000 + 0x1000 n, UART3 at 0x40007000, UART4 at 0x40009000 */
#define MPS2_UART(n) ((struct cmsdk_uart *)(uintptr_t)((n) == 4 ? 0x40009000u : 0x40004000u + 0x1000u * (uint32_t)(n)))
#define MPS2_TIMER0 ((struct cmsdk_timer *)(uintptr_t)0x40000000u)
#define MPS2_TIMER1 ((struct cmsdk_timer *)(uintptr_t)0x40001000u)

/* NVIC lines of the AN386 (QEMU's hw/arm/mps2.c): UART n receive, TIMER1. */
#define MPS2_IRQ_UART0_RX 0u
#define MPS2_IRQ_UART1_RX 2u
#define MPS2_IRQ_UART2_RX 4u
#define MPS2_IRQ_UART3_RX 18u
#define MPS2_IRQ_UART4_RX 20u
#define MPS2_IRQ_TIMER1 9u
#define NVIC_ISER0 (*(volatile uint32_t *)(uintptr_t)0xE000E100u) /* set enable */
#define NVIC_ICPR0 (*(volatile uint32_t *)(uintptr_t)0xE000E280u) /* clear pending */

/* 921,600 baud: the divider a board would use; QEMU moves bytes as fast as its host does. */
#define MPS2_UART_BAUDDIV (MPS2_PCLK_HZ / 921600u)

/* rx_irq: the receive interrupt request is raised (to end a WFI; it is never taken). */
static inline void cmsdk_uart_init(struct cmsdk_uart *u, bool rx_irq)
{
	u->bauddiv = MPS2_UART_BAUDDIV;
	u->ctrl = rx_irq ? 0xBu : 0x3u;
}

static inline void cmsdk_uart_clear_rx_irq(struct cmsdk_uart *u) { u->intstatus = 0x2u; }

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

/* Reloads every period ticks and raises its interrupt request each time. */
static inline void cmsdk_timer_start_periodic(struct cmsdk_timer *t, uint32_t period)
{
	t->ctrl = 0;
	t->reload = period;
	t->value = period;
	t->intstatus = 0x1u;
	t->ctrl = 0x9u;
}

#endif /* OCTO_MPS2_CMSDK_H */
