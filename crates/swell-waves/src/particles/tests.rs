use glam::DVec2;

use super::kernel::kernel;
use super::*;
use crate::math::SwellRng;

fn layer(spec: &ParticleLayerSpec) -> ParticleLayer {
    ParticleLayer::new(spec, 7, Dispersion::default(), "layers[0]").unwrap()
}

fn impact(t: f64, x: f64, z: f64, strength: f64, radius: f64) -> Impact {
    Impact {
        t,
        position: [x, z],
        strength,
        radius,
    }
}

/// A field at t holding only `ring` in state `s` (no grid, no ambient particles), so
/// `visit_rings_only` gives that ring's own contributions.
fn one_ring(t: f64, ring: &Ring, s: &RingState) -> ParticleField {
    ParticleField::new(
        t,
        vec![field::LiveRing {
            ring: *ring,
            d: s.distance,
            n: s.count,
            amp: s.amplitude,
            inv_r2: 1.0 / (ring.radius * ring.radius),
            amp_rate: 0.0,
        }],
    )
}

/// The kernel's analytic gradient against central differences, over its whole support.
#[test]
fn kernel_gradient_matches_finite_differences() {
    let mut rng = SwellRng::new(1, 2);
    let (a, r) = (0.7, 1.3);
    let inv_r2 = 1.0 / (r * r);
    let h = |d: DVec2| kernel(a, d, inv_r2).map_or(0.0, |(h, _)| h);
    for _ in 0..2000 {
        let d = DVec2::new(rng.uniform() * 2.8 - 1.4, rng.uniform() * 2.8 - 1.4);
        let g = kernel(a, d, inv_r2).map_or(DVec2::ZERO, |(_, g)| g);
        let e = 1e-6;
        let fx = (h(d + DVec2::X * e) - h(d - DVec2::X * e)) / (2.0 * e);
        let fz = (h(d + DVec2::Y * e) - h(d - DVec2::Y * e)) / (2.0 * e);
        assert!(
            (fx - g.x).abs() < 1e-7 && (fz - g.y).abs() < 1e-7,
            "{d}: {g} vs ({fx}, {fz})"
        );
    }
    // C² at the rim: value, slope and curvature vanish as q → 1.
    let rim = DVec2::new(r * (1.0 - 1e-4), 0.0);
    let (hv, gv) = kernel(a, rim, inv_r2).unwrap();
    assert!(hv < 1e-11 && gv.length() < 1e-6);
    assert!(kernel(a, DVec2::new(r, 0.0), inv_r2).is_none());
}

/// The layer's gradient (ambient and rings, all scales) against central differences of its
/// height.
#[test]
fn layer_gradient_matches_finite_differences() {
    let l = layer(&ParticleLayerSpec {
        scales: vec![0.33, 0.66, 1.0],
        ..Default::default()
    });
    let impacts = Impacts::from_events(vec![
        impact(1.0, 3.0, 4.0, 0.5, 0.6),
        impact(2.5, -6.0, 1.0, 0.3, 1.2),
    ])
    .unwrap();
    let t = 4.0;
    let f = l.field(t, Some(&impacts)).unwrap();
    assert_eq!(f.live_rings(), 2);
    let mut rng = SwellRng::new(5, 6);
    for _ in 0..500 {
        let x = DVec2::new(rng.uniform() * 30.0 - 15.0, rng.uniform() * 30.0 - 10.0);
        let (_, g) = f.sample(&l, x, 0.0);
        let e = 1e-6;
        let h = |p: DVec2| f.sample(&l, p, 0.0).0;
        let fx = (h(x + DVec2::X * e) - h(x - DVec2::X * e)) / (2.0 * e);
        let fz = (h(x + DVec2::Y * e) - h(x - DVec2::Y * e)) / (2.0 * e);
        assert!(
            (fx - g.x).abs() < 1e-6 && (fz - g.y).abs() < 1e-6,
            "{x}: {g} vs ({fx}, {fz})"
        );
    }
}

