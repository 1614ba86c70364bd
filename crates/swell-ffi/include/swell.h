/* Swell's C ABI: the wave model and body world of crates/swell-ffi.
 * Generated from the crate's source by cbindgen (crates/swell-ffi/cbindgen.toml); do not edit.
 * Regenerate: SWELL_BLESS_HEADER=1 cargo test -p swell-ffi --test header */

#ifndef SWELL_H
#define SWELL_H

#include <stddef.h>
#include <stdint.h>

// Ask for the height at the world point (with inversion of the horizontal displacement).
#define SWELL_FIELD_HEIGHT 1

// Ask for the unit normal of the displaced surface at the world point.
#define SWELL_FIELD_NORMAL 2

// Ask for the displacement `(Dx, y, Dz)` of the world point taken as an undisplaced point.
#define SWELL_FIELD_DISPLACEMENT 4

// Ask for the Jacobian determinant and the fold flag.
#define SWELL_FIELD_JACOBIAN 8

// Ask for the inversion residual.
#define SWELL_FIELD_RESIDUAL 16

// Every field (what the golden vectors pin).
#define SWELL_FIELD_ALL 31

// `from_tick` of a [`SwellInput`] that acts from the world's current tick (the next one it
// steps), the server's default.
#define SWELL_FROM_NOW INT64_MIN

// Most ticks one input may act for (the server's limit).
#define SWELL_MAX_INPUT_TICKS 10000000

// A built scene (opaque). Made by [`swell_surface_new`], freed by [`swell_surface_free`].
// Queries on one surface may run on several threads at once; body worlds made from it keep
// what they need, so it may be freed before them.
typedef struct SwellSurface SwellSurface;

// A scene's body world (opaque). Made by [`swell_world_new`] or [`swell_world_clone`], freed by
// [`swell_world_free`]. Not for use by two threads at once.
typedef struct SwellWorld SwellWorld;

// What every fallible function returns: [`SWELL_OK`] or one of the `SWELL_ERR_*` codes.
// On an error, [`swell_last_error_message`] says what was wrong.
typedef int32_t SwellStatus;

// An impact on the scene's particle layer, as `GET /v1/scenes/{id}/impacts` and tick frames
// list them: a ring of ripples spreading from `position` from scene time `t`.
typedef struct SwellImpact {
  // Scene time of the impact, s.
  double t;
  // World `[x, z]` of the impact, m.
  double position[2];
  // Height of the splash at the impact point at `t`, m, in (0, 100].
  double strength;
  // Radius of the ring's particles, m, in [0.01, 1000].
  double radius;
} SwellImpact;

// What a scene is: its rates and the few facts a client branches on.
typedef struct SwellSceneInfo {
  // Ticks per second of scene time (the body world's step rate), Hz.
  double tick_hz;
  // Gravity of the sea, m/s².
  double gravity;
  // Unix time of t = 0, s, when `has_epoch` is 1.
  double epoch;
  // 1 if the spec gives an epoch.
  int32_t has_epoch;
  // 1 if any layer is an FFT layer (queries at a new grid time compute frames).
  int32_t has_fft;
  // 1 if the bodies make impacts of their own (splashes and wakes: a body world then needs
  // every body of the server's to follow it).
  int32_t has_body_impacts;
  // Number of layers.
  uint32_t layers;
  // The fold number `Σ Q·k·A` of the analytic layers (< 1).
  double fold_number;
  // The model version the numbers belong to (`swell_waves::MODEL_VERSION`).
  uint32_t model_version;
} SwellSceneInfo;

// Query settings, as the server's `accuracy` object. [`swell_query_options_default`] fills in
// the server's defaults; pass null to a query to use them.
typedef struct SwellQueryOptions {
  // Inversion method: 0 Newton (default), 1 fixed point.
  int32_t method;
  // Most inversion steps, 0..=64. Default 8.
  uint32_t iterations;
  // Inversion tolerance, m (finite, >= 0). Default 1e-5.
  double tolerance;
  // FFT grid filter: 0 bicubic (default), 1 bilinear, 2 nearest.
  int32_t filter;
  // Arithmetic: 0 f64 (default, the model's reference bits), 1 the f32 fast path.
  int32_t precision;
  // FFT time sampling: 0 grid (default, linear between grid frames), 1 exact.
  int32_t time;
} SwellQueryOptions;

