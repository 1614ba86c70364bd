//! A particle layer at one time: what queries read.
//!
//! Built per evaluated time ([`super::ParticleLayer::field`]): the live rings are listed at once
//! (a binary search in the impact list, then O(live impacts)); the spatial indexes are found
//! or built lazily, on the first query that needs them, and shared by every query on the
//! snapshot:
//! - the ambient index: the ambient particles bucketed into cells wider than a particle, so a
//!   query reads the 3×3 cells around it (O(particles near the point)). Not built per time:
//!   the layer keeps the last one ([`super::ambient::Ambient::index`]), and an index of the
//!   cells at t0 serves every t at which no particle can have crossed more than one cell since
//!   (±0.4 s at `harbour`), so queries at "now", each at its own t, share one. Such a query
//!   gathers the 5×5 cells around it and visits what lies in its 3×3 at t in the per-time
//!   order; a snapshot that answers more than a few points builds its own index at exactly t;
//! - the ring grid (only with more than [`RING_GRID_MIN`] live rings): each ring listed in the
//!   cells its annulus `d ± r` crosses, so a query looks only at rings passing near it.
//!
//! The indexes only skip rings and particles whose kernel is exactly zero at the point, and
//! the visiting order does not depend on whether the ring grid exists (rings in canonical
//! order, particles by index from the start of the angular window), so a query gives the same
//! bits with or without them.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, OnceLock};

use glam::DVec2;

use super::ParticleLayer;
use super::ambient::{Ambient, AmbientIndex};
use super::kernel::kernel;
use super::ripple::{Ring, direction};
use crate::math::{TAU, atan2};

/// Live rings above which a snapshot indexes them in a grid (below it, rejecting a ring costs
/// one distance test, cheaper than a grid lookup).
pub const RING_GRID_MIN: usize = 8;

/// Rings that count at one point at most. Where more than this many rings' annuli
/// (`|ρ − d| < r`) cover a point, only the newest ones (the last in canonical order) add to it,
/// still summed oldest first; the older ones have lost the most to decay. This bounds a query's
/// cost whatever the number of live rings: at most this many rings' angular windows per point
/// (issue 27: 1,024 rings of the largest size stacked over a harbour made a 2,000-point sample
/// cost 600× one without). Below the cap nothing changes, so seas with ordinary splash counts
/// keep their bits.
pub const MAX_RINGS_PER_POINT: usize = 32;

/// One live ring at the field's time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LiveRing {
    pub ring: Ring,
    /// Ring radius d, m.
    pub d: f64,
    /// Particles N_g.
    pub n: u32,
    /// Per-particle amplitude, m.
    pub amp: f64,
    /// 1/r².
    pub inv_r2: f64,
    /// `−s/decay`: the relative rate of change of the amplitude, 1/s.
    pub amp_rate: f64,
}

/// The ring grid: ring indices per cell (each list in ring order).
#[derive(Debug, Clone)]
struct RingGrid {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<u32>>,
}

/// Rings of at most this many particles read their directions `(cos, sin)(2π·i/N)` from a table
/// shared by every ring of that count in the field, built on first use (the same values
/// [`direction`] computes, so the same bits). Larger rings are visited in a narrow angular
/// window, where computing the few directions needed costs less than a table.
const DIRECTION_TABLE_MAX: u32 = 72;
/// Tables per field: particle counts `N_min·3^k` for k below this (a field's rings all share
/// the layer's `N0`, so their counts are `N0·3^g`).
const DIRECTION_TABLES: usize = 4;

/// Points a field answers from the layer's shared ambient index (built for a nearby time, so
/// each point gathers 5×5 cells and re-sorts what it finds) before it builds an index at
/// exactly its own time (each point then reads 3×3 cells in order, as a per-time grid did).
/// At `harbour` (512 particles, three scales; callgrind, `examples/point_cost.rs`) a build costs
/// ~100k instructions and a point on the shared index ~8k more than one on an exact index, so
/// the build pays for itself after about a dozen points: a single point or a handful (a body's
/// probes) never pay for one, and a batch pays once. Either path gives the same bits.
const OWN_INDEX_AFTER: u32 = 16;

