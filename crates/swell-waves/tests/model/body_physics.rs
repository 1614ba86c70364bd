//! Rigid-body buoyancy simulation against the formulas: draft, heave period, damping, bounded
//! energy and drift, a storm with 100 bodies, hull averaging, replay and snapshot bits, NaN
//! containment.

use crate::common;

use glam::{DMat3, DVec2, DVec3};
use swell_waves::body::{
    BodyId, BodyInput, BodySpec, BodyState, HullSpec, World, WorldSettings, substeps_for,
};
use swell_waves::fft::{FftBackend, FftSpec};
use swell_waves::gerstner::{GerstnerLayerSpec, GerstnerWave};
use swell_waves::sine::{SineLayerSpec, SineWave};
use swell_waves::spectrum::{SpectrumSpec, SpreadingSpec};
use swell_waves::{Inversion, LayerSpec, QueryFields, QueryOptions, Surface, SurfaceSpec};

const RHO: f64 = 1025.0;
const G: f64 = 9.81;

fn sine_sea(amplitude: f64, wavelength: f64) -> Surface {
    Surface::new(&SurfaceSpec {
        seed: 0,
        gravity: G,
        depth: None,
        layers: vec![LayerSpec::Sine(SineLayerSpec {
            waves: vec![SineWave {
                amplitude,
                wavelength,
                direction: [1.0, 0.0],
                phase: 0.0,
                speed: None,
            }],
        })],
    })
    .unwrap()
}

fn flat_sea() -> Surface {
    sine_sea(0.0, 10.0)
}

fn gerstner_sea(amplitude: f64, wavelength: f64, steepness: f64) -> Surface {
    Surface::new(&SurfaceSpec {
        seed: 0,
        gravity: G,
        depth: None,
        layers: vec![LayerSpec::Gerstner(GerstnerLayerSpec {
            waves: vec![GerstnerWave {
                amplitude,
                wavelength,
                direction: [1.0, 0.0],
                phase: 0.0,
                speed: None,
                steepness,
            }],
            ..Default::default()
        })],
    })
    .unwrap()
}

fn world(tick_hz: f64) -> World {
    World::new(WorldSettings {
        tick_hz,
        ..WorldSettings::default()
    })
    .unwrap()
}

/// A box of mass m and dims l × b × h with heave damping ratio ζ at its floating draft
/// (`c₁ = 2ζ·sqrt(k·m)/f`, k = ρ·g·L·B, f = draft/height), matching roll/pitch damping.
fn damped_box(m: f64, l: f64, b: f64, h: f64, zeta: f64) -> BodySpec {
    let k = RHO * G * l * b;
    let f = m / (RHO * l * b * h);
    let c1 = 2.0 * zeta * (k * m).sqrt() / f;
    BodySpec {
        linear_drag: c1,
        angular_damping: c1 * (l * l + b * b) / 12.0,
        ..BodySpec::boxed(m, l, b, h)
    }
}

fn forward_axis(w: &World, id: BodyId) -> DVec3 {
    w.body(id).unwrap().state().rotation * DVec3::X
}

#[test]
fn flat_water_box_floats_level_at_its_draft() {
    // Draft d = m/(ρ·L·B) = 2000/(1025·8) = 0.2439 m; the box (height 1 m) is centred on its
    // origin, so the origin rests at y = d − 0.5.
    let (m, l, b, h) = (2000.0, 4.0, 2.0, 1.0);
    let sea = flat_sea();
    let mut w = world(30.0);
    let id = w
        .add(
            &damped_box(m, l, b, h, 0.4),
            BodyState::at_rest(DVec3::new(3.0, 0.2, -1.0), 0.6),
        )
        .unwrap();
    for _ in 0..30 * 30 {
        w.step_surface(&sea, &QueryOptions::default()).unwrap();
    }
    let s = *w.body(id).unwrap().state();
    let draft = -(s.position.y - 0.5 * h);
    let expect = m / (RHO * l * b);
    assert!(
        (draft - expect).abs() < 0.01 * expect,
        "draft {draft} vs {expect}"
    );
    let up = s.rotation * DVec3::Y;
    assert!(up.y > 1.0 - 1e-9, "not level: up = {up}");
    assert!((s.position.x - 3.0).abs() < 1e-6 && (s.position.z + 1.0).abs() < 1e-6);
    let sub = w.body(id).unwrap().status().submerged;
    assert!((sub - expect / h).abs() < 0.01 * expect / h);
}

