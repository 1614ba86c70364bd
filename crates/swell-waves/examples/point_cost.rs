//! N heights at "now" on a built-in sea, each a new snapshot at a t 17 µs after the last (what
//! the server does per `GET /v1/scenes/{id}/height` at now), for instruction counts that do not
//! move with the machine's load:
//!
//! ```sh
//! cargo build --release -p swell-waves --example point_cost
//! for s in harbour lake; do for n in 0 20000; do
//!   valgrind --tool=callgrind --callgrind-out-file=/dev/null target/release/examples/point_cost $s $n 2>&1 | grep refs
//! done; done
//! ```
//!
//! (instructions for n queries − for 0) / n is one query's count. A third argument k asks k
//! points of each snapshot (a small batch) instead of one.

// The built-in scenes' surfaces, shared with the benches.
#[path = "../benches/common/mod.rs"]
mod common;

use std::hint::black_box;

use glam::DVec2;
use swell_waves::math::SwellRng;
use swell_waves::{QueryFields, QueryOptions};

fn main() {
    let mut args = std::env::args().skip(1);
    let scene = args.next().unwrap_or_else(|| "harbour".into());
    let n: usize = args.next().map_or(10_000, |s| s.parse().expect("a count"));
    let k: usize = args
        .next()
        .map_or(1, |s| s.parse().expect("points per snapshot"));
    let s = match scene.as_str() {
        "harbour" => common::harbour(),
        "lake" => common::lake(),
        other => panic!("harbour or lake, not {other}"),
    };
    let mut rng = SwellRng::new(29, 4);
    let mut t = 1.0e6;
    let mut sum = 0.0;
    for _ in 0..n {
        t += 17.0e-6;
        let sea = s
            .at(t, QueryFields::HEIGHT, &QueryOptions::default())
            .expect("t");
        for _ in 0..k {
            let p = DVec2::new(rng.uniform() * 400.0 - 200.0, rng.uniform() * 400.0 - 200.0);
            sum += sea.query(p, QueryFields::HEIGHT).height;
        }
    }
    println!("{scene} {n}×{k} {}", black_box(sum));
}
