//! Time evolution of the spectrum and the transforms into grids.

use std::sync::{Arc, Mutex};

use rustfft::num_complex::Complex;

use super::fields::{FftFields, FftGrid};
use super::layer::{FftLayer, evolve};
use super::{AlignedVec, Grid};
use crate::math::{reduce_phase, sin_cos};

/// The fields of an FFT layer at one time, on the layer's N×N grid.
///
/// Grid layout: the value at `x = i·L/N`, `z = j·L/N` is stored at `[j·N + i]`. The tile repeats
/// with period L in x and z.
///
/// A frame made by [`FftLayer::frame`] hands its grid buffers back to its layer when it is
/// dropped, and the layer's next frames reuse them (see [`FftLayer::frame`]): holding frames in
/// an `Arc` or a cache and dropping them when stale is all the recycling a server needs.
#[derive(Clone)]
pub struct FftFrame {
    pub(crate) t: f64,
    pub(crate) fields: FftFields,
    pub(crate) n: usize,
    pub(crate) tile_size: f64,
    pub(crate) grids: [Option<Grid>; 8],
    pub(crate) transforms: usize,
    /// Where the grids go when the frame is dropped (`None`: to the allocator).
    pub(crate) pool: Option<Arc<GridPool>>,
}

impl std::fmt::Debug for FftFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FftFrame")
            .field("t", &self.t)
            .field("fields", &self.fields)
            .field("n", &self.n)
            .field("tile_size", &self.tile_size)
            .field("transforms", &self.transforms)
            .finish_non_exhaustive()
    }
}

impl Drop for FftFrame {
    fn drop(&mut self) {
        if let Some(pool) = &self.pool {
            for grid in self.grids.iter_mut().filter_map(Option::take) {
                pool.put(grid);
            }
        }
    }
}

/// Grid buffers (N² f64 each) of dropped frames, for the next frames of a layer.
///
/// A fresh N² buffer costs page faults (N = 256: 128 pages of 4 KiB, ~0.05 ms a grid here, a
/// fifth of its transform): the allocator hands large blocks back to the OS when they are freed
/// and maps new ones for the next frame. Reusing them cannot change a result, because a frame
/// overwrites every value of every grid it computes. At most `cap` buffers are kept (the grids of
/// one full frame, and no more than `GRID_POOL_BYTES`), so an idle layer holds at most that much.
pub(crate) struct GridPool {
    len: usize,
    cap: usize,
    pub(crate) free: Mutex<Vec<Grid>>,
}

/// Most bytes of grid buffers a layer's pool keeps: 16 MiB is one full frame at 512² (8 grids)
/// and two grids at 1024²; at 256² the one-frame count limit (4 MiB) applies first.
const GRID_POOL_BYTES: usize = 16 << 20;

impl GridPool {
    /// A pool of N×N grids.
    pub(crate) fn new(n: usize) -> Self {
        let len = n * n;
        let by_bytes = GRID_POOL_BYTES / (len * std::mem::size_of::<f64>());
        Self {
            len,
            cap: by_bytes.clamp(1, FftGrid::ALL.len()),
            free: Mutex::new(Vec::new()),
        }
    }

    /// A buffer of N² values (contents unspecified: the caller overwrites all of them).
    pub(crate) fn take(&self) -> Grid {
        let pooled = self.free.lock().ok().and_then(|mut f| f.pop());
        pooled.unwrap_or_else(|| Grid::zeroed(self.len))
    }

    /// Keeps `grid` for a later frame if it has the pool's size and the pool has room; otherwise
    /// frees it. A poisoned lock only means the buffer is freed.
    fn put(&self, grid: Grid) {
        if grid.len() != self.len {
            return;
        }
        if let Ok(mut free) = self.free.lock()
            && free.len() < self.cap
        {
            free.push(grid);
        }
    }
}

impl std::fmt::Debug for GridPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GridPool")
            .field("len", &self.len)
            .field("cap", &self.cap)
            .finish_non_exhaustive()
    }
}

impl FftFrame {
    /// The time asked for, s (not reduced modulo T).
    pub fn t(&self) -> f64 {
        self.t
    }

    /// The fields present.
    pub fn fields(&self) -> FftFields {
        self.fields
    }

    /// Grid side N.
    pub fn resolution(&self) -> usize {
        self.n
    }

    /// Tile side L, m.
    pub fn tile_size(&self) -> f64 {
        self.tile_size
    }

    /// The N×N values of one grid (`[j·N + i]`), or `None` if the frame did not compute it.
    pub fn grid(&self, grid: FftGrid) -> Option<&[f64]> {
        self.grids[grid.index()].as_deref()
    }

    /// Number of 2-D inverse real transforms this frame cost: one per grid present.
    pub fn transforms(&self) -> usize {
        self.transforms
    }
}

