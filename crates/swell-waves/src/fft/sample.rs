//! Reading a frame at any world point: nearest, bilinear and Catmull–Rom bicubic filters on the
//! periodic grid.

use glam::{DVec2, DVec3};

use super::fields::FftGrid;
use super::frame::FftFrame;

/// How a frame is read between grid nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SampleFilter {
    /// The nearest node (`round` half away from zero, per axis). Cheapest; error O(h).
    Nearest,
    /// Bilinear between the four surrounding nodes; error O(h²).
    Bilinear,
    /// Catmull–Rom bicubic over the 4×4 surrounding nodes (interpolating, C¹); error O(h³).
    /// The default: on a sea with no waves shorter than 8 grid cells it reads within 0.1% of Hs
    /// of the exact series (measured in the tests).
    #[default]
    Bicubic,
}

/// Which grids a read of a frame needs (see [`FftFrame::sample_some`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FftReads {
    /// `(Dx, h, Dz)` only: heights and displacements.
    Displacement,
    /// What a Newton step of the inversion reads: the displacement, and in `jacobian` the
    /// derivatives of the Catmull–Rom interpolant of the two displacement grids (see
    /// [`FftFrame::newton_jacobian`]), not the frame's Jacobian grids: three grids, not six.
    Newton,
    /// Every field, slopes too (normals).
    All,
}

impl FftReads {
    /// Every field if `derivatives`, else the displacement only.
    #[inline]
    pub(crate) fn every(derivatives: bool) -> Self {
        if derivatives {
            Self::All
        } else {
            Self::Displacement
        }
    }
}

/// Fields of an FFT layer at one point. Fields the frame did not compute are 0.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FftSample {
    /// `(Dx, h, Dz)`, m: horizontal displacement and height.
    pub displacement: DVec3,
    /// `(∂h/∂x, ∂h/∂z)`.
    pub slope: DVec2,
    /// `(∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z)`.
    pub jacobian: DVec3,
}

/// Grid coordinate of a world coordinate: `(i, f)` with node `i` in `0 … N−1` and fraction `f` in
/// [0, 1]. `u = x.rem_euclid(L)` (exact), `g = u·N / L` (`u·N` exact: N is a power of two),
/// `i = floor(g) mod N`, `f = g − floor(g)`. `rem_euclid` may round up to L itself for tiny
/// negative x; then g = N, which wraps to node 0.
///
/// Computed without library calls, to the same bits as that formula (pinned by a test against
/// `tests::grid_coord_reference`): for |x| < L, `x % L` is exactly x, so `rem_euclid` is x or
/// x + L, and for |x| < 2L it is x ∓ L, also exact (the fmod call is needed only farther out); g is in [0, N] or is −0, where truncation
/// is floor, and `+ 0.0` turns the fraction −0 that g = −0 would give into floor's +0. N is a
/// power of two (the layer checks it), so `mod N` is a mask.
#[inline]
fn grid_coord(x: f64, l: f64, n: usize) -> (usize, f64) {
    let u = if x.abs() < l {
        if x < 0.0 { x + l } else { x }
    } else if x.abs() < 2.0 * l {
        // rem_euclid's own steps, with the fmod done by hand: for L ≤ |x| < 2L, `x % L` is
        // x ∓ L, exact (Sterbenz), and so is adding L to a negative remainder. (At x = −L this
        // gives +0 where fmod gives −0; both floor to node 0 with fraction +0.)
        let r = if x < 0.0 { x + l } else { x - l };
        if r < 0.0 { r + l } else { r }
    } else {
        x.rem_euclid(l)
    };
    let g = u * n as f64 / l;
    // Through i64, not usize: for g in [0, N] (and NaN, which both casts send to 0) the same
    // whole number, in one conversion instruction each way where the unsigned casts take a
    // dozen on x86-64 without AVX-512.
    let t = g as i64;
    (t as usize & (n - 1), (g - t as f64) + 0.0)
}

/// Catmull–Rom weights for nodes −1, 0, 1, 2 at fraction t:
/// `w₋₁ = 0.5·((−t + 2)·t − 1)·t`, `w₀ = 0.5·((3t − 5)·t·t + 2)`,
/// `w₁ = 0.5·((−3t + 4)·t + 1)·t`, `w₂ = 0.5·(t − 1)·t·t` (evaluated as written).
#[inline]
fn catmull_rom(t: f64) -> [f64; 4] {
    [
        0.5 * (((-t + 2.0) * t - 1.0) * t),
        0.5 * ((3.0 * t - 5.0) * t * t + 2.0),
        0.5 * (((-3.0 * t + 4.0) * t + 1.0) * t),
        0.5 * ((t - 1.0) * t * t),
    ]
}

