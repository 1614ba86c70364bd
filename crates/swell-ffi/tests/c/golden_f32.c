/* The single-precision fast path through the C ABI: checks proto/vectors/surface_f32_v1.json bit
 * for bit (input prepared by tests/c_abi.rs): per point, the height query with f32 evaluation
 * (binary64 bits) and the f32 batch's displacement and normal of the point taken as undisplaced
 * (binary32 bits).
 *
 * Input: "case <name>", "spec <n>\n<json>", then per point
 * "point <t> <x> <z> <height> <d0> <d1> <d2> <n0> <n1> <n2>" (t, x, z, height: hex binary64;
 * the rest hex binary32), and "end". Prints "N passed, M failed". */
#include "common.h"

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
  SwellQueryOptions f32;
  CHECK(swell_query_options_default(&f32));
  f32.precision = 1;
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
      double height = read_hex(f);
      float want[6];
      for (int i = 0; i < 6; i++) want[i] = read_hex32(f);
      SwellPoint p;
      SwellPointF32 q;
      CHECK(swell_surface_sample(surface, t, xz, 1, SWELL_FIELD_ALL, &f32, &p));
      CHECK(swell_surface_displacement_normal_f32(surface, t, xz, 1, &q));
      int bad = double_to_bits(p.height) != double_to_bits(height);
      for (int i = 0; i < 3; i++) {
        bad |= memcmp(&q.displacement[i], &want[i], sizeof(float)) != 0;
        bad |= memcmp(&q.normal[i], &want[3 + i], sizeof(float)) != 0;
      }
      if (bad) {
        fprintf(stderr, "%s t=%.17g (%.17g, %.17g): height %.17g want %.17g; d %.9g %.9g %.9g want %.9g %.9g %.9g\n",
                name, t, xz[0], xz[1], p.height, height, q.displacement[0], q.displacement[1],
                q.displacement[2], want[0], want[1], want[2]);
        failed++;
      } else {
        passed++;
      }
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
