/* Helpers shared by the C tests: reading the inputs that tests/c_abi.rs writes (whitespace-
 * separated tokens; doubles as IEEE-754 bit patterns in hex, so no decimal conversion can
 * change a bit; JSON texts as a byte count and the bytes). */
#ifndef SWELL_TEST_COMMON_H
#define SWELL_TEST_COMMON_H

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell.h"

static inline double bits_to_double(uint64_t b) {
  double d;
  memcpy(&d, &b, sizeof d);
  return d;
}

static inline uint64_t double_to_bits(double d) {
  uint64_t b;
  memcpy(&b, &d, sizeof b);
  return b;
}

/* Reads one hex bit pattern as a double; exits on malformed input. */
static inline double read_hex(FILE *f) {
  uint64_t b;
  if (fscanf(f, "%" SCNx64, &b) != 1) {
    fprintf(stderr, "malformed input: expected a hex double\n");
    exit(2);
  }
  return bits_to_double(b);
}

/* Reads one hex bit pattern as a float; exits on malformed input. */
static inline float read_hex32(FILE *f) {
  uint32_t b;
  float x;
  if (fscanf(f, "%" SCNx32, &b) != 1) {
    fprintf(stderr, "malformed input: expected a hex float\n");
    exit(2);
  }
  memcpy(&x, &b, sizeof x);
  return x;
}

/* Reads "<n>\n<n bytes>"; the caller frees. */
static inline char *read_text(FILE *f, size_t *len) {
  size_t n;
  if (fscanf(f, "%zu", &n) != 1 || fgetc(f) != '\n') {
    fprintf(stderr, "malformed input: expected a byte count\n");
    exit(2);
  }
  char *buf = malloc(n + 1);
  if (buf == NULL || fread(buf, 1, n, f) != n) {
    fprintf(stderr, "malformed input: short text\n");
    exit(2);
  }
  buf[n] = '\0';
  *len = n;
  return buf;
}

/* Whether two body states have the same bits in every field (not memcmp: the struct's
 * trailing padding is not part of the state and may hold anything). */
static inline int same_state(const SwellBodyState *a, const SwellBodyState *b) {
  const double *x[4] = {a->position, a->rotation, a->velocity, a->angular_velocity};
  const double *y[4] = {b->position, b->rotation, b->velocity, b->angular_velocity};
  const int n[4] = {3, 4, 3, 3};
  if (a->id != b->id || a->quarantined != b->quarantined) return 0;
  if (double_to_bits(a->submerged) != double_to_bits(b->submerged)) return 0;
  for (int v = 0; v < 4; v++)
    for (int i = 0; i < n[v]; i++)
      if (double_to_bits(x[v][i]) != double_to_bits(y[v][i])) return 0;
  return 1;
}

/* Exits with the library's message when a call fails. */
#define CHECK(call)                                                               \
  do {                                                                            \
    SwellStatus st_ = (call);                                                     \
    if (st_ != SWELL_OK) {                                                        \
      fprintf(stderr, "%s:%d: %s failed with %d: %s\n", __FILE__, __LINE__, #call, \
              (int)st_, swell_last_error_message());                              \
      exit(1);                                                                    \
    }                                                                             \
  } while (0)

#endif