/// A particle layer frozen at one time.
#[derive(Debug)]
pub struct ParticleField {
    t: f64,
    rings: Vec<LiveRing>,
    /// The layer's shared ambient index for a window around t ([`Ambient::index`]).
    ambient: OnceLock<Arc<AmbientIndex>>,
    /// Points answered from `ambient` so far (counted until `own` exists).
    windowed: AtomicU32,
    /// An ambient index at exactly t, built after [`OWN_INDEX_AFTER`] windowed points.
    own: OnceLock<AmbientIndex>,
    ring_grid: OnceLock<Option<RingGrid>>,
    /// The smallest particle count among the rings: table k holds `n_min·3^k` directions.
    n_min: u32,
    directions: [OnceLock<Box<[DVec2]>>; DIRECTION_TABLES],
}

impl ParticleField {
    pub(crate) fn new(t: f64, rings: Vec<LiveRing>) -> ParticleField {
        ParticleField {
            t,
            n_min: rings.iter().map(|r| r.n).min().unwrap_or(1).max(1),
            rings,
            ambient: OnceLock::new(),
            windowed: AtomicU32::new(0),
            own: OnceLock::new(),
            ring_grid: OnceLock::new(),
            directions: Default::default(),
        }
    }

    /// The direction table for rings of `n` particles, if such rings use one.
    #[inline]
    fn direction_table(&self, n: u32) -> Option<&[DVec2]> {
        if n > DIRECTION_TABLE_MAX {
            return None;
        }
        let (mut k, mut m) = (0, self.n_min);
        while m < n && k < DIRECTION_TABLES {
            m *= 3;
            k += 1;
        }
        if m != n || k >= DIRECTION_TABLES {
            return None;
        }
        Some(self.directions[k].get_or_init(|| (0..n).map(|i| direction(i, n)).collect()))
    }

    /// The time, s.
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Rings alive at this time.
    pub fn live_rings(&self) -> usize {
        self.rings.len()
    }

    /// Ring particles alive at this time (over every live ring).
    pub fn live_ring_particles(&self) -> usize {
        self.rings.iter().map(|r| r.n as usize).sum()
    }

    fn ring_grid(&self) -> Option<&RingGrid> {
        self.ring_grid
            .get_or_init(|| {
                (self.rings.len() > RING_GRID_MIN).then(|| build_ring_grid(&self.rings))
            })
            .as_ref()
    }

    /// The ambient index a query reads: the field's own at exactly t once it has one, the
    /// shared one while that is at t or for the first [`OWN_INDEX_AFTER`] points, then its own.
    #[inline]
    fn ambient_index(&self, amb: &Ambient) -> &AmbientIndex {
        if let Some(own) = self.own.get() {
            return own;
        }
        let shared = self.ambient.get_or_init(|| amb.index(self.t));
        if Ambient::index_time(shared) == self.t
            || self.windowed.fetch_add(1, Ordering::Relaxed) < OWN_INDEX_AFTER
        {
            return shared;
        }
        self.own.get_or_init(|| amb.build_index(self.t))
    }

    /// Visits every particle whose kernel reaches x: `(height, gradient, particle velocity,
    /// relative amplitude rate)`. Ambient first, then rings in canonical order.
    #[inline]
    fn visit(
        &self,
        layer: &ParticleLayer,
        x: DVec2,
        min_wavelength: f64,
        mut f: impl FnMut(f64, DVec2, DVec2, f64),
    ) {
        let amb = layer.ambient();
        if !amb.is_empty() {
            let index = self.ambient_index(amb);
            amb.visit(index, x, self.t, min_wavelength, &mut |h, g, v| {
                f(h, g, v, 0.0)
            });
        }
        if self.rings.is_empty() {
            return;
        }
        let kept = |r: &LiveRing| 4.0 * r.ring.radius >= min_wavelength;
        match self.ring_grid() {
            Some(grid) => {
                let key = (
                    (x.x / grid.cell).floor() as i64,
                    (x.y / grid.cell).floor() as i64,
                );
                if let Some(list) = grid.cells.get(&key) {
                    let list = &list[newest_reaching(list, &self.rings, x, &kept)..];
                    for &i in list {
                        let r = &self.rings[i as usize];
                        if kept(r) {
                            visit_ring(r, self.direction_table(r.n), x, &mut f);
                        }
                    }
                }
            }
            // At most RING_GRID_MIN < MAX_RINGS_PER_POINT rings: no cap to apply.
            None => self
                .rings
                .iter()
                .filter(|r| kept(r))
                .for_each(|r| visit_ring(r, self.direction_table(r.n), x, &mut f)),
        }
    }

