/*
 * size_main.c - an empty program, linked twice per target to measure the flash
 * and RAM the core really costs: once alone, once with every global function of
 * the core kept (-Wl,--undefined=...); the difference is the core plus what it
 * pulls from libgcc and libm (soft-float arithmetic on M0, sinf, atan2f...).
 */
int main(void);

int main(void) { return 0; }