/// Runs a box released `lift` above its equilibrium on flat water for `seconds`, returning the
/// heave `y − y_eq` at every tick.
fn heave_record(zeta: f64, lift: f64, tick_hz: f64, seconds: f64) -> (Vec<f64>, f64) {
    let (m, l, b, h) = (2000.0, 4.0, 2.0, 1.0);
    let y_eq = 0.5 * h - m / (RHO * l * b);
    let sea = flat_sea();
    let mut w = world(tick_hz);
    let id = w
        .add(
            &damped_box(m, l, b, h, zeta),
            BodyState::at_rest(DVec3::new(0.0, y_eq + lift, 0.0), 0.0),
        )
        .unwrap();
    let mut out = vec![lift];
    for _ in 0..(seconds * tick_hz) as usize {
        w.step_surface(&sea, &QueryOptions::default()).unwrap();
        out.push(w.body(id).unwrap().state().position.y - y_eq);
    }
    (
        out,
        2.0 * std::f64::consts::PI * (m / (RHO * G * l * b)).sqrt(),
    )
}

/// Times of upward zero crossings, linearly interpolated.
fn up_crossings(y: &[f64], dt: f64) -> Vec<f64> {
    let mut t = Vec::new();
    for i in 1..y.len() {
        if y[i - 1] < 0.0 && y[i] >= 0.0 {
            t.push(dt * ((i - 1) as f64 + y[i - 1] / (y[i - 1] - y[i])));
        }
    }
    t
}

#[test]
fn heave_period_matches_the_hydrostatic_spring_and_damping_decays_it() {
    // T = 2π·sqrt(m/(ρ·g·L·B)) = 0.991 s for 2000 kg on 4 m × 2 m. Released 5 cm high (less
    // than the 0.24 m draft, so the hull never leaves the water: the spring stays linear).
    let hz = 60.0;
    let (y, period) = heave_record(0.0, 0.05, hz, 20.0);
    let c = up_crossings(&y, 1.0 / hz);
    assert!(c.len() >= 15, "{} crossings", c.len());
    let measured = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    assert!(
        (measured - period).abs() < 0.05 * period,
        "period {measured} vs {period}"
    );
    // Undamped: the symplectic integrator keeps the amplitude (within 2%).
    let peak = |ys: &[f64]| ys.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let n = y.len();
    assert!(
        (peak(&y[n - 2 * hz as usize..]) - 0.05).abs() < 0.001,
        "{}",
        peak(&y[n - 120..])
    );
    // Damped (ζ = 0.1): after 5 periods the amplitude has fallen by about e^{−2πζ·5} ≈ 0.04.
    let (yd, _) = heave_record(0.1, 0.05, hz, 20.0);
    let first = peak(&yd[..hz as usize]);
    let later = peak(&yd[(5.0 * period * hz) as usize..(6.0 * period * hz) as usize]);
    assert!(later < 0.15 * first, "amplitude {first} → {later}");
    assert!(peak(&yd[n - hz as usize..]) < 1e-3);
}