/// Closed-form ambient positions against explicit stepping `p += v·dt` with wrapping, forwards
/// and backwards.
#[test]
fn ambient_positions_match_explicit_stepping() {
    let l = layer(&ParticleLayerSpec {
        count: 64,
        ..Default::default()
    });
    let amb = l.ambient();
    let dt = 1.0 / 60.0;
    for dir in [1.0, -1.0] {
        let mut p: Vec<DVec2> = (0..amb.len()).map(|i| amb.position(i, 0.0)).collect();
        for step in 1..=6000 {
            let t = dir * step as f64 * dt;
            for (i, q) in p.iter_mut().enumerate() {
                let (_, v, _) = amb.particle(i);
                *q += v * (dir * dt) / amb.tile_size();
                q.x -= q.x.floor();
                q.y -= q.y.floor();
            }
            if step % 600 == 0 {
                for (i, q) in p.iter().enumerate() {
                    let e = amb.position(i, t) - *q;
                    let e = DVec2::new(e.x - e.x.round(), e.y - e.y.round());
                    assert!(e.length() < 1e-11, "particle {i} at t = {t}: off by {e}");
                }
            }
        }
    }
}

/// A stepping simulation of Yuksel's algorithm (move every particle, split any whose gap
/// exceeds the radius into three, drop any below the floor) against the closed form.
#[test]
fn ring_closed_form_matches_stepped_subdivision() {
    let l = layer(&ParticleLayerSpec::default());
    let e = impact(2.0, 10.0, -5.0, 0.8, 0.5);
    let ring = l.ring(&e);
    // (angle, width, amplitude before decay)
    let n0 = ring.n0;
    let mut ps: Vec<(f64, f64, f64)> = (0..n0)
        .map(|i| {
            let w = crate::math::TAU / f64::from(n0);
            (w * f64::from(i), w, ring.a0)
        })
        .collect();
    let dt = 1.0 / 240.0;
    let mut t = e.t;
    let mut splits_seen = 0;
    while t < e.t + 40.0 {
        t += dt;
        let d = ring.speed * (t - e.t);
        let mut next = Vec::with_capacity(ps.len() * 3);
        for &(phi, w, a) in &ps {
            if d * w > ring.radius {
                for k in [-1.0, 0.0, 1.0] {
                    next.push((phi + k * w / 3.0, w / 3.0, a / 3.0));
                }
            } else {
                next.push((phi, w, a));
            }
        }
        if next.len() != ps.len() {
            splits_seen += 1;
        }
        ps = next;
        let Some(s) = ring.state(t) else {
            break;
        };
        // The stepped ring may split up to one step late.
        if (t - ring.split_time(s.generation.saturating_sub(1))).abs() < 2.0 * dt
            || (t - ring.split_time(s.generation)).abs() < 2.0 * dt
        {
            continue;
        }
        assert_eq!(ps.len() as u32, s.count, "t = {t}");
        let decay = crate::math::exp(-d / l.ripples().decay);
        assert!((ps[0].2 * decay - s.amplitude).abs() < 1e-12 * ring.a0);
        // The same angles: sorted, they are 2π·i/N.
        let mut angles: Vec<f64> = ps
            .iter()
            .map(|p| p.0.rem_euclid(crate::math::TAU))
            .collect();
        angles.sort_by(f64::total_cmp);
        for (i, a) in angles.iter().enumerate() {
            let want = crate::math::TAU * i as f64 / f64::from(s.count);
            let diff = (a - want).abs();
            assert!(
                diff < 1e-9 || (crate::math::TAU - diff) < 1e-9,
                "{a} vs {want}"
            );
        }
    }
    assert!(
        splits_seen >= 2,
        "the test should see splits: {splits_seen}"
    );
}

