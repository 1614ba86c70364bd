/* The C contract: every failure is a status code with a message, null pointers are reported
 * (never dereferenced), handles free in any order. Prints "N passed, M failed". */
#include "common.h"

static long passed = 0, failed = 0;

static void want(const char *what, SwellStatus got, SwellStatus expected, const char *needle) {
  const char *msg = swell_last_error_message();
  int ok = got == expected && (needle == NULL || strstr(msg, needle) != NULL);
  if (got != SWELL_OK && swell_last_error_code() != got) ok = 0;
  if (ok) {
    passed++;
  } else {
    fprintf(stderr, "%s: got %d (%s), want %d with \"%s\"\n", what, (int)got, msg, (int)expected,
            needle ? needle : "");
    failed++;
  }
}

static const char LAKE[] =
    "{\"tick_hz\": 30, \"seed\": 7, \"depth\": 12, \"layers\": [{\"kind\": \"gerstner\","
    " \"waves\": [{\"amplitude\": 0.25, \"wavelength\": 22, \"direction\": [1, 0.4], \"steepness\": 0.5}]}]}";
static const char BOAT[] =
    "{\"mass\": 3000, \"hull\": {\"kind\": \"box\", \"length\": 8, \"beam\": 3, \"height\": 1.5},"
    " \"position\": [5, 0.4, -3]}";