#[test]
fn calm_sea_energy_is_bounded_and_decays_and_drift_is_small() {
    // One Gerstner swell A = 0.3 m, λ = 40 m, Q = 0.5 for 10 simulated minutes, box dropped
    // from 0.5 m above equilibrium. Energy E = ½m|v|² + ½ωᵀI_wω + ½k(y − y_eq)² with the
    // hydrostatic stiffness k = ρ·g·L·B.
    let (m, l, b, h) = (2000.0, 4.0, 2.0, 1.0);
    let (a, lambda, q) = (0.3, 40.0, 0.5);
    let sea = gerstner_sea(a, lambda, q);
    let y_eq = 0.5 * h - m / (RHO * l * b);
    let k = RHO * G * l * b;
    let hz = 20.0;
    let mut w = world(hz);
    let id = w
        .add(
            &damped_box(m, l, b, h, 0.2),
            BodyState::at_rest(DVec3::new(0.0, y_eq + 0.5, 0.0), 0.0),
        )
        .unwrap();
    let inertia = w.body(id).unwrap().model().inertia();
    let energy = |w: &World| {
        let s = w.body(id).unwrap().state();
        let r = DMat3::from_quat(s.rotation);
        let iw = r * inertia * r.transpose();
        let dy = s.position.y - y_eq;
        0.5 * m * s.velocity.length_squared()
            + 0.5 * s.angular_velocity.dot(iw * s.angular_velocity)
            + 0.5 * k * dy * dy
    };
    let e0 = energy(&w);
    let ticks = (600.0 * hz) as usize;
    let mut e_max: f64 = 0.0;
    let mut e_last_minute = 0.0;
    for i in 0..ticks {
        w.step_surface(&sea, &QueryOptions::default()).unwrap();
        let e = energy(&w);
        assert!(e.is_finite());
        if i > (60.0 * hz) as usize {
            e_max = e_max.max(e);
        }
        if i >= ticks - (60.0 * hz) as usize {
            e_last_minute += e / (60.0 * hz);
        }
    }
    // Bounded: once the drop has died out the body only follows the swell, whose forcing
    // energy is about ½k·A² (the spring stretched by the wave amplitude) plus the kinetic
    // energy of riding it, ½m(ωA)²; we allow twice their sum.
    let omega = (G * std::f64::consts::TAU / lambda).sqrt();
    let forced = 0.5 * k * a * a + 0.5 * m * (omega * a) * (omega * a);
    assert!(
        e_max < 2.0 * forced,
        "E max {e_max} vs forced {forced} (E0 {e0})"
    );
    // Decaying: the drop's energy is gone; the last minute holds less than the start.
    assert!(
        e_last_minute < e0,
        "E last minute {e_last_minute} vs E0 {e0}"
    );
    // Drift: at most the Stokes transport of the swell, u_s = ω·k·A², over the run, plus 1 m.
    let kw = std::f64::consts::TAU / lambda;
    let u_s = omega * kw * a * a;
    let p = w.body(id).unwrap().state().position;
    let drift = DVec2::new(p.x, p.z).length();
    assert!(
        drift < u_s * 600.0 + 1.0,
        "drift {drift} m vs Stokes {}",
        u_s * 600.0
    );
}

fn storm_sea() -> Surface {
    // Four random Gerstner waves (2–100 m) at fold number 0.9 plus a small height-field FFT layer.
    let mut spec = common::gerstner_spec(7, 4, 0.9);
    spec.layers.push(LayerSpec::Fft(FftSpec {
        resolution: 16,
        tile_size: 64.0,
        choppiness: 0.0,
        repeat_period: 100.0,
        spectrum: SpectrumSpec::PiersonMoskowitz { wind_speed: 6.0 },
        spreading: SpreadingSpec::default(),
        wind_direction: [1.0, 0.3],
        band: None,
        seed: None,
        backend: FftBackend::Portable,
        time_step: None,
    }));
    Surface::new(&spec).unwrap()
}

/// The storm test runs in two halves (even and odd bodies) so the test harness can run them on
/// two threads; bodies do not interact, so this is the same simulation as one world of 100.
#[test]
fn storm_hundred_bodies_from_one_kilogram_to_500_tonnes_even_half() {
    storm_bodies(0);
}

#[test]
fn storm_hundred_bodies_from_one_kilogram_to_500_tonnes_odd_half() {
    storm_bodies(1);
}