/// Subdivision conserves the ring's total amplitude: just before and just after each split the
/// particle amplitudes sum to the same (before the distance decay, exactly `strength`).
#[test]
fn subdivision_conserves_total_amplitude() {
    let l = layer(&ParticleLayerSpec {
        ripples: RippleSpec {
            decay: 1e6,
            floor: 1e-9,
            ..Default::default()
        },
        ..Default::default()
    });
    let e = impact(0.0, 0.0, 0.0, 0.6, 0.4);
    let ring = l.ring(&e);
    for g in 0..3 {
        let ts = ring.split_time(g);
        let before = ring.particles(ts - 1e-9);
        let after = ring.particles(ts + 1e-9);
        assert_eq!(after.len(), 3 * before.len(), "split {g}");
        let sum = |v: &[(DVec2, f64)]| v.iter().map(|p| p.1).sum::<f64>();
        let (b, a) = (sum(&before), sum(&after));
        assert!((a - b).abs() < 1e-9 * b, "split {g}: {b} -> {a}");
        assert!((b - 0.6).abs() < 1e-5, "total {b}");
    }
}

/// The ring dies at its closed-form death time (floor and lifetime), and not before t0.
#[test]
fn ring_death_time_is_closed_form() {
    let l = layer(&ParticleLayerSpec::default());
    for (strength, radius) in [(0.5, 0.5), (0.01, 0.2), (5.0, 3.0), (0.2, 0.05)] {
        let ring = l.ring(&impact(3.0, 0.0, 0.0, strength, radius));
        let td = ring.death_time();
        assert!(ring.state(3.0 - 1e-9).is_none());
        assert!(ring.state(3.0).is_some());
        let eps = 1e-9 * td.abs().max(1.0);
        assert!(
            ring.state(td - eps).is_some(),
            "{strength} {radius}: alive before {td}"
        );
        assert!(
            ring.state(td + eps).is_none(),
            "{strength} {radius}: dead after {td}"
        );
    }
}

/// The live set at t is a pure function of (impacts, t): any order of arrival, any order of
/// evaluation times (forwards, backwards, random seeks) gives the same bits.
#[test]
fn replay_seek_and_reverse_are_bit_identical() {
    let l = layer(&ParticleLayerSpec {
        scales: vec![0.5, 1.0],
        ..Default::default()
    });
    let mut rng = SwellRng::new(9, 9);
    let events: Vec<Impact> = (0..40)
        .map(|_| {
            impact(
                rng.uniform() * 30.0,
                rng.uniform() * 60.0 - 30.0,
                rng.uniform() * 60.0 - 30.0,
                0.05 + rng.uniform(),
                0.2 + rng.uniform(),
            )
        })
        .collect();
    let a = Impacts::from_events(events.clone()).unwrap();
    let mut rev = events.clone();
    rev.reverse();
    let mut b = Impacts::new();
    for e in rev {
        b = b.with(e).unwrap();
    }
    assert_eq!(a, b);
    let points: Vec<DVec2> = (0..50)
        .map(|_| DVec2::new(rng.uniform() * 80.0 - 40.0, rng.uniform() * 80.0 - 40.0))
        .collect();
    let times: Vec<f64> = (0..40).map(|i| i as f64 * 0.9).collect();
    let eval = |imp: &Impacts, t: f64| -> Vec<u64> {
        let f = l.field(t, Some(imp)).unwrap();
        points
            .iter()
            .flat_map(|&p| {
                let (h, g) = f.sample(&l, p, 0.0);
                [h.to_bits(), g.x.to_bits(), g.y.to_bits()]
            })
            .collect()
    };
    let forward: Vec<Vec<u64>> = times.iter().map(|&t| eval(&a, t)).collect();
    let backward: Vec<Vec<u64>> = times.iter().rev().map(|&t| eval(&b, t)).collect();
    for (f, b) in forward.iter().zip(backward.iter().rev()) {
        assert_eq!(f, b);
    }
    for _ in 0..20 {
        let i = (rng.uniform() * times.len() as f64) as usize % times.len();
        assert_eq!(eval(&a, times[i]), forward[i]);
    }
}

