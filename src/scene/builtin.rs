//! The scenes `swell serve` starts with, so it is useful with no configuration.
//!
//! Written as JSON (the same text a client would `PUT`) so they double as examples.

use super::SceneSpec;

/// `(id, spec JSON)` of every built-in scene, in listing order.
pub const BUILTIN: &[(&str, &str)] = &[
    (
        "calm",
        r#"{
  "description": "Calm water: three compound sine waves, no horizontal motion. The cheapest scene.",
  "tick_hz": 30,
  "seed": 1,
  "layers": [
    {"kind": "sine", "waves": [
      {"amplitude": 0.12, "wavelength": 18, "direction": [1, 0.2]},
      {"amplitude": 0.06, "wavelength": 7.5, "direction": [0.3, 1], "phase": 1.1},
      {"amplitude": 0.03, "wavelength": 3.2, "direction": [-0.6, 0.8], "phase": 2.3}
    ]}
  ]
}"#,
    ),
    (
        "lake",
        r#"{
  "description": "Wind chop on a lake: one Gerstner wave plus a seeded Gerstner cascade (fold number about 0.54).",
  "tick_hz": 30,
  "seed": 7,
  "depth": 12,
  "layers": [
    {"kind": "gerstner",
     "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
     "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}
  ]
}"#,
    ),
    (
        "open-sea",
        r#"{
  "description": "Open sea: JONSWAP wind sea (U10 = 10 m/s, 100 km fetch) on a 256 m FFT tile at 256², plus a long Gerstner swell.",
  "tick_hz": 30,
  "seed": 42,
  "layers": [
    {"kind": "fft", "resolution": 256, "tile_size": 256, "choppiness": 1.0, "repeat_period": 200,
     "wind_direction": [1, 0.3],
     "spectrum": {"kind": "jonswap", "wind_speed": 10, "fetch": 100000, "gamma": 3.3},
     "spreading": {"kind": "donelan_banner"}},
    {"kind": "gerstner",
     "waves": [{"amplitude": 0.6, "wavelength": 160, "direction": [0.4, 1], "steepness": 0.3}]}
  ]
}"#,
    ),
    (
        "storm",
        r#"{
  "description": "Storm: steep JONSWAP sea (U10 = 20 m/s, 300 km fetch) on a 256 m FFT tile at 256², choppiness 2.6: sharp crests that just fold (Jacobian slightly below 0: foam).",
  "tick_hz": 30,
  "seed": 1337,
  "layers": [
    {"kind": "fft", "resolution": 256, "tile_size": 256, "choppiness": 2.6, "repeat_period": 300,
     "wind_direction": [1, -0.2],
     "spectrum": {"kind": "jonswap", "wind_speed": 20, "fetch": 300000, "gamma": 3.3},
     "spreading": {"kind": "mitsuyasu"}}
  ]
}"#,
    ),
    (
        "harbour",
        r#"{
  "description": "Harbour: a low Gerstner swell under wave particles (512 seeded particles on a 32 m tile, summed at 33 %, 66 % and 100 % as the seed article does); POST /v1/scenes/harbour/impacts makes splashes that ring out, subdivide and fade for every client alike.",
  "tick_hz": 30,
  "seed": 21,
  "layers": [
    {"kind": "gerstner",
     "waves": [
       {"amplitude": 0.12, "wavelength": 26, "direction": [1, 0.3], "steepness": 0.4},
       {"amplitude": 0.05, "wavelength": 9, "direction": [0.2, 1], "steepness": 0.4, "phase": 1.3}
     ]},
    {"kind": "particles", "count": 512, "tile_size": 32, "radius": 1.0, "amplitude": 0.03,
     "scales": [0.33, 0.66, 1.0],
     "ripples": {"particles": 8, "decay": 30, "floor": 0.0001, "lifetime": 60}}
  ]
}"#,
    ),
];

/// The built-in scene specs, parsed.
///
/// # Panics
/// Never for the shipped texts: a unit test parses and builds every one.
pub fn specs() -> Vec<(String, SceneSpec)> {
    BUILTIN
        .iter()
        .map(|(id, text)| {
            let v: serde_json::Value = serde_json::from_str(text).expect("built-in scene JSON");
            let spec = SceneSpec::from_value(v).expect("built-in scene spec");
            ((*id).to_owned(), spec)
        })
        .collect()
}

/// The built-in scene `id`, built (for tests across the crate).
///
/// # Panics
/// If `id` is not a built-in scene.
#[cfg(test)]
pub(crate) fn built(id: &str) -> super::Scene {
    let (_, spec) = specs()
        .into_iter()
        .find(|(i, _)| i == id)
        .unwrap_or_else(|| panic!("{id} is not a built-in scene"));
    super::Scene::build(id, spec).expect("built-in scenes build")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn every_builtin_builds() {
        for (id, spec) in specs() {
            crate::scene::validate_id(&id).unwrap();
            let s = Scene::build(&id, spec).unwrap_or_else(|e| panic!("{id}: {e}"));
            assert!(!s.spec.description.is_empty());
        }
    }

    /// Smallest Jacobian determinant of the horizontal map over FFT grid nodes at a few times
    /// (1 for a scene without horizontal motion): below 0 the surface folds (foam).
    fn min_jacobian(id: &str) -> f64 {
        use swell_waves::{QueryFields, QueryOptions};
        let (_, spec) = specs().into_iter().find(|(i, _)| i == id).unwrap();
        let scene = Scene::build(id, spec).unwrap();
        let mut min = f64::INFINITY;
        for t in [0.0, 7.3, 41.0] {
            let sea = scene
                .surface
                .at(t, QueryFields::ALL, &QueryOptions::default())
                .unwrap();
            for i in 0..128 {
                for j in 0..128 {
                    let p = glam::DVec2::new(i as f64 * 2.0 + 0.5, j as f64 * 2.0 + 0.25);
                    min = min.min(sea.sample(p, true).jacobian());
                }
            }
        }
        min
    }

    /// What the built-ins promise: `storm` is steep enough to fold a little (foam on the
    /// crests), the others never fold.
    #[test]
    fn storm_is_near_folding_and_the_others_are_not() {
        let storm = min_jacobian("storm");
        eprintln!("storm min J = {storm}");
        assert!((-0.6..0.1).contains(&storm), "storm min J = {storm}");
        for id in ["calm", "lake", "open-sea"] {
            let j = min_jacobian(id);
            eprintln!("{id} min J = {j}");
            assert!(j > 0.2, "{id} min J = {j}");
        }
    }
}
