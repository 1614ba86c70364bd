//! Ambient wave particles: a seeded set on a periodic tile, each moving at constant velocity.
//!
//! Particle i starts at `u0_i` (tile units, `[0, 1)²`) and moves at `w_i = v_i/L` tiles per
//! second, so at any time t (past, future, reversed) it is exactly at
//! `u_i(t) = wrap(u0_i + w_i·t)`, `wrap(u) = u − floor(u)` per axis: no stepping.
//!
//! **Scales** (the seed article samples one texture at 33 %, 66 % and 100 % of its size): at
//! scale s the same pattern is shrunk in space: tile `s·L`, particle radius `s·r`, amplitude
//! `s·a`, speed `s·v` (a texture sampled at `x/s`). Slopes are the same at every scale, so the
//! finer copies add detail without steepening the sea. The height of the layer at world x is
//!
//! ```text
//! h(x, t) = Σ_scales Σ_i s·a_i·K(δ_i),    δ_i = image(x/(s·L) − u_i(t))
//! ```
//!
//! with K the [`super::kernel`] in tile units (radius `r/L`) and `image(δ) = δ − round(δ)` per
//! axis, the nearest periodic image (unique because `r ≤ L/4`).
//!
//! **Generation** (seeded, stream [`AMBIENT_STREAM`] of [`crate::math::SwellRng`]): per
//! particle i, in this order, `u0 = (U, U)`, amplitude `a·(1 − jitter·U)·(−1)^i` (alternating
//! signs keep the mean level near zero: bumps and dips), then its direction: without a wind
//! direction, the seed article's even dispersal, `φ_0 = 2π·U` and `φ_{i+1} = φ_i − (2° + 3°·U)`
//! (turning clockwise seen from above); with one, `φ_i = φ_wind + spread·(U − ½)`. Speed is the
//! spec's or [`super::ripple::particle_speed`] of the radius.

use glam::DVec2;

use super::kernel::kernel;
use crate::math::{SwellRng, TAU, atan2, sin_cos};

/// PCG32 stream of the ambient particle draws ("part").
pub const AMBIENT_STREAM: u64 = 0x7061_7274;

/// Most grid cells per tile side (the grid only speeds queries up; it never changes a result's
/// meaning, and this cap bounds its memory at 128² cells).
const MAX_CELLS: u32 = 128;

/// The built ambient particles of one layer.
#[derive(Debug, Clone, PartialEq)]
pub struct Ambient {
    u0: Vec<DVec2>,
    w: Vec<DVec2>,
    a: Vec<f64>,
    tile: f64,
    radius: f64,
    speed: f64,
    scales: Vec<f64>,
    /// Per scale: `1/(s·L)` (world to tile units).
    inv_sl: Vec<f64>,
    /// `(L/r)²`: the kernel's `1/r²` in tile units.
    inv_rr2: f64,
    /// Grid cells per tile side: `floor(0.999·L/r)` capped at 128 (so a cell is wider than the
    /// kernel radius and a query looks at the 3×3 cells around it), or 1 when that is below 3.
    cells: u32,
}

/// What [`Ambient::new`] is built from (validated by the layer).
pub(crate) struct AmbientParams<'a> {
    pub count: u32,
    pub tile: f64,
    pub radius: f64,
    pub amplitude: f64,
    pub jitter: f64,
    pub speed: f64,
    pub direction: Option<DVec2>,
    pub spread_rad: f64,
    pub scales: &'a [f64],
    pub seed: u64,
}

/// The ambient particles' positions at one time, bucketed by grid cell (a counting sort, stable
/// in particle index).
#[derive(Debug, Clone)]
pub(crate) struct AmbientGrid {
    /// `start[c]..start[c + 1]` are cell c's entries; cells are row-major `cz·cells + cx`.
    start: Vec<u32>,
    entries: Vec<Entry>,
}

