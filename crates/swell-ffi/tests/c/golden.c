/* Golden vectors through the C ABI: builds each case's surface from its spec and checks every
 * output of proto/vectors/surface_v1.json bit for bit (input prepared by tests/c_abi.rs).
 *
 * Input: "case <name>", "spec <n>\n<json>", then per point
 * "point <t> <x> <z> <height> <n0> <n1> <n2> <d0> <d1> <d2> <jacobian> <residual> <folded>"
 * (hex doubles, folded 0/1), and "end". Prints "N passed, M failed". */
#include "common.h"

static int compare(const char *name, const char *what, double got, double want, double t,
                   double x, double z) {
  if (double_to_bits(got) == double_to_bits(want)) return 0;
  fprintf(stderr, "%s t=%.17g (%.17g, %.17g): %s is %.17g (%016" PRIx64 "), want %.17g (%016" PRIx64 ")\n",
          name, t, x, z, what, got, double_to_bits(got), want, double_to_bits(want));
  return 1;
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s INPUT\n", argv[0]);
    return 2;
  }
  FILE *f = fopen(argv[1], "r");
  if (f == NULL) {
    perror(argv[1]);
    return 2;
  }
  char word[64], name[256] = "";
  SwellSurface *surface = NULL;
  long passed = 0, failed = 0;
  while (fscanf(f, "%63s", word) == 1) {
    if (strcmp(word, "case") == 0) {
      if (fscanf(f, "%255s", name) != 1) return 2;
    } else if (strcmp(word, "spec") == 0) {
      size_t len;
      char *json = read_text(f, &len);
      swell_surface_free(surface);
      CHECK(swell_surface_new(json, len, &surface));
      free(json);
    } else if (strcmp(word, "point") == 0) {
      double t = read_hex(f), xz[2];
      xz[0] = read_hex(f);
      xz[1] = read_hex(f);
      double want[9];
      for (int i = 0; i < 9; i++) want[i] = read_hex(f);
      int folded;
      if (fscanf(f, "%d", &folded) != 1) return 2;
      SwellPoint p;
      CHECK(swell_surface_sample(surface, t, xz, 1, SWELL_FIELD_ALL, NULL, &p));
      int bad = 0;
      bad += compare(name, "height", p.height, want[0], t, xz[0], xz[1]);
      for (int i = 0; i < 3; i++) bad += compare(name, "normal", p.normal[i], want[1 + i], t, xz[0], xz[1]);
      for (int i = 0; i < 3; i++)
        bad += compare(name, "displacement", p.displacement[i], want[4 + i], t, xz[0], xz[1]);
      bad += compare(name, "jacobian", p.jacobian, want[7], t, xz[0], xz[1]);
      bad += compare(name, "residual", p.residual, want[8], t, xz[0], xz[1]);
      if (p.folded != folded) {
        fprintf(stderr, "%s: folded is %d, want %d\n", name, p.folded, folded);
        bad++;
      }
      /* The single-point height call answers the same bits as the batch. */
      double h;
      CHECK(swell_surface_height(surface, t, xz[0], xz[1], &h));
      bad += compare(name, "swell_surface_height", h, want[0], t, xz[0], xz[1]);
      if (bad) failed++; else passed++;
    } else if (strcmp(word, "end") == 0) {
      break;
    } else {
      fprintf(stderr, "malformed input: %s\n", word);
      return 2;
    }
  }
  swell_surface_free(surface);
  fclose(f);
  printf("%ld passed, %ld failed\n", passed, failed);
  return failed == 0 && passed > 0 ? 0 : 1;
}
