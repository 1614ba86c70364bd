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

use std::sync::{Arc, Mutex, PoisonError};

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
    /// The largest `|w_i.x|` or `|w_i.z|`, tiles/s: how fast a particle can cross cells.
    w_max: f64,
    /// The last index built ([`Ambient::index`]), shared by every query whose time it serves.
    cache: IndexCache,
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

/// The ambient particles bucketed by the cell each occupies at `t0` (a counting sort, stable
/// in particle index). It serves every t at which no particle can be more than one cell from
/// where it was at `t0` ([`Ambient::index_serves`]): a query at such a t gathers the 5×5 cells
/// around its own cell, which hold every particle that is in the 3×3 it reads at t, and puts
/// those back in the order a grid built at t would visit them. So one index answers a stretch
/// of time (at `harbour`'s 2.5 m/s particles in 1.03 m cells, ±0.4 s) with a per-time grid's
/// bits, and a query at "now" no longer pays for a 512-particle counting sort.
#[derive(Debug)]
pub(crate) struct AmbientIndex {
    /// The time the cells are those of, s.
    t0: f64,
    /// `start[c]..start[c + 1]` are cell c's entries in `ids`; cells are row-major
    /// `cz·cells + cx`.
    start: Vec<u32>,
    /// The particles by cell at `t0`, ascending index within a cell.
    entries: Vec<Entry>,
}

/// One particle in [`AmbientIndex`]: its position at `t0` in tile units (what a query at `t0`
/// reads, so that one costs what a per-time grid's did), amplitude, velocity in tiles/s and
/// index.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    pos: DVec2,
    amp: f64,
    vel: DVec2,
    id: u32,
}

/// Holds the last [`AmbientIndex`] built. Not part of the layer's value: a clone starts empty
/// and any two compare equal, since which index answers a query changes no bit of it.
#[derive(Default)]
struct IndexCache(Mutex<Option<Arc<AmbientIndex>>>);

impl Clone for IndexCache {
    fn clone(&self) -> Self {
        IndexCache::default()
    }
}

impl PartialEq for IndexCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for IndexCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IndexCache")
    }
}

/// `v mod n` for `v < 3n` without a division (cell arithmetic runs per query and cell).
#[inline]
fn cyclic(v: u32, n: u32) -> u32 {
    let v = if v >= n { v - n } else { v };
    if v >= n { v - n } else { v }
}

/// Where cell `p` sits among the three cells `c − 1, c, c + 1` (cyclic, `n` a side) a query in
/// cell c reads, in their visiting order; `None` outside them.
#[inline]
fn slot(p: u32, c: u32, n: u32) -> Option<u32> {
    if n == 1 {
        return Some(1);
    }
    let off = cyclic(p + n - c, n);
    if off == n - 1 {
        Some(0)
    } else if off <= 1 {
        Some(off + 1)
    } else {
        None
    }
}

/// Most candidates a query keeps on the stack per scale; a denser neighbourhood spills to the
/// heap. At the densest layer (16,384 particles in 128² cells) the 3×3 holds 9 on average.
const STACK_CANDIDATES: usize = 32;

/// The particles a query reads at one scale, as `(visiting key, entry, position at t)`: the
/// key is `(slot_z·3 + slot_x) << 32 | particle index`, so ascending keys are a per-time grid's
/// order.
struct Candidates {
    stack: [(u64, u32, DVec2); STACK_CANDIDATES],
    len: usize,
    heap: Vec<(u64, u32, DVec2)>,
}

impl Candidates {
    #[inline]
    fn new() -> Self {
        Candidates {
            stack: [(0, 0, DVec2::ZERO); STACK_CANDIDATES],
            len: 0,
            heap: Vec::new(),
        }
    }

    #[inline]
    fn push(&mut self, c: (u64, u32, DVec2)) {
        if self.len < STACK_CANDIDATES {
            self.stack[self.len] = c;
            self.len += 1;
        } else {
            self.heap.push(c);
        }
    }

