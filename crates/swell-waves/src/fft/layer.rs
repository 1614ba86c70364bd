//! An FFT layer: validated spec, the kept wave vectors, their random amplitudes h0(k) and their
//! quantised frequencies.

use glam::DVec2;
use rustfft::num_complex::Complex;

use std::sync::Arc;

use super::frame::GridPool;
use super::transform::{InverseRealFft2, SpreadWaves};
use super::{DEFAULT_TIME_STEP, FftBackend, FftSpec, MIN_TIME_STEP};
use crate::error::{SpecError, direction, finite, in_range, non_negative};
use crate::math::{SwellRng, TAU, mode_key};
use crate::spectrum::Dispersion;

/// Smallest grid side: below 16 a tile holds too few waves to look like a sea.
pub const MIN_RESOLUTION: u32 = 16;
/// Largest grid side: a 1024² frame with all eight fields is ~64 MiB of f64 and ~0.1 s of work;
/// larger tiles belong in a cascade of layers.
pub const MAX_RESOLUTION: u32 = 1024;
/// Largest choppiness λ. Tessendorf's sea is λ = 1; beyond a few the surface folds everywhere,
/// and 10 bounds the damage a typo can do.
pub const MAX_CHOPPINESS: f64 = 10.0;

/// Smallest tile side L, m: below a metre every wave of the grid is a capillary ripple the model
/// does not describe.
pub const MIN_TILE_SIZE: f64 = 1.0;

/// Largest tile side L, m (100 km). Far beyond it the spectrum's lowest modes and the
/// wrap of positions into the tile stop being finite (found by the `config_toml` fuzz target:
/// `tile_size = 1e308` answered NaN heights).
pub const MAX_TILE_SIZE: f64 = 100_000.0;

/// Shortest repeat period T, s. ω is quantised to whole multiples of 2π/T; below a second that
/// step (≥ 2π rad/s) is coarser than the spectrum's own frequencies, so the sea degenerates, and
/// a subnormal period made 2π/T infinite and every height NaN (found by the `scene_spec` fuzz
/// target's 10-minute rerun: `repeat_period = 1.996e-321`).
pub const MIN_REPEAT_PERIOD: f64 = 1.0;

/// Longest repeat period T, s (about 11.6 days). The evolution's phase ω_q·(t mod T) must stay
/// where the deterministic `sin_cos` reduces exactly (|x| ≲ 2.7·10¹⁰ rad): the fastest mode a
/// layer can hold (N = 1024 on a 1 m tile at g = 1000 m/s²) is ~1.8·10³ rad/s, so 10⁶ s keeps
/// every phase under 2·10⁹ rad. Far beyond it heights were NaN (found by the `scene_spec` fuzz
/// target: `repeat_period = 1.991e303`).
pub const MAX_REPEAT_PERIOD: f64 = 1.0e6;

/// One entry of the half plane `m = 0 … N/2 − 1`: the wave vector k = Δk·(m, n), its quantised
/// frequency and the amplitudes of the waves along +k and −k.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Mode {
    pub(crate) kx: f64,
    pub(crate) kz: f64,
    /// 1/|k|, or 0 for k = 0.
    pub(crate) inv_k: f64,
    /// ω_q(|k|), rad/s.
    pub(crate) omega_q: f64,
    /// h0(k), m.
    pub(crate) h0: Complex<f64>,
    /// h0(−k), m.
    pub(crate) h0_neg: Complex<f64>,
}

impl Mode {
    /// Whether the entry carries no wave (its h̃ is zero at every time).
    pub(crate) fn is_empty(&self) -> bool {
        self.h0 == Complex::new(0.0, 0.0) && self.h0_neg == Complex::new(0.0, 0.0)
    }

    /// h̃(k, t) = h0(k)·e^{−iω_q t_r} + conj(h0(−k))·e^{+iω_q t_r}, given `(s, c)` =
    /// `sin_cos(reduce_phase(ω_q·t_r))`. Bit-level recipe, with h0 = a + ib, h0(−k) = p + iq:
    /// `re = (a·c + b·s) + (p·c + q·s)`, `im = (b·c − a·s) + (p·s − q·c)`.
    #[inline]
    pub(crate) fn evolve(&self, s: f64, c: f64) -> Complex<f64> {
        evolve(
            [self.h0.re, self.h0.im, self.h0_neg.re, self.h0_neg.im],
            s,
            c,
        )
    }
}

