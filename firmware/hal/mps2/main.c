/*
 * main.c - octo-fw on the MPS2 AN386 board: the struct hal, the three links and the loop
 * (see board.h and docs/pil.md).
 *
 * Each pass of the loop reads the 64-bit clock, takes every byte waiting on the plant and
 * ground UARTs (a complete X-Plane datagram runs one step at once; a complete MAVLink
 * packet goes to mav_receive), then runs the X-Plane client's periodic requests, app_tick,
 * mav_tick, and sends the log events that are waiting. A pass that finds the links quiet
 * ends in WFI until the next byte or tick (see idle()). Console lines (hal report) go to
 * the semihosting console, the only output a board without a debugger would not have.
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "board.h"
#include "cmsdk.h"
#include "host.h"

#define UART_PLANT MPS2_UART(0)
#define UART_GROUND MPS2_UART(1)
#define UART_LOG MPS2_UART(2)

/* The plant's bytes towards the board come dealt in turn over four receivers (docs/pil.md):
 * QEMU moves one byte per UART at a time, so four lanes take four bytes at a time. */
#define PLANT_LANES 4u
static struct cmsdk_uart *const plant_lane[PLANT_LANES] = {MPS2_UART(0), MPS2_UART(2), MPS2_UART(3), MPS2_UART(4)};

int _write(int fd, const char *buf, int len); /* tests/arm/semihost.c: the console */

static void console_line(const char *prefix, const char *line)
{
	(void)_write(1, prefix, (int)strlen(prefix));
	(void)_write(1, line, (int)strlen(line));
	(void)_write(1, "\n", 1);
}