/// One particle in [`AmbientGrid`]: position in tile units, amplitude, velocity in tiles/s.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    pos: DVec2,
    amp: f64,
    vel: DVec2,
}

/// `⌊u⌋`, exactly, without a libm call where |u| < 2^52 (truncation through i64 is exact
/// there); larger, infinite or NaN `u` go to `f64::floor`. Integral `u` (−0 included) is
/// returned as is, as `floor` does.
#[inline]
fn floor(u: f64) -> f64 {
    if u.abs() < 4_503_599_627_370_496.0 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss)]
        let t = (u as i64) as f64;
        if t == u {
            u
        } else if u < 0.0 {
            t - 1.0
        } else {
            t
        }
    } else {
        u.floor()
    }
}

#[inline]
fn wrap(u: f64) -> f64 {
    let v = u - floor(u);
    // u slightly below an integer can round to exactly 1.0.
    if v >= 1.0 { 0.0 } else { v }
}

impl Ambient {
    pub(crate) fn new(p: &AmbientParams<'_>) -> Ambient {
        let mut rng = SwellRng::new(p.seed, AMBIENT_STREAM);
        let n = p.count as usize;
        let (mut u0, mut w, mut a) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let wind = p.direction.map(|d| atan2(d.y, d.x));
        let mut phi = 0.0;
        for i in 0..n {
            let ux = rng.uniform();
            let uz = rng.uniform();
            u0.push(DVec2::new(wrap(ux), wrap(uz)));
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            a.push(p.amplitude * (1.0 - p.jitter * rng.uniform()) * sign);
            let ud = rng.uniform();
            phi = match wind {
                Some(wind) => wind + p.spread_rad * (ud - 0.5),
                None if i == 0 => TAU * ud,
                None => phi - (2.0 + 3.0 * ud) * (TAU / 360.0),
            };
            let (s, c) = sin_cos(phi);
            w.push(DVec2::new(c, s) * (p.speed / p.tile));
        }
        let rr = p.radius / p.tile;
        let cells = ((0.999 / rr).floor() as u32).min(MAX_CELLS);
        Ambient {
            u0,
            w,
            a,
            tile: p.tile,
            radius: p.radius,
            speed: p.speed,
            scales: p.scales.to_vec(),
            inv_sl: p.scales.iter().map(|&s| 1.0 / (s * p.tile)).collect(),
            inv_rr2: 1.0 / (rr * rr),
            cells: if cells < 3 { 1 } else { cells },
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.a.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.a.is_empty()
    }

    /// Tile size L, m.
    pub fn tile_size(&self) -> f64 {
        self.tile
    }

    /// Particle radius r at scale 1, m.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Particle speed |v| at scale 1, m/s.
    pub fn speed(&self) -> f64 {
        self.speed
    }

    /// The tile scales.
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// Particle i at scale 1: start position `L·u0_i` (m, in `[0, L)²`), velocity `L·w_i`
    /// (m/s) and amplitude (m, signed). What a client needs to draw the same particles.
    ///
    /// # Panics
    /// If `i >= self.len()`.
    pub fn particle(&self, i: usize) -> (DVec2, DVec2, f64) {
        (self.u0[i] * self.tile, self.w[i] * self.tile, self.a[i])
    }

    /// Particle i in tile units, exactly as stored: start `u0_i` (in `[0, 1)²`), velocity `w_i`
    /// (tiles/s) and amplitude (m, signed). [`Ambient::position`] is `wrap(u0_i + w_i·t)` of
    /// these, so a client holding them evaluates the same bits ([`Ambient::particle`]'s metres
    /// are these times L, which rounds unless L is a power of two).
    ///
    /// # Panics
    /// If `i >= self.len()`.
    pub fn particle_tile(&self, i: usize) -> (DVec2, DVec2, f64) {
        (self.u0[i], self.w[i], self.a[i])
    }

    /// Position of particle i at time t in tile units, `wrap(u0_i + w_i·t)` ∈ `[0, 1)²`
    /// (multiply by `s·L` for world metres at scale s).
    ///
    /// # Panics
    /// If `i >= self.len()`.
    #[inline]
    pub fn position(&self, i: usize, t: f64) -> DVec2 {
        let u = self.u0[i] + self.w[i] * t;
        DVec2::new(wrap(u.x), wrap(u.y))
    }

    #[inline]
    fn cell_of(&self, u: DVec2) -> (u32, u32) {
        let n = self.cells;
        let c = |v: f64| ((v * f64::from(n)) as u32).min(n - 1);
        (c(u.x), c(u.y))
    }

    /// Every particle's position at t, bucketed by cell (a counting sort, stable in index).
    pub(crate) fn grid(&self, t: f64) -> AmbientGrid {
        let n = self.cells as usize;
        let mut start = vec![0u32; n * n + 1];
        let placed: Vec<(DVec2, usize)> = (0..self.len())
            .map(|i| {
                let u = self.position(i, t);
                let (cx, cz) = self.cell_of(u);
                let c = cz as usize * n + cx as usize;
                start[c + 1] += 1;
                (u, c)
            })
            .collect();
        for c in 0..n * n {
            start[c + 1] += start[c];
        }
        // Place each particle at its cell's cursor; afterwards start[c] holds cell c's end,
        // which is cell c + 1's start: shift back by one.
        let mut entries = vec![Entry::default(); placed.len()];
        for (i, &(pos, c)) in placed.iter().enumerate() {
            let k = start[c] as usize;
            start[c] += 1;
            entries[k] = Entry {
                pos,
                amp: self.a[i],
                vel: self.w[i],
            };
        }
        for c in (1..=n * n).rev() {
            start[c] = start[c - 1];
        }
        start[0] = 0;
        AmbientGrid { start, entries }
    }

    /// Visits every particle (at every kept scale) whose kernel reaches world point x, with
    /// `(height, gradient, particle velocity)` in world units: scales in order, then the 3×3
    /// cells around x in row-major order, then particles in index order within a cell. Scales
    /// whose particles are narrower than `min_wavelength` (`4·s·r < min_wavelength`) are left
    /// out.
    #[inline]
    pub(crate) fn visit(
        &self,
        grid: &AmbientGrid,
        x: DVec2,
        min_wavelength: f64,
        f: &mut impl FnMut(f64, DVec2, DVec2),
    ) {
        let n = self.cells;
        for (&s, &inv) in self.scales.iter().zip(&self.inv_sl) {
            if 4.0 * s * self.radius < min_wavelength {
                continue;
            }
            let q = DVec2::new(wrap(x.x * inv), wrap(x.y * inv));
            let (cx, cz) = self.cell_of(q);
            let sl = s * self.tile;
            let mut cell = |c: usize| {
                let (lo, hi) = (grid.start[c] as usize, grid.start[c + 1] as usize);
                for e in &grid.entries[lo..hi] {
                    let mut d = q - e.pos;
                    d.x -= d.x.round();
                    d.y -= d.y.round();
                    if let Some((h, g)) = kernel(s * e.amp, d, self.inv_rr2) {
                        f(h, g * inv, e.vel * sl);
                    }
                }
            };
            if n == 1 {
                cell(0);
                continue;
            }
            for dz in [n - 1, 0, 1] {
                for dx in [n - 1, 0, 1] {
                    let (ix, iz) = ((cx + dx) % n, (cz + dz) % n);
                    cell(iz as usize * n as usize + ix as usize);
                }
            }
        }
    }

    /// Slow reference of the fast path's order: every kept scale, then the 3×3 cells around x
    /// in row-major order, then, per cell, a scan of every particle in index order keeping those
    /// whose position at t ([`Ambient::position`]) lies in that cell. The same operands in the
    /// same order as [`Ambient::visit`], with no index, so the fast path must give its bits.
    /// Returns `(height, gradient, ∂h/∂t)`, each summed as [`super::ParticleField`] sums them.
    pub fn sample_ordered_reference(
        &self,
        x: DVec2,
        t: f64,
        min_wavelength: f64,
    ) -> (f64, DVec2, f64) {
        let (mut h, mut g, mut v) = (0.0, DVec2::ZERO, 0.0);
        let n = self.cells;
        for (&s, &inv) in self.scales.iter().zip(&self.inv_sl) {
            if 4.0 * s * self.radius < min_wavelength {
                continue;
            }
            let q = DVec2::new(wrap(x.x * inv), wrap(x.y * inv));
            let (cx, cz) = self.cell_of(q);
            let sl = s * self.tile;
            let neighbours: Vec<(u32, u32)> = if n == 1 {
                vec![(0, 0)]
            } else {
                [n - 1, 0, 1]
                    .iter()
                    .flat_map(|&dz| [n - 1, 0, 1].map(|dx| ((cx + dx) % n, (cz + dz) % n)))
                    .collect()
            };
            for cell in neighbours {
                for i in 0..self.len() {
                    let u = self.position(i, t);
                    if self.cell_of(u) != cell {
                        continue;
                    }
                    let mut d = q - u;
                    d.x -= d.x.round();
                    d.y -= d.y.round();
                    if let Some((hk, gk)) = kernel(s * self.a[i], d, self.inv_rr2) {
                        let (gk, pv) = (gk * inv, self.w[i] * sl);
                        h += hk;
                        g += gk;
                        v += hk * 0.0 - gk.dot(pv);
                    }
                }
            }
        }
        (h, g, v)
    }

    /// Slow reference of the grid-indexed ambient sum: every particle at every kept scale, in
    /// index order, positions from [`Ambient::position`]. Returns `(height, gradient, ∂h/∂t)`.
    pub fn sample_reference(&self, x: DVec2, t: f64, min_wavelength: f64) -> (f64, DVec2, f64) {
        let (mut h, mut g, mut v) = (0.0, DVec2::ZERO, 0.0);
        for (&s, &inv) in self.scales.iter().zip(&self.inv_sl) {
            if 4.0 * s * self.radius < min_wavelength {
                continue;
            }
            let q = DVec2::new(wrap(x.x * inv), wrap(x.y * inv));
            for i in 0..self.len() {
                let mut d = q - self.position(i, t);
                d.x -= d.x.round();
                d.y -= d.y.round();
                if let Some((hk, gk)) = kernel(s * self.a[i], d, self.inv_rr2) {
                    h += hk;
                    g += gk * inv;
                    v -= (gk * inv).dot(self.w[i] * (s * self.tile));
                }
            }
        }
        (h, g, v)
    }
}

#[cfg(test)]
mod floor_tests {
    use super::floor;
    use crate::math::SwellRng;

    /// The fast floor is `f64::floor` to the bit: signed zeros, integers, halves, values next
    /// to integers, the 2^52 boundary, infinities, NaN, and a million seeded doubles of every
    /// magnitude.
    #[test]
    fn fast_floor_is_floor_to_the_bit() {
        let two52 = 4_503_599_627_370_496.0_f64;
        let mut cases = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.7,
            -2.7,
            f64::EPSILON,
            -f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            -1.0 + f64::EPSILON / 2.0,
            two52,
            -two52,
            two52 - 0.5,
            -(two52 - 0.5),
            two52 * 2.0,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut rng = SwellRng::new(3, 3);
        for _ in 0..1_000_000 {
            let mag = 10f64.powf(rng.uniform() * 40.0 - 20.0);
            cases.push(if rng.uniform() < 0.5 { -mag } else { mag });
        }
        for u in cases {
            assert_eq!(floor(u).to_bits(), u.floor().to_bits(), "{u:e}");
        }
        assert!(floor(f64::NAN).is_nan());
    }
}
