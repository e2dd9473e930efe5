/*
 * insn_count.c - QEMU TCG plugin: guest instructions executed between two marker calls.
 *
 *   qemu-system-arm ... -plugin build/arm/insn-count.so,begin=0xADDR,end=0xADDR[,out=FILE]
 *
 * begin/end are the addresses of two noinline marker functions (bench_mark_begin,
 * bench_mark_end in tests/arm/bench_mark.c; take them from arm-none-eabi-nm, the
 * Thumb bit is ignored). Counting starts after the begin marker's translation
 * block (its own `bx lr` is not counted) and stops when the end marker's block
 * starts: the count is everything executed in between, the `bl bench_mark_end`
 * included (one instruction of overhead). Each begin/end pair prints one line
 *   octo-count: region N: M instructions
 * to QEMU's log (stderr unless -D FILE) or to out=FILE.
 *
 * Profile (optional): profile=FILE[,from=N][,to=M][,every=K] also writes, at exit, one line
 * "PC INSNS" (decimal) per translation block with the instructions it executed inside the regions
 * N, N + K, N + 2K, ... up to M (1-based; default all). tests/arm/insn-profile.sh sums
 * them per function.
 *
 * Debian's QEMU 7.2 ships no qemu-plugin.h, so the few v1 API declarations used
 * are written out here (ABI of QEMU_PLUGIN_VERSION 1). Counting is per
 * translation block, so an exception in the middle of a block would over-count
 * that block: no interrupts are enabled in the measured images.
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, qemu_plugin_vcpu_udata_cb_t cb,
					  enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_outs(const char *string);

#define EXPORT __attribute__((visibility("default")))
EXPORT int qemu_plugin_version = 1;

enum { TB_PLAIN, TB_BEGIN, TB_END };
struct tb_info {
	uint64_t n, pc, prof;
	int kind;
	struct tb_info *next;
};

static uint64_t begin_addr = UINT64_MAX, end_addr = UINT64_MAX, count;
static int active, regions, prof_on;
static long prof_from = 1, prof_to = -1, prof_every = 1;
static FILE *out, *prof;
static struct tb_info *tbs;

static void report(const char *line)
{
	if (out) {
		fputs(line, out);
		fflush(out);
	} else {
		qemu_plugin_outs(line);
	}
}

static void tb_exec(unsigned int vcpu, void *udata)
{
	const struct tb_info *t = udata;
	(void)vcpu;
	if (t->kind == TB_END && active) {
		char line[96];
		snprintf(line, sizeof line, "octo-count: region %d: %" PRIu64 " instructions\n", ++regions, count);
		report(line);
		active = 0;
	} else if (t->kind == TB_BEGIN) {
		long next = regions + 1;
		active = 1;
		count = 0;
		prof_on = prof && next >= prof_from && (prof_to < 0 || next <= prof_to) &&
			  (next - prof_from) % prof_every == 0;
	} else if (active) {
		count += t->n;
		if (prof_on)
			((struct tb_info *)udata)->prof += t->n;
	}
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
	(void)id;
	struct tb_info *t = malloc(sizeof *t); /* lives as long as the block */
	uint64_t pc = qemu_plugin_tb_vaddr(tb) & ~(uint64_t)1;
	t->n = qemu_plugin_tb_n_insns(tb);
	t->pc = pc;
	t->prof = 0;
	t->kind = pc == begin_addr ? TB_BEGIN : pc == end_addr ? TB_END : TB_PLAIN;
	t->next = tbs;
	tbs = t;
	qemu_plugin_register_vcpu_tb_exec_cb(tb, tb_exec, QEMU_PLUGIN_CB_NO_REGS, t);
}

static void at_exit(qemu_plugin_id_t id, void *udata)
{
	(void)id, (void)udata;
	if (active)
		report("octo-count: end marker never reached\n");
	else if (regions == 0)
		report("octo-count: no begin/end marker pair executed\n");
	if (out)
		fclose(out);
	if (prof) {
		for (const struct tb_info *t = tbs; t; t = t->next)
			if (t->prof)
				fprintf(prof, "%" PRIu64 " %" PRIu64 "\n", t->pc, t->prof);
		fclose(prof);
	}
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const void *info, int argc, char **argv)
{
	(void)info;
	for (int i = 0; i < argc; i++) {
		if (!strncmp(argv[i], "begin=", 6))
			begin_addr = strtoull(argv[i] + 6, NULL, 0) & ~(uint64_t)1;
		else if (!strncmp(argv[i], "end=", 4))
			end_addr = strtoull(argv[i] + 4, NULL, 0) & ~(uint64_t)1;
		else if (!strncmp(argv[i], "out=", 4) && !(out = fopen(argv[i] + 4, "w")))
			return -1;
		else if (!strncmp(argv[i], "profile=", 8) && !(prof = fopen(argv[i] + 8, "w")))
			return -1;
		else if (!strncmp(argv[i], "from=", 5))
			prof_from = strtol(argv[i] + 5, NULL, 0);
		else if (!strncmp(argv[i], "to=", 3))
			prof_to = strtol(argv[i] + 3, NULL, 0);
		else if (!strncmp(argv[i], "every=", 6))
			prof_every = strtol(argv[i] + 6, NULL, 0) > 0 ? strtol(argv[i] + 6, NULL, 0) : 1;
	}
	if (begin_addr == UINT64_MAX || end_addr == UINT64_MAX) {
		qemu_plugin_outs("octo-count: needs begin=ADDR,end=ADDR\n");
		return -1;
	}
	qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
	qemu_plugin_register_atexit_cb(id, at_exit, NULL);
	return 0;
}
