/* A body log replayed through the C ABI: for each case, the scene, the world's anchor tick,
 * spawns and inputs at their ticks; every body's state at every tick must have the bits the
 * server's body code reached (proto/vectors/bodies_v1.json, input prepared by tests/c_abi.rs).
 *
 * It also replays each case a second time the way a predicting client does: a confirmed copy
 * of the world (swell_world_clone) kept at a tick the server sent, a prediction stepped ahead
 * from it, then rewound (swell_world_assign) and stepped again: the same bits.
 *
 * Input: "case <name>", "scene <n>\n<json>", "anchor <tick>",
 * "spawn <tick> <id> <n>\n<json>", "input <tick> <id> <fx> <fy> <fz> <tx> <ty> <tz> <from> <ticks>"
 * (from = "now" for the current tick), "expect <tick> <id> <13 hex: position, rotation,
 * velocity, angular velocity> <submerged hex> <quarantined>", "done" (end of a case), "end".
 * Prints "N passed, M failed". */
#include "common.h"

static long passed = 0, failed = 0;

static int same(double a, double b) { return double_to_bits(a) == double_to_bits(b); }

static void expect(const char *name, SwellWorld *w, int64_t tick, uint64_t id, const double *want,
                   double submerged, int quarantined) {
  SwellBodyState s;
  CHECK(swell_world_state(w, id, &s));
  const double *got[4] = {s.position, s.rotation, s.velocity, s.angular_velocity};
  const int n[4] = {3, 4, 3, 3};
  const char *what[4] = {"position", "rotation", "velocity", "angular_velocity"};
  int bad = 0, k = 0;
  for (int v = 0; v < 4; v++)
    for (int i = 0; i < n[v]; i++, k++)
      if (!same(got[v][i], want[k])) {
        fprintf(stderr, "%s tick %" PRId64 " body %" PRIu64 ": %s[%d] is %.17g, want %.17g\n", name,
                tick, id, what[v], i, got[v][i], want[k]);
        bad = 1;
      }
  if (!same(s.submerged, submerged) || s.quarantined != quarantined) {
    fprintf(stderr, "%s tick %" PRId64 " body %" PRIu64 ": submerged/quarantined differ\n", name, tick, id);
    bad = 1;
  }
  if (bad) failed++; else passed++;
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
  SwellWorld *world = NULL;
  /* The prediction check: a confirmed copy taken at the first expectation past 10 ticks. */
  SwellWorld *confirmed = NULL;
  int64_t anchor = 0;
  while (fscanf(f, "%63s", word) == 1) {
    if (strcmp(word, "case") == 0) {
      if (fscanf(f, "%255s", name) != 1) return 2;
    } else if (strcmp(word, "scene") == 0) {
      size_t len;
      char *json = read_text(f, &len);
      swell_surface_free(surface);
      CHECK(swell_surface_new(json, len, &surface));
      free(json);
    } else if (strcmp(word, "anchor") == 0) {
      if (fscanf(f, "%" SCNd64, &anchor) != 1) return 2;
      swell_world_free(world);
      CHECK(swell_world_new(surface, anchor, &world));
    } else if (strcmp(word, "spawn") == 0) {
      int64_t tick;
      uint64_t id, got;
      if (fscanf(f, "%" SCNd64 " %" SCNu64, &tick, &id) != 2) return 2;
      size_t len;
      char *json = read_text(f, &len);
      CHECK(swell_world_step_to(world, tick));
      CHECK(swell_world_spawn(world, json, len, &got));
      free(json);
      if (got != id) {
        fprintf(stderr, "%s: spawn gave id %" PRIu64 ", want %" PRIu64 "\n", name, got, id);
        failed++;
      }
    } else if (strcmp(word, "input") == 0) {
      int64_t tick;
      uint64_t id;
      if (fscanf(f, "%" SCNd64 " %" SCNu64, &tick, &id) != 2) return 2;
      SwellInput in;
      for (int i = 0; i < 3; i++) in.force[i] = read_hex(f);
      for (int i = 0; i < 3; i++) in.torque[i] = read_hex(f);
      char from[32];
      if (fscanf(f, "%31s %" SCNu64, from, &in.ticks) != 2) return 2;
      in.from_tick = strcmp(from, "now") == 0 ? SWELL_FROM_NOW : strtoll(from, NULL, 10);
      CHECK(swell_world_step_to(world, tick));
      CHECK(swell_world_input(world, id, &in));
    } else if (strcmp(word, "expect") == 0) {
      int64_t tick;
      uint64_t id;
      if (fscanf(f, "%" SCNd64 " %" SCNu64, &tick, &id) != 2) return 2;
      double want[13];
      for (int i = 0; i < 13; i++) want[i] = read_hex(f);
      double submerged = read_hex(f);
      int quarantined;
      if (fscanf(f, "%d", &quarantined) != 1) return 2;
      CHECK(swell_world_step_to(world, tick));
      expect(name, world, tick, id, want, submerged, quarantined);
      if (confirmed == NULL && tick >= anchor + 10) {
        /* The client's loop: keep what the server confirmed, predict ahead, rewind to the
         * confirmed world, step again: the same bits as a copy that never ran ahead. */
        CHECK(swell_world_clone(world, &confirmed));
        SwellWorld *ahead = NULL, *straight = NULL;
        CHECK(swell_world_clone(confirmed, &ahead));
        CHECK(swell_world_clone(confirmed, &straight));
        CHECK(swell_world_step_to(ahead, tick + 7));
        CHECK(swell_world_assign(ahead, confirmed));
        CHECK(swell_world_step_to(ahead, tick + 3));
        CHECK(swell_world_step_to(straight, tick + 3));
        SwellBodyState a, b;
        CHECK(swell_world_state(ahead, id, &a));
        CHECK(swell_world_state(straight, id, &b));
        if (!same_state(&a, &b)) {
          fprintf(stderr, "%s: a rewound prediction left the trajectory\n", name);
          failed++;
        } else {
          passed++;
        }
        swell_world_free(straight);
        swell_world_free(ahead);
      }
    } else if (strcmp(word, "done") == 0) {
      swell_world_free(confirmed);
      confirmed = NULL;
    } else if (strcmp(word, "end") == 0) {
      break;
    } else {
      fprintf(stderr, "malformed input: %s\n", word);
      return 2;
    }
  }
  swell_world_free(confirmed);
  swell_world_free(world);
  swell_surface_free(surface);
  fclose(f);
  printf("%ld passed, %ld failed\n", passed, failed);
  return failed == 0 && passed > 0 ? 0 : 1;
}
