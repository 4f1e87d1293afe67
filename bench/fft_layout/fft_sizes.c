/* FFTW's complex transforms of the FFT operator's slow axis (src/operators/mirror_transform.f90,
 * pruned_transform.f90) at each padded size n: `pairs` contiguous lines of n complex numbers, a
 * line apart by the scratch's odd leading dimension (line_stride in fftw_interfaces.f90), planned
 * with FFTW_ESTIMATE (beadmob's default planner), forward in place. The time of one pass over the
 * lines is the median of 5 batches of `passes` passes; the size's figure is the median of
 * `repeats` such timings, the sizes alternated. Usage: fft_sizes pairs passes repeats n1 n2 ...
 * Prints per size: n, microseconds per line, nanoseconds per point. */
#include <fftw3.h>
#include <stdio.h>
#include <stdlib.h>

#include "timing.h"

int main(int argc, char **argv) {
  if (argc < 5) {
    fprintf(stderr, "usage: fft_sizes pairs passes repeats n1 [n2 ...]\n");
    return 2;
  }
  int pairs = atoi(argv[1]), passes = atoi(argv[2]), repeats = atoi(argv[3]), sizes = argc - 4;
  int *n = malloc(sizeof(int) * sizes);
  fftw_complex **data = malloc(sizeof(fftw_complex *) * sizes);
  fftw_plan *plan = malloc(sizeof(fftw_plan) * sizes);
  double *seconds = malloc(sizeof(double) * sizes * repeats);
  for (int s = 0; s < sizes; s++) {
    n[s] = atoi(argv[4 + s]);
    int lead = n[s] + 1 - n[s] % 2; /* line_stride */
    data[s] = fftw_alloc_complex((size_t)lead * pairs);
    fftw_iodim along = {n[s], 1, 1};
    fftw_iodim across = {pairs, lead, lead};
    plan[s] = fftw_plan_guru_dft(1, &along, 1, &across, data[s], data[s], FFTW_FORWARD, FFTW_ESTIMATE);
    for (size_t i = 0; i < (size_t)lead * pairs; i++) {
      data[s][i][0] = (double)(i % 13) - 6.0;
      data[s][i][1] = 0.0;
    }
  }
  for (int r = 0; r < repeats; r++)
    for (int s = 0; s < sizes; s++) {
      double batch[5];
      for (int b = 0; b < 5; b++) {
        double t0 = now();
        for (int p = 0; p < passes; p++) fftw_execute(plan[s]);
        batch[b] = (now() - t0) / passes;
      }
      seconds[s * repeats + r] = median(batch, 5);
    }
  for (int s = 0; s < sizes; s++) {
    double pass = median(seconds + s * repeats, repeats);
    printf("%d %.3f %.4f\n", n[s], 1e6 * pass / pairs, 1e9 * pass / pairs / n[s]);
  }
  return 0;
}
