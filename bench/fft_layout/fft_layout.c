/* The slow-axis transform of the FFT operator (src/operators/mirror_transform.f90, pruned_transform.f90),
 * timed in its two layouts with FFTW's two planners. One middle line holds `pairs` complex numbers
 * per slow-axis site (the row of fast frequencies and fields; in the mirror-class transform two real lines per complex one) and
 * n_slow sites; a rank holds `lines` middle lines.
 *   strided:    the row contiguous, each slow-axis line a row apart (the layout of the spectrum;
 *               beadmob before 3e95435 transformed it in place like this)
 *   contiguous: each slow-axis line contiguous, one line's scratch (beadmob since 3e95435)
 * Each case is timed `repeats` times (alternating the four), each time the median of 5 batches of
 * transforms; the table takes the median over repeats. Usage: fft_layout n_slow pairs lines repeats */
#include <fftw3.h>
#include <stdio.h>
#include <stdlib.h>

#include "timing.h"

/* seconds of one pass over all lines: the median of 5 batches */
static double time_pass(fftw_plan p, fftw_complex *data, size_t line_stride, int lines, int per_line) {
  double batch[5];
  for (int b = 0; b < 5; b++) {
    double t0 = now();
    if (per_line)
      for (int l = 0; l < lines; l++) fftw_execute_dft(p, data + l * line_stride, data + l * line_stride);
    else
      fftw_execute(p);
    batch[b] = now() - t0;
  }
  return median(batch, 5);
}

int main(int argc, char **argv) {
  if (argc != 5) {
    fprintf(stderr, "usage: fft_layout n_slow pairs lines repeats\n");
    return 2;
  }
  int n = atoi(argv[1]), pairs = atoi(argv[2]), lines = atoi(argv[3]), repeats = atoi(argv[4]);
  size_t line_size = (size_t)n * pairs;
  fftw_complex *strided = fftw_alloc_complex(line_size * lines);
  fftw_complex *contiguous = fftw_alloc_complex(line_size * lines);
  fftw_plan plan[4];
  double planning[4];
  /* strided: length n, stride pairs; vectors: the pairs (stride 1) and the lines */
  fftw_iodim along = {n, pairs, pairs};
  fftw_iodim across[2] = {{pairs, 1, 1}, {lines, (int)line_size, (int)line_size}};
  /* contiguous: length n, stride 1; vectors: the pairs of one line (stride n) */
  fftw_iodim along_c = {n, 1, 1};
  fftw_iodim across_c[1] = {{pairs, n, n}};
  unsigned flags[2] = {FFTW_ESTIMATE, FFTW_MEASURE};
  for (int f = 0; f < 2; f++) {
    double t0 = now();
    plan[2 * f] = fftw_plan_guru_dft(1, &along, 2, across, strided, strided, FFTW_FORWARD, flags[f]);
    planning[2 * f] = now() - t0;
    t0 = now();
    plan[2 * f + 1] = fftw_plan_guru_dft(1, &along_c, 1, across_c, contiguous, contiguous, FFTW_FORWARD, flags[f]);
    planning[2 * f + 1] = now() - t0;
  }
  for (size_t i = 0; i < line_size * lines; i++) {
    strided[i][0] = contiguous[i][0] = (double)(i % 13) - 6.0;
    strided[i][1] = contiguous[i][1] = 0.0;
  }
  double *seconds = malloc(sizeof(double) * 4 * repeats);
  for (int r = 0; r < repeats; r++)
    for (int c = 0; c < 4; c++)
      seconds[c * repeats + r] = c % 2 ? time_pass(plan[c], contiguous, line_size, lines, 1)
                                       : time_pass(plan[c], strided, line_size, lines, 0);
  /* n pairs lines | strided estimate, contiguous estimate, strided measure, contiguous measure (ms)
     | planning of the measured plans (s) */
  printf("%d %d %d", n, pairs, lines);
  for (int c = 0; c < 4; c++) printf(" %.4f", 1e3 * median(seconds + c * repeats, repeats));
  printf(" %.3f %.3f\n", planning[2], planning[3]);
  return 0;
}
