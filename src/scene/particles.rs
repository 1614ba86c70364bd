//! What a client needs to render a scene's particle layer exactly as the server evaluates it.

use serde_json::Value;
use swell_waves::particles::{ParticleLayer, ParticleLayerSpec};

/// The `derived` entry of a particle layer: its settings in use (the speed filled in), the
/// ripple settings, and every ambient particle as `[x0, z0, vx, vz, amplitude]` at scale 1 (m,
/// m/s, m; position at t is `wrap(p0 + v·t)` on the tile), so a client needs neither the seed
/// nor the generator to draw the same particles.
///
/// `particles_tile` lists the same particles as the model holds them, `[u0x, u0z, wx, wz]` in
/// tile units (start in `[0, 1)²`, velocity in tiles/s; position at t `wrap(u0 + w·t)`): a
/// client that evaluates the layer to the server's bits needs these, since the metres above are
/// rounded products with L (exact only for a power-of-two L), and the seed (a u64) does not
/// survive a JSON parser that reads numbers as doubles.
pub fn derived(layer: &ParticleLayer, spec: &ParticleLayerSpec) -> Value {
    let amb = layer.ambient();
    let particles: Vec<[f64; 5]> = (0..amb.len())
        .map(|i| {
            let (p, v, a) = amb.particle(i);
            [p.x, p.y, v.x, v.y, a]
        })
        .collect();
    let tile: Vec<[f64; 4]> = (0..amb.len())
        .map(|i| {
            let (u, w, _) = amb.particle_tile(i);
            [u.x, u.y, w.x, w.y]
        })
        .collect();
    serde_json::json!({
        "kind": "particles",
        "seed": layer.seed(),
        "count": amb.len(),
        "tile_size": amb.tile_size(),
        "radius": amb.radius(),
        "speed": amb.speed(),
        "scales": amb.scales(),
        "direction": spec.direction,
        "kernel": "a*(1-q^2)^3, q = |x-c|/r < 1",
        "ripples": layer.ripples(),
        "particles": particles,
        "particles_tile": tile,
    })
}