impl FftLayer {
    /// The grids of `fields` at time `t`, s.
    ///
    /// Time is reduced first, `t_r = t.rem_euclid(T)`, so frames at `t` and `t + T` are
    /// bit-identical (whenever `t + T` is itself exact in f64). Each kept k evolves as
    /// `h̃(k, t) = h0(k)·e^{−iω_q t_r} + conj(h0(−k))·e^{+iω_q t_r}` with
    /// `(sin, cos) = math::sin_cos(reduce_phase(ω_q·t_r))`; each grid is then
    /// `Σ_k c(k)·h̃(k, t)·e^{i k·x}` (see [`FftGrid`]), one 2-D inverse real transform per grid,
    /// computed only for the grids in `fields`.
    ///
    /// `t` should be finite: a non-finite `t` gives NaN grids (validate times at the boundary).
    /// The result depends only on the layer, `t_r` and `fields`; with the portable backend it is
    /// the same to the bit on every platform.
    ///
    /// Grid buffers come from the layer's pool of dropped frames' grids when it has some (every
    /// value is overwritten, so this cannot change a result), else from the allocator.
    pub fn frame(&self, t: f64, fields: FftFields) -> FftFrame {
        let mut frame = FftFrame {
            t,
            fields: FftFields::NONE,
            n: self.n,
            tile_size: self.tile_size,
            grids: Default::default(),
            transforms: 0,
            pool: None,
        };
        self.frame_into(t, fields, &mut frame);
        frame
    }

    /// [`FftLayer::frame`] into an existing frame, reusing its grid buffers (a frame of this
    /// layer, or of any layer of the same resolution): the same bits as `frame(t, fields)`, since
    /// every value of every grid asked is overwritten, but no allocation and no fresh pages from
    /// the OS once the buffers exist. A tick loop that keeps the previous tick's frame recycles
    /// it here; grids not in `fields` go to the old frame's pool (see [`FftLayer::frame`]).
    pub fn frame_into(&self, t: f64, fields: FftFields, frame: &mut FftFrame) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::simd_level() >= crate::simd::SimdLevel::Avx2 {
            // SAFETY: `simd_level` is Avx2 or wider only where the CPU has AVX2 (detected at run time).
            unsafe { self.frame_into_avx2(t, fields, frame) };
            return;
        }
        self.frame_into_body(t, fields, frame);
    }

    /// [`FftLayer::frame_into`]'s passes outside the FFT library (evolution, multipliers,
    /// packing) compiled for AVX2 — the same bits, see `surface::for_blocks`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn frame_into_avx2(&self, t: f64, fields: FftFields, frame: &mut FftFrame) {
        self.frame_into_body(t, fields, frame);
    }

    #[inline(always)]
    fn frame_into_body(&self, t: f64, fields: FftFields, frame: &mut FftFrame) {
        let n = self.n;
        let t_r = t.rem_euclid(self.repeat_period);
        let mut grids: [Option<Grid>; 8] = Default::default();
        let mut old = std::mem::take(&mut frame.grids);
        let old_pool = frame.pool.take();
        let mut transforms = 0;
        if fields.grid_count() > 0 {
            // Buffers come from the layer's pool: a frame allocates only the grids it returns.
            let mut scratch = self.transform.take_scratch();
            let mut htilde = std::mem::replace(&mut scratch.htilde, AlignedVec::new(0));
            self.evolve_into(t_r, &mut scratch.phases, &mut htilde);
            for grid in FftGrid::ALL.into_iter().filter(|&g| fields.has(g)) {
                let mut out = old[grid.index()]
                    .take()
                    .filter(|g| g.len() == n * n)
                    .unwrap_or_else(|| self.grid_pool.take());
                self.transform.process_grid(
                    grid,
                    transforms == 0,
                    &htilde,
                    (&self.kx_cols, &self.kz_rows, &self.inv_ks),
                    self.choppiness,
                    self.spread_waves.as_ref(),
                    &mut scratch,
                    &mut out,
                );
                grids[grid.index()] = Some(out);
                transforms += 1;
            }
            scratch.htilde = htilde;
            self.transform.give_back(scratch);
        }
        // Grids the old frame had and this one does not go back to the old frame's pool.
        if let Some(pool) = &old_pool {
            for grid in old.into_iter().flatten() {
                pool.put(grid);
            }
        }
        *frame = FftFrame {
            t,
            fields,
            n,
            tile_size: self.tile_size,
            grids,
            transforms,
            pool: Some(Arc::clone(&self.grid_pool)),
        };
    }

    /// h̃(k, t) of every half-plane entry at reduced time `t_r` into `htilde` (zero for empty
    /// entries), as [`FftLayer::frame`] documents; `phases` is working memory.
    ///
    /// The phase of an entry depends on its ω_q only, and a layer has few distinct ω_q (whole
    /// multiples of ω0): `sin_cos(reduce_phase(ω·t_r))` is evaluated once per distinct value
    /// (`phase_omegas`) and gathered per entry (`phase_index`). Same operands and operations as
    /// evaluating each entry's own phase, so the same bits (pinned by a test against that form).
    #[inline(always)]
    pub(crate) fn evolve_into(
        &self,
        t_r: f64,
        phases: &mut Vec<(f64, f64)>,
        htilde: &mut [Complex<f64>],
    ) {
        let zero = Complex::new(0.0, 0.0);
        phases.clear();
        phases.extend(
            self.phase_omegas
                .iter()
                .map(|&w| sin_cos(reduce_phase(w * t_r))),
        );
        let entries = self.amplitudes.iter().zip(&self.phase_index);
        for (h, (&amp, &ix)) in htilde.iter_mut().zip(entries) {
            // `Mode::is_empty`: h0(k) = h0(−k) = 0.
            *h = if amp == [0.0; 4] {
                zero
            } else {
                let (s, c) = phases[ix as usize];
                evolve(amp, s, c)
            };
        }
    }
}