/// Derivatives `dw/dt` of the Catmull–Rom weights ([`catmull_rom`]) for nodes −1, 0, 1, 2:
/// `0.5·((−3t + 4)·t − 1)`, `0.5·(9t − 10)·t`, `0.5·((−9t + 8)·t + 1)`, `0.5·(3t − 2)·t`
/// (evaluated as written; they sum to 0 for every t, as the weights sum to 1).
#[inline]
fn catmull_rom_slope(t: f64) -> [f64; 4] {
    [
        0.5 * ((-3.0 * t + 4.0) * t - 1.0),
        0.5 * ((9.0 * t - 10.0) * t),
        0.5 * ((-9.0 * t + 8.0) * t + 1.0),
        0.5 * ((3.0 * t - 2.0) * t),
    ]
}

/// Where a point falls on a frame's grid, and how to read any grid there: the node and fraction
/// per axis, computed once per point and shared by every grid the point reads.
#[derive(Debug, Clone, Copy)]
struct Stencil {
    n: usize,
    i: usize,
    j: usize,
    fx: f64,
    fz: f64,
    filter: SampleFilter,
}

impl Stencil {
    #[inline]
    fn new(frame: &FftFrame, p0: DVec2, filter: SampleFilter) -> Self {
        let n = frame.n;
        debug_assert!(n.is_power_of_two());
        let (i, fx) = grid_coord(p0.x, frame.tile_size, n);
        let (j, fz) = grid_coord(p0.y, frame.tile_size, n);
        Self {
            n,
            i,
            j,
            fx,
            fz,
            filter,
        }
    }

    /// Node index `base + off` mod N (N a power of two).
    #[inline]
    fn wrap(&self, base: usize, off: isize) -> usize {
        base.wrapping_add_signed(off) & (self.n - 1)
    }

    /// [`Stencil::read`] of `K` grids at once: the node indices and weights are worked out
    /// once for all of them, and each grid's sum runs in the order `read` sums it (so the same
    /// bits), side by side, which the compiler can vectorise across grids.
    #[inline(always)]
    fn read_many<const K: usize>(&self, grids: [&[f64]; K]) -> [f64; K] {
        if self.filter != SampleFilter::Bicubic {
            return grids.map(|g| self.read(g));
        }
        let Self {
            n, i, j, fx, fz, ..
        } = *self;
        let wx = catmull_rom(fx);
        let wz = catmull_rom(fz);
        let mut acc = [0.0; K];
        if i >= 1 && i + 2 < n && j >= 1 && j + 2 < n {
            // No node wraps (all but a 3-node border of the tile): each grid's 16 nodes are
            // four runs of four on rows j − 1 … j + 2 from column i − 1, read as `[f64; 4]`
            // (one bounds check a run instead of one a node). The same sums in the same order.
            let first = (j - 1) * n + (i - 1);
            for (b, wzb) in wz.iter().enumerate() {
                let at = first + b * n;
                let mut r = [0.0; K];
                for (r, g) in r.iter_mut().zip(&grids) {
                    let run: &[f64; 4] = g[at..at + 4].try_into().unwrap_or(&[0.0; 4]);
                    for (wxa, v) in wx.iter().zip(run) {
                        *r += wxa * v;
                    }
                }
                for (acc, r) in acc.iter_mut().zip(r) {
                    *acc += wzb * r;
                }
            }
            return acc;
        }
        let cols = [self.wrap(i, -1), i, self.wrap(i, 1), self.wrap(i, 2)];
        for (b, wzb) in wz.iter().enumerate() {
            let row = self.wrap(j, b as isize - 1) * n;
            let mut r = [0.0; K];
            for (a, wxa) in wx.iter().enumerate() {
                let at = row + cols[a];
                for (r, g) in r.iter_mut().zip(&grids) {
                    *r += wxa * g[at];
                }
            }
            for (acc, r) in acc.iter_mut().zip(r) {
                *acc += wzb * r;
            }
        }
        acc
    }

