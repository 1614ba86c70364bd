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