    /// The candidates in key order (keys are distinct: one per particle).
    #[inline]
    fn sorted(&mut self) -> &[(u64, u32, DVec2)] {
        if self.heap.is_empty() {
            let s = &mut self.stack[..self.len];
            // Insertion sort: a handful of entries, mostly gathered in order already.
            for i in 1..s.len() {
                let mut j = i;
                while j > 0 && s[j - 1].0 > s[j].0 {
                    s.swap(j - 1, j);
                    j -= 1;
                }
            }
            s
        } else {
            self.heap.extend_from_slice(&self.stack[..self.len]);
            self.heap.sort_unstable_by_key(|c| c.0);
            &self.heap
        }
    }
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
            a,
            tile: p.tile,
            radius: p.radius,
            speed: p.speed,
            scales: p.scales.to_vec(),
            inv_sl: p.scales.iter().map(|&s| 1.0 / (s * p.tile)).collect(),
            inv_rr2: 1.0 / (rr * rr),
            cells: if cells < 3 { 1 } else { cells },
            w_max: w
                .iter()
                .map(|v| v.x.abs().max(v.y.abs()))
                .fold(0.0, f64::max),
            w,
            cache: IndexCache::default(),
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

    /// The grid cell `(cx, cz)` holding tile position u.
    #[inline]
    pub(crate) fn cell_of(&self, u: DVec2) -> (u32, u32) {
        let n = self.cells;
        let c = |v: f64| ((v * f64::from(n)) as u32).min(n - 1);
        (c(u.x), c(u.y))
    }

    /// Whether an index of the cells at `t0` serves a query at t: a particle moves
    /// `w·(t − t0)` between them, at most `w_max·|t − t0|` along either axis, and its computed
    /// positions carry at most a few ulps of `|w·t| + 1` each (one product, one sum, the wrap
    /// and `cell_of`'s scaling; the slack below is four times that). Under one cell of travel,
    /// a particle's cell at t is at most one cell (cyclically) from its cell at `t0`, so the
    /// 5×5 cells around a query's hold its 3×3 at t. At `t == t0` the cells are the same
    /// computation, so an index always serves its own time (even where |t| is so large that
    /// the slack exceeds a cell). Tiles of under 5 cells a side gather every cell: any t.
    #[inline]
    pub(crate) fn index_serves(&self, t0: f64, t: f64) -> bool {
        if t == t0 || self.cells < 5 {
            return true;
        }
        let slack = 4.0 * f64::EPSILON * (self.w_max * (t.abs() + t0.abs()) + 4.0);
        f64::from(self.cells) * (self.w_max * (t - t0).abs() + slack) <= 0.99
    }

    /// An index that serves t ([`Ambient::index_serves`]): the last one built when it does
    /// (shared by every query near that time), otherwise a new one at `t0 = t`, which replaces
    /// it. Which index a query gets changes none of its bits.
    pub(crate) fn index(&self, t: f64) -> Arc<AmbientIndex> {
        let held = self
            .cache
            .0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        if let Some(index) = held.filter(|ix| self.index_serves(ix.t0, t)) {
            return index;
        }
        // Built outside the lock: queries near the held index's time keep using it meanwhile.
        let index = Arc::new(self.build_index(t));
        *self.cache.0.lock().unwrap_or_else(PoisonError::into_inner) = Some(Arc::clone(&index));
        index
    }

    /// The time an index's cells are those of, s.
    pub(crate) fn index_time(index: &AmbientIndex) -> f64 {
        index.t0
    }

    /// Every particle's cell at `t0`, bucketed (a counting sort, stable in index).
    pub(crate) fn build_index(&self, t0: f64) -> AmbientIndex {
        let n = self.cells as usize;
        let mut start = vec![0u32; n * n + 1];
        let placed: Vec<(DVec2, u32)> = (0..self.len())
            .map(|i| {
                let u = self.position(i, t0);
                let (cx, cz) = self.cell_of(u);
                let c = cz as usize * n + cx as usize;
                start[c + 1] += 1;
                (u, c as u32)
            })
            .collect();
        for c in 0..n * n {
            start[c + 1] += start[c];
        }
        // Place each particle at its cell's cursor; afterwards start[c] holds cell c's end,
        // which is cell c + 1's start: shift back by one.
        let mut entries = vec![Entry::default(); placed.len()];
        for (i, &(pos, c)) in placed.iter().enumerate() {
            let k = &mut start[c as usize];
            entries[*k as usize] = Entry {
                pos,
                amp: self.a[i],
                vel: self.w[i],
                id: i as u32,
            };
            *k += 1;
        }
        for c in (1..=n * n).rev() {
            start[c] = start[c - 1];
        }
        start[0] = 0;
        AmbientIndex { t0, start, entries }
    }