    /// A Newton round's read in one pass over the 16 nodes: the bicubic values of Dx, h and Dz
    /// (the bits of [`Stencil::read_many`]: the same row sums in the same order; h reads 0 when
    /// the frame has no height grid) and the gradients `(gx, gz)` of the Catmull–Rom interpolant
    /// of Dx and Dz in grid units (per node spacing), whatever the stencil's filter:
    /// `gx = Σ_b wz_b·(Σ_a w'x_a·v(i+a, j+b))`, `gz = Σ_b w'z_b·(Σ_a wx_a·v(i+a, j+b))`, a and b
    /// running −1, 0, 1, 2 in that order, the row sums accumulated side by side from 0 (see
    /// [`FftFrame::newton_jacobian`]).
    #[inline(always)]
    fn read_newton(
        &self,
        dx: &[f64],
        h: Option<&[f64]>,
        dz: &[f64],
    ) -> ([f64; 3], [(f64, f64); 2]) {
        let Self {
            n, i, j, fx, fz, ..
        } = *self;
        let (wx, dwx) = (catmull_rom(fx), catmull_rom_slope(fx));
        let (wz, dwz) = (catmull_rom(fz), catmull_rom_slope(fz));
        // The 4×4 nodes of each grid first (rows j − 1 … j + 2, columns i − 1 … i + 2), then
        // the sums: one loop, no closure (a closure here was not inlined, and ran out of line in
        // baseline code outside the AVX2 body kernel).
        let mut nodes = [[[0.0; 4]; 3]; 4];
        if i >= 1 && i + 2 < n && j >= 1 && j + 2 < n {
            // No node wraps: four runs of four per grid (see `read_many`).
            let first = (j - 1) * n + (i - 1);
            for (b, rows) in nodes.iter_mut().enumerate() {
                let at = first + b * n;
                for (run, g) in rows.iter_mut().zip([Some(dx), h, Some(dz)]) {
                    if let Some(g) = g {
                        *run = g[at..at + 4].try_into().unwrap_or([0.0; 4]);
                    }
                }
            }
        } else {
            let cols = [self.wrap(i, -1), i, self.wrap(i, 1), self.wrap(i, 2)];
            for (b, rows) in nodes.iter_mut().enumerate() {
                let at = self.wrap(j, b as isize - 1) * n;
                for (run, g) in rows.iter_mut().zip([Some(dx), h, Some(dz)]) {
                    if let Some(g) = g {
                        *run = cols.map(|c| g[at + c]);
                    }
                }
            }
        }
        let mut acc = [0.0; 3];
        let mut grad = [(0.0, 0.0); 2];
        for (b, run) in nodes.iter().enumerate() {
            let mut rv = [0.0; 3];
            let mut rd = [0.0; 2];
            for a in 0..4 {
                for (r, g) in rv.iter_mut().zip(run) {
                    *r += wx[a] * g[a];
                }
                rd[0] += dwx[a] * run[0][a];
                rd[1] += dwx[a] * run[2][a];
            }
            for (acc, r) in acc.iter_mut().zip(rv) {
                *acc += wz[b] * r;
            }
            for (k, g) in grad.iter_mut().enumerate() {
                g.0 += wz[b] * rd[k];
                g.1 += dwz[b] * rv[2 * k];
            }
        }
        (acc, grad)
    }

    /// The filtered value of one N×N grid (see [`FftFrame::sample`] for the formulas).
    #[inline]
    fn read(&self, g: &[f64]) -> f64 {
        let Self {
            n, i, j, fx, fz, ..
        } = *self;
        match self.filter {
            SampleFilter::Nearest => {
                let ii = self.wrap(i, isize::from(fx >= 0.5));
                let jj = self.wrap(j, isize::from(fz >= 0.5));
                g[jj * n + ii]
            }
            SampleFilter::Bilinear => {
                let (i1, j1) = (self.wrap(i, 1), self.wrap(j, 1));
                let row0 = (1.0 - fx) * g[j * n + i] + fx * g[j * n + i1];
                let row1 = (1.0 - fx) * g[j1 * n + i] + fx * g[j1 * n + i1];
                (1.0 - fz) * row0 + fz * row1
            }
            SampleFilter::Bicubic => {
                let wx = catmull_rom(fx);
                let wz = catmull_rom(fz);
                let cols = [self.wrap(i, -1), i, self.wrap(i, 1), self.wrap(i, 2)];
                let mut acc = 0.0;
                for (b, wzb) in wz.iter().enumerate() {
                    let row = self.wrap(j, b as isize - 1) * n;
                    let mut r = 0.0;
                    for (a, wxa) in wx.iter().enumerate() {
                        r += wxa * g[row + cols[a]];
                    }
                    acc += wzb * r;
                }
                acc
            }
        }
    }
}