/// Storm, 10 simulated minutes, bodies `i ≡ half (mod 2)` of 100 with masses log-spaced from
/// 1 kg to 500 t: all finite, never quarantined, none below the sea above it by more than its
/// hull height, none above the highest possible crest by more than its hull height.
fn storm_bodies(half: usize) {
    let sea = storm_sea();
    // Highest possible crest: Σ A of the Gerstner waves plus Σ|h̃| ≤ Σ (|h0(k)| + |h0(−k)|)
    // over the FFT modes.
    let mut crest: f64 = sea.layers()[0].waves().iter().map(|w| w.amplitude).sum();
    if let swell_waves::Layer::Fft(f) = &sea.layers()[1] {
        for m in -8..8 {
            for n in -8..8 {
                crest += f.h0(m, n).norm();
            }
        }
    }
    let hz = 10.0;
    let mut w = world(hz);
    let at0 = sea
        .at(0.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let mut heights = std::collections::BTreeMap::new();
    for i in (half..100).step_by(2) {
        // Masses log-spaced from 1 kg to 500 t; boxes 4:2:1 at 40% of the water's density.
        let m = 1.0 * (5e5f64).powf(i as f64 / 99.0);
        let s = (m / (0.4 * RHO * 8.0)).cbrt();
        let (l, b, h) = (4.0 * s, 2.0 * s, s);
        let spec = BodySpec {
            quadratic_drag: 0.5 * RHO * 1.0 * b * h,
            ..damped_box(m, l, b, h, 0.3)
        };
        let x = (i % 10) as f64 * 30.0;
        let z = (i / 10) as f64 * 30.0;
        let y = at0.height(x, z) + 0.5 * h - 0.4 * h;
        w.insert(
            i as u64,
            &spec,
            BodyState::at_rest(DVec3::new(x, y, z), i as f64),
        )
        .unwrap();
        heights.insert(i as u64, h);
    }
    // Bodies need the sea height to a millimetre, not the 0.01 mm default: fewer Newton steps.
    let opts = QueryOptions {
        inversion: Inversion {
            tolerance: 1e-3,
            iterations: 4,
            ..Inversion::default()
        },
        ..QueryOptions::default()
    };
    let ticks = (600.0 * hz) as usize;
    for tick in 0..ticks {
        w.step_surface(&sea, &opts).unwrap();
        if tick % 5 != 0 {
            continue;
        }
        let at = sea
            .at(w.time(), QueryFields::HEIGHT, &QueryOptions::default())
            .unwrap();
        for (id, body) in w.bodies() {
            let s = body.state();
            assert!(s.is_finite(), "body {id} not finite at tick {tick}");
            assert!(
                !body.status().quarantined,
                "body {id} quarantined at tick {tick}"
            );
            let hh = heights[&id];
            let eta = at.height(s.position.x, s.position.z);
            assert!(
                s.position.y > eta - hh,
                "body {id} sank: y {} under sea {eta} by more than {hh} at tick {tick}",
                s.position.y
            );
            assert!(
                s.position.y < crest + hh,
                "body {id} launched: y {} above crest bound {crest} + {hh} at tick {tick}",
                s.position.y
            );
        }
    }
}

/// Largest |sin pitch| over the last `seconds` of a run on `sea`.
fn max_pitch(sea: &Surface, spec: &BodySpec, seconds: f64) -> f64 {
    let hz = 20.0;
    let mut w = world(hz);
    let id = w
        .add(spec, BodyState::at_rest(DVec3::new(0.0, 0.0, 0.0), 0.0))
        .unwrap();
    let mut out: f64 = 0.0;
    let ticks = (seconds * hz) as usize;
    for i in 0..ticks {
        w.step_surface(sea, &QueryOptions::default()).unwrap();
        if i > ticks / 3 {
            out = out.max(forward_axis(&w, id).y.abs());
        }
    }
    out
}

#[test]
fn a_long_boat_on_a_short_swell_pitches_less_than_a_short_boat() {
    // λ = 12 m, A = 0.3 m head sea (along the boats' length): a 4 m boat rides every slope
    // (max slope k·A = 0.16), a 40 m boat spans 3⅓ wavelengths and averages them out.
    let sea = sine_sea(0.3, 12.0);
    let short = damped_box(4000.0, 4.0, 2.0, 1.0, 0.2);
    let long = BodySpec {
        hull: HullSpec::Box {
            length: 40.0,
            beam: 8.0,
            height: 3.0,
            cells: Some([16, 2]),
        },
        ..damped_box(300_000.0, 40.0, 8.0, 3.0, 0.2)
    };
    let p_short = max_pitch(&sea, &short, 60.0);
    let p_long = max_pitch(&sea, &long, 60.0);
    assert!(p_short > 0.05, "short boat barely pitches: {p_short}");
    assert!(p_long < 0.25 * p_short, "long {p_long} vs short {p_short}");
    // With the size filter (waves shorter than 0.5 hull lengths ignored), the long boat does
    // not feel the 12 m swell at all.
    let filtered = BodySpec {
        min_wavelength_factor: 0.5,
        ..long
    };
    assert!(max_pitch(&sea, &filtered, 20.0) < 1e-12);
}

fn scenario(w: &mut World) -> Vec<BodyId> {
    let mut ids = Vec::new();
    for i in 0..4 {
        let spec = damped_box(500.0 + 700.0 * i as f64, 3.0 + i as f64, 1.5, 0.8, 0.2);
        ids.push(
            w.add(
                &spec,
                BodyState::at_rest(DVec3::new(10.0 * i as f64, 0.3, 2.0), 0.3 * i as f64),
            )
            .unwrap(),
        );
    }
    w.input(BodyInput {
        body: ids[1],
        force: [3000.0, 0.0, 0.0],
        torque: [0.0, 800.0, 0.0],
        from_tick: 20,
        ticks: 100,
    })
    .unwrap();
    w.input(BodyInput {
        body: ids[2],
        force: [0.0, 0.0, -900.0],
        torque: [0.0; 3],
        from_tick: 150,
        ticks: 40,
    })
    .unwrap();
    w.input(BodyInput {
        body: ids[1],
        force: [-500.0, 0.0, 0.0],
        torque: [0.0; 3],
        from_tick: 60,
        ticks: 5,
    })
    .unwrap();
    ids
}

fn bits(w: &World) -> Vec<u64> {
    w.bodies()
        .flat_map(|(_, b)| {
            let s = b.state();
            [
                s.position.to_array(),
                s.velocity.to_array(),
                s.angular_velocity.to_array(),
            ]
            .into_iter()
            .flatten()
            .chain(s.rotation.to_array())
            .map(f64::to_bits)
            .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn replay_and_snapshot_restore_are_bit_identical() {
    let sea = storm_sea();
    let opts = QueryOptions::default();
    let mut a = world(30.0);
    scenario(&mut a);
    let mut at_tick = Vec::new();
    let mut snap = None;
    for t in 0..300 {
        if t == 120 {
            snap = Some(a.snapshot());
        }
        a.step_surface(&sea, &opts).unwrap();
        at_tick.push(bits(&a));
    }
    // Replay from the initial states and the input log.
    let mut b = world(30.0);
    scenario(&mut b);
    for (t, expect) in at_tick.iter().enumerate() {
        b.step_surface(&sea, &opts).unwrap();
        assert_eq!(&bits(&b), expect, "replay differs at tick {t}");
    }
    // Restore and step on.
    let snap = snap.unwrap();
    assert_eq!(snap.tick(), 120);
    a.restore(&snap);
    for (t, expect) in at_tick.iter().enumerate().skip(120) {
        a.step_surface(&sea, &opts).unwrap();
        assert_eq!(&bits(&a), expect, "restore differs at tick {t}");
    }
    // A body's trajectory does not depend on the others: alone it gives the same bits.
    let mut c = world(30.0);
    let spec = damped_box(500.0 + 700.0 * 3.0, 6.0, 1.5, 0.8, 0.2);
    c.insert(
        3,
        &spec,
        BodyState::at_rest(DVec3::new(30.0, 0.3, 2.0), 0.3 * 3.0),
    )
    .unwrap();
    for _ in 0..300 {
        c.step_surface(&sea, &opts).unwrap();
    }
    assert_eq!(bits(&c)[..], at_tick[299][3 * 13..]);
}

#[test]
fn issue_5_huge_force_is_rolled_back_and_flagged_never_nan() {
    // A 1e300 N push overflows the velocity to infinity within a couple of ticks; the body
    // must stay at its last good state with zero velocity, flagged, and the others unaffected.
    let sea = sine_sea(0.3, 20.0);
    let mut w = world(30.0);
    let good = w
        .add(
            &damped_box(1000.0, 2.0, 1.0, 1.0, 0.2),
            BodyState::at_rest(DVec3::ZERO, 0.0),
        )
        .unwrap();
    let bad = w
        .add(
            &damped_box(1.0, 0.3, 0.2, 0.1, 0.2),
            BodyState::at_rest(DVec3::new(5.0, 0.0, 0.0), 0.0),
        )
        .unwrap();
    w.input(BodyInput {
        body: bad,
        force: [1e300, 1e300, 0.0],
        torque: [1e300, 0.0, 0.0],
        from_tick: 10,
        ticks: 50,
    })
    .unwrap();
    let mut reference = world(30.0);
    reference
        .insert(
            good,
            &damped_box(1000.0, 2.0, 1.0, 1.0, 0.2),
            BodyState::at_rest(DVec3::ZERO, 0.0),
        )
        .unwrap();
    let mut flagged = 0;
    for _ in 0..100 {
        w.step_surface(&sea, &QueryOptions::default()).unwrap();
        reference
            .step_surface(&sea, &QueryOptions::default())
            .unwrap();
        for (_, b) in w.bodies() {
            assert!(b.state().is_finite());
        }
        let st = w.body(bad).unwrap().status();
        if st.quarantined {
            flagged += 1;
            assert_eq!(w.body(bad).unwrap().state().velocity, DVec3::ZERO);
        }
        assert_eq!(bits(&reference)[..], bits(&w)[..13]);
    }
    assert!(flagged > 0);
    let st = w.body(bad).unwrap().status();
    assert!(st.rollbacks >= flagged);
    // After the input ends the body recovers (floats again, no more rollbacks).
    assert!(!st.quarantined);
    // Non-finite inputs are refused at the boundary.
    let e = w
        .input(BodyInput {
            body: bad,
            force: [f64::NAN, 0.0, 0.0],
            torque: [0.0; 3],
            from_tick: 0,
            ticks: 1,
        })
        .unwrap_err();
    assert_eq!(e.field(), "input.force[0]");
}

#[test]
fn substeps_follow_the_heave_frequency_rule() {
    let settings = WorldSettings::default();
    // 2000 kg on 8 m²: ω_n = sqrt(1025·9.81·8/2000) = 6.34 rad/s; dt·ω_n/0.25 = 0.85 → 1.
    let m = BodySpec::boxed(2000.0, 4.0, 2.0, 1.0).build("b").unwrap();
    assert_eq!(substeps_for(&m, &settings), 1);
    // 1 kg on 0.3 m × 0.2 m: ω_n = 24.6 rad/s → 3.3 → 4.
    let m = BodySpec::boxed(1.0, 0.3, 0.2, 0.1).build("b").unwrap();
    assert_eq!(substeps_for(&m, &settings), 4);
    // 1 g on 1 m²: absurdly stiff → clamped to 256.
    let m = BodySpec::boxed(1e-3, 1.0, 1.0, 0.1).build("b").unwrap();
    assert_eq!(substeps_for(&m, &settings), 256);
}

#[test]
fn body_spec_errors_name_the_field() {
    let e = BodySpec::boxed(-1.0, 1.0, 1.0, 1.0)
        .build("bodies[2]")
        .unwrap_err();
    assert_eq!(e.field(), "bodies[2].mass");
    let e = BodySpec::boxed(1.0, 0.0, 1.0, 1.0).build("b").unwrap_err();
    assert_eq!(e.field(), "b.hull.length");
    let mut s = BodySpec::boxed(1.0, 1.0, 1.0, 1.0);
    s.center_of_mass = [0.0, 2.0, 0.0];
    assert_eq!(s.build("b").unwrap_err().field(), "b.center_of_mass[1]");
    let mut s = BodySpec::boxed(1.0, 1.0, 1.0, 1.0);
    s.quadratic_drag = f64::INFINITY;
    assert_eq!(s.build("b").unwrap_err().field(), "b.quadratic_drag");
    let mut s = BodySpec::boxed(1.0, 1.0, 1.0, 1.0);
    s.hull = HullSpec::Box {
        length: 1.0,
        beam: 1.0,
        height: 1.0,
        cells: Some([0, 2]),
    };
    assert_eq!(s.build("b").unwrap_err().field(), "b.hull.cells[0]");
    s.hull = HullSpec::Cells { cells: vec![] };
    assert_eq!(s.build("b").unwrap_err().field(), "b.hull.cells");
    s.hull = HullSpec::Cells {
        cells: vec![swell_waves::body::CellSpec {
            position: [0.0; 3],
            volume: 0.0,
            height: 1.0,
        }],
    };
    assert_eq!(s.build("b").unwrap_err().field(), "b.hull.cells[0].volume");
    let mut s = BodySpec::boxed(1.0, 1.0, 1.0, 1.0);
    s.min_wavelength_factor = -1.0;
    assert_eq!(s.build("b").unwrap_err().field(), "b.min_wavelength_factor");
    // An empty prefix names the fields from the spec's root, as a spawn request writes them.
    let e = BodySpec::boxed(1.0, 1.0, 0.0, 1.0).build("").unwrap_err();
    assert_eq!(e.field(), "hull.beam");
    let e = BodySpec::boxed(-1.0, 1.0, 1.0, 1.0).build("").unwrap_err();
    assert_eq!(e.field(), "mass");
    let e = World::new(WorldSettings {
        tick_hz: 0.0,
        ..WorldSettings::default()
    })
    .unwrap_err();
    assert_eq!(e.field(), "tick_hz");
}

/// Issue 27: `World::add` named a spec's errors under `body.` (`body.mass`,
/// `body.hull.length`), where the spawn request the spec comes from (the server's body, the C
/// ABI's JSON) has those fields at its root; a client was told of a field it never sent.
#[test]
fn world_add_names_spec_fields_as_a_spawn_request_writes_them() {
    let mut w = world(30.0);
    let at_rest = BodyState::at_rest(DVec3::ZERO, 0.0);
    let e = w
        .add(&BodySpec::boxed(2e9, 4.0, 2.0, 1.0), at_rest)
        .unwrap_err();
    assert_eq!(e.field(), "mass");
    assert!(
        e.to_string()
            .starts_with("mass = 2000000000 is out of range"),
        "{e}"
    );
    let e = w
        .add(&BodySpec::boxed(2000.0, 4.0, 2.0, 1e4), at_rest)
        .unwrap_err();
    assert_eq!(e.field(), "hull.height");
    let mut cells = BodySpec::boxed(2000.0, 4.0, 2.0, 1.0);
    cells.hull = HullSpec::Cells {
        cells: vec![
            swell_waves::body::CellSpec {
                position: [0.0; 3],
                volume: 1.0,
                height: 1.0,
            };
            3
        ],
    };
    if let HullSpec::Cells { cells } = &mut cells.hull {
        cells[2].volume = f64::NAN;
    }
    assert_eq!(
        w.add(&cells, at_rest).unwrap_err().field(),
        "hull.cells[2].volume"
    );
    assert!(w.is_empty());
}

/// Issue 27: `World::add` named its spec's errors as a spawn request writes them (`mass`), but
/// its initial state's under `state.` (`state.position[1]`), a field no spawn request has: the
/// request's position is `position`. Every initial state field is now named from the root.
#[test]
fn world_add_names_the_initial_state_as_a_spawn_request_writes_it() {
    let mut w = world(30.0);
    let spec = BodySpec::boxed(2000.0, 4.0, 2.0, 1.0);
    let e = w
        .add(
            &spec,
            BodyState::at_rest(DVec3::new(0.0, f64::NAN, 0.0), 0.0),
        )
        .unwrap_err();
    assert_eq!(e.field(), "position[1]");
    assert!(e.to_string().starts_with("position[1] "), "{e}");
    let mut moving = BodyState::at_rest(DVec3::ZERO, 0.0);
    moving.velocity.x = f64::INFINITY;
    assert_eq!(w.add(&spec, moving).unwrap_err().field(), "velocity[0]");
    let mut spinning = BodyState::at_rest(DVec3::ZERO, 0.0);
    spinning.angular_velocity.z = f64::NAN;
    assert_eq!(
        w.add(&spec, spinning).unwrap_err().field(),
        "angular_velocity[2]"
    );
    let mut unrotated = BodyState::at_rest(DVec3::ZERO, 0.0);
    unrotated.rotation = glam::DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0);
    assert_eq!(w.add(&spec, unrotated).unwrap_err().field(), "rotation");
    assert!(w.is_empty());
}

/// Issue 10 (bodies on FFT scenes): the velocity grids of FFT layers are made once per tick,
/// at the tick's time, from the grid frames around it, and every substep of the tick reads
/// them. Pinned against a step that attaches the tick-time grids by hand (the same bits), and
/// against one that computes grids at every substep time (different bits: the substeps do read
/// velocity).
#[test]
fn fft_velocity_grids_are_the_ticks_for_every_substep() {
    let sea = storm_sea();
    let o = QueryOptions::default();
    // A light, stiff body takes several substeps a tick at 10 Hz; drag reads the velocity.
    let make = || {
        let mut w = world(10.0);
        let spec = BodySpec {
            linear_drag: 2000.0,
            ..BodySpec::boxed(300.0, 2.0, 1.0, 0.5)
        };
        let id = w
            .add(&spec, BodyState::at_rest(DVec3::new(3.0, 0.2, -2.0), 0.4))
            .unwrap();
        (w, id)
    };
    let (mut a, id) = make();
    let (mut b, _) = make();
    let (mut c, _) = make();
    let grids_at = |t: f64| -> Vec<Option<std::sync::Arc<swell_waves::fft::FftVelocityFrame>>> {
        sea.layers()
            .iter()
            .map(|l| match l {
                swell_waves::Layer::Fft(f) => {
                    let fields = sea.fft_fields_for(f, QueryFields::HEIGHT);
                    let frame = |k| Some(std::sync::Arc::new(f.grid_frame(k, fields)));
                    Some(std::sync::Arc::new(
                        f.grid_velocity_frame(t, frame).unwrap(),
                    ))
                }
                _ => None,
            })
            .collect()
    };
    for _ in 0..20 {
        a.step_surface(&sea, &o).unwrap();
        let tick_grids = grids_at(b.time());
        b.step(|t| {
            sea.at(t, QueryFields::HEIGHT, &o)
                .unwrap()
                .with_velocity_frames(tick_grids.clone())
                .unwrap()
        });
        c.step(|t| sea.at(t, QueryFields::HEIGHT, &o).unwrap().with_velocity());
    }
    assert!(a.body(id).unwrap().status().substeps > 1);
    let bits = |w: &World| {
        let s = w.body(id).unwrap().state();
        [s.position, s.velocity].map(|v| v.to_array().map(f64::to_bits))
    };
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
}