// The answers for one world point; fields not asked read 0 (the normal straight up, the
// Jacobian 1).
typedef struct SwellPoint {
  // Elevation of the surface above the world point, m.
  double height;
  // Unit normal `[x, y, z]` of the displaced surface there.
  double normal[3];
  // `[Dx, y, Dz]` of the world point taken as undisplaced, m.
  double displacement[3];
  // Jacobian determinant of the horizontal map at the source point.
  double jacobian;
  // Inversion residual, m.
  double residual;
  // 1 where the surface folds (`jacobian <= 0`), else 0.
  int32_t folded;
} SwellPoint;

// A body's footprint for [`swell_surface_orientation`] (the server's `orientation` request).
typedef struct SwellFootprint {
  // World `[x, z]` of the body origin, m.
  double position[2];
  // Yaw, rad (about +y), within ±1e9.
  double yaw;
  // Length, m, in (0, 10 km].
  double length;
  // Beam, m, in (0, 10 km].
  double beam;
} SwellFootprint;

// A footprint's orientation on the sea: the plane fitted through its probe heights.
typedef struct SwellOrientation {
  // Height of the fitted plane at the body origin, m.
  double heave;
  // World rotation quaternion `[x, y, z, w]`.
  double rotation[4];
  // Unit normal of the plane.
  double normal[3];
  // Pitch, rad (bow up positive).
  double pitch;
  // Roll, rad.
  double roll;
} SwellOrientation;

// One point of [`swell_surface_displacement_normal_f32`], in single precision.
typedef struct SwellPointF32 {
  // `[Dx, y, Dz]` of the point taken as undisplaced, m.
  float displacement[3];
  // Unit normal `[x, y, z]` of the displaced surface there.
  float normal[3];
} SwellPointF32;

// A force and torque on one body for a span of ticks (the server's body input).
typedef struct SwellInput {
  // Force `[x, y, z]` in the body frame, N (x forward: thrust).
  double force[3];
  // Torque `[x, y, z]` in the body frame, N·m (y: rudder/yaw).
  double torque[3];
  // First scene tick it acts on, not before the world's current tick; [`SWELL_FROM_NOW`] for
  // the current tick.
  int64_t from_tick;
  // Number of ticks it acts for, 1..=10⁷.
  uint64_t ticks;
} SwellInput;

// One body's state, as the server streams it.
typedef struct SwellBodyState {
  // The body's id.
  uint64_t id;
  // World position of the body origin, m.
  double position[3];
  // World rotation quaternion `[x, y, z, w]`.
  double rotation[4];
  // Linear velocity, m/s.
  double velocity[3];
  // Angular velocity (world frame), rad/s.
  double angular_velocity[3];
  // Submerged fraction of the hull volume after the last step, in [0, 1].
  double submerged;
  // 1 if the last step was rolled back (the state had turned non-finite).
  int32_t quarantined;
} SwellBodyState;

// Success.
#define SWELL_OK 0

// A pointer the function needs was null.
#define SWELL_ERR_NULL 1

// Text that is not UTF-8 or not JSON, or JSON of the wrong shape (a wrongly typed or unknown
// field): the server answers 400 `bad_json` for the same text.
#define SWELL_ERR_BAD_JSON 2

// A spec the model rejects (a value out of range, an inconsistent layer): the server answers
// 422 `invalid_spec` for the same spec.
#define SWELL_ERR_INVALID_SPEC 3

// An argument out of range: a non-finite time or coordinate, a tick in the past, a bad span or
// option.
#define SWELL_ERR_INVALID_ARGUMENT 4

// No body with that id in the world (or one already has the id asked for).
#define SWELL_ERR_NOT_FOUND 5

// Something this ABI cannot reproduce to the server's bits. No function returns it at present
// (body worlds of scenes with `body_impacts` were refused with it before they derived
// splashes and wakes); kept so the codes stay what they were.
#define SWELL_ERR_UNSUPPORTED 6

// A bug in the library: a panic was caught at the boundary. The handle involved may be left
// in any state that is safe to free; please report the message.
#define SWELL_ERR_PANIC 7

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// The model version the library's numbers belong to (`swell_waves::MODEL_VERSION`): compare it
// with the server's to know you evaluate the same sea.
uint32_t swell_model_version(void);

// The message of the most recent call on this thread that failed (UTF-8, NUL-terminated);
// an empty string if none has. Never null. The text stays valid until the next failing call on
// the same thread: copy it to keep it.
const char *swell_last_error_message(void);