impl FftFrame {
    /// The frame's fields at world point `p0 = (x, z)`, m (any finite magnitude; the tile wraps).
    ///
    /// Filters, with `(i, fx)`, `(j, fz)` the grid coordinates of x and z (see
    /// [`SampleFilter`]), node indices taken mod N, `v(i, j)` the grid value:
    /// - `Nearest`: `v(i + [fx ≥ ½], j + [fz ≥ ½])`.
    /// - `Bilinear`: `(1−fz)·((1−fx)·v(i,j) + fx·v(i+1,j)) + fz·((1−fx)·v(i,j+1) + fx·v(i+1,j+1))`.
    /// - `Bicubic`: `Σ_b wz_b·(Σ_a wx_a·v(i+a, j+b))`, a and b running −1, 0, 1, 2 in that order,
    ///   with Catmull–Rom weights `w₋₁ = 0.5·((−t+2)·t − 1)·t`, `w₀ = 0.5·((3t−5)·t·t + 2)`,
    ///   `w₁ = 0.5·((−3t+4)·t + 1)·t`, `w₂ = 0.5·(t−1)·t·t`.
    ///
    /// Grid coordinates: `u = x.rem_euclid(L)` (exact), `g = u·N/L`, `i = floor(g) mod N`,
    /// `fx = g − floor(g)`; likewise z. Fields not in the frame read as 0.
    pub fn sample(&self, p0: DVec2, filter: SampleFilter) -> FftSample {
        self.sample_some(p0, filter, FftReads::All)
    }

    /// [`FftFrame::sample`] reading only the grids `reads` names; the fields left out read 0.
    /// Each field read has the bits `sample` gives it (the same stencil, the same sum). A
    /// bicubic read of a 256² grid touches 16 nodes on four rows, mostly cache misses on a
    /// large frame, so leaving out grids nobody uses is most of the saving.
    #[inline(always)]
    pub(crate) fn sample_some(
        &self,
        p0: DVec2,
        filter: SampleFilter,
        reads: FftReads,
    ) -> FftSample {
        use FftGrid::{DisplacementX, DisplacementZ, DxDx, DxDz, DzDz, Height, SlopeX, SlopeZ};
        let at = Stencil::new(self, p0, filter);
        match reads {
            FftReads::Displacement => {
                let [x, h, z] = self.read_fields(&at, [DisplacementX, Height, DisplacementZ]);
                FftSample {
                    displacement: DVec3::new(x, h, z),
                    ..FftSample::default()
                }
            }
            FftReads::Newton => {
                let (Some(dx), Some(dz)) = (self.grid(DisplacementX), self.grid(DisplacementZ))
                else {
                    // No displacement grids: nothing to invert, a zero Jacobian.
                    let [x, h, z] = self.read_fields(&at, [DisplacementX, Height, DisplacementZ]);
                    return FftSample {
                        displacement: DVec3::new(x, h, z),
                        ..FftSample::default()
                    };
                };
                let (values, [(xx, xz), (zx, zz)]) = at.read_newton(dx, self.grid(Height), dz);
                // The bicubic values come with the gradients; another filter reads its own.
                let [x, h, z] = if filter == SampleFilter::Bicubic {
                    values
                } else {
                    self.read_fields(&at, [DisplacementX, Height, DisplacementZ])
                };
                FftSample {
                    displacement: DVec3::new(x, h, z),
                    slope: DVec2::ZERO,
                    jacobian: self.newton_terms(xx, xz, zx, zz),
                }
            }
            FftReads::All => {
                let [x, h, z, xx, zz, xz, sx, sz] = self.read_fields(
                    &at,
                    [
                        DisplacementX,
                        Height,
                        DisplacementZ,
                        DxDx,
                        DzDz,
                        DxDz,
                        SlopeX,
                        SlopeZ,
                    ],
                );
                FftSample {
                    displacement: DVec3::new(x, h, z),
                    slope: DVec2::new(sx, sz),
                    jacobian: DVec3::new(xx, zz, xz),
                }
            }
        }
    }

