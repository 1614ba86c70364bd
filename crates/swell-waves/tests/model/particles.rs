//! The particle layer inside a surface: queries, inversion, normals, orientation, bodies'
//! filtered sea, batches, and finiteness under random specs and impacts.

use crate::common;

use glam::DVec2;
use proptest::prelude::*;
use swell_waves::body::BodyFootprint;
use swell_waves::particles::{Impact, Impacts, ParticleLayerSpec, RippleSpec};
use swell_waves::{Layer, LayerSpec, QueryFields, QueryOptions, Surface, SurfaceSpec};

fn harbour() -> SurfaceSpec {
    serde_json::from_value(serde_json::json!({
        "seed": 11,
        "layers": [
            {"kind": "gerstner", "waves": [
                {"amplitude": 0.25, "wavelength": 18.0, "direction": [1.0, 0.4], "steepness": 0.6}
            ]},
            {"kind": "particles", "scales": [0.33, 0.66, 1.0]}
        ]
    }))
    .unwrap()
}

fn impacts() -> Impacts {
    Impacts::from_events(vec![
        Impact {
            t: 10.0,
            position: [5.0, -3.0],
            strength: 0.6,
            radius: 0.8,
        },
        Impact {
            t: 11.5,
            position: [-8.0, 2.0],
            strength: 0.3,
            radius: 0.4,
        },
    ])
    .unwrap()
}