/* xp_client.c's console */
void host_report(const char *fmt, ...)
{
	char line[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	console_line("octo-fw: ", line);
}

/* The step markers: empty, not inlined, so that the counting plugin sees their addresses. */
__attribute__((noinline)) void board_step_begin(void) { __asm__ volatile("" ::: "memory"); }
__attribute__((noinline)) void board_step_end(void) { __asm__ volatile("" ::: "memory"); }

/* ---------------------------------------------------------------- clock */

static void clock_update(struct board *b)
{
	uint32_t v = MPS2_TIMER0->value;
	b->ticks += (uint32_t)(b->timer_last - v); /* a down-counter: elapsed ticks, modulo 2^32 */
	b->timer_last = v;
	b->now_us = b->ticks / (MPS2_PCLK_HZ / 1000000u);
}

/* ---------------------------------------------------------------- struct hal */

static uint64_t wall_us(void *ctx)
{
	const struct board *b = ctx;
	return b->now_us;
}

/* No real-time clock: time since reset (MAVLink signing is not used on this platform). */
static uint64_t unix_us(void *ctx)
{
	const struct board *b = ctx;
	return b->now_us;
}

static void plant_actuate(void *ctx, const float thr[HAL_ROTORS])
{
	struct board *b = ctx;
	memcpy(b->thr, thr, sizeof b->thr);
	b->actuate = true;
}

static void plant_stats(void *ctx, struct hal_plant_stats *out)
{
	const struct board *b = ctx;
	*out = b->xp.stats;
	out->dropped += b->plant_rx.dropped;
}

static void ground_send(void *ctx, const uint8_t *buf, size_t len)
{
	(void)ctx;
	for (size_t i = 0; i < len; i++)
		cmsdk_uart_putc(UART_GROUND, buf[i]);
}

static bool ground_signing_key(void *ctx, uint8_t key[32])
{
	(void)ctx, (void)key;
	return false;
}

static int param_store(void *ctx, const char *text, size_t len)
{
	struct board *b = ctx;
	if (hal_ram_param_put(b->param, sizeof b->param, &b->param_len, text, len) < 0) {
		console_line("octo-fw: ", "parameter sector full: not stored");
		return -1;
	}
	return 0;
}

static long param_fetch(void *ctx, char *buf, size_t cap)
{
	const struct board *b = ctx;
	return hal_ram_param_get(b->param, b->param_len, buf, cap);
}

static void log_frame(void *ctx, const struct app_log_frame *f)
{
	struct board *b = ctx;
	b->log_pending = f; /* the app's own record: unchanged until its next frame */
}

static struct board_event *event_slot(struct board *b)
{
	if (b->ev_n == BOARD_EVENTS) {
		b->ev_lost++;
		return NULL;
	}
	struct board_event *e = &b->events[(b->ev_head + b->ev_n++) % BOARD_EVENTS];
	return e;
}

static void log_event(void *ctx, double t_s, int severity, const char *text)
{
	struct board *b = ctx;
	struct board_event *e = event_slot(b);
	if (!e)
		return;
	e->kind = BOARD_REC_EVENT;
	e->t_s = t_s;
	e->severity = (int8_t)severity;
	size_t n = strlen(text);
	if (n >= sizeof e->text)
		n = sizeof e->text - 1;
	memcpy(e->text, text, n);
	e->text[n] = 0;
}

static void log_id_result(void *ctx, double t_s, const struct app_id_result *r)
{
	struct board *b = ctx;
	struct board_event *e = event_slot(b);
	if (!e)
		return;
	e->kind = BOARD_REC_ID;
	e->t_s = t_s;
	e->id = *r;
}

static void report(void *ctx, const char *line)
{
	(void)ctx;
	console_line("octo-fw: ", line);
}

/* ---------------------------------------------------------------- links */

static void put_plant(void *ctx, uint8_t c)
{
	(void)ctx;
	cmsdk_uart_putc(UART_PLANT, c);
}

static void put_log(void *ctx, uint8_t c)
{
	(void)ctx;
	cmsdk_uart_putc(UART_LOG, c);
}

/* The X-Plane client's requests and actuations: one SLIP frame per datagram. */
static void plant_send(void *ctx, const uint8_t *buf, size_t len)
{
	struct board *b = ctx;
	slip_tx_begin(&b->plant_tx);
	slip_tx_add(&b->plant_tx, buf, len);
	slip_tx_end(&b->plant_tx);
}

static void log_send(struct board *b, uint8_t kind, const uint8_t *body, size_t len)
{
	if (!len)
		return;
	slip_tx_begin(&b->log_tx);
	slip_tx_add(&b->log_tx, &kind, 1);
	slip_tx_add(&b->log_tx, body, len);
	slip_tx_end(&b->log_tx);
}

static void flush_events(struct board *b)
{
	uint8_t buf[BOARD_EVENT_TEXT + 16];
	while (b->ev_n) {
		const struct board_event *e = &b->events[b->ev_head];
		size_t n = e->kind == BOARD_REC_ID ? board_enc_id(buf, sizeof buf, e->t_s, &e->id)
						   : board_enc_event(buf, sizeof buf, e->t_s, e->severity, e->text);
		log_send(b, e->kind, buf, n);
		b->ev_head = (b->ev_head + 1) % BOARD_EVENTS;
		b->ev_n--;
	}
}

/* A frame's record the app handed over (at the frame boundary after its step: app_settle,
 * in app_tick or at the start of the next step), then the events. */
static void flush_log(struct board *b)
{
	if (b->log_pending) {
		static uint8_t rec[1024]; /* the encoded record; one at a time */
		log_send(b, BOARD_REC_FRAME, rec, board_enc_frame(rec, sizeof rec, b->log_pending));
		b->log_pending = NULL;
	}
	flush_events(b);
}

/* One control step on the frame just decoded, then what it handed over. */
static void step(struct board *b)
{
	b->actuate = false;
	board_step_begin();
	app_on_frame(&b->app, &b->frame);
	board_step_end();
	b->steps++;
	if (b->actuate)
		xp_client_actuate(&b->xp, b->thr, b->now_us);
	flush_log(b);
}

/* Every plant byte waiting, taken from the lanes in their turn; returns how many there were. */
static unsigned poll_plant(struct board *b)
{
	unsigned got = 0;
	uint8_t c;
	while (cmsdk_uart_getc(plant_lane[b->lane], &c)) {
		b->lane = (b->lane + 1u) % PLANT_LANES;
		got++;
		size_t n = slip_rx_byte(&b->plant_rx, c);
		if (n && xp_client_input(&b->xp, b->plant_rx.buf, n, &b->plant_addr, &b->frame, b->now_us) == 1)
			step(b);
	}
	return got;
}

/* MAVLink packet length from its first bytes (v2 0xFD, v1 0xFE); 0 while unknown. */
static size_t mav_packet_len(const uint8_t *p, size_t n)
{
	if (n < 3)
		return 0;
	if (p[0] == 0xFE)
		return 8u + p[1];
	return 12u + p[1] + ((p[2] & 0x01u) ? 13u : 0u);
}

/* Ground bytes into whole packets for mav_receive. A packet that does not check (a byte
 * lost or changed) is given up one byte at a time: the search goes on from its next
 * start byte, so the link finds the next good packet. */
static void ground_byte(struct board *b, uint8_t c)
{
	if (b->mav_n == 0 && c != 0xFD && c != 0xFE) {
		b->mav_junk++;
		return;
	}
	b->mav_rx[b->mav_n++] = c;
	for (;;) {
		size_t want = mav_packet_len(b->mav_rx, b->mav_n);
		if (!want || b->mav_n < want)
			return;
		if (mav_receive(&b->mav, b->mav_rx, want) > 0) {
			memmove(b->mav_rx, b->mav_rx + want, b->mav_n - want);
			b->mav_n -= want;
		} else {
			size_t k = 1;
			while (k < b->mav_n && b->mav_rx[k] != 0xFD && b->mav_rx[k] != 0xFE)
				k++;
			b->mav_junk += (uint32_t)k;
			memmove(b->mav_rx, b->mav_rx + k, b->mav_n - k);
			b->mav_n -= k;
		}
		if (b->mav_n == 0)
			return;
	}
}

static unsigned poll_ground(struct board *b)
{
	unsigned got = 0;
	uint8_t c;
	while (cmsdk_uart_getc(UART_GROUND, &c)) {
		got++;
		ground_byte(b, c);
	}
	return got;
}

/* ---------------------------------------------------------------- idle */

#define WAKE_IRQS                                                                                                \
	(1u << MPS2_IRQ_UART0_RX | 1u << MPS2_IRQ_UART1_RX | 1u << MPS2_IRQ_UART2_RX | 1u << MPS2_IRQ_UART3_RX | \
	 1u << MPS2_IRQ_UART4_RX | 1u << MPS2_IRQ_TIMER1)

/* Clears the wake-up requests seen so far. Called before the links are polled, so that a
 * byte arriving after its UART was drained is still pending when the pass ends in WFI. */
static void wake_clear(void)
{
	for (unsigned i = 0; i < 5; i++)
		cmsdk_uart_clear_rx_irq(MPS2_UART(i));
	MPS2_TIMER1->intstatus = 0x1u;
	NVIC_ICPR0 = WAKE_IRQS;
}

/* The requests pend (PRIMASK is set) and end the WFI; none is taken. */
static void wake_setup(void)
{
	__asm__ volatile("cpsid i" ::: "memory");
	cmsdk_timer_start_periodic(MPS2_TIMER1, MPS2_PCLK_HZ / 1000000u * BOARD_TICK_US);
	wake_clear();
	NVIC_ISER0 = WAKE_IRQS;
}

/* After a pass: WFI when nothing came. The bytes of a datagram arrive one at a time, so within
 * BOARD_SPIN_US of the last byte the board polls on and sleeps only between datagrams. */
static void idle(struct board *b, unsigned got)
{
	if (got) {
		b->rx_last_us = b->now_us;
		return;
	}
	if (b->now_us - b->rx_last_us < BOARD_SPIN_US)
		return;
	__asm__ volatile("dsb\n\twfi" ::: "memory");
}

/* ---------------------------------------------------------------- start */

static void board_init(struct board *b)
{
	memset(b, 0, sizeof *b);
	b->hal = (struct hal){
		.ctx = b,
		.wall_us = wall_us,
		.unix_us = unix_us,
		.plant_actuate = plant_actuate,
		.plant_stats = plant_stats,
		.ground_send = ground_send,
		.ground_signing_key = ground_signing_key,
		.param_store = param_store,
		.param_fetch = param_fetch,
		.log_frame = log_frame,
		.log_event = log_event,
		.log_id_result = log_id_result,
		.report = report,
	};
	b->param_len = -1;
	for (int i = 0; i < 5; i++)
		cmsdk_uart_init(MPS2_UART(i), true);
	cmsdk_timer_start(MPS2_TIMER0);
	b->timer_last = MPS2_TIMER0->value;
	wake_setup();
	b->plant_addr.sin_family = AF_INET;
	b->plant_addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	xp_client_init(&b->xp, &b->plant_addr, XP_ACT_DATA25);
	b->xp.send = plant_send;
	b->xp.send_ctx = b;
	b->plant_tx = (struct slip_tx){.put = put_plant, .ctx = b};
	b->log_tx = (struct slip_tx){.put = put_log, .ctx = b};
}

int main(int argc, char **argv)
{
	(void)argc, (void)argv;
	static struct board b;
	board_init(&b);
	clock_update(&b);
	app_init(&b.app, &b.hal);
	mav_init(&b.mav, &b.app, &b.hal, b.now_us);
#if OCTO_FIXED
	console_line(
		"octo-fw: ",
		"MPS2 AN386 (Cortex-M4F), Q16.16 build: plant on UART0 (in: lanes UART0, 2, 3, 4), MAVLink on UART1, log on UART2");
#else
	console_line(
		"octo-fw: ",
		"MPS2 AN386 (Cortex-M4F), float build: plant on UART0 (in: lanes UART0, 2, 3, 4), MAVLink on UART1, log on UART2");
#endif
	for (;;) {
		wake_clear();
		clock_update(&b);
		unsigned got = poll_plant(&b);
		got += poll_ground(&b);
		xp_client_poll(&b.xp, b.now_us);
		app_tick(&b.app);
		flush_log(&b); /* the last frame's record (app_tick's frame boundary) before MAVLink */
		mav_tick(&b.mav, b.now_us);
		flush_events(&b);
		idle(&b, got);
	}
}