    /// Visits every particle (at every kept scale) whose kernel reaches world point x at time
    /// t, with `(height, gradient, particle velocity)` in world units, in a per-time grid's
    /// order: scales in order, then the 3×3 cells around x in row-major order, then particles
    /// in index order within a cell ([`Ambient::sample_ordered_reference`] is that order by a
    /// plain scan). Scales whose particles are narrower than `min_wavelength`
    /// (`4·s·r < min_wavelength`) are left out.
    ///
    /// # Panics
    /// In debug builds, if `index` does not serve t.
    #[inline]
    pub(crate) fn visit(
        &self,
        index: &AmbientIndex,
        x: DVec2,
        t: f64,
        min_wavelength: f64,
        f: &mut impl FnMut(f64, DVec2, DVec2),
    ) {
        debug_assert!(
            self.index_serves(index.t0, t),
            "index at {} for {t}",
            index.t0
        );
        let n = self.cells;
        // The cells gathered along each axis: the query's, widened by two each side (its 3×3
        // plus the one cell a particle can have crossed since t0), or all of them.
        let (span, back) = if n >= 5 { (5, n - 2) } else { (n, 0) };
        for (&s, &inv) in self.scales.iter().zip(&self.inv_sl) {
            if 4.0 * s * self.radius < min_wavelength {
                continue;
            }
            let q = DVec2::new(wrap(x.x * inv), wrap(x.y * inv));
            let (cx, cz) = self.cell_of(q);
            let sl = s * self.tile;
            let mut visit = |e: &Entry, pos: DVec2| {
                let mut d = q - pos;
                d.x -= d.x.round();
                d.y -= d.y.round();
                if let Some((h, g)) = kernel(s * e.amp, d, self.inv_rr2) {
                    f(h, g * inv, e.vel * sl);
                }
            };
            if index.t0 == t {
                // The index's cells are the cells at t: read the 3×3 in order, as a grid built
                // at t would.
                let rows = if n == 1 { 1 } else { 3 };
                for jz in 0..rows {
                    let iz = if n == 1 {
                        0
                    } else {
                        cyclic(cz + n - 1 + jz, n)
                    };
                    for jx in 0..rows {
                        let ix = if n == 1 {
                            0
                        } else {
                            cyclic(cx + n - 1 + jx, n)
                        };
                        let c = (iz * n + ix) as usize;
                        let (lo, hi) = (index.start[c] as usize, index.start[c + 1] as usize);
                        for e in &index.entries[lo..hi] {
                            visit(e, e.pos);
                        }
                    }
                }
                continue;
            }
            let mut found = Candidates::new();
            for jz in 0..span {
                let iz = cyclic(cz + back + jz, n);
                for jx in 0..span {
                    let c = (iz * n + cyclic(cx + back + jx, n)) as usize;
                    let (lo, hi) = (index.start[c] as usize, index.start[c + 1] as usize);
                    for (k, e) in (lo..hi).zip(&index.entries[lo..hi]) {
                        let u = self.position(e.id as usize, t);
                        let (px, pz) = self.cell_of(u);
                        if let (Some(sx), Some(sz)) = (slot(px, cx, n), slot(pz, cz, n)) {
                            let key = (u64::from(sz * 3 + sx) << 32) | u64::from(e.id);
                            found.push((key, k as u32, u));
                        }
                    }
                }
            }
            for &(_, k, pos) in found.sorted() {
                visit(&index.entries[k as usize], pos);
            }
        }
    }

    /// Slow reference of the fast path's order: every kept scale, then the 3×3 cells around x
    /// in row-major order, then, per cell, a scan of every particle in index order keeping those
    /// whose position at t ([`Ambient::position`]) lies in that cell. The same operands in the
    /// same order as the indexed walk (`Ambient::visit`), with no index, so the fast path must
    /// give its bits.
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
