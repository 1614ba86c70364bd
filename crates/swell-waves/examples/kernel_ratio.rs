//! `targets/gerstner16_disp_normal` timed for a busy machine: the f64 batch (`sample_batch` with
//! derivatives, then `SurfaceSample::normal`) against the naive std `sin_cos` loop, 4,096
//! points, at each SIMD level this CPU has.
//!
//! Criterion times the two sides one after the other, so load from other processes that comes
//! and goes between them moves the ratio (on a shared 2-core VM, passes of the same build gave
//! 8.4–10.2×). Here the two sides alternate every round and each keeps its fastest round,
//! which is the run least disturbed by anything else; the ratio of those is stable to a few
//! per cent under load.
//!
//! Run: `cargo run --release -p swell-waves --example kernel_ratio [rounds]` (default 300).

use std::hint::black_box;
use std::time::Instant;

use glam::{DVec2, DVec3};
use swell_waves::simd::{SimdLevel, force_simd_level};
use swell_waves::wave::SurfaceSample;
use swell_waves::{QueryFields, QueryOptions};

#[path = "../benches/common/mod.rs"]
mod common;

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .map_or(300, |a| a.parse().expect("rounds: a whole number"));
    // The bench's points and time.
    let pts: Vec<DVec2> = (0..4096)
        .map(|i| DVec2::new((i % 64) as f64 * 1.37 - 40.0, (i / 64) as f64 * 1.91 - 60.0))
        .collect();
    let s = common::gerstner16(0.9);
    let sea = s
        .at(10.0, QueryFields::ALL, &QueryOptions::default())
        .expect("a snapshot");
    let waves = s.layers()[0].waves().to_vec();
    let mut naive = vec![[0.0; 6]; pts.len()];
    let mut buf = vec![SurfaceSample::default(); pts.len()];
    let mut normals = vec![DVec3::ZERO; pts.len()];
    println!("{rounds} alternated rounds, fastest of each side");
    for level in SimdLevel::available() {
        force_simd_level(Some(level));
        let (mut best_naive, mut best_batch) = (f64::MAX, f64::MAX);
        for _ in 0..rounds {
            let t0 = Instant::now();
            common::naive_gerstner_normal(&waves, black_box(&pts), 10.0, &mut naive);
            let t1 = Instant::now();
            sea.sample_batch(black_box(&pts), true, &mut buf);
            for (n, s) in normals.iter_mut().zip(&buf) {
                *n = s.normal();
            }
            let t2 = Instant::now();
            best_naive = best_naive.min((t1 - t0).as_secs_f64());
            best_batch = best_batch.min((t2 - t1).as_secs_f64());
            black_box((&naive, &normals));
        }
        println!(
            "{:>6}: naive {:7.1} µs, batch {:7.1} µs, {:5.2}×",
            level.name(),
            best_naive * 1e6,
            best_batch * 1e6,
            best_naive / best_batch
        );
    }
    force_simd_level(None);
}