/// `{"kind": "particles"}` alone is a valid layer with the documented defaults.
#[test]
fn bare_particles_kind_is_valid() {
    let spec: SurfaceSpec = serde_json::from_str(r#"{"layers": [{"kind": "particles"}]}"#).unwrap();
    let LayerSpec::Particles(p) = &spec.layers[0] else {
        panic!("not a particle layer")
    };
    assert_eq!(p, &ParticleLayerSpec::default());
    let s = Surface::new(&spec).unwrap();
    assert!(s.has_particles() && !s.has_horizontal_motion());
    let sea = s
        .at(3.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap();
    let r = sea.query(DVec2::new(1.0, 2.0), QueryFields::ALL);
    assert!(r.height.is_finite() && r.height.abs() < 0.2);
    // Unknown fields are rejected, with their name.
    let e =
        serde_json::from_str::<SurfaceSpec>(r#"{"layers": [{"kind": "particles", "cont": 3}]}"#)
            .unwrap_err();
    assert!(e.to_string().contains("cont"), "{e}");
}

/// On a Gerstner sea, heights come from the inversion with the particles included, and the
/// normal is the analytic one: it matches central differences of the height (through the
/// inversion) over a ring and the ambient particles.
#[test]
fn heights_and_normals_include_particles_through_the_inversion() {
    let spec = harbour();
    let s = Surface::new(&spec).unwrap();
    let t = 13.0;
    let opts = QueryOptions {
        inversion: swell_waves::Inversion {
            tolerance: 1e-12,
            iterations: 40,
            ..Default::default()
        },
        ..Default::default()
    };
    let sea = s
        .at(t, QueryFields::ALL, &opts)
        .unwrap()
        .with_impacts(&impacts())
        .unwrap();
    let plain = s.at(t, QueryFields::ALL, &opts).unwrap();
    let mut moved = 0;
    for p in common::points(3, 400, (0.0, 0.0), 15.0) {
        let r = sea.query(p, QueryFields::ALL);
        if (r.height - plain.height(p.x, p.y)).abs() > 1e-6 {
            moved += 1;
        }
        // Consistency: the height is y at the source point the inversion found.
        let inv = sea.invert(p, true);
        let src = sea.sample(inv.source, true);
        assert!((src.displacement.y - r.height).abs() < 1e-12);
        // Normal against finite differences of the height field.
        let e = 1e-5;
        let hx = (sea.height(p.x + e, p.y) - sea.height(p.x - e, p.y)) / (2.0 * e);
        let hz = (sea.height(p.x, p.y + e) - sea.height(p.x, p.y - e)) / (2.0 * e);
        let n = glam::DVec3::new(-hx, 1.0, -hz).normalize();
        assert!((n - r.normal).length() < 1e-5, "{p}: {} vs {n}", r.normal);
    }
    assert!(moved > 10, "the ring should move heights near it: {moved}");
}

/// Single points, batches and parallel batches give the same bits with particles and impacts.
#[test]
fn batches_are_bit_identical_to_single_points() {
    let s = Surface::new(&harbour()).unwrap();
    let sea = s
        .at(12.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap()
        .with_impacts(&impacts())
        .unwrap();
    let pts = common::points(8, 333, (0.0, 0.0), 20.0);
    let batch = sea.query_batch(&pts, QueryFields::ALL);
    let par = sea.query_batch_parallel(&pts, QueryFields::ALL, 3);
    for (i, p) in pts.iter().enumerate() {
        let one = sea.query(*p, QueryFields::ALL);
        assert_eq!(format!("{one:?}"), format!("{:?}", batch[i]));
        assert_eq!(format!("{one:?}"), format!("{:?}", par[i]));
    }
}

/// The fast path against the slow reference (closed forms, no grids) on a whole surface.
#[test]
fn surface_matches_reference_sample() {
    let s = Surface::new(&harbour()).unwrap();
    let sea = s
        .at(12.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap()
        .with_impacts(&impacts())
        .unwrap();
    for p in common::points(9, 300, (0.0, 0.0), 20.0) {
        let a = sea.sample(p, true);
        let b = sea.sample_reference(p);
        assert!((a.displacement - b.displacement).length() < 1e-9);
        assert!((a.d_dx - b.d_dx).length() < 1e-9 && (a.d_dz - b.d_dz).length() < 1e-9);
        let v = sea.velocity(p);
        let vr = sea.velocity_reference(p);
        assert!((v - vr).length() < 1e-9, "{v} vs {vr}");
    }
}

/// The particles' vertical velocity is ∂h/∂t: central differences in time at a fixed point of a
/// particle-only surface.
#[test]
fn vertical_velocity_is_the_time_derivative() {
    let spec: SurfaceSpec =
        serde_json::from_str(r#"{"layers": [{"kind": "particles", "scales": [0.5, 1.0]}]}"#)
            .unwrap();
    let s = Surface::new(&spec).unwrap();
    let imp = impacts();
    let at = |t: f64| {
        s.at(t, QueryFields::ALL, &QueryOptions::default())
            .unwrap()
            .with_impacts(&imp)
            .unwrap()
    };
    for p in common::points(4, 200, (0.0, 0.0), 12.0) {
        let t = 12.3;
        let e = 1e-6;
        let dh = (at(t + e).displacement(p).y - at(t - e).displacement(p).y) / (2.0 * e);
        let v = at(t).velocity(p).y;
        assert!((dh - v).abs() < 1e-6, "{p}: {v} vs {dh}");
    }
}

/// Body orientation and the bodies' filtered sea see the particles; a filter longer than the
/// particles removes them.
#[test]
fn orientation_and_filtered_sea_see_particles() {
    let spec: SurfaceSpec = serde_json::from_str(
        r#"{"layers": [{"kind": "particles", "count": 0, "ripples": {"decay": 1000}}]}"#,
    )
    .unwrap();
    let s = Surface::new(&spec).unwrap();
    let imp = Impacts::from_events(vec![Impact {
        t: 0.0,
        position: [0.0, 0.0],
        strength: 2.0,
        radius: 2.0,
    }])
    .unwrap();
    let sea = s
        .at(2.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap()
        .with_impacts(&imp)
        .unwrap();
    let ring_d = sea.particle_field(0).map(|_| ()).is_some();
    assert!(ring_d);
    let Layer::Particles(layer) = &s.layers()[0] else {
        unreachable!()
    };
    let d = layer.ring(&imp.events()[0]).state(2.0).unwrap().distance;
    let body = BodyFootprint {
        position: [d, 0.0],
        yaw: 0.0,
        length: 3.0,
        beam: 2.0,
        probes: None,
    };
    let o = body.orientation(&sea, "bodies[0]").unwrap();
    assert!(o.heave.abs() > 1e-3 && o.pitch.abs() > 1e-3, "{o:?}");
    let w = sea.water_at(DVec2::new(d, 0.0), 0.0);
    assert!(w.height > 1e-3 && w.velocity.y.abs() > 1e-4, "{w:?}");
    let filtered = sea.water_at(DVec2::new(d, 0.0), 9.0);
    assert_eq!(filtered.height, 0.0);
}

/// Impacts on a surface without a particle layer change nothing.
#[test]
fn impacts_without_a_particle_layer_change_nothing() {
    let s = Surface::new(&common::sine_spec()).unwrap();
    let a = s
        .at(11.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap();
    let b = a.clone().with_impacts(&impacts()).unwrap();
    for p in common::points(1, 50, (0.0, 0.0), 10.0) {
        assert_eq!(a.height(p.x, p.y).to_bits(), b.height(p.x, p.y).to_bits());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any valid spec, impacts, time and point give finite heights, normals and velocities.
    #[test]
    fn finite_everywhere(
        count in 0u32..2000,
        tile in 0.5f64..5000.0,
        rfrac in 0.001f64..0.25,
        amp in 0.0f64..10.0,
        scale in 0.01f64..64.0,
        n0 in 3u32..64,
        t in -1e9f64..1e9,
        x in -1e9f64..1e9,
        z in -1e9f64..1e9,
        events in prop::collection::vec(
            (-100.0f64..100.0, -50.0f64..50.0, -50.0f64..50.0, 1e-3f64..100.0, 0.01f64..1000.0),
            0..12,
        ),
    ) {
        let spec = SurfaceSpec {
            seed: 3,
            gravity: 9.81,
            depth: None,
            layers: vec![LayerSpec::Particles(ParticleLayerSpec {
                count,
                tile_size: tile,
                radius: tile * rfrac,
                amplitude: amp,
                scales: vec![scale, 1.0],
                ripples: RippleSpec { particles: n0, max_ring_particles: 4096, ..Default::default() },
                ..Default::default()
            })],
        };
        let s = Surface::new(&spec).unwrap();
        let imp = Impacts::from_events(
            events
                .iter()
                .map(|&(dt, ex, ez, st, r)| Impact {
                    t: t + dt,
                    position: [x + ex, z + ez],
                    strength: st,
                    radius: r,
                })
                .collect(),
        )
        .unwrap();
        let sea = s
            .at(t, QueryFields::ALL, &QueryOptions::default())
            .unwrap()
            .with_impacts(&imp)
            .unwrap();
        for p in [DVec2::new(x, z), DVec2::new(x + 3.0, z - 2.0)] {
            let r = sea.query(p, QueryFields::ALL);
            prop_assert!(r.height.is_finite() && r.normal.is_finite(), "{r:?}");
            prop_assert!(sea.velocity(p).is_finite());
        }
    }
}

/// Inversion leaves particle layers out of its rounds (they move the surface vertically only)
/// and adds them once at the point it keeps. That is the same answer as evaluating them every
/// round: the source found is the particle-free surface's, to the bit, and the sample is a full
/// evaluation there, to the bit, in f64 and f32, with and without derivatives, in single points
/// and in batches.
#[test]
fn inversion_adds_particles_once_at_the_point_it_keeps() {
    let spec = harbour();
    let mut bare_spec = spec.clone();
    bare_spec.layers.truncate(1);
    let (s, bare) = (
        Surface::new(&spec).unwrap(),
        Surface::new(&bare_spec).unwrap(),
    );
    let bits = |v: glam::DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    for precision in [swell_waves::Precision::F64, swell_waves::Precision::F32] {
        let options = QueryOptions {
            precision,
            ..QueryOptions::default()
        };
        let t = 12.0;
        let sea = s
            .at(t, QueryFields::ALL, &options)
            .unwrap()
            .with_impacts(&impacts())
            .unwrap();
        let flat = bare.at(t, QueryFields::ALL, &options).unwrap();
        let targets: Vec<DVec2> = (0..64)
            .map(|i| DVec2::new(i as f64 * 0.71 - 20.0, (i * 7 % 64) as f64 * 0.43 - 12.0))
            .collect();
        for derivatives in [false, true] {
            for &target in &targets {
                let inv = sea.invert(target, derivatives);
                let free = flat.invert(target, derivatives);
                assert_eq!(
                    (
                        inv.source.x.to_bits(),
                        inv.source.y.to_bits(),
                        inv.iterations
                    ),
                    (
                        free.source.x.to_bits(),
                        free.source.y.to_bits(),
                        free.iterations
                    ),
                    "{precision:?} {target}"
                );
                let full = sea.sample_lanes(&[inv.source], derivatives).get(0);
                assert_eq!(bits(inv.sample.displacement), bits(full.displacement));
                if derivatives {
                    assert_eq!(bits(inv.sample.d_dx), bits(full.d_dx));
                    assert_eq!(bits(inv.sample.d_dz), bits(full.d_dz));
                }
            }
            // The batch path answers the same bits.
            let batch = sea.query_batch(&targets, QueryFields::ALL);
            for (r, &target) in batch.iter().zip(&targets) {
                assert_eq!(
                    r.height.to_bits(),
                    sea.query(target, QueryFields::ALL).height.to_bits()
                );
            }
        }
    }
}