// The code of the most recent call on this thread that failed ([`SWELL_OK`] if none has).
SwellStatus swell_last_error_code(void);

// Sets the impacts whose ripples the surface's queries include, replacing the set before
// (`n` = 0 clears it): pass the scene's impacts as `GET /v1/scenes/{id}/impacts` lists them
// (and add those tick frames announce), and queries give the server's bits for the same set.
// Safe to call while other threads query: each query uses the set in force when it starts.
// Body worlds feel API impacts through `swell_world_feel_impact`.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] naming `impacts[i]` for an
// impact the model rejects (a non-finite or out-of-range value), or more impacts than a scene
// holds.
//
// # Safety
// `surface` a live handle; `impacts` readable for `n` impacts (null when `n` is 0).
SwellStatus swell_surface_set_impacts(const struct SwellSurface *surface,
                                      const struct SwellImpact *impacts,
                                      size_t n);

// Builds a scene from its JSON spec (UTF-8, `len` bytes, no terminator needed): exactly the
// text the server accepts for `PUT /v1/scenes/{id}` (`description`, `tick_hz`, `epoch` and the
// surface: `seed`, `gravity`, `depth`, `layers`). On success `*out` holds a new handle.
//
// Building an FFT layer draws its spectrum (milliseconds for 256²).
//
// # Errors
// [`crate::SWELL_ERR_NULL`] (`out`, or `json` with `len > 0`), [`crate::SWELL_ERR_BAD_JSON`],
// [`crate::SWELL_ERR_INVALID_SPEC`].
//
// # Safety
// `json` must point to `len` readable bytes; `out` must be writable.
SwellStatus swell_surface_new(const char *json, size_t len, struct SwellSurface **out);

// Frees a surface handle. Null is ignored.
//
// # Safety
// `surface` must be null or a handle from [`swell_surface_new`] not yet freed, used by no other
// thread during the call.
void swell_surface_free(struct SwellSurface *surface);

// Fills `*out` with what the scene is.
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `surface` must be a live handle (or null); `out` writable (or null).
SwellStatus swell_surface_info(const struct SwellSurface *surface, struct SwellSceneInfo *out);

// Fills `*out` with the server's default query settings (its `accuracy` defaults).
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `out` must be writable (or null).
SwellStatus swell_query_options_default(struct SwellQueryOptions *out);

// Queries `n` world points `points[2i], points[2i+1]` = `(x, z)` at scene time `t` (s), asking
// the fields in the `fields` mask (`SWELL_FIELD_*`), with `options` (null: the defaults), into
// `out[0..n]`. The same bits as the server's `/sample` with the same accuracy.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t` or
// coordinate, an unknown field bit, or bad options.
//
// # Safety
// `surface` a live handle; `points` readable for `2n` doubles and `out` writable for `n`
// points (both may be null when `n` is 0); `options` null or readable.
SwellStatus swell_surface_sample(const struct SwellSurface *surface,
                                 double t,
                                 const double *points,
                                 size_t n,
                                 uint32_t fields,
                                 const struct SwellQueryOptions *options,
                                 struct SwellPoint *out);

// Height at world `(x, z)` at scene time `t`, with the default accuracy (the server's
// `/height`): `*out` in m.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite input.
//
// # Safety
// `surface` a live handle (or null); `out` writable (or null).
SwellStatus swell_surface_height(const struct SwellSurface *surface,
                                 double t,
                                 double x,
                                 double z,
                                 double *out);

// Orientation of a body footprint at scene time `t` (the server's `orientation` query, default
// accuracy): the plane through the heights at its probes. `probes` holds `n_probes` points
// `[u, v]` in the body frame (m, u along the length); null with `n_probes` 0 gives the default
// 3×3 grid over the footprint.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t`,
// position or yaw, a yaw beyond ±1e9 rad, or a footprint the model rejects (size, probes).
//
// # Safety
// `surface` a live handle; `footprint` readable; `probes` readable for `2·n_probes` doubles
// (or null when 0); `out` writable.
SwellStatus swell_surface_orientation(const struct SwellSurface *surface,
                                      double t,
                                      const struct SwellFootprint *footprint,
                                      const double *probes,
                                      size_t n_probes,
                                      struct SwellOrientation *out);