/// [`Mode::evolve`] from the amplitudes `[a, b, p, q]` (h0 = a + ib, h0(−k) = p + iq).
#[inline]
pub(crate) fn evolve([a, b, p, q]: [f64; 4], s: f64, c: f64) -> Complex<f64> {
    Complex::new(
        (a * c + b * s) + (p * c + q * s),
        (b * c - a * s) + (p * s - q * c),
    )
}

/// A built Tessendorf FFT layer: a seeded random sea on a periodic square tile, ready to produce
/// frames ([`FftLayer::frame`]) and reference samples ([`FftLayer::sample_reference`]).
///
/// See the [module docs](super) for the full recipe. The layer is immutable, `Send + Sync`, and
/// cheap to share behind an `Arc`.
#[derive(Debug, Clone)]
pub struct FftLayer {
    pub(crate) n: usize,
    pub(crate) tile_size: f64,
    pub(crate) choppiness: f64,
    pub(crate) repeat_period: f64,
    /// Steps M of the time grid per repeat period (≥ 1).
    pub(crate) grid_steps: u64,
    /// The grid's step Δ = T/M, s.
    pub(crate) time_step: f64,
    pub(crate) backend: FftBackend,
    /// Half plane, column-major: entry (m, n) at `m·N + (n mod N)` for m = 0 … N/2 − 1.
    pub(crate) half: Vec<Mode>,
    /// The distinct values of `half[i].omega_q`, ascending (bit-distinct: equal bits, one entry).
    /// ω_q is a whole multiple of ω0, so a layer has few of them (≈ 200 at 256² with T = 200 s,
    /// against 32 768 half-plane entries): a frame evaluates `sin_cos(reduce_phase(ω·t_r))` once
    /// per value here and gathers it through `phase_index`.
    pub(crate) phase_omegas: Vec<f64>,
    /// For each half-plane entry i, the position of `half[i].omega_q` in `phase_omegas`. Since
    /// `phase_omegas[phase_index[i]]` has the very bits of `half[i].omega_q`, the gathered
    /// (sin, cos) is bit-identical to evaluating the entry's own phase.
    pub(crate) phase_index: Vec<u32>,
    /// `[a, b, p, q]` of `half[i]` (h0 = a + ib, h0(−k) = p + iq), contiguous: the evolution
    /// streams through these 32 bytes per entry rather than the whole mode.
    pub(crate) amplitudes: Vec<[f64; 4]>,
    /// The wave vectors of `half` in parts, for the multiplier passes
    /// ([`super::FftGrid::apply_column`]): `kx_cols[m] = m·Δk`, `kz_rows[i] = q·Δk` for row i
    /// of every column (q = i, or i − N past N/2; 0 on the Nyquist row, which is never kept) and
    /// `inv_ks[i] = 1/|k|` of `half[i]` (0 for an empty entry): 8 bytes per entry to stream
    /// rather than a `[kx, kz, 1/|k|]` triple or the whole mode. (Storing each grid's factor r
    /// of c(k) instead, 8 bytes per entry and grid, measured no faster for 2.3× the memory.)
    pub(crate) kx_cols: Vec<f64>,
    pub(crate) kz_rows: Vec<f64>,
    pub(crate) inv_ks: Vec<f64>,
    /// The same parts laid out for the portable backend's column pass (`None` for the native
    /// backend).
    pub(crate) spread_waves: Option<SpreadWaves>,
    pub(crate) modes: usize,
    pub(crate) variance: f64,
    pub(crate) transform: InverseRealFft2,
    /// Grid buffers of this layer's dropped frames (shared by clones of the layer, which have the
    /// same resolution).
    pub(crate) grid_pool: Arc<GridPool>,
}

impl FftLayer {
    /// Validates `spec` and builds the layer from its spectrum, spreading and wind direction:
    /// the density is [`crate::spectrum::DirectionalSpectrum::density`] (see
    /// [`FftLayer::from_density`] for everything else).
    ///
    /// # Errors
    /// As [`FftLayer::from_density`], plus any spectrum or spreading field out of range
    /// (`{field}.spectrum.*`, `{field}.spreading.*`).
    pub fn new(
        spec: &FftSpec,
        seed: u64,
        dispersion: Dispersion,
        field: &str,
    ) -> Result<FftLayer, SpecError> {
        let wind = direction(&format!("{field}.wind_direction"), spec.wind_direction)?;
        let spectrum = crate::spectrum::DirectionalSpectrum::new(
            &spec.spectrum,
            &spec.spreading,
            wind,
            dispersion,
            field,
        )?;
        Self::from_density(spec, seed, dispersion, field, |k| spectrum.density(k))
    }

