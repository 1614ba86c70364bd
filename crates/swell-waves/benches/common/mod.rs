//! Surfaces of the server's built-in scenes (`src/scene/builtin.rs`), for the model's benches and
//! examples: one copy of each spec. Each bench uses some of them.
#![allow(dead_code)]

use serde_json::json;
use swell_waves::{Surface, SurfaceSpec};

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).expect("a built-in spec");
    Surface::new(&spec).expect("a built-in surface")
}

/// `harbour`: two Gerstner waves under 512 ambient wave particles at three scales.
pub fn harbour() -> Surface {
    surface(json!({"seed": 21, "layers": [
        {"kind": "gerstner", "waves": [
            {"amplitude": 0.12, "wavelength": 26, "direction": [1, 0.3], "steepness": 0.4},
            {"amplitude": 0.05, "wavelength": 9, "direction": [0.2, 1], "steepness": 0.4, "phase": 1.3}
        ]},
        {"kind": "particles", "count": 512, "tile_size": 32, "radius": 1.0, "amplitude": 0.03,
         "scales": [0.33, 0.66, 1.0],
         "ripples": {"particles": 8, "decay": 30, "floor": 0.0001, "lifetime": 60}}
    ]}))
}

/// `lake`: a Gerstner wave and its cascade.
pub fn lake() -> Surface {
    surface(json!({"seed": 7, "depth": 12, "layers": [
        {"kind": "gerstner",
         "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
         "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}
    ]}))
}