/// The grids only skip particles whose kernel is zero: the fast path equals the brute-force
/// closed-form sum (to rounding; the order differs), and with more than `RING_GRID_MIN` rings
/// the ring grid gives the bits of the plain scan.
#[test]
fn grid_paths_match_the_reference() {
    let l = layer(&ParticleLayerSpec {
        scales: vec![0.33, 0.66, 1.0],
        ..Default::default()
    });
    let mut rng = SwellRng::new(4, 4);
    let events: Vec<Impact> = (0..30)
        .map(|_| {
            impact(
                rng.uniform() * 10.0,
                rng.uniform() * 40.0 - 20.0,
                rng.uniform() * 40.0 - 20.0,
                0.05 + rng.uniform(),
                0.1 + rng.uniform(),
            )
        })
        .collect();
    let impacts = Impacts::from_events(events).unwrap();
    let t = 12.0;
    let f = l.field(t, Some(&impacts)).unwrap();
    assert!(f.live_rings() > RING_GRID_MIN, "{}", f.live_rings());
    // The same rings one at a time (no grid: each field has one ring).
    let mut worst: f64 = 0.0;
    for _ in 0..3000 {
        let x = DVec2::new(rng.uniform() * 100.0 - 50.0, rng.uniform() * 100.0 - 50.0);
        let (h, g) = f.sample(&l, x, 0.0);
        let (hr, gr, _) = f.sample_reference(&l, x);
        worst = worst.max((h - hr).abs()).max((g - gr).length());
    }
    assert!(worst < 1e-12, "grid vs reference: {worst}");
    // Ring grid against the plain scan: a field with the grid disabled is a field with at most
    // RING_GRID_MIN rings, so compare sums of sub-fields... instead compare against a scan done
    // here, ring by ring, in canonical order.
    let live = l.live_rings(t, &impacts);
    for _ in 0..3000 {
        let x = DVec2::new(rng.uniform() * 100.0 - 50.0, rng.uniform() * 100.0 - 50.0);
        let (h, g) = f.sample(&l, x, 0.0);
        let empty = l.field(t, None).unwrap();
        let (mut hs, mut gs) = empty.sample(&l, x, 0.0);
        for (ring, s) in &live {
            // The ring's own contribution, added in ring order like the fast path does.
            one_ring(t, ring, s).visit_rings_only(x, &mut |hk, gk| {
                hs += hk;
                gs += gk;
            });
        }
        assert_eq!(
            (h.to_bits(), g.x.to_bits(), g.y.to_bits()),
            (hs.to_bits(), gs.x.to_bits(), gs.y.to_bits()),
            "{x}"
        );
    }
}