    /// Validates `spec` and builds the layer from a wave-vector variance density.
    ///
    /// `density(k)` is E(kx, kz) in m⁴ (so that ∫∫E dk = m0, the variance of the height); it is
    /// evaluated once at every kept wave vector, in the order m = −N/2+1 … N/2−1 (outer),
    /// n likewise (inner), and never at k = 0. `field` prefixes error paths (e.g. `layers[2]`);
    /// `seed` is the layer's resolved seed (`spec.seed` is not read here); `dispersion` gives ω(k).
    /// The spec's `spectrum` and `spreading` are not read either: they are what `density` is
    /// built from.
    ///
    /// # Errors
    /// [`SpecError`] naming the field, when:
    /// - `{field}.resolution` is not a power of two in 16..=1024;
    /// - `{field}.tile_size` is not in [[`MIN_TILE_SIZE`], [`MAX_TILE_SIZE`]] m;
    /// - `{field}.repeat_period` is not in [[`MIN_REPEAT_PERIOD`], [`MAX_REPEAT_PERIOD`]] s;
    /// - `{field}.choppiness` is not in [0, 10];
    /// - `{field}.time_step` is not finite and in [[`MIN_TIME_STEP`], `repeat_period`];
    /// - `{field}.wind_direction` is not finite or is the zero vector;
    /// - `{field}.band.min_wavelength` is not finite and ≥ 0, or `{field}.band.max_wavelength` is
    ///   not finite and > min;
    /// - `{field}.spectrum`: `density` returned a negative or non-finite value at a kept mode.
    pub fn from_density(
        spec: &FftSpec,
        seed: u64,
        dispersion: Dispersion,
        field: &str,
        density: impl Fn(DVec2) -> f64,
    ) -> Result<FftLayer, SpecError> {
        let res = spec.resolution;
        if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&res) || !res.is_power_of_two() {
            return Err(SpecError::OutOfRange {
                field: format!("{field}.resolution"),
                value: f64::from(res),
                allowed: format!("a power of two in {MIN_RESOLUTION}..={MAX_RESOLUTION}"),
            });
        }
        let tile_size = in_range(
            &format!("{field}.tile_size"),
            spec.tile_size,
            MIN_TILE_SIZE,
            MAX_TILE_SIZE,
        )?;
        let choppiness = in_range(
            &format!("{field}.choppiness"),
            spec.choppiness,
            0.0,
            MAX_CHOPPINESS,
        )?;
        let repeat_period = in_range(
            &format!("{field}.repeat_period"),
            spec.repeat_period,
            MIN_REPEAT_PERIOD,
            MAX_REPEAT_PERIOD,
        )?;
        let (grid_steps, time_step) = time_grid(field, spec.time_step, repeat_period)?;
        direction(&format!("{field}.wind_direction"), spec.wind_direction)?;
        let (min_wl, max_wl) = match spec.band {
            None => (0.0, f64::INFINITY),
            Some(band) => {
                let min =
                    non_negative(&format!("{field}.band.min_wavelength"), band.min_wavelength)?;
                let max = match band.max_wavelength {
                    None => f64::INFINITY,
                    Some(max) => {
                        let name = format!("{field}.band.max_wavelength");
                        finite(&name, max)?;
                        if max <= min {
                            return Err(SpecError::OutOfRange {
                                field: name,
                                value: max,
                                allowed: format!("> min_wavelength = {min} m"),
                            });
                        }
                        max
                    }
                };
                (min, max)
            }
        };

        let n = res as usize;
        let h = (n / 2) as i32;
        let dk = TAU / tile_size;
        let omega0 = TAU / repeat_period;
        let wave_vector = |m: i32, q: i32| DVec2::new(f64::from(m) * dk, f64::from(q) * dk);
        let kept = |m: i32, q: i32| {
            if (m, q) == (0, 0) || m <= -h || m >= h || q <= -h || q >= h {
                return false;
            }
            let wavelength = TAU / wave_vector(m, q).length();
            min_wl <= wavelength && wavelength < max_wl
        };

