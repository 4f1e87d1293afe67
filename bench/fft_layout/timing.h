/* The clock and the median of fft_layout.c and fft_sizes.c. */
#ifndef BEADMOB_BENCH_TIMING_H
#define BEADMOB_BENCH_TIMING_H
#include <stdlib.h>
#include <time.h>

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int by_value(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* the median of v[0 .. n - 1] (sorts v) */
static double median(double *v, int n) {
  qsort(v, n, sizeof(double), by_value);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
#endif