    /// The horizontal Jacobian that the inversion's Newton steps use at world point `p0`, as
    /// `(∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z)`: the derivatives of the Catmull–Rom interpolant of the frame's
    /// displacement grids Dx and Dz (whatever the filter), not the Jacobian grids. With
    /// `(gx, gz)` a grid's interpolant gradient per node spacing (Catmull–Rom weights `w` and
    /// their derivatives `w'`: `gx = Σ_b wz_b·(Σ_a w'x_a·v)`, `gz = Σ_b w'z_b·(Σ_a wx_a·v)`) and
    /// `s = N/L` nodes per metre:
    /// `(gx(Dx)·s, gz(Dz)·s, 0.5·(gz(Dx)·s + gx(Dz)·s))` — the two cross terms of an
    /// interpolant differ slightly (the sea's are equal), and Newton takes their mean.
    ///
    /// Why: it is the derivative of the very function Newton solves when the filter is
    /// bicubic (so the steps converge quadratically), it reads the 16 nodes the displacement
    /// read has just brought into cache, and a frame for heights then needs 3 grids instead of
    /// 6 (`Surface::fft_fields_for`): about 40% less transform work per frame. Zero when the
    /// frame has no displacement grids.
    pub fn newton_jacobian(&self, p0: DVec2) -> DVec3 {
        self.sample_some(p0, SampleFilter::Bicubic, FftReads::Newton)
            .jacobian
    }

    /// `(∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z)` per metre from the interpolant gradients per node spacing.
    #[inline(always)]
    fn newton_terms(&self, xx: f64, xz: f64, zx: f64, zz: f64) -> DVec3 {
        let s = self.n as f64 / self.tile_size;
        DVec3::new(xx * s, zz * s, 0.5 * (xz * s + zx * s))
    }

    /// The filtered values of `grids` at a stencil, 0 for a grid the frame did not compute
    /// (all at once when the frame has every one of them, the common case).
    #[inline(always)]
    fn read_fields<const K: usize>(&self, at: &Stencil, grids: [FftGrid; K]) -> [f64; K] {
        let found = grids.map(|g| self.grid(g));
        if found.iter().all(Option::is_some) {
            at.read_many(found.map(|g| g.unwrap_or_default()))
        } else {
            found.map(|g| g.map_or(0.0, |g| at.read(g)))
        }
    }

    /// Height h, m, at world point `p0 = (x, z)`: `sample(p0, filter).displacement.y` to the bit,
    /// reading only the height grid (0 if the frame has none). Note that p0 is the undisplaced
    /// point: on a choppy layer the surface above world (x, z) is found by inverting the
    /// displacement (see [`crate::query`]), which this does not do.
    pub fn sample_height(&self, p0: DVec2, filter: SampleFilter) -> f64 {
        self.sample_grid(FftGrid::Height, p0, filter)
    }

    /// One grid's value at world point `p0 = (x, z)` with `filter` (the formulas of
    /// [`FftFrame::sample`], to the bit), or 0 if the frame did not compute that grid.
    pub fn sample_grid(&self, grid: FftGrid, p0: DVec2, filter: SampleFilter) -> f64 {
        self.grid(grid)
            .map_or(0.0, |g| Stencil::new(self, p0, filter).read(g))
    }
}