        // h0 over the full plane, indexed [(m + N/2)·N + (q + N/2)].
        let zero = Complex::new(0.0, 0.0);
        let mut h0 = vec![zero; n * n];
        let mut modes = 0;
        for m in 1 - h..h {
            for q in 1 - h..h {
                if !kept(m, q) {
                    continue;
                }
                let k = wave_vector(m, q);
                let e = density(k);
                if !(e.is_finite() && e >= 0.0) {
                    return Err(SpecError::Inconsistent {
                        field: format!("{field}.spectrum"),
                        reason: format!(
                            "the spectral density at k = ({}, {}) rad/m is {e}; it must be finite and >= 0",
                            k.x, k.y
                        ),
                    });
                }
                modes += 1;
                let (g1, g2) = SwellRng::new(mode_key(seed, m, q), 0).gaussian_pair();
                let s = (e * (dk * dk) * 0.25).sqrt();
                h0[((m + h) as usize) * n + (q + h) as usize] = Complex::new(g1 * s, g2 * s);
            }
        }
        let at = |m: i32, q: i32| h0[((m + h) as usize) * n + (q + h) as usize];

        // Realised variance: the time average of mean(h²) = Σ_k |h0(k)|² + |h0(−k)|².
        let mut sum = 0.0;
        for v in &h0 {
            sum += v.norm_sqr();
        }
        let variance = 2.0 * sum;

        let mut half = vec![Mode::default(); n / 2 * n];
        for m in 0..h {
            for q in 1 - h..h {
                if !kept(m, q) {
                    continue;
                }
                let k = wave_vector(m, q);
                let len = k.length();
                let omega = dispersion.omega(len);
                half[(m as usize) * n + q.rem_euclid(n as i32) as usize] = Mode {
                    kx: k.x,
                    kz: k.y,
                    inv_k: 1.0 / len,
                    omega_q: (omega / omega0).floor() * omega0,
                    h0: at(m, q),
                    h0_neg: at(-m, -q),
                };
            }
        }

        let (phase_omegas, phase_index) = phase_table(&half);
        let amplitudes = half
            .iter()
            .map(|m| [m.h0.re, m.h0.im, m.h0_neg.re, m.h0_neg.im])
            .collect();
        let kx_cols: Vec<f64> = (0..h).map(|m| wave_vector(m, 0).x).collect();
        let kz_rows: Vec<f64> = (0..n as i32)
            .map(|i| match i {
                _ if i < h => wave_vector(0, i).y,
                _ if i == h => 0.0,
                _ => wave_vector(0, i - n as i32).y,
            })
            .collect();
        let inv_ks: Vec<f64> = half.iter().map(|m| m.inv_k).collect();
        let transform = InverseRealFft2::new(n, spec.backend);
        let spread_waves = transform.spread_waves(&kx_cols, &kz_rows, &inv_ks);
        Ok(FftLayer {
            n,
            tile_size,
            choppiness,
            repeat_period,
            grid_steps,
            time_step,
            backend: spec.backend,
            half,
            phase_omegas,
            phase_index,
            amplitudes,
            kx_cols,
            kz_rows,
            inv_ks,
            spread_waves,
            modes,
            variance,
            transform,
            grid_pool: Arc::new(GridPool::new(n)),
        })
    }

    /// Grid side N.
    pub fn resolution(&self) -> usize {
        self.n
    }

    /// Tile side L, m.
    pub fn tile_size(&self) -> f64 {
        self.tile_size
    }

    /// Horizontal displacement scale λ.
    pub fn choppiness(&self) -> f64 {
        self.choppiness
    }

    /// Repeat period T, s.
    pub fn repeat_period(&self) -> f64 {
        self.repeat_period
    }

    /// Step Δ of the time grid in use, s: `T/M` (see [`FftSpec::time_step`]).
    pub fn time_step(&self) -> f64 {
        self.time_step
    }

    /// Steps M of the time grid per repeat period: grid indices run over `0..M`.
    pub fn grid_steps(&self) -> u64 {
        self.grid_steps
    }

    /// The time of grid index `index`, s: `index·Δ` (indices are taken modulo M).
    pub fn grid_time(&self, index: u64) -> f64 {
        (index % self.grid_steps) as f64 * self.time_step
    }

    /// Where `t` lies on the time grid: `t_r = t.rem_euclid(T)`,
    /// `index` the largest grid index with `grid_time(index) ≤ t_r` (`floor(t_r/Δ)` up to
    /// rounding), `next = (index + 1) mod M` and
    /// `weight = clamp((t_r − grid_time(index))/Δ, 0, 1)`. A query at t reads the frames of
    /// `index` and, when `weight > 0`, `next` ([`crate::SurfaceAt`] does this). `t` must be
    /// finite (the weight is NaN otherwise).
    pub fn grid_position(&self, t: f64) -> GridPosition {
        let t_r = t.rem_euclid(self.repeat_period);
        // floor(t_r/Δ) is the index up to rounding (t_r/Δ may land one ulp on the wrong side of
        // a whole number, and reach M just below t_r = T; saturating `as` maps NaN to 0), so it
        // is corrected against the grid times themselves: grid_time(index) ≤ t_r <
        // grid_time(index + 1). A query at a grid time thus reads that one frame, with weight 0.
        let mut index = ((t_r / self.time_step).floor() as u64).min(self.grid_steps - 1);
        if index + 1 < self.grid_steps && self.grid_time(index + 1) <= t_r {
            index += 1;
        } else if index > 0 && self.grid_time(index) > t_r {
            index -= 1;
        }
        let weight = ((t_r - self.grid_time(index)) / self.time_step).clamp(0.0, 1.0);
        let next = if index + 1 == self.grid_steps {
            0
        } else {
            index + 1
        };
        GridPosition {
            index,
            next,
            weight,
        }
    }

    /// The frame of grid index `index`: exactly [`FftLayer::frame`] at
    /// [`FftLayer::grid_time`]`(index)`.
    pub fn grid_frame(&self, index: u64, fields: super::FftFields) -> super::FftFrame {
        self.frame(self.grid_time(index), fields)
    }

    /// The FFT backend frames use.
    pub fn backend(&self) -> FftBackend {
        self.backend
    }

    /// Number of kept wave vectors (both k and −k counted): inside the grid, inside the band,
    /// not k = 0. Modes where the density is zero are kept (with h0 = 0) and counted.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// The realised discrete m0, m²: `Σ_k |h0(k)|² + |h0(−k)|²` over kept k, which is the time
    /// average of the grid mean of h² (exactly so when no kept ω_q is 0). Its expectation over
    /// seeds is `Σ_k E(k)·Δk²`. Significant wave height `Hs = 4·sqrt(variance)`.
    pub fn variance(&self) -> f64 {
        self.variance
    }

    /// The complex amplitude h0(k), m, of the wave with mode numbers `(m, n)` (k = 2π/L·(m, n));
    /// zero for modes that are not kept or lie outside the grid.
    pub fn h0(&self, m: i32, n: i32) -> Complex<f64> {
        let h = (self.n / 2) as i32;
        if m <= -h || m >= h || n <= -h || n >= h {
            return Complex::new(0.0, 0.0);
        }
        let col = |q: i32| q.rem_euclid(self.n as i32) as usize;
        if m >= 0 {
            self.half[m as usize * self.n + col(n)].h0
        } else {
            self.half[(-m) as usize * self.n + col(-n)].h0_neg
        }
    }
}