int main(void) {
  SwellSurface *s = NULL;
  SwellWorld *w = NULL;
  uint64_t id = 0;
  SwellPoint p;
  double h;

  want("model version", swell_model_version() >= 2 ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  want("null out", swell_surface_new(LAKE, strlen(LAKE), NULL), SWELL_ERR_NULL, "out");
  want("null json", swell_surface_new(NULL, 5, &s), SWELL_ERR_NULL, "json");
  want("not json", swell_surface_new("{oops", 5, &s), SWELL_ERR_BAD_JSON, "scene spec");
  want("out cleared on failure", s == NULL ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  const char *unknown = "{\"layers\": [], \"colour\": 1}";
  want("unknown field", swell_surface_new(unknown, strlen(unknown), &s), SWELL_ERR_BAD_JSON, "colour");
  const char *fast = "{\"tick_hz\": 5000, \"layers\": []}";
  want("tick_hz", swell_surface_new(fast, strlen(fast), &s), SWELL_ERR_INVALID_SPEC, "tick_hz");
  const char *steep =
      "{\"layers\": [{\"kind\": \"gerstner\", \"waves\": [{\"amplitude\": 5, \"wavelength\": 10,"
      " \"direction\": [1, 0], \"steepness\": 1}]}]}";
  want("fold number", swell_surface_new(steep, strlen(steep), &s), SWELL_ERR_INVALID_SPEC, NULL);

  want("lake builds", swell_surface_new(LAKE, strlen(LAKE), &s), SWELL_OK, NULL);
  want("null surface", swell_surface_height(NULL, 0.0, 0.0, 0.0, &h), SWELL_ERR_NULL, "surface");
  want("null height out", swell_surface_height(s, 0.0, 0.0, 0.0, NULL), SWELL_ERR_NULL, "out");
  want("nan time", swell_surface_height(s, 0.0 / 0.0, 0.0, 0.0, &h), SWELL_ERR_INVALID_ARGUMENT, "t");
  double xz[2] = {1.0, 1.0 / 0.0};
  want("inf point", swell_surface_sample(s, 1.0, xz, 1, SWELL_FIELD_ALL, NULL, &p),
       SWELL_ERR_INVALID_ARGUMENT, "points[0].z");
  want("no points", swell_surface_sample(s, 1.0, NULL, 0, SWELL_FIELD_ALL, NULL, NULL), SWELL_OK, NULL);
  want("bad fields", swell_surface_sample(s, 1.0, xz, 1, 64, NULL, &p), SWELL_ERR_INVALID_ARGUMENT, "fields");
  SwellQueryOptions o;
  want("default options", swell_query_options_default(&o), SWELL_OK, NULL);
  o.iterations = 100;
  xz[1] = 2.0;
  want("bad options", swell_surface_sample(s, 1.0, xz, 1, SWELL_FIELD_ALL, &o, &p),
       SWELL_ERR_INVALID_ARGUMENT, "iterations");
  SwellFootprint fp = {{0.0, 0.0}, 0.0, 8.0, 3.0};
  SwellOrientation orient;
  want("orientation", swell_surface_orientation(s, 3.0, &fp, NULL, 0, &orient), SWELL_OK, NULL);
  fp.length = -1.0;
  want("bad footprint", swell_surface_orientation(s, 3.0, &fp, NULL, 0, &orient),
       SWELL_ERR_INVALID_ARGUMENT, "length");
  SwellSceneInfo info;
  want("info", swell_surface_info(s, &info), SWELL_OK, NULL);
  want("info values", info.tick_hz == 30.0 && info.layers == 1 && !info.has_fft ? SWELL_OK : SWELL_ERR_PANIC,
       SWELL_OK, NULL);

  want("world", swell_world_new(s, 100, &w), SWELL_OK, NULL);
  /* The world keeps the scene: the surface handle may go first. */
  swell_surface_free(s);
  s = NULL;
  want("bad spawn", swell_world_spawn(w, "{\"mass\": 1}", 11, &id), SWELL_ERR_BAD_JSON, "spawn");
  want("spawn", swell_world_spawn(w, BOAT, strlen(BOAT), &id), SWELL_OK, NULL);
  want("spawn as taken id", swell_world_spawn_as(w, id, BOAT, strlen(BOAT)), SWELL_ERR_NOT_FOUND, "already");
  SwellInput in = {{1000.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 99, 5};
  want("input in the past", swell_world_input(w, id, &in), SWELL_ERR_INVALID_ARGUMENT, "past");
  in.from_tick = SWELL_FROM_NOW;
  in.ticks = 0;
  want("input ticks", swell_world_input(w, id, &in), SWELL_ERR_INVALID_ARGUMENT, "ticks");
  in.ticks = 5;
  want("input unknown body", swell_world_input(w, 42, &in), SWELL_ERR_NOT_FOUND, "42");
  want("input", swell_world_input(w, id, &in), SWELL_OK, NULL);
  want("step", swell_world_step(w), SWELL_OK, NULL);
  want("step_to", swell_world_step_to(w, 110), SWELL_OK, NULL);
  want("step back", swell_world_step_to(w, 105), SWELL_ERR_INVALID_ARGUMENT, "past");
  int64_t tick;
  want("tick", swell_world_tick(w, &tick), SWELL_OK, NULL);
  want("tick value", tick == 110 ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  SwellBodyState st;
  want("state", swell_world_state(w, id, &st), SWELL_OK, NULL);
  want("moved", st.velocity[0] != 0.0 ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  want("set state", swell_world_set_state(w, id, &st), SWELL_OK, NULL);
  st.rotation[0] = st.rotation[1] = st.rotation[2] = st.rotation[3] = 0.0;
  want("degenerate state", swell_world_set_state(w, id, &st), SWELL_ERR_INVALID_ARGUMENT, NULL);
  want("remove", swell_world_remove(w, id), SWELL_OK, NULL);
  want("remove again", swell_world_remove(w, id), SWELL_ERR_NOT_FOUND, NULL);
  want("null world", swell_world_step(NULL), SWELL_ERR_NULL, "world");
  swell_world_free(w);
  swell_world_free(NULL);
  swell_surface_free(NULL);

  /* Regression: swell_world_assign between worlds of two scenes used to keep the destination's
   * FFT frame memo, keyed by layer index and time only, so the copy stepped on the other
   * scene's frames. Two FFT scenes that differ only in their seed. */
  const char *fft_a =
      "{\"seed\": 1, \"layers\": [{\"kind\": \"fft\", \"resolution\": 16, \"tile_size\": 64, \"wind_direction\": [1, 0],"
      " \"spectrum\": {\"kind\": \"phillips\", \"wind_speed\": 12}}]}";
  const char *fft_b =
      "{\"seed\": 2, \"layers\": [{\"kind\": \"fft\", \"resolution\": 16, \"tile_size\": 64, \"wind_direction\": [1, 0],"
      " \"spectrum\": {\"kind\": \"phillips\", \"wind_speed\": 12}}]}";
  SwellSurface *sa = NULL, *sb = NULL;
  SwellWorld *wa = NULL, *wb = NULL;
  want("fft a", swell_surface_new(fft_a, strlen(fft_a), &sa), SWELL_OK, NULL);
  want("fft b", swell_surface_new(fft_b, strlen(fft_b), &sb), SWELL_OK, NULL);
  want("world a", swell_world_new(sa, 0, &wa), SWELL_OK, NULL);
  want("world b", swell_world_new(sb, 0, &wb), SWELL_OK, NULL);
  want("spawn a", swell_world_spawn(wa, BOAT, strlen(BOAT), &id), SWELL_OK, NULL);
  want("spawn b", swell_world_spawn(wb, BOAT, strlen(BOAT), &id), SWELL_OK, NULL);
  /* b's memo then holds its grid frames up to tick 3's; a copy of a at tick 2 steps on the
   * frames of ticks 2 and 3 (the memo drops its oldest frame first, so a copy from tick 0
   * would have evicted each stale frame just before reading it). */
  want("step a", swell_world_step_to(wa, 2), SWELL_OK, NULL);
  want("step b (fills its memo)", swell_world_step_to(wb, 3), SWELL_OK, NULL);
  want("assign a to b", swell_world_assign(wb, wa), SWELL_OK, NULL);
  want("step a on", swell_world_step_to(wa, 4), SWELL_OK, NULL);
  want("step b on", swell_world_step_to(wb, 4), SWELL_OK, NULL);
  SwellBodyState sta, stb;
  want("state a", swell_world_state(wa, id, &sta), SWELL_OK, NULL);
  want("state b", swell_world_state(wb, id, &stb), SWELL_OK, NULL);
  want("assigned world steps on its own scene", same_state(&sta, &stb) ? SWELL_OK : SWELL_ERR_PANIC,
       SWELL_OK, NULL);
  swell_world_free(wa);
  swell_world_free(wb);
  swell_surface_free(sa);
  swell_surface_free(sb);

  /* Impacts: a scene whose bodies make impacts (once refused) makes a world; an API impact is
   * felt from the tick given (a later one waits for it), so a world that feels it differs from
   * one that does not, and a clone carries what is still pending; a boat dropped from 2 m
   * splashes. */
  const char *wharf =
      "{\"layers\": [{\"kind\": \"sine\", \"waves\": [{\"amplitude\": 0.1, \"wavelength\": 20, \"direction\": [1, 0]}]},"
      " {\"kind\": \"particles\", \"count\": 0, \"body_impacts\": {}}]}";
  const char *drop =
      "{\"mass\": 2000, \"hull\": {\"kind\": \"box\", \"length\": 6, \"beam\": 2.5, \"height\": 1.2},"
      " \"position\": [0, 2.5, 0]}";
  SwellSurface *sw = NULL;
  SwellWorld *felt = NULL, *plain = NULL, *copy = NULL;
  want("body_impacts scene", swell_surface_new(wharf, strlen(wharf), &sw), SWELL_OK, NULL);
  want("body_impacts world", swell_world_new(sw, 0, &felt), SWELL_OK, NULL);
  want("drop", swell_world_spawn(felt, drop, strlen(drop), &id), SWELL_OK, NULL);
  want("plain twin", swell_world_clone(felt, &plain), SWELL_OK, NULL);
  SwellImpact hit = {12.0 / 30.0, {2.0, 0.5}, 0.5, 1.0};
  want("feel at tick 10", swell_world_feel_impact(felt, &hit, 10), SWELL_OK, NULL);
  want("clone with a pending impact", swell_world_clone(felt, &copy), SWELL_OK, NULL);
  want("feel in the past", swell_world_step_to(felt, 3) == SWELL_OK
       ? swell_world_feel_impact(felt, &hit, 2) : SWELL_ERR_PANIC, SWELL_ERR_INVALID_ARGUMENT, "at_tick");
  SwellImpact nan_hit = hit;
  nan_hit.radius = 0.0 / 0.0;
  want("bad impact", swell_world_feel_impact(felt, &nan_hit, SWELL_FROM_NOW), SWELL_ERR_INVALID_SPEC,
       "impact.radius");
  want("null impact", swell_world_feel_impact(felt, NULL, 0), SWELL_ERR_NULL, "impact");
  size_t made = 0;
  want("step felt", swell_world_step_to(felt, 30), SWELL_OK, NULL);
  want("step plain", swell_world_step_to(plain, 30), SWELL_OK, NULL);
  want("step copy", swell_world_step_to(copy, 30), SWELL_OK, NULL);
  want("state felt", swell_world_state(felt, id, &sta), SWELL_OK, NULL);
  want("state plain", swell_world_state(plain, id, &stb), SWELL_OK, NULL);
  want("the impact rocks the boat", !same_state(&sta, &stb) ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  want("state copy", swell_world_state(copy, id, &stb), SWELL_OK, NULL);
  want("the clone felt it too", same_state(&sta, &stb) ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  want("made impacts", swell_world_made_impacts(felt, NULL, 0, &made), SWELL_OK, NULL);
  want("one splash", made == 1 ? SWELL_OK : SWELL_ERR_PANIC, SWELL_OK, NULL);
  swell_world_free(felt);
  swell_world_free(plain);
  swell_world_free(copy);
  swell_surface_free(sw);

  printf("%ld passed, %ld failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