/// Reads the sea at time `t` between two frames of the same layer by linear interpolation in
/// time: `a.sample + w·(b.sample − a.sample)` per field, `w = (t − a.t)/(b.t − a.t)` clamped to
/// [0, 1] (`w = 0` when the frames share a time).
///
/// The cheap middle setting of the "time between FFT ticks" knob: a server that computes frames
/// at a fixed tick rate can answer queries at any time in between without a new frame. Its error
/// grows with the tick period squared (a wave of frequency ω is off by up to `A·(ωΔt)²/8`), and
/// it also shrinks amplitudes slightly between ticks; `docs/accuracy.md` measures it against the
/// exact frame and against reading the nearest tick.
///
/// Deterministic (plain `*`/`+`), with the arithmetic of [`lerp_samples`], which the layer's time
/// grid uses ([`super::FftLayer::grid_position`]). Both frames should have the same fields; a
/// field missing from either reads as 0 there.
pub fn sample_between(
    a: &FftFrame,
    b: &FftFrame,
    t: f64,
    p0: DVec2,
    filter: SampleFilter,
) -> FftSample {
    let span = b.t() - a.t();
    let w = if span != 0.0 {
        ((t - a.t()) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    lerp_samples(&a.sample(p0, filter), &b.sample(p0, filter), w)
}

/// `a + (b − a)·w` for every field of two samples, component by component (plain `−`, `*`, `+`
/// in that order: the time grid's interpolation, see the [module docs](super), step 7). `w = 0`
/// gives `a`'s bits exactly.
#[inline]
pub fn lerp_samples(a: &FftSample, b: &FftSample, w: f64) -> FftSample {
    FftSample {
        displacement: a.displacement + (b.displacement - a.displacement) * w,
        slope: a.slope + (b.slope - a.slope) * w,
        jacobian: a.jacobian + (b.jacobian - a.jacobian) * w,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catmull_rom_weights_interpolate_and_sum_to_one() {
        assert_eq!(catmull_rom(0.0), [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(catmull_rom(1.0), [0.0, 0.0, 1.0, 0.0]);
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let w = catmull_rom(t);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            // Reproduces linear functions exactly: Σ w_a·a = t.
            let lin = -w[0] + w[2] + 2.0 * w[3];
            assert!((lin - t).abs() < 1e-15);
        }
    }

    /// The formula of [`grid_coord`], evaluated as written (`rem_euclid`, `floor`, `%`).
    pub(super) fn grid_coord_reference(x: f64, l: f64, n: usize) -> (usize, f64) {
        let u = x.rem_euclid(l);
        let g = u * n as f64 / l;
        let f = g.floor();
        ((f as usize) % n, g - f)
    }

    /// The call-free grid coordinate must equal the formula bit for bit, fraction sign included:
    /// inside the tile's fast path, at its edges, for tiny negatives that round to L, and far out.
    #[test]
    fn grid_coord_equals_the_reference_bit_for_bit() {
        use crate::math::SwellRng;
        let mut rng = SwellRng::new(17, 3);
        let check = |x: f64, l: f64, n: usize| {
            let (i, f) = grid_coord(x, l, n);
            let (ri, rf) = grid_coord_reference(x, l, n);
            assert_eq!(
                (i, f.to_bits()),
                (ri, rf.to_bits()),
                "x = {x:e}, L = {l}, N = {n}"
            );
        };
        for &(l, n) in &[
            (100.0, 64),
            (256.0, 256),
            (3.7, 16),
            (1000.0, 1024),
            (0.1, 32),
        ] {
            let h = l / n as f64;
            let edges = [
                0.0,
                -0.0,
                l,
                -l,
                2.0 * l,
                -2.0 * l,
                l * (1.0 - f64::EPSILON),
                -l * (1.0 - f64::EPSILON),
                f64::MIN_POSITIVE,
                -f64::MIN_POSITIVE,
                5e-324,
                -5e-324,
                -1e-300,
                -1e-17,
                h,
                -h,
                0.5 * h,
                -0.5 * h,
                l - h,
                -(l - h),
                1e7 + 25.0,
                -1e7 - 25.0,
                1e300,
                -1e300,
            ];
            for x in edges {
                check(x, l, n);
                check(f64::from_bits(x.to_bits() + 1), l, n);
                if x != 0.0 {
                    check(f64::from_bits(x.to_bits() - 1), l, n);
                }
            }
            for k in -3 * n as i64..=3 * n as i64 {
                check(k as f64 * h, l, n);
            }
            for _ in 0..20_000 {
                let (a, b) = rng.gaussian_pair();
                check(a * l, l, n);
                check(b * l * 1e-12, l, n);
                check(a * l * 1e6, l, n);
                check(b * 1e15, l, n);
            }
        }
    }

    #[test]
    fn grid_coord_wraps_and_handles_rounding_to_the_tile_edge() {
        assert_eq!(grid_coord(0.0, 100.0, 64), (0, 0.0));
        assert_eq!(grid_coord(-1e-300, 100.0, 64), (0, 0.0));
        let (i, f) = grid_coord(-100.0 / 64.0 * 0.5, 100.0, 64);
        assert_eq!(i, 63);
        assert!((f - 0.5).abs() < 1e-12);
        let (i, f) = grid_coord(1e7 + 25.0, 100.0, 64);
        assert_eq!((i, f), (16, 0.0));
    }
}