/// A query time's place on an FFT layer's time grid ([`FftLayer::grid_position`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridPosition {
    /// The grid index at or before the time (in `0..M`).
    pub index: u64,
    /// The grid index after it, `(index + 1) mod M`.
    pub next: u64,
    /// Weight of the `next` frame, in [0, 1]: 0 on a grid time.
    pub weight: f64,
}

/// The time grid of a layer: `(M, T/M)` with `M = max(1, round(T/Δ))`.
fn time_grid(field: &str, step: Option<f64>, period: f64) -> Result<(u64, f64), SpecError> {
    let step = match step {
        None => DEFAULT_TIME_STEP.min(period),
        Some(dt) => in_range(&format!("{field}.time_step"), dt, MIN_TIME_STEP, period)?,
    };
    // period/step ≥ 1 here; a period of 10^15 s at 1 ms would overflow nothing either (as u64
    // saturates), but keep M well inside the exactly representable integers of f64.
    let m = (period / step).round().clamp(1.0, 9.0e15) as u64;
    Ok((m, period / m as f64))
}

/// The distinct ω_q of `half` in ascending order, and each entry's position among them (see
/// `FftLayer::phase_omegas`). Values are compared by their bits, so the table can never merge
/// two frequencies that would round differently in `ω·t_r`.
fn phase_table(half: &[Mode]) -> (Vec<f64>, Vec<u32>) {
    let mut omegas: Vec<f64> = half.iter().map(|m| m.omega_q).collect();
    omegas.sort_by(f64::total_cmp);
    omegas.dedup_by(|a, b| a.to_bits() == b.to_bits());
    let index = half
        .iter()
        .map(|m| {
            let i = omegas
                .binary_search_by(|w| w.total_cmp(&m.omega_q))
                .expect("every omega_q is in the table");
            // At most N/2·N ≤ 2^19 entries (MAX_RESOLUTION), so the position fits in u32.
            i as u32
        })
        .collect();
    (omegas, index)
}
