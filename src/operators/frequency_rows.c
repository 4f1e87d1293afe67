/* The FFT operator's frequency product (docs/theory.md T4, "The frequency product in real
 * arithmetic") on ROW_CHUNK consecutive frequencies of one row of the kernel and two real columns:
 *   w(k, c, s) = sum_t K'_k(s, t) z(k, c, t),  K'_k(s, t) = factor[e] kernel[entry[e] row_stride + k]
 * for the packed entry e of (s, t), s <= t, the upper triangle by columns. The frequencies are the
 * innermost index, so the loops are vector operations over them; the function is compiled for the
 * x86-64-v3 level (AVX2 and FMA) and for the build's default, and the processor picks one when the
 * program loads (GCC's target_clones), so one binary runs on every x86-64 node. In C because
 * gfortran has no such attribute; frequency_rows.f90 declares it (ROW_CHUNK there: row_chunk). */
#include <stddef.h>

#define ROW_CHUNK 8

/* BEADMOB_NO_CLONES: set by CMake where a test program with target_clones does not build. */
#if defined(__GNUC__) && __GNUC__ >= 11 && !defined(__clang__) && defined(__x86_64__) && !defined(BEADMOB_NO_CLONES)
#define BEADMOB_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define BEADMOB_CLONES
#endif

/* z, w: [slot][column 0, 1][frequency], ROW_CHUNK frequencies each (Fortran (ROW_CHUNK, 2, nb)) */
static inline void chunk_product(int nb, int row_stride, const double *restrict kernel, const int *restrict entry,
                                 const double *restrict factor, const double *restrict z, double *restrict w) {
  for (int i = 0; i < 2 * ROW_CHUNK * nb; i++) w[i] = 0.0;
  int e = 0;
  for (int t = 0; t < nb; t++) {
    const double *z_t = z + 2 * ROW_CHUNK * t;
    double *w_t = w + 2 * ROW_CHUNK * t;
    double column_t[2 * ROW_CHUNK] = {0.0};   /* row t's sum over s < t, kept in registers */
    for (int s = 0; s < t; s++, e++) {
      const double *k_st = kernel + (size_t)entry[e] * row_stride;
      const double f = factor[e];
      const double *z_s = z + 2 * ROW_CHUNK * s;
      double *w_s = w + 2 * ROW_CHUNK * s;
      for (int c = 0; c < 2; c++)
        for (int k = 0; k < ROW_CHUNK; k++) {
          const double a = f * k_st[k];
          w_s[c * ROW_CHUNK + k] += a * z_t[c * ROW_CHUNK + k];
          column_t[c * ROW_CHUNK + k] += a * z_s[c * ROW_CHUNK + k];
        }
    }
    const double *k_tt = kernel + (size_t)entry[e] * row_stride;
    const double f = factor[e];
    e++;
    for (int c = 0; c < 2; c++)
      for (int k = 0; k < ROW_CHUNK; k++)
        w_t[c * ROW_CHUNK + k] += column_t[c * ROW_CHUNK + k] + f * k_tt[k] * z_t[c * ROW_CHUNK + k];
  }
}

/* The product as the processor runs it: the clone for its level. */
BEADMOB_CLONES
void beadmob_chunk_product(int nb, int row_stride, const double *restrict kernel, const int *restrict entry,
                           const double *restrict factor, const double *restrict z, double *restrict w) {
  chunk_product(nb, row_stride, kernel, entry, factor, z, w);
}

/* The same for the build's default target only, whatever the processor: what a node without AVX2
   runs, here so that the tests check it on every machine (test_frequency_rows). */
void beadmob_chunk_product_default(int nb, int row_stride, const double *restrict kernel,
                                   const int *restrict entry, const double *restrict factor,
                                   const double *restrict z, double *restrict w) {
  chunk_product(nb, row_stride, kernel, entry, factor, z, w);
}