    /// Test hook: every ring's particles near x, scanning all rings in order (no grid).
    #[cfg(test)]
    pub(crate) fn visit_rings_only(&self, x: DVec2, f: &mut impl FnMut(f64, DVec2)) {
        for r in &self.rings {
            visit_ring(r, None, x, &mut |h, g, _, _| f(h, g));
        }
    }

    /// Height (m) and its gradient `(∂h/∂x, ∂h/∂z)` at world point x, leaving out particles
    /// narrower than `min_wavelength` (`4r < min_wavelength`; 0 keeps all).
    #[inline]
    pub fn sample(&self, layer: &ParticleLayer, x: DVec2, min_wavelength: f64) -> (f64, DVec2) {
        let (mut h, mut g) = (0.0, DVec2::ZERO);
        self.visit(layer, x, min_wavelength, |hk, gk, _, _| {
            h += hk;
            g += gk;
        });
        (h, g)
    }

    /// Vertical velocity of the surface at x, m/s: `Σ (−∇K·v_particle + K·rate)` (each kernel
    /// moves with its particle; a ring's amplitude also decays at `rate = −s/decay`).
    pub fn vertical_velocity(&self, layer: &ParticleLayer, x: DVec2, min_wavelength: f64) -> f64 {
        let mut v = 0.0;
        self.visit(layer, x, min_wavelength, |h, g, pv, rate| {
            v += h * rate - g.dot(pv);
        });
        v
    }

    /// Slow reference for [`ParticleField::sample`] and [`ParticleField::vertical_velocity`]:
    /// every ambient particle and every particle of every live ring, positions recomputed from
    /// their closed forms ([`super::ambient::Ambient::position`], [`Ring::particles`]), no grid,
    /// no window. Returns `(height, gradient, ∂h/∂t)`. Equal to the fast path up to rounding
    /// (the sums run in another order).
    pub fn sample_reference(&self, layer: &ParticleLayer, x: DVec2) -> (f64, DVec2, f64) {
        let (mut h, mut g, mut v) = layer.ambient().sample_reference(x, self.t, 0.0);
        // The newest MAX_RINGS_PER_POINT rings covering x, by a plain scan of all of them.
        let covering: Vec<usize> = (0..self.rings.len())
            .filter(|&i| reaches(&self.rings[i], x))
            .collect();
        let skip = covering.len().saturating_sub(MAX_RINGS_PER_POINT);
        let oldest = covering.get(skip).copied().unwrap_or(self.rings.len());
        for r in self.rings[oldest..].iter().filter(|r| reaches(r, x)) {
            for (i, (p, a)) in r.ring.particles(self.t).into_iter().enumerate() {
                if let Some((hk, gk)) = kernel(a, x - p, r.inv_r2) {
                    h += hk;
                    g += gk;
                    let pv = direction(i as u32, r.n) * r.ring.speed;
                    v += hk * r.amp_rate - gk.dot(pv);
                }
            }
        }
        (h, g, v)
    }
}

/// Whether ring `r`'s annulus covers x: `|ρ − d| < r` with `ρ = |x − c|`, the test
/// [`visit_ring`] starts with (the same operations, so the same answer).
#[inline]
fn reaches(r: &LiveRing, x: DVec2) -> bool {
    let rho = (x - r.ring.center).length();
    (rho - r.d).abs() < r.ring.radius
}

/// The start of the tail of `list` (ring indices in canonical order) that holds its newest
/// [`MAX_RINGS_PER_POINT`] rings covering x and passing `kept`: 0 when there are no more than
/// that. Scans from the newest end and stops at the cap, so it costs O(cap) where rings pile up.
#[inline]
fn newest_reaching(
    list: &[u32],
    rings: &[LiveRing],
    x: DVec2,
    kept: &impl Fn(&LiveRing) -> bool,
) -> usize {
    if list.len() <= MAX_RINGS_PER_POINT {
        return 0;
    }
    let mut found = 0;
    for (at, &i) in list.iter().enumerate().rev() {
        let r = &rings[i as usize];
        if kept(r) && reaches(r, x) {
            found += 1;
            if found == MAX_RINGS_PER_POINT {
                return at;
            }
        }
    }
    0
}

