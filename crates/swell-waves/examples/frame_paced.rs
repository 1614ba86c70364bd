//! `storm`'s grid frames with the grids a height query at now reads (`Surface::fft_fields_for`:
//! height and displacement, 3 of 8), computed back to back and then paced one every
//! `gap` ms (17 ms: the default grid step, as the server's frame-ahead loop computes them for a
//! scene in use), and two back to back every `2·gap`, 300 frames each, in the same run. On a VM a frame that starts after its thread
//! slept runs slower than one right after another (caches and the core given to others
//! meanwhile), so the paced figure is the one a scene in use costs.
//!
//! Run: `cargo run --release -p swell-waves --example frame_paced [gap_ms]` (default 17).

use std::time::{Duration, Instant};

use swell_waves::{Layer, QueryFields, Surface, SurfaceSpec};

fn main() {
    let gap_ms: u64 = std::env::args()
        .nth(1)
        .map_or(17, |s| s.parse().expect("a gap in ms"));
    let spec: SurfaceSpec = serde_json::from_value(serde_json::json!({"seed": 1337, "layers": [
        {"kind": "fft", "resolution": 256, "tile_size": 256, "choppiness": 2.6, "repeat_period": 300,
         "wind_direction": [1, -0.2],
         "spectrum": {"kind": "jonswap", "wind_speed": 20, "fetch": 300000, "gamma": 3.3},
         "spreading": {"kind": "mitsuyasu"}}]}))
    .expect("storm's spec");
    let surface = Surface::new(&spec).expect("storm's surface");
    let Some(Layer::Fft(layer)) = surface.layers().first() else {
        unreachable!("storm is one FFT layer")
    };
    let fields = surface.fft_fields_for(layer, QueryFields::HEIGHT);
    let grids = fields.grid_count();
    let mut index = 0;
    // `per` frames back to back, then a sleep of `gap` (`per` grid steps' worth when paced).
    let mut run = |gap: Duration, per: usize| {
        // The server holds a scene's near frames: dropped frames return their grids to the
        // layer's pool, as there.
        let mut kept = std::collections::VecDeque::new();
        let mut ms: Vec<f64> = (0..300)
            .map(|k| {
                let start = Instant::now();
                let frame = layer.grid_frame(index, fields);
                let took = start.elapsed().as_secs_f64() * 1e3;
                index += 1;
                kept.push_back(frame);
                if kept.len() > 6 {
                    kept.pop_front();
                }
                if !gap.is_zero() && (k + 1) % per == 0 {
                    std::thread::sleep(gap);
                }
                took
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        (ms.iter().sum::<f64>() / ms.len() as f64, ms[ms.len() / 2])
    };
    run(Duration::ZERO, 1); // warm-up: the pools fill, the pages are touched
    let (mean0, p50_0) = run(Duration::ZERO, 1);
    let (mean1, p50_1) = run(Duration::from_millis(gap_ms), 1);
    let (mean2, p50_2) = run(Duration::from_millis(2 * gap_ms), 2);
    println!("storm 256², {grids} grids, 300 frames each");
    println!("  back to back      mean {mean0:.3} ms  p50 {p50_0:.3} ms");
    println!(
        "  one every {gap_ms:>2} ms  mean {mean1:.3} ms  p50 {p50_1:.3} ms  ({:.2}×)",
        mean1 / mean0
    );
    println!(
        "  two every {:>2} ms  mean {mean2:.3} ms  p50 {p50_2:.3} ms  ({:.2}×)",
        2 * gap_ms,
        mean2 / mean0
    );
    println!(
        "  60 paced frames a second: {:.1}% of a core one at a time, {:.1}% in pairs",
        60.0 * mean1 / 10.0,
        60.0 * mean2 / 10.0
    );
}