/// Where more than `MAX_RINGS_PER_POINT` rings cover a point, the newest that many add to it,
/// oldest first: the fast path gives the bits of that selection summed ring by ring, and equals
/// the reference (which applies the same rule by a plain scan) to rounding.
#[test]
fn stacked_rings_count_only_the_newest_per_point() {
    let l = layer(&ParticleLayerSpec::default());
    let mut rng = SwellRng::new(9, 9);
    // 200 splashes within 3 m of the origin over 1 s: their rings pile up near it.
    let events: Vec<Impact> = (0..200)
        .map(|_| {
            impact(
                10.0 + rng.uniform(),
                rng.uniform() * 6.0 - 3.0,
                rng.uniform() * 6.0 - 3.0,
                0.05 + rng.uniform(),
                1.0 + rng.uniform(),
            )
        })
        .collect();
    let impacts = Impacts::from_events(events).unwrap();
    let t = 11.5;
    let f = l.field(t, Some(&impacts)).unwrap();
    let live = l.live_rings(t, &impacts);
    assert!(live.len() > 2 * MAX_RINGS_PER_POINT, "{}", live.len());
    let empty = l.field(t, None).unwrap();
    let (mut capped, mut worst) = (0, 0.0_f64);
    for _ in 0..2000 {
        let x = DVec2::new(rng.uniform() * 40.0 - 20.0, rng.uniform() * 40.0 - 20.0);
        let covering: Vec<usize> = (0..live.len())
            .filter(|&i| {
                let (ring, s) = &live[i];
                ((x - ring.center).length() - s.distance).abs() < ring.radius
            })
            .collect();
        let chosen = &covering[covering.len().saturating_sub(MAX_RINGS_PER_POINT)..];
        if covering.len() > MAX_RINGS_PER_POINT {
            capped += 1;
        }
        let (mut hs, mut gs) = empty.sample(&l, x, 0.0);
        for &i in chosen {
            let (ring, s) = &live[i];
            one_ring(t, ring, s).visit_rings_only(x, &mut |hk, gk| {
                hs += hk;
                gs += gk;
            });
        }
        let (h, g) = f.sample(&l, x, 0.0);
        assert_eq!(
            (h.to_bits(), g.x.to_bits(), g.y.to_bits()),
            (hs.to_bits(), gs.x.to_bits(), gs.y.to_bits()),
            "{x}: {} rings cover it",
            covering.len()
        );
        let (hr, gr, _) = f.sample_reference(&l, x);
        worst = worst.max((h - hr).abs()).max((g - gr).length());
    }
    assert!(capped > 100, "only {capped} points had more than the cap");
    assert!(worst < 1e-12, "fast vs reference: {worst}");
}

#[test]
fn defaults_are_valid_and_errors_name_fields() {
    let l = layer(&ParticleLayerSpec::default());
    assert_eq!(l.ambient().len(), 512);
    let bad = |spec: ParticleLayerSpec| {
        ParticleLayer::new(&spec, 1, Dispersion::default(), "layers[2]")
            .unwrap_err()
            .field()
            .to_string()
    };
    let d = ParticleLayerSpec::default;
    assert_eq!(
        bad(ParticleLayerSpec {
            count: 20_000,
            ..d()
        }),
        "layers[2].count"
    );
    assert_eq!(
        bad(ParticleLayerSpec { radius: 9.0, ..d() }),
        "layers[2].radius"
    );
    assert_eq!(
        bad(ParticleLayerSpec {
            tile_size: -1.0,
            ..d()
        }),
        "layers[2].tile_size"
    );
    assert_eq!(
        bad(ParticleLayerSpec {
            scales: vec![],
            ..d()
        }),
        "layers[2].scales"
    );
    assert_eq!(
        bad(ParticleLayerSpec {
            scales: vec![1.0, f64::NAN],
            ..d()
        }),
        "layers[2].scales[1]"
    );
    assert_eq!(
        bad(ParticleLayerSpec {
            direction: Some([0.0, 0.0]),
            ..d()
        }),
        "layers[2].direction"
    );
    assert_eq!(
        bad(ParticleLayerSpec {
            ripples: RippleSpec {
                particles: 2,
                ..Default::default()
            },
            ..d()
        }),
        "layers[2].ripples.particles"
    );
    let e = Impacts::from_events(vec![
        impact(0.0, 0.0, 0.0, 0.5, 0.5),
        impact(0.0, f64::NAN, 0.0, 0.5, 0.5),
    ])
    .unwrap_err();
    assert_eq!(e.field(), "impacts[1].position[0]");
    let e = Impacts::new()
        .with(impact(0.0, 0.0, 0.0, 0.0, 0.5))
        .unwrap_err();
    assert_eq!(e.field(), "strength");
    let e = Impacts::new()
        .with(impact(0.0, 0.0, 0.0, 0.5, 1e6))
        .unwrap_err();
    assert_eq!(e.field(), "radius");
}

