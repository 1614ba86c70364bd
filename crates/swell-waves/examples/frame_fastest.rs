//! The FFT frame of `benches/waves.rs` (`fft_frame/portable_256_all_fields`: 256², all 8 grids,
//! portable backend), computed 600 times back to back at successive times; prints the fastest,
//! the 10th percentile and the median, ms. On a shared VM whose speed moves from minute to
//! minute, the fastest of many frames compares two builds better than a mean: run the two
//! binaries alternately, a few rounds each. `SWELL_SIMD` caps the SIMD level.
//!
//! Run: `cargo run --release -p swell-waves --example frame_fastest`

use swell_waves::fft::FftFields;
use swell_waves::{Surface, SurfaceSpec};

fn main() {
    let spec: SurfaceSpec = serde_json::from_value(serde_json::json!({"seed": 1, "layers": [
        {"kind": "fft", "resolution": 256, "tile_size": 256.0, "choppiness": 1.0,
         "wind_direction": [1.0, 0.2], "backend": "portable",
         "spectrum": {"kind": "jonswap", "wind_speed": 10.0, "fetch": 100000.0}}]}))
    .expect("the bench's spec");
    let surface = Surface::new(&spec).expect("the bench's surface");
    let mut ms: Vec<f64> = (0..600)
        .map(|k| {
            let start = std::time::Instant::now();
            let frame = surface.fft_frame(0, 10.0 + k as f64 * 0.01, FftFields::ALL);
            std::hint::black_box(&frame);
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    println!(
        "256², 8 grids, {} level, 600 frames: fastest {:.3} ms, p10 {:.3} ms, p50 {:.3} ms",
        swell_waves::simd::simd_level().name(),
        ms[0],
        ms[60],
        ms[300]
    );
}