// The single-precision fast path for rendering: displacement and normal of `n` undisplaced
// points `points[2i], points[2i+1]` = `(x0, z0)` at scene time `t`, into `out[0..n]` (phases
// reduced in f64, then f32 sin/cos and sums; a few micrometres off the f64 model, several
// times cheaper, and just as deterministic: `proto/vectors/surface_f32_v1.json` pins it).
// FFT layers are read from their grids at the default filter and time sampling.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t` or
// coordinate.
//
// # Safety
// `surface` a live handle; `points` readable for `2n` doubles and `out` writable for `n`
// points (both may be null when `n` is 0).
SwellStatus swell_surface_displacement_normal_f32(const struct SwellSurface *surface,
                                                  double t,
                                                  const double *points,
                                                  size_t n,
                                                  struct SwellPointF32 *out);

// Makes an empty body world for the scene of `surface`, anchored at scene tick `anchor_tick`
// (world tick 0 is that scene tick), with the scene's tick rate and gravity, as the server
// makes a scene's world. On success `*out` holds a new handle.
//
// The anchor is part of the bits: to reproduce the server's states, use the tick its world is
// anchored at (the scene tick of the scene's first spawn, or of its last re-anchor), which the
// server publishes as `anchor_tick` (spawn answer, `GET …/bodies`, tick frames).
//
// When the scene's particle layer has `body_impacts`, every step derives the bodies' splashes
// and wakes as the server's do, and later steps feel them: then each body moves the others, so
// the world must hold every body of the server's (spawned at its `spawn_tick`, with its
// inputs) to follow it. API impacts are fed with [`swell_world_feel_impact`].
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] if the scene's tick rate or
// gravity is out of the body model's range.
//
// # Safety
// `surface` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_new(const struct SwellSurface *surface,
                            int64_t anchor_tick,
                            struct SwellWorld **out);

// Frees a world. Null is ignored.
//
// # Safety
// `world` must be null or a live handle, used by no other thread during the call.
void swell_world_free(struct SwellWorld *world);

// A copy of `world` with everything that decides its later ticks (bodies, their warm starts,
// the input log, the impacts felt, pending and made): stepping the copy and the original alike gives the same bits. Keep one at
// the last tick the server confirmed, to rewind to when its inputs turn out to differ.
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `world` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_clone(const struct SwellWorld *world,
                              struct SwellWorld **out);

// Makes `dst` a copy of `src` (as [`swell_world_clone`], into an existing handle): rewinds a
// prediction to a confirmed world.
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `dst` and `src` live handles (or null), `dst` used by no other thread during the call.
SwellStatus swell_world_assign(struct SwellWorld *dst, const struct SwellWorld *src);

// `*out` = the scene tick the states are at (the next tick a step computes).
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `world` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_tick(const struct SwellWorld *world, int64_t *out);

// `*out` = the scene time the states are at, s (`anchor/tick_hz + n/tick_hz`).
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `world` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_time(const struct SwellWorld *world, double *out);

// Spawns a body at the world's current tick from the JSON the server takes for
// `POST /v1/scenes/{id}/bodies` (`mass`, `hull`, `position`, optional `yaw`,
// `center_of_mass`, `linear_drag`, `quadratic_drag`, `angular_damping`,
// `min_wavelength_factor`; the damping defaults are the server's), at rest. `*out_id` gets the
// next free id, as the server gives it in a world with the same history; to mirror a body
// whose id the server chose, use [`swell_world_spawn_as`].
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_BAD_JSON`];
// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite position or a yaw beyond ±1e9;
// [`crate::SWELL_ERR_INVALID_SPEC`] for a body the model rejects.
//
// # Safety
// `world` a live handle; `json` readable for `len` bytes; `out_id` writable (or null).
SwellStatus swell_world_spawn(struct SwellWorld *world,
                              const char *json,
                              size_t len,
                              uint64_t *out_id);

// [`swell_world_spawn`] with the id `id` (the one the server gave the body). A body's
// trajectory does not depend on its id or on the other bodies, so a client may hold only its
// own boat under the server's id.
//
// # Errors
// As [`swell_world_spawn`]; [`crate::SWELL_ERR_NOT_FOUND`] if `id` is taken.
//
// # Safety
// `world` a live handle; `json` readable for `len` bytes.
SwellStatus swell_world_spawn_as(struct SwellWorld *world,
                                 uint64_t id,
                                 const char *json,
                                 size_t len);

// Removes body `id`, its inputs and its wake distance.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`].
//
// # Safety
// `world` a live handle (or null).
SwellStatus swell_world_remove(struct SwellWorld *world, uint64_t id);