/// Ambient layers that stress the cell index: the harbour's (31² cells, three scales), a dense
/// wind-driven one at the 128² cap, and coarse ones with 3, 4 and 5 cells a side (where the
/// 3×3 neighbourhood is most of the tile).
fn index_layers() -> Vec<ParticleLayer> {
    let harbour = ParticleLayerSpec {
        scales: vec![0.33, 0.66, 1.0],
        ..Default::default()
    };
    let dense = ParticleLayerSpec {
        count: 4096,
        tile_size: 64.0,
        radius: 0.4,
        speed: Some(7.0),
        direction: Some([1.0, 0.2]),
        spread: 30.0,
        scales: vec![0.5, 1.0],
        ..Default::default()
    };
    let coarse = |radius: f64| ParticleLayerSpec {
        count: 200,
        tile_size: 10.0,
        radius,
        ..Default::default()
    };
    [harbour, dense, coarse(2.5), coarse(2.0), coarse(1.9)]
        .iter()
        .map(layer)
        .collect()
}

fn ambient_bits(h: f64, g: DVec2, v: f64) -> [u64; 4] {
    [h.to_bits(), g.x.to_bits(), g.y.to_bits(), v.to_bits()]
}

/// The fast ambient sum (through a [`ParticleField`], as queries reach it) gives the bits of
/// [`ambient::Ambient::sample_ordered_reference`] (every particle scanned per neighbour cell) at
/// seeded points and times: far apart, runs of nearby times (answered from the layer's shared
/// index), large |t|, with scales left out by a minimum wavelength, and fields asked enough
/// points to build their own index.
#[test]
fn ambient_index_gives_the_ordered_reference_bits() {
    let mut rng = SwellRng::new(29, 4);
    for l in index_layers() {
        let amb = l.ambient();
        let mut t = 0.0;
        for k in 0..200 {
            t = match k % 4 {
                0 => rng.uniform() * 2.0e4 - 1.0e4,
                1 => t + rng.uniform() * 0.05,
                2 => 1.0e9 + rng.uniform() * 10.0,
                _ => t - rng.uniform() * 0.5,
            };
            let f = l.field(t, None).unwrap();
            // Past OWN_INDEX_AFTER points a field switches to an index at exactly t.
            for _ in 0..(if k % 8 < 4 { 10 } else { 40 }) {
                let x = DVec2::new(rng.uniform() * 400.0 - 200.0, rng.uniform() * 400.0 - 200.0);
                let mw = if rng.uniform() < 0.25 { 3.0 } else { 0.0 };
                let (h, g) = f.sample(&l, x, mw);
                let v = f.vertical_velocity(&l, x, mw);
                let (hr, gr, vr) = amb.sample_ordered_reference(x, t, mw);
                assert_eq!(
                    ambient_bits(h, g, v),
                    ambient_bits(hr, gr, vr),
                    "t {t} x {x} mw {mw}"
                );
            }
        }
    }
}

/// The ambient sum at t through `index`, accumulated as [`ParticleField`] accumulates it.
fn ambient_through(
    amb: &ambient::Ambient,
    index: &ambient::AmbientIndex,
    x: DVec2,
    t: f64,
    mw: f64,
) -> (f64, DVec2, f64) {
    let (mut h, mut g, mut v) = (0.0, DVec2::ZERO, 0.0);
    amb.visit(index, x, t, mw, &mut |hk, gk, pv| {
        h += hk;
        g += gk;
        v += hk * 0.0 - gk.dot(pv);
    });
    (h, g, v)
}

