//! Floating-body orientation on real seas: hull averaging for huge bodies, steep crests,
//! degenerate sizes.

use crate::common;

use common::gerstner_spec;
use serde_json::json;
use swell_waves::body::{BodyFootprint, MAX_FOOTPRINT};
use swell_waves::{QueryFields, QueryOptions, Surface, SurfaceSpec};

fn body(x: f64, z: f64, yaw: f64, length: f64, beam: f64) -> BodyFootprint {
    BodyFootprint {
        position: [x, z],
        yaw,
        length,
        beam,
        probes: None,
    }
}

#[test]
fn a_body_far_larger_than_the_longest_wave_sits_level_at_mean_height() {
    // Waves up to 100 m long under a 5 km × 3 km footprint of 15 × 15 probes: the plane fit
    // averages them out.
    let s = Surface::new(&gerstner_spec(21, 16, 0.5)).unwrap();
    let sea = s
        .at(30.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let probes: Vec<[f64; 2]> = (0..15)
        .flat_map(|i| {
            (0..15).map(move |j| [-2500.0 + 357.0 * i as f64, -1500.0 + 214.0 * j as f64])
        })
        .collect();
    let mut b = body(123.0, -45.0, 0.7, 5000.0, 3000.0);
    b.probes = Some(probes);
    let o = b.orientation(&sea, "bodies[0]").unwrap();
    // A point on this sea moves by up to Σ A; averaged over the hull the heave is a few percent
    // of that (225 samples of a random-phase sum, plus Gerstner's slight mean-level drop).
    let sum_a: f64 = s.layers()[0].waves().iter().map(|w| w.amplitude).sum();
    assert!(
        o.heave.abs() < 0.05 * sum_a,
        "heave {} vs ΣA {sum_a}",
        o.heave
    );
    assert!(
        o.pitch.abs() < 1e-3 && o.roll.abs() < 1e-3,
        "pitch {} roll {}",
        o.pitch,
        o.roll
    );
    assert!((o.normal.y - 1.0).abs() < 1e-6);
}

#[test]
fn a_small_body_on_a_steep_crest_rides_the_crest() {
    // One steep wave (Q·k·A = 0.95) travelling along +x: a 1 m raft at the crest is lifted to
    // about A and stays level along the crest line; probes on the crest stay finite.
    let spec: SurfaceSpec = serde_json::from_value(json!({"layers": [{"kind": "gerstner", "waves": [
        {"amplitude": 0.95 * 40.0 / std::f64::consts::TAU, "wavelength": 40.0, "direction": [1.0, 0.0], "steepness": 1.0}
    ]}]}))
    .unwrap();
    let s = Surface::new(&spec).unwrap();
    let a = 0.95 * 40.0 / std::f64::consts::TAU;
    let sea = s
        .at(0.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    // θ = k·x0 = π/2 is the crest; its displaced position is x0 + Q·A·cos(π/2) = x0 = 10 m.
    // At S = 0.95 the crest is nearly a cusp: Δx from it is (1 − S)·Δθ/k, so a 5 cm raft spans
    // ±0.08 rad of phase and rides at about A·cos(0.08) ≈ 0.997·A.
    let o = body(10.0, 0.0, 0.0, 0.05, 0.05)
        .orientation(&sea, "b")
        .unwrap();
    assert!(
        (o.heave - a).abs() < 0.01 * a,
        "heave {} vs crest {a}",
        o.heave
    );
    assert!(o.pitch.abs() < 1e-6, "pitch {}", o.pitch);
    assert!(o.roll.abs() < 1e-9);
    // A 1 m raft on the same crest: its probes sit on the steep flanks; the heave is the mean of
    // the probe heights (symmetric probes), each checked against the converged reference.
    let b = body(10.0, 0.0, 0.0, 1.0, 1.0);
    let o = b.orientation(&sea, "b").unwrap();
    let probes = b.probes("b").unwrap();
    let mean_ref = probes
        .iter()
        .map(|&p| sea.invert_reference(b.probe_world(p)).sample.displacement.y)
        .sum::<f64>()
        / probes.len() as f64;
    assert!(
        (o.heave - mean_ref).abs() < 1e-3,
        "heave {} vs reference mean {mean_ref}",
        o.heave
    );
    assert!(o.heave < 0.95 * a, "a 1 m raft cannot ride the cusp's tip");
    // Off the crest the raft pitches with the face of the wave, never NaN.
    for x in [8.0, 9.0, 9.9, 10.1, 11.0, 12.0] {
        let o = body(x, 0.0, 0.3, 2.0, 1.0).orientation(&sea, "b").unwrap();
        assert!(o.heave.is_finite() && o.rotation.is_finite() && o.normal.is_finite());
    }
}

#[test]
fn zero_size_bodies_are_errors() {
    let s = Surface::new(&gerstner_spec(1, 4, 0.3)).unwrap();
    let sea = s
        .at(0.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let e = body(0.0, 0.0, 0.0, 0.0, 2.0)
        .orientation(&sea, "bodies[3]")
        .unwrap_err();
    assert_eq!(e.field(), "bodies[3].length");
}

/// Regression (issue 11): a body of length 1e300 was accepted and its orientation came out NaN
/// (the plane fit squares probe offsets of 5e299), which the server sent as `"heave": null`.
/// Sizes and probe offsets are now bounded by `MAX_FOOTPRINT`, and the largest allowed body
/// still gets a finite orientation.
#[test]
fn issue_11_huge_footprints_are_rejected_not_nan() {
    let s = Surface::new(&gerstner_spec(1, 4, 0.3)).unwrap();
    let sea = s
        .at(0.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    for (b, field) in [
        (body(0.0, 0.0, 0.0, 1e300, 1.0), "bodies[0].length"),
        (
            body(0.0, 0.0, 0.0, 1.0, 2.0 * MAX_FOOTPRINT),
            "bodies[0].beam",
        ),
        (
            BodyFootprint {
                probes: Some(vec![[0.0, 0.0], [1e300, 0.0]]),
                ..body(0.0, 0.0, 0.0, 1.0, 1.0)
            },
            "bodies[0].probes[1][0]",
        ),
    ] {
        let e = b.orientation(&sea, "bodies[0]").unwrap_err();
        assert_eq!(e.field(), field, "{e}");
    }
    let largest = BodyFootprint {
        probes: Some(vec![
            [-MAX_FOOTPRINT, -MAX_FOOTPRINT],
            [MAX_FOOTPRINT, 0.0],
            [0.0, MAX_FOOTPRINT],
        ]),
        ..body(1e9, -1e9, 2.0, MAX_FOOTPRINT, MAX_FOOTPRINT)
    };
    let o = largest.orientation(&sea, "bodies[0]").unwrap();
    assert!(o.heave.is_finite() && o.rotation.is_finite() && o.normal.is_finite());
    let grid = body(1e9, -1e9, 2.0, MAX_FOOTPRINT, MAX_FOOTPRINT);
    let o = grid.orientation(&sea, "bodies[0]").unwrap();
    assert!(o.heave.is_finite() && o.rotation.is_finite() && o.normal.is_finite());
}

/// `World::resume` + `World::restore_body` restore a world mid-trajectory: a world rebuilt at
/// tick 40 from the states, inputs and next id of one that ran from tick 0 steps to the same bits
/// as the original. (`insert` renormalises the rotation and a fresh world with its `start_time`
/// moved to tick 40 rounds substep times differently: either drifts in the last bits.)
#[test]
fn a_resumed_world_continues_to_the_same_bits() {
    use swell_waves::body::{
        BodyInput, BodySpec, BodyState, HullSpec, WarmStart, World, WorldSettings,
    };
    let spec: swell_waves::SurfaceSpec = serde_json::from_value(serde_json::json!({"layers": [
        {"kind": "gerstner", "waves": [
            {"amplitude": 0.5, "wavelength": 23.0, "direction": [1.0, 0.3], "steepness": 0.5}]}
    ]}))
    .unwrap();
    let surface = swell_waves::Surface::new(&spec).unwrap();
    let options = swell_waves::QueryOptions::default();
    let settings = WorldSettings {
        tick_hz: 30.0,
        water_density: 1025.0,
        gravity: 9.81,
        start_time: 1234.0 / 30.0,
    };
    let body = BodySpec {
        mass: 2000.0,
        hull: HullSpec::Box {
            length: 6.0,
            beam: 2.5,
            height: 1.2,
            cells: None,
        },
        center_of_mass: [0.0; 3],
        linear_drag: 500.0,
        quadratic_drag: 0.0,
        angular_damping: 200.0,
        min_wavelength_factor: 0.0,
    };
    let mut a = World::new(settings).unwrap();
    let id = a
        .add(
            &body,
            BodyState::at_rest(glam::DVec3::new(0.0, 0.8, 0.0), 0.4),
        )
        .unwrap();
    a.input(BodyInput {
        body: id,
        force: [9000.0, 0.0, 100.0],
        torque: [0.0, 400.0, 0.0],
        from_tick: 30,
        ticks: 50,
    })
    .unwrap();
    for _ in 0..40 {
        a.step_surface(&surface, &options).unwrap();
    }
    let (state, status) = (*a.body(id).unwrap().state(), *a.body(id).unwrap().status());
    let warm = a.body(id).unwrap().warm_start();
    assert!(
        warm.is_some(),
        "a stepped body carries its inversions' starts"
    );
    // `b` gets everything back; `cold` all but where its inversions start.
    let restored = |warm: Option<&WarmStart>| {
        let mut b = World::resume(settings, a.tick(), a.next_id()).unwrap();
        b.restore_body(id, &body, state, status, warm).unwrap();
        assert_eq!(*b.body(id).unwrap().state(), state, "restored to the bit");
        assert_eq!(b.body(id).unwrap().warm_start().as_ref(), warm);
        for i in a.inputs() {
            b.input(*i).unwrap();
        }
        assert_eq!(b.next_id(), 1);
        b
    };
    let (mut b, mut cold) = (restored(warm.as_ref()), restored(None));
    for _ in 0..60 {
        a.step_surface(&surface, &options).unwrap();
        b.step_surface(&surface, &options).unwrap();
        cold.step_surface(&surface, &options).unwrap();
    }
    assert_eq!(a.body(id).unwrap().state(), b.body(id).unwrap().state());
    // The warm start is state: without it the trajectory leaves the bits (by far less than the
    // inversion tolerance moves a hull).
    let (sa, sc) = (a.body(id).unwrap().state(), cold.body(id).unwrap().state());
    assert_ne!(sa, sc, "the warm start made no difference");
    assert!((sa.position - sc.position).length() < 1e-3);
}

/// A world stepped at every SIMD level this CPU has ends in the bits of the baseline build's
/// loops: the run-time AVX2 path (the whole hull's loads, the sea's wave kernel and FFT reads
/// inlined into it, four cells a block) and the AVX-512 one (eight cells a block on an analytic
/// sea). Boats of three sizes on a steep Gerstner cascade and on Gerstner waves over an FFT
/// layer, 40 ticks.
#[test]
fn body_step_gives_the_same_bits_at_every_simd_level() {
    use swell_waves::body::{BodySpec, BodyState, HullSpec, World, WorldSettings};
    use swell_waves::simd::{SimdLevel, force_simd_level};
    if !common::avx2_or_skip("body_step_gives_the_same_bits_at_every_simd_level") {
        return;
    }
    let mut with_fft = gerstner_spec(8, 6, 0.5);
    with_fft.layers.push(
        serde_json::from_value(json!({"kind": "fft", "resolution": 64, "tile_size": 120.0,
            "choppiness": 1.0, "wind_direction": [1.0, 0.3],
            "spectrum": {"kind": "jonswap", "wind_speed": 12.0, "fetch": 60000.0}}))
        .unwrap(),
    );
    for spec in [gerstner_spec(31, 16, 0.8), with_fft] {
        let surface = Surface::new(&spec).unwrap();
        let options = QueryOptions::default();
        let run = |level: SimdLevel| {
            force_simd_level(Some(level));
            let mut world = World::new(WorldSettings::default()).unwrap();
            for (i, (length, mass)) in [(3.0, 400.0), (8.0, 3000.0), (20.0, 40_000.0)]
                .into_iter()
                .enumerate()
            {
                let body = BodySpec {
                    mass,
                    hull: HullSpec::Box {
                        length,
                        beam: length / 2.5,
                        height: length / 5.0,
                        cells: None,
                    },
                    center_of_mass: [0.0; 3],
                    linear_drag: 0.2 * mass,
                    quadratic_drag: 0.05 * mass,
                    angular_damping: mass,
                    min_wavelength_factor: 0.0,
                };
                let at = glam::DVec3::new(37.0 * i as f64 - 20.0, 0.2, 11.0 * i as f64);
                world
                    .add(&body, BodyState::at_rest(at, 0.3 * i as f64))
                    .unwrap();
            }
            for _ in 0..40 {
                world.step_surface(&surface, &options).unwrap();
            }
            world
                .bodies()
                .map(|(_, b)| format!("{:?}", b.state()))
                .collect::<Vec<_>>()
        };
        let levels = SimdLevel::available();
        let states: Vec<_> = levels.iter().map(|&l| run(l)).collect();
        force_simd_level(None);
        for (level, got) in levels.iter().zip(&states).skip(1) {
            assert_eq!(
                got,
                &states[0],
                "{} against {}",
                level.name(),
                levels[0].name()
            );
        }
    }
}