/// The particles of ring `r` near x. With `rel = x − c`, `ρ = |rel|`: nothing when
/// `|ρ − d| ≥ r`; otherwise the particles within the angular window around `atan2(rel)` that
/// can reach x: a particle at angle Δ from x's is at distance² `(d − ρ)² + 4dρ·sin²(Δ/2)`, so
/// `|Δ| ≤ 2·asin(r/(2√(dρ))) ≤ π·r/(2√(dρ))` (all of them when `r² ≥ 4dρ`), widened by one index
/// each side against rounding. Particle i is at `c + d·(cos, sin)(2π·i/N)`, its offset
/// `rel − d·(cos, sin)`.
/// `table`, when given, holds the ring's `N` directions ([`ParticleField::direction_table`]).
#[inline]
fn visit_ring(
    r: &LiveRing,
    table: Option<&[DVec2]>,
    x: DVec2,
    f: &mut impl FnMut(f64, DVec2, DVec2, f64),
) {
    let rel = x - r.ring.center;
    let rho = rel.length();
    let rad = r.ring.radius;
    if (rho - r.d).abs() >= rad {
        return;
    }
    let n = r.n;
    let dr = r.d * rho;
    let mut each = |i: u32| {
        let dir = table.map_or_else(|| direction(i, n), |t| t[i as usize]);
        if let Some((h, g)) = kernel(r.amp, rel - dir * r.d, r.inv_r2) {
            f(h, g, dir * r.ring.speed, r.amp_rate);
        }
    };
    if rad * rad >= 4.0 * dr {
        (0..n).for_each(each);
        return;
    }
    let half = std::f64::consts::PI * rad / (2.0 * dr.sqrt());
    let per = f64::from(n) / TAU;
    let phi = atan2(rel.y, rel.x);
    let lo = ((phi - half) * per).floor() as i64 - 1;
    let hi = ((phi + half) * per).ceil() as i64 + 1;
    if hi - lo + 1 >= i64::from(n) {
        (0..n).for_each(each);
    } else {
        (lo..=hi).for_each(|k| each(k.rem_euclid(i64::from(n)) as u32));
    }
}

/// Lists each ring in the cells its annulus `[d − r, d + r]` (widened by a rounding margin)
/// crosses, row by row: in the row band `[z0, z1]` the annulus covers
/// `|x − cx| ∈ [√(max(0, r_in² − dz_max²)), √(R² − dz_min²)]`. Cell size
/// `max(2·r_max, d_max/16)`, so a ring crosses O(16) cells along its circumference.
fn build_ring_grid(rings: &[LiveRing]) -> RingGrid {
    let r_max = rings.iter().map(|r| r.ring.radius).fold(0.0, f64::max);
    let d_max = rings.iter().map(|r| r.d).fold(0.0, f64::max);
    let h = (2.0 * r_max).max(d_max / 16.0);
    let mut cells: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
    let idx = |v: f64| (v / h).floor() as i64;
    for (i, r) in rings.iter().enumerate() {
        let c = r.ring.center;
        let margin = 1e-6 * (r.ring.radius + r.d + 1.0) + 1e-15 * (c.x.abs() + c.y.abs());
        let outer = r.d + r.ring.radius + margin;
        let inner = (r.d - r.ring.radius - margin).max(0.0);
        for j in idx(c.y - outer)..=idx(c.y + outer) {
            let (z0, z1) = (j as f64 * h, (j + 1) as f64 * h);
            let dz_min = if c.y < z0 {
                z0 - c.y
            } else if c.y > z1 {
                c.y - z1
            } else {
                0.0
            };
            let dz_max = (c.y - z0).abs().max((z1 - c.y).abs());
            if dz_min > outer {
                continue;
            }
            let xo = (outer * outer - dz_min * dz_min).sqrt() + margin;
            let xi = if dz_max < inner {
                ((inner * inner - dz_max * dz_max).sqrt() - margin).max(0.0)
            } else {
                0.0
            };
            let (a1, b1) = (idx(c.x - xo), idx(c.x - xi));
            let (a2, b2) = (idx(c.x + xi), idx(c.x + xo));
            let mut add = |a: i64, b: i64| {
                for k in a..=b {
                    cells.entry((k, j)).or_default().push(i as u32);
                }
            };
            if a2 <= b1 + 1 {
                add(a1, b2);
            } else {
                add(a1, b1);
                add(a2, b2);
            }
        }
    }
    RingGrid { cell: h, cells }
}