// Queues an input for body `id`, as the server does (`SceneBodies::input`): it acts from
// `input.from_tick` (scene ticks; [`SWELL_FROM_NOW`] for the current tick) for `input.ticks`
// ticks. Inputs for the same body and tick add up in the order given.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`];
// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a tick before the current one, `ticks` outside
// 1..=10⁷, or a non-finite component.
//
// # Safety
// `world` a live handle; `input` readable (or null).
SwellStatus swell_world_input(struct SwellWorld *world,
                              uint64_t id,
                              const struct SwellInput *input);

// Steps every body by one tick (`1/tick_hz` s).
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `world` a live handle (or null).
SwellStatus swell_world_step(struct SwellWorld *world);

// Steps every body until the states are at scene tick `tick` (nothing if they are already).
// Each tick costs a sea evaluation per hull cell and substep: step in small spans.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a tick before the
// current one (bodies only move forward: rewind with [`swell_world_assign`]).
//
// # Safety
// `world` a live handle (or null).
SwellStatus swell_world_step_to(struct SwellWorld *world, int64_t tick);

// `*out` = body `id`'s state at the world's current tick.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`].
//
// # Safety
// `world` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_state(const struct SwellWorld *world,
                              uint64_t id,
                              struct SwellBodyState *out);

// Number of bodies in the world, into `*out`.
//
// # Errors
// [`crate::SWELL_ERR_NULL`].
//
// # Safety
// `world` a live handle (or null); `out` writable (or null).
SwellStatus swell_world_len(const struct SwellWorld *world, size_t *out);

// Puts body `id` at `state` (its `id` field is ignored; the rotation is normalised unless it
// is within 1e-9 of unit length): the fallback of a reconciliation when a client only has the
// server's streamed state. The server's next ticks also depend on where each hull cell's
// height inversion starts (its warm start, not on the wire), so after this the prediction
// follows the server to within the inversion tolerance (1 mm), not to the bit; rewinding to a
// confirmed world ([`swell_world_assign`]) and replaying the inputs keeps the bits. The one
// state it is on the bits from is a body's `carried.state` at a re-anchored world's
// `anchor_tick` (`GET …/bodies`), put on a world anchored there: the server starts that world
// cold too.
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`];
// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite or degenerate state.
//
// # Safety
// `world` a live handle; `state` readable (or null).
SwellStatus swell_world_set_state(struct SwellWorld *world,
                                  uint64_t id,
                                  const struct SwellBodyState *state);

// Makes the world's bodies feel an API impact (`POST /v1/scenes/{id}/impacts`) from scene
// tick `at_tick` on, as the server's do: pass the `body_tick` the server published for it (the
// impact answer's `body_tick`, or `felt_impacts[i].tick` in `GET …/bodies`), the tick it
// reached the server's body world at; [`SWELL_FROM_NOW`] for the world's current tick. An
// impact at a later tick waits until a step reaches that tick. The tick matters to the bits:
// the same impact felt a tick earlier or later gives other states (rings alive before the
// impact's own time `t` are not, but the pruning of old ones and the ripples of an impact whose
// `t` is already past are).
//
// # Errors
// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] naming `impact.…` for an impact
// the model rejects (a non-finite or out-of-range value); [`crate::SWELL_ERR_INVALID_ARGUMENT`]
// for a tick before the world's current one (rewind to a world at or before it with
// [`swell_world_assign`], then feel it and step again). Nothing changes on an error.
//
// # Safety
// `world` a live handle (or null); `impact` readable (or null).
SwellStatus swell_world_feel_impact(struct SwellWorld *world,
                                    const struct SwellImpact *impact,
                                    int64_t at_tick);

// Copies the impacts the world's bodies made (splashes and wakes, when the scene's particle
// layer has `body_impacts`; canonical order, pruned to the last hour) into `out`, at most
// `cap` of them; `*out_len` = how many there are (more than `cap`: call again with a larger
// buffer). With the scene's API impacts they are what the server's queries ripple with
// ([`crate::swell_surface_set_impacts`]).
//
// # Errors
// [`crate::SWELL_ERR_NULL`] (`out` may be null when `cap` is 0).
//
// # Safety
// `world` a live handle (or null); `out` writable for `cap` impacts; `out_len` writable.
SwellStatus swell_world_made_impacts(const struct SwellWorld *world,
                                     struct SwellImpact *out,
                                     size_t cap,
                                     size_t *out_len);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* SWELL_H */
