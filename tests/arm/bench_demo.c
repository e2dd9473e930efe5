/*
 * bench_demo.c - the insn-count plugin's reference measurement: one 4x8 float
 * matrix-vector product y = A x between the two markers (toolchain-notes.md:
 * about 190 instructions on Cortex-M4F, about 5,700 on Cortex-M0 with soft float).
 * `make arm-count` builds this for both targets and prints the counts.
 */
#include <stdio.h>

#include "bench_mark.h"

#define ROWS 4
#define COLS 8

/* external linkage: the compiler cannot assume their contents at the call */
float demo_a[ROWS][COLS], demo_x[COLS], demo_y[ROWS];

static __attribute__((noinline)) void matvec(const float a[ROWS][COLS], const float x[COLS], float y[ROWS])
{
	for (int i = 0; i < ROWS; i++) {
		float s = 0.0f;
		for (int j = 0; j < COLS; j++)
			s += a[i][j] * x[j];
		y[i] = s;
	}
}

int main(void)
{
	for (int i = 0; i < ROWS; i++)
		for (int j = 0; j < COLS; j++)
			demo_a[i][j] = (float)(i + 1) * 0.5f - (float)j * 0.25f;
	for (int j = 0; j < COLS; j++)
		demo_x[j] = 1.0f + (float)j * 0.125f;

	bench_mark_begin();
	matvec(demo_a, demo_x, demo_y);
	bench_mark_end();

	printf("y = %.6g %.6g %.6g %.6g\n", (double)demo_y[0], (double)demo_y[1], (double)demo_y[2], (double)demo_y[3]);
	return 0;
}