/// The last `dt` (to the ulp, on the side of `dir`) at which an index at `t0` still serves
/// `t0 + dt`.
fn window_edge(amb: &ambient::Ambient, t0: f64, dir: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0e6_f64);
    assert!(!amb.index_serves(t0, t0 + dir * hi));
    loop {
        let mid = lo + (hi - lo) / 2.0;
        if mid == lo || mid == hi {
            return dir * lo;
        }
        if amb.index_serves(t0, t0 + dir * mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
}

/// One index serves a stretch of time with the bits of a grid built at each time: at seeded
/// points, at times on the very edges of an index's window (the last serving time each side,
/// to the ulp), inside it and at the index's own time, with |t0| from 0 to 1e9. At the edges
/// particles have crossed into neighbouring cells, so the gathered 5×5 and the reordering are
/// what keeps the bits. Just past an edge the index no longer serves, and `Ambient::index`
/// builds one that does.
#[test]
fn ambient_index_window_edges_give_the_ordered_reference_bits() {
    let mut rng = SwellRng::new(29, 5);
    let mut crossed = 0;
    for l in index_layers() {
        let amb = l.ambient();
        for k in 0..24 {
            let t0 = match k % 3 {
                0 => rng.uniform() * 200.0 - 100.0,
                1 => 1.0e9 * (rng.uniform() - 0.5),
                _ => 0.0,
            };
            let index = amb.build_index(t0);
            // Tiles of under 5 cells a side gather every cell: any time is served.
            let coarse = amb.index_serves(t0, t0 + 1.0e6);
            let (back, ahead) = if coarse {
                (-1.0e3, 1.0e3)
            } else {
                (window_edge(amb, t0, -1.0), window_edge(amb, t0, 1.0))
            };
            let times = [
                t0 + back,
                t0 + ahead,
                t0,
                t0 + back * rng.uniform(),
                t0 + ahead * rng.uniform(),
            ];
            for &t in &times {
                assert!(amb.index_serves(t0, t), "t0 {t0} t {t}");
                crossed += (0..amb.len())
                    .filter(|&i| {
                        amb.cell_of(amb.position(i, t0)) != amb.cell_of(amb.position(i, t))
                    })
                    .count();
                for _ in 0..40 {
                    let x =
                        DVec2::new(rng.uniform() * 400.0 - 200.0, rng.uniform() * 400.0 - 200.0);
                    let mw = if rng.uniform() < 0.25 { 3.0 } else { 0.0 };
                    let (h, g, v) = ambient_through(amb, &index, x, t, mw);
                    let (hr, gr, vr) = amb.sample_ordered_reference(x, t, mw);
                    assert_eq!(
                        ambient_bits(h, g, v),
                        ambient_bits(hr, gr, vr),
                        "t0 {t0} t {t} x {x} mw {mw}"
                    );
                }
            }
            for t in [t0 + 2.0 * back, t0 + 2.0 * ahead] {
                if coarse {
                    continue;
                }
                assert!(!amb.index_serves(t0, t), "t0 {t0} t {t}");
                let fresh = amb.index(t);
                let x = DVec2::new(rng.uniform() * 400.0, rng.uniform() * 400.0);
                assert_eq!(
                    ambient_bits2(ambient_through(amb, &fresh, x, t, 0.0)),
                    ambient_bits2(amb.sample_ordered_reference(x, t, 0.0)),
                );
            }
        }
    }
    assert!(
        crossed > 1000,
        "particles changed cells inside windows: {crossed}"
    );
}

fn ambient_bits2((h, g, v): (f64, DVec2, f64)) -> [u64; 4] {
    ambient_bits(h, g, v)
}

/// Issue 29 item 4: every query at "now" has its own t, and each used to build the ambient
/// particles' cell index afresh (512 positions and a counting sort per single-point height at
/// `harbour`, most of its cost). Snapshots at nearby times must share the layer's index; one
/// at a time the index cannot serve gets a new one, which the next nearby times then share.
#[test]
fn issue_29_queries_at_now_share_one_ambient_index() {
    let l = layer(&ParticleLayerSpec {
        scales: vec![0.33, 0.66, 1.0],
        ..Default::default()
    });
    let amb = l.ambient();
    let first = amb.index(1000.0);
    for k in 1..1000 {
        let t = 1000.0 + f64::from(k) * 17.0e-6;
        assert!(std::sync::Arc::ptr_eq(&first, &amb.index(t)), "t {t}");
    }
    let later = amb.index(1010.0);
    assert!(!std::sync::Arc::ptr_eq(&first, &later));
    assert!(std::sync::Arc::ptr_eq(&later, &amb.index(1010.1)));
}
