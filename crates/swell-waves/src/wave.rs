//! One travelling wave, the building block of the sine and Gerstner layers.

use glam::DVec2;

use crate::error::{SpecError, direction, in_range, positive_at_most};
#[cfg(target_arch = "x86_64")]
use crate::math::RoundByTrunc;
use crate::math::{
    RoundBySelects, Rounding, TAU, reduce_phase, reduce_turns, sin_cos, sin_cos_phases,
    sin_cos_turns_f32,
};
use crate::spectrum::Dispersion;

/// A built, validated wave: everything needed to evaluate it, and everything a client needs to
/// render exactly the same wave.
///
/// Phase `θ = k·(d·p0) − ω·t + φ`. A sine wave moves the surface vertically only
/// (`y = A·sin θ`); a Gerstner wave also moves it horizontally by `Q·A·d·cos θ`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Wave {
    /// Amplitude A, m.
    pub amplitude: f64,
    /// Wave number k = 2π/λ, rad/m.
    pub wavenumber: f64,
    /// Angular frequency ω, rad/s (from the dispersion relation, or `c·k` when a speed is given).
    pub omega: f64,
    /// Unit direction of travel `[x, z]`.
    pub direction: DVec2,
    /// Phase offset φ, rad.
    pub phase: f64,
    /// Gerstner steepness Q in [0, 1] (0 for a sine wave).
    pub steepness: f64,
}

/// Sum of a set of waves and their first derivatives at one undisplaced point.
///
/// `displacement` is `(Dx, y, Dz)`: the horizontal displacement and the elevation. `d_dx` is
/// `∂(Dx, y, Dz)/∂x0` and `d_dz` is `∂(Dx, y, Dz)/∂z0`, so the displaced surface's tangents are
/// `(1, 0, 0) + d_dx` and `(0, 0, 1) + d_dz`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfaceSample {
    /// `(Dx, y, Dz)`, m.
    pub displacement: glam::DVec3,
    /// Derivative of `displacement` along x0 (dimensionless).
    pub d_dx: glam::DVec3,
    /// Derivative of `displacement` along z0 (dimensionless).
    pub d_dz: glam::DVec3,
}

impl SurfaceSample {
    /// Adds another sample (layers sum linearly).
    #[inline]
    pub fn add(&mut self, o: &SurfaceSample) {
        self.displacement += o.displacement;
        self.d_dx += o.d_dx;
        self.d_dz += o.d_dz;
    }

    /// Jacobian determinant of the horizontal map `p0 ↦ p0 + (Dx, Dz)`:
    /// `J = (1 + ∂Dx/∂x)(1 + ∂Dz/∂z) − (∂Dx/∂z)(∂Dz/∂x)`. `J ≤ 0` means the surface folds here.
    #[inline]
    pub fn jacobian(&self) -> f64 {
        (1.0 + self.d_dx.x) * (1.0 + self.d_dz.z) - self.d_dz.x * self.d_dx.z
    }

    /// Unit normal of the displaced surface: `(e_z + d_dz) × (e_x + d_dx)`, normalised (y up).
    /// Falls back to straight up if the tangents are degenerate (a fold's edge).
    #[inline]
    pub fn normal(&self) -> glam::DVec3 {
        let tx = glam::DVec3::X + self.d_dx;
        let tz = glam::DVec3::Z + self.d_dz;
        let n = tz.cross(tx);
        let len = n.length();
        if len > 1e-300 && len.is_finite() {
            n / len
        } else {
            glam::DVec3::Y
        }
    }
}

/// Largest amplitude an analytic wave may have, m: ten times any sea ever measured. Beyond it
/// the number is a typo, and sums, slopes (`A·k`) and normals of hundreds of such waves stop
/// being finite.
pub const MAX_AMPLITUDE: f64 = 1e3;
/// Shortest wavelength an analytic wave may have, m (capillary ripples are ~17 mm): keeps the
/// wave number `2π/λ` and the phase `k·x` at `|x| ≤ 10⁹ m` finite and reducible.
pub const MIN_WAVELENGTH: f64 = 1e-3;
/// Longest wavelength an analytic wave may have, m (a tide's is ~10⁷ m).
pub const MAX_WAVELENGTH: f64 = 1e7;
/// Largest `|phase|` offset, rad: any angle fits in [−π, π]; this leaves room for unreduced
/// inputs while keeping the phase sum accurate.
pub const MAX_PHASE: f64 = 1e6;
/// Largest phase speed a wave may be given (`speed`), m/s: a 10⁷ m deep-water wave runs at
/// ~4·10³ m/s.
pub const MAX_SPEED: f64 = 1e5;

impl Wave {
    /// Builds a wave from its spec values. `field` is the error path prefix.
    ///
    /// ω comes from `dispersion` unless `speed` (phase speed c, m/s) is given, then `ω = c·k`.
    ///
    /// # Errors
    /// Amplitude outside [0, [`MAX_AMPLITUDE`]], wavelength outside [[`MIN_WAVELENGTH`],
    /// [`MAX_WAVELENGTH`]], a zero direction, `|phase|` over [`MAX_PHASE`], a speed outside
    /// (0, [`MAX_SPEED`]], a steepness outside [0, 1], or anything non-finite.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        field: &str,
        amplitude: f64,
        wavelength: f64,
        dir: [f64; 2],
        phase: f64,
        speed: Option<f64>,
        steepness: f64,
        dispersion: &Dispersion,
    ) -> Result<Wave, SpecError> {
        in_range(&format!("{field}.amplitude"), amplitude, 0.0, MAX_AMPLITUDE)?;
        in_range(
            &format!("{field}.wavelength"),
            wavelength,
            MIN_WAVELENGTH,
            MAX_WAVELENGTH,
        )?;
        let direction = direction(&format!("{field}.direction"), dir)?;
        in_range(&format!("{field}.phase"), phase, -MAX_PHASE, MAX_PHASE)?;
        in_range(&format!("{field}.steepness"), steepness, 0.0, 1.0)?;
        let k = TAU / wavelength;
        let omega = match speed {
            Some(c) => positive_at_most(&format!("{field}.speed"), c, MAX_SPEED)? * k,
            None => dispersion.omega(k),
        };
        if !(k.is_finite() && omega.is_finite()) {
            return Err(SpecError::OutOfRange {
                field: format!("{field}.wavelength"),
                value: wavelength,
                allowed: "a wavelength whose wave number and frequency are finite".into(),
            });
        }
        Ok(Wave {
            amplitude,
            wavenumber: k,
            omega,
            direction,
            phase: reduce_phase(phase),
            steepness,
        })
    }

    /// Wavelength λ = 2π/k, m.
    pub fn wavelength(&self) -> f64 {
        TAU / self.wavenumber
    }

    /// This wave's share of the fold number, `Q·k·A`.
    pub fn fold_contribution(&self) -> f64 {
        self.steepness * self.wavenumber * self.amplitude
    }

    /// The phase `θ = k·(d·p0) − ω·t + φ`, formed in f64 and reduced to [−π, π].
    #[inline]
    pub fn phase_at(&self, p0: DVec2, t: f64) -> f64 {
        let along = self.direction.x * p0.x + self.direction.y * p0.y;
        reduce_phase(self.wavenumber * along - self.omega * t + self.phase)
    }

    /// Adds this wave's displacement (and, if `derivatives`, its derivatives) at `p0`, time `t`.
    ///
    /// Same arithmetic, operation for operation, as one lane of [`WaveSoA::accumulate_lanes`].
    #[inline]
    pub fn accumulate(&self, p0: DVec2, t: f64, derivatives: bool, out: &mut SurfaceSample) {
        let (s, c) = sin_cos(self.phase_at(p0, t));
        accumulate_with(self, s, c, derivatives, out);
    }

    /// Slow reference: the same sum with the phase left unreduced and the platform's f64
    /// `sin`/`cos` (which reduce exactly). For tests and reports, not for model results.
    pub fn accumulate_reference(&self, p0: DVec2, t: f64, out: &mut SurfaceSample) {
        let along = self.direction.x * p0.x + self.direction.y * p0.y;
        let theta = self.wavenumber * along - self.omega * t + self.phase;
        let (s, c) = theta.sin_cos(); // determinism: reference (platform trig on purpose)
        accumulate_with(self, s, c, true, out);
    }
}

#[inline]
fn accumulate_with(w: &Wave, s: f64, c: f64, derivatives: bool, out: &mut SurfaceSample) {
    let a = w.amplitude;
    let qa = w.steepness * a;
    let (dx, dz) = (w.direction.x, w.direction.y);
    out.displacement.x += qa * dx * c;
    out.displacement.y += a * s;
    out.displacement.z += qa * dz * c;
    if derivatives {
        let ak_c = a * w.wavenumber * c;
        let qak_s = qa * w.wavenumber * s;
        // ∂/∂x0 of (Q A dx cos θ, A sin θ, Q A dz cos θ) with ∂θ/∂x0 = k dx.
        out.d_dx.x -= qak_s * dx * dx;
        out.d_dx.y += ak_c * dx;
        out.d_dx.z -= qak_s * dx * dz;
        out.d_dz.x -= qak_s * dx * dz;
        out.d_dz.y += ak_c * dz;
        out.d_dz.z -= qak_s * dz * dz;
    }
}

/// Sums `waves` at `p0`, time `t` into `out`.
#[inline]
pub fn accumulate_all(
    waves: &[Wave],
    p0: DVec2,
    t: f64,
    derivatives: bool,
    out: &mut SurfaceSample,
) {
    for w in waves {
        w.accumulate(p0, t, derivatives, out);
    }
}

/// Points per block of the batch kernels: 8 f64 lanes fill two AVX2 registers (or one AVX-512
/// register) per quantity; with 9 accumulators per lane that still fits the register file.
/// The block size never changes a result, only speed (every lane is computed on its own).
pub const BLOCK: usize = 8;

/// Waves per group of the f64 block kernel: the kernel computes the sines and cosines of this
/// many waves side by side before adding their terms in wave order. Four independent chains
/// (four AVX-512 registers per step) hide most of each step's latency and still leave room in
/// the register file for the nine accumulators; a group never changes a result, only speed.
const WAVE_GROUP: usize = 4;

/// A set of waves stored as a structure of arrays, for evaluating many points at once.
///
/// Per wave it keeps exactly the factors the scalar path forms first (`Q·A·dx`, `A·k`, …, each
/// rounded as [`Wave::accumulate`] rounds it), so that the block kernels give the same bits as
/// the one-point path: each lane computes `θ = reduce_phase((k·(dx·x + dz·z) − ω·t) + φ)`,
/// `(s, c) = math::sin_cos(θ)` and adds the terms in wave order, exactly as
/// [`Wave::accumulate`] does. Lanes never mix, so results do not depend on the block size or on
/// which other points share the block.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WaveSoA {
    k: Vec<f64>,
    omega: Vec<f64>,
    phase: Vec<f64>,
    dx: Vec<f64>,
    dz: Vec<f64>,
    a: Vec<f64>,
    /// `Q·A·dx`, `Q·A·dz`: horizontal displacement amplitudes.
    qadx: Vec<f64>,
    qadz: Vec<f64>,
    /// `A·k` and `Q·A·k`: derivative amplitudes.
    ak: Vec<f64>,
    qak: Vec<f64>,
    /// `A·ω` and `Q·(A·ω)`: particle velocity amplitudes ([`crate::velocity`]).
    aw: Vec<f64>,
    qaw: Vec<f64>,
    /// The single-precision fast path's constants (see [`WaveSoA::accumulate_lanes_f32`]).
    fast: FastWaves,
}

/// Per-wave constants of the single-precision fast kernel: the wave vector in turns per metre
/// (f64, the phase is formed in f64) and the amplitudes of the eight summed terms (f32).
#[derive(Debug, Clone, Default, PartialEq)]
struct FastWaves {
    /// `k·dx/2π`, `k·dz/2π`, turns/m.
    kx: Vec<f64>,
    kz: Vec<f64>,
    /// `A`, `Q·A·dx`, `Q·A·dz`, m.
    a: Vec<f32>,
    qadx: Vec<f32>,
    qadz: Vec<f32>,
    /// `A·k·dx`, `A·k·dz`; `Q·A·k·dx²`, `Q·A·k·dx·dz`, `Q·A·k·dz²` (dimensionless).
    akdx: Vec<f32>,
    akdz: Vec<f32>,
    qakxx: Vec<f32>,
    qakxz: Vec<f32>,
    qakzz: Vec<f32>,
}

/// Accumulators of one block of the single-precision fast path: `(Dx, y, Dz)` and its
/// derivatives along x0 and z0, one f32 lane per point (the f32 twin of [`Lanes`]).
#[derive(Debug, Clone, Copy)]
pub struct LanesF32<const B: usize> {
    /// `Dx`, `y`, `Dz` per lane, m.
    pub disp: [[f32; B]; 3],
    /// `∂(Dx, y, Dz)/∂x0` per lane.
    pub d_dx: [[f32; B]; 3],
    /// `∂(Dx, y, Dz)/∂z0` per lane.
    pub d_dz: [[f32; B]; 3],
}

impl<const B: usize> Default for LanesF32<B> {
    fn default() -> Self {
        Self {
            disp: [[0.0; B]; 3],
            d_dx: [[0.0; B]; 3],
            d_dz: [[0.0; B]; 3],
        }
    }
}

impl<const B: usize> LanesF32<B> {
    /// Lane `l` widened to f64, as a [`SurfaceSample`].
    #[inline]
    pub fn get(&self, l: usize) -> SurfaceSample {
        let v = |a: &[[f32; B]; 3]| {
            glam::DVec3::new(f64::from(a[0][l]), f64::from(a[1][l]), f64::from(a[2][l]))
        };
        SurfaceSample {
            displacement: v(&self.disp),
            d_dx: v(&self.d_dx),
            d_dz: v(&self.d_dz),
        }
    }

    /// Every lane widened to f64.
    #[inline]
    pub fn widen(&self) -> Lanes<B> {
        let w = |a: &[[f32; B]; 3]| -> [[f64; B]; 3] {
            std::array::from_fn(|c| std::array::from_fn(|l| f64::from(a[c][l])))
        };
        Lanes {
            disp: w(&self.disp),
            d_dx: w(&self.d_dx),
            d_dz: w(&self.d_dz),
        }
    }

    /// Adds `s` to lane `l`, rounded to f32 first (how f64 contributions, such as FFT layers
    /// read from their grids, join the single-precision sum).
    #[inline]
    pub fn add(&mut self, l: usize, s: &SurfaceSample) {
        let put = |a: &mut [[f32; B]; 3], v: glam::DVec3| {
            a[0][l] += v.x as f32;
            a[1][l] += v.y as f32;
            a[2][l] += v.z as f32;
        };
        put(&mut self.disp, s.displacement);
        put(&mut self.d_dx, s.d_dx);
        put(&mut self.d_dz, s.d_dz);
    }

    /// Unit normals of the displaced surface, per lane, in f32: `n = (e_z + d_dz) × (e_x + d_dx)`
    /// normalised by `1/√(n·n)` (IEEE square root and division: correctly rounded, so the same
    /// on every CPU), or straight up `(0, 1, 0)` where `n·n` is not in (10⁻³⁰, ∞) — the f32 twin
    /// of [`SurfaceSample::normal`], branch-free so it vectorises.
    // Indexing several lane arrays by one counter is the shape the vectoriser wants.
    #[allow(clippy::needless_range_loop)]
    #[inline]
    pub fn normals(&self) -> [[f32; B]; 3] {
        let mut n = [[0.0f32; B]; 3];
        for l in 0..B {
            let (ax, ay, az) = (1.0 + self.d_dx[0][l], self.d_dx[1][l], self.d_dx[2][l]);
            let (bx, by, bz) = (self.d_dz[0][l], self.d_dz[1][l], 1.0 + self.d_dz[2][l]);
            let cx = by * az - bz * ay;
            let cy = bz * ax - bx * az;
            let cz = bx * ay - by * ax;
            let len2 = cx * cx + cy * cy + cz * cz;
            let ok = len2 > 1e-30 && len2 < f32::INFINITY;
            let inv = 1.0 / len2.sqrt();
            n[0][l] = if ok { cx * inv } else { 0.0 };
            n[1][l] = if ok { cy * inv } else { 1.0 };
            n[2][l] = if ok { cz * inv } else { 0.0 };
        }
        n
    }
}

/// Accumulators of one block: `(Dx, y, Dz)` and the six derivatives, one lane per point.
#[derive(Debug, Clone, Copy)]
pub struct Lanes<const B: usize> {
    /// `Dx`, `y`, `Dz` per lane.
    pub disp: [[f64; B]; 3],
    /// `∂(Dx, y, Dz)/∂x0` per lane.
    pub d_dx: [[f64; B]; 3],
    /// `∂(Dx, y, Dz)/∂z0` per lane.
    pub d_dz: [[f64; B]; 3],
}

impl<const B: usize> Default for Lanes<B> {
    fn default() -> Self {
        Self {
            disp: [[0.0; B]; 3],
            d_dx: [[0.0; B]; 3],
            d_dz: [[0.0; B]; 3],
        }
    }
}

impl<const B: usize> Lanes<B> {
    /// Lane `l` as a [`SurfaceSample`].
    #[inline]
    pub fn get(&self, l: usize) -> SurfaceSample {
        let v = |a: &[[f64; B]; 3]| glam::DVec3::new(a[0][l], a[1][l], a[2][l]);
        SurfaceSample {
            displacement: v(&self.disp),
            d_dx: v(&self.d_dx),
            d_dz: v(&self.d_dz),
        }
    }

    /// Adds `d` to lane `l`'s displacement only.
    #[inline]
    pub fn add_displacement(&mut self, l: usize, d: glam::DVec3) {
        self.disp[0][l] += d.x;
        self.disp[1][l] += d.y;
        self.disp[2][l] += d.z;
    }

    /// Adds `s` to lane `l` (component-wise, as [`SurfaceSample::add`] does).
    #[inline]
    pub fn add(&mut self, l: usize, s: &SurfaceSample) {
        let put = |a: &mut [[f64; B]; 3], v: glam::DVec3| {
            a[0][l] += v.x;
            a[1][l] += v.y;
            a[2][l] += v.z;
        };
        put(&mut self.disp, s.displacement);
        put(&mut self.d_dx, s.d_dx);
        put(&mut self.d_dz, s.d_dz);
    }
}

impl WaveSoA {
    /// Lays `waves` out as arrays.
    pub fn new(waves: &[Wave]) -> Self {
        let col = |f: &dyn Fn(&Wave) -> f64| waves.iter().map(f).collect::<Vec<f64>>();
        Self {
            k: col(&|w| w.wavenumber),
            omega: col(&|w| w.omega),
            phase: col(&|w| w.phase),
            dx: col(&|w| w.direction.x),
            dz: col(&|w| w.direction.y),
            a: col(&|w| w.amplitude),
            qadx: col(&|w| w.steepness * w.amplitude * w.direction.x),
            qadz: col(&|w| w.steepness * w.amplitude * w.direction.y),
            ak: col(&|w| w.amplitude * w.wavenumber),
            qak: col(&|w| w.steepness * w.amplitude * w.wavenumber),
            aw: col(&|w| w.amplitude * w.omega),
            qaw: col(&|w| w.steepness * (w.amplitude * w.omega)),
            fast: FastWaves::new(waves),
        }
    }

    /// Number of waves.
    pub fn len(&self) -> usize {
        self.k.len()
    }

    /// Whether there are no waves.
    pub fn is_empty(&self) -> bool {
        self.k.is_empty()
    }

    /// Adds every wave at the `B` undisplaced points `(x[l], z[l])`, time `t`, into `out`
    /// (derivatives too if `derivatives`). Bit-identical, lane by lane, to
    /// [`accumulate_all`] on each point.
    #[inline]
    pub fn accumulate_lanes<const B: usize>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
    ) {
        self.accumulate_lanes_v::<B, false>(x, z, t, derivatives, out, &mut [[0.0; B]; 3]);
    }

    /// [`WaveSoA::accumulate_lanes`] that also adds each wave's particle velocity, m/s, into
    /// `velocity` (`[vx, vy, vz][lane]`) from the same `sin θ`, `cos θ`:
    /// `vx += (Q·A·ω·sin θ)·dx`, `vy −= A·ω·cos θ`, `vz += (Q·A·ω·sin θ)·dz`, in wave order —
    /// lane by lane the bits of [`crate::velocity::accumulate_velocity`] over the same waves, for
    /// the price of three more multiply-adds per wave instead of a second pass of `sin_cos`.
    #[inline(always)]
    pub fn accumulate_lanes_with_velocity<const B: usize>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        self.accumulate_lanes_v::<B, true>(x, z, t, derivatives, out, velocity);
    }

    /// The two above: the kernel instance for `derivatives`, velocities summed if `V`.
    #[inline(always)]
    fn accumulate_lanes_v<const B: usize, const V: bool>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        #[cfg(target_arch = "x86_64")]
        match crate::simd::simd_level() {
            crate::simd::SimdLevel::Avx512 => {
                // SAFETY: `simd_level` is Avx512 only where the CPU has AVX-512 F (detected at
                // run time).
                unsafe { self.kernel_avx512::<B, V>(x, z, t, derivatives, out, velocity) };
                return;
            }
            crate::simd::SimdLevel::Avx2 => {
                // SAFETY: `simd_level` is Avx2 only where the CPU has AVX2 (detected at run time).
                unsafe { self.kernel_avx2::<B, V>(x, z, t, derivatives, out, velocity) };
                return;
            }
            _ => {}
        }
        self.kernel_for::<B, V, RoundBySelects>(x, z, t, derivatives, out, velocity);
    }

    /// The block kernel compiled for AVX-512 F, whatever its caller was compiled for: 8 f64
    /// lanes per register, rounding by truncation (`vrndscalepd`). Never FMA: Rust does not
    /// contract `a * b + c`, and [`RoundByTrunc`] gives [`RoundBySelects`]' bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn kernel_avx512<const B: usize, const V: bool>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        self.kernel_for::<B, V, RoundByTrunc>(x, z, t, derivatives, out, velocity);
    }

    /// The block kernel compiled for AVX2 (4 lanes, `vroundpd`); see
    /// [`WaveSoA::kernel_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn kernel_avx2<const B: usize, const V: bool>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        self.kernel_for::<B, V, RoundByTrunc>(x, z, t, derivatives, out, velocity);
    }

    /// The kernel instance for `derivatives`.
    #[inline(always)]
    fn kernel_for<const B: usize, const V: bool, R: Rounding>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        derivatives: bool,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        if derivatives {
            self.kernel::<B, true, V, R>(x, z, t, out, velocity);
        } else {
            self.kernel::<B, false, V, R>(x, z, t, out, velocity);
        }
    }

    /// The block kernel: waves outer (so each lane sums in wave order, like the scalar path),
    /// lanes inner (branch-free, so the lane loop vectorises). The waves go [`WAVE_GROUP`] at a
    /// time through [`crate::math::sin_cos_phases`], which interleaves their independent
    /// sin/cos chains; their terms are then added one wave after another, as the scalar path
    /// adds them.
    #[inline(always)]
    fn kernel<const B: usize, const D: bool, const V: bool, R: Rounding>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        // Local copies, so that the sums stay in registers rather than going back to `out`
        // after every wave.
        let mut acc = *out;
        let mut vel = *velocity;
        let n = self.k.len();
        let full = n - n % WAVE_GROUP;
        for w0 in (0..full).step_by(WAVE_GROUP) {
            self.group::<B, WAVE_GROUP, D, V, R>(w0, x, z, t, &mut acc, &mut vel);
        }
        // The waves after the last full group go as one shorter group (`lake`'s 17 waves
        // end in a group of one, a 23-wave layer in a group of three).
        match n - full {
            0 => {}
            1 => self.group::<B, 1, D, V, R>(full, x, z, t, &mut acc, &mut vel),
            2 => self.group::<B, 2, D, V, R>(full, x, z, t, &mut acc, &mut vel),
            3 => self.group::<B, 3, D, V, R>(full, x, z, t, &mut acc, &mut vel),
            // Only reachable if WAVE_GROUP grows past 4.
            _ => {
                for w0 in full..n {
                    self.group::<B, 1, D, V, R>(w0, x, z, t, &mut acc, &mut vel);
                }
            }
        }
        *out = acc;
        *velocity = vel;
    }

    /// Waves `w0..w0 + G` of the block kernel: their `G·B` sines and cosines, then their terms,
    /// wave by wave, each lane exactly as [`Wave::accumulate`] adds it.
    // Indexing several lane arrays by one counter is the shape the vectoriser wants.
    #[allow(clippy::needless_range_loop, clippy::too_many_arguments)]
    #[inline(always)]
    fn group<const B: usize, const G: usize, const D: bool, const V: bool, R: Rounding>(
        &self,
        w0: usize,
        x: &[f64; B],
        z: &[f64; B],
        t: f64,
        out: &mut Lanes<B>,
        velocity: &mut [[f64; B]; 3],
    ) {
        let ws = w0..w0 + G;
        let (k, om, ph) = (
            &self.k[ws.clone()],
            &self.omega[ws.clone()],
            &self.phase[ws.clone()],
        );
        let (dxs, dzs, a) = (
            &self.dx[ws.clone()],
            &self.dz[ws.clone()],
            &self.a[ws.clone()],
        );
        let (qadx, qadz) = (&self.qadx[ws.clone()], &self.qadz[ws.clone()]);
        let (ak, qak) = (&self.ak[ws.clone()], &self.qak[ws.clone()]);
        let (aw, qaw) = (&self.aw[ws.clone()], &self.qaw[ws]);
        // Lanes outer and waves inner, as in `sin_cos_phases` (the loops over G unroll, the lane
        // loops vectorise); each accumulator still takes its terms in wave order.
        let mut theta = [[0.0f64; B]; G];
        for l in 0..B {
            for g in 0..G {
                let along = dxs[g] * x[l] + dzs[g] * z[l];
                theta[g][l] = k[g] * along - om[g] * t + ph[g];
            }
        }
        let (sin, cos) = sin_cos_phases::<R, G, B>(&theta);
        for l in 0..B {
            for g in 0..G {
                let (dx, dz) = (dxs[g], dzs[g]);
                let (s, c) = (sin[g][l], cos[g][l]);
                out.disp[0][l] += qadx[g] * c;
                out.disp[1][l] += a[g] * s;
                out.disp[2][l] += qadz[g] * c;
                if D {
                    let ak_c = ak[g] * c;
                    let qak_s = qak[g] * s;
                    out.d_dx[0][l] -= qak_s * dx * dx;
                    out.d_dx[1][l] += ak_c * dx;
                    out.d_dx[2][l] -= qak_s * dx * dz;
                    out.d_dz[0][l] -= qak_s * dx * dz;
                    out.d_dz[1][l] += ak_c * dz;
                    out.d_dz[2][l] -= qak_s * dz * dz;
                }
                if V {
                    let qaw_s = qaw[g] * s;
                    velocity[0][l] += qaw_s * dx;
                    velocity[1][l] -= aw[g] * c;
                    velocity[2][l] += qaw_s * dz;
                }
            }
        }
    }

    /// Phase offsets of the single-precision fast path at time `t`, one per wave, in turns:
    /// `c = reduce_phase(φ − ω·t) / 2π` ∈ [−½, ½]. Computed once per time (a snapshot computes
    /// them on its first f32 evaluation and keeps them), so the per-point work carries no time
    /// term.
    pub fn phase_offsets(&self, t: f64) -> Vec<f64> {
        self.omega
            .iter()
            .zip(&self.phase)
            .map(|(&om, &ph)| reduce_phase(ph - om * t) * INV_TAU)
            .collect()
    }

    /// The single-precision fast path (an approximation knob, not the model's default): adds
    /// every wave at the `B` points `(x[l], z[l])` into `out`, with `offsets` from
    /// [`WaveSoA::phase_offsets`] at the time wanted.
    ///
    /// Per wave and point: the phase in turns is formed and reduced in f64,
    /// `u = reduce_turns((k·dx/2π)·x + (k·dz/2π)·z + c)` (exact for phases below 2⁵¹ turns,
    /// clamped to [−½, ½] beyond, so any finite point gives finite results); only u goes to
    /// f32, where [`crate::math::sin_cos_turns_f32`] gives `(sin 2πu, cos 2πu)` and the eight
    /// terms are summed in wave order:
    /// `Dx += Q·A·dx·cos`, `y += A·sin`, `Dz += Q·A·dz·cos`, `∂y/∂x0 += A·k·dx·cos`,
    /// `∂y/∂z0 += A·k·dz·cos`, `∂Dx/∂x0 −= Q·A·k·dx²·sin`, `∂Dz/∂z0 −= Q·A·k·dz²·sin` and
    /// `∂Dx/∂z0 = ∂Dz/∂x0 −= Q·A·k·dx·dz·sin` (one sum for both). Error: a few f32 ulp of the
    /// summed amplitudes (≈ 10⁻⁶ relative; see `docs/accuracy.md`).
    ///
    /// Deterministic like the f64 path (plain `*`/`+`, no fused operations, no branch): each lane
    /// is computed on its own, so any block size, batch or thread split gives the same bits, on
    /// every x86-64 level.
    ///
    /// # Panics
    /// If `offsets` is shorter than the wave list.
    #[inline]
    pub fn accumulate_lanes_f32<const B: usize>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        offsets: &[f64],
        derivatives: bool,
        out: &mut LanesF32<B>,
    ) {
        if derivatives {
            self.fast_kernel::<B, true>(x, z, offsets, out);
        } else {
            self.fast_kernel::<B, false>(x, z, offsets, out);
        }
    }

    // Indexing several lane arrays by one counter is the shape the vectoriser wants.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn fast_kernel<const B: usize, const D: bool>(
        &self,
        x: &[f64; B],
        z: &[f64; B],
        offsets: &[f64],
        out: &mut LanesF32<B>,
    ) {
        let f = &self.fast;
        let n = f.kx.len();
        let (kx, kz, off) = (&f.kx[..n], &f.kz[..n], &offsets[..n]);
        let (a, qadx, qadz) = (&f.a[..n], &f.qadx[..n], &f.qadz[..n]);
        let (akdx, akdz) = (&f.akdx[..n], &f.akdz[..n]);
        let (qxx, qxz, qzz) = (&f.qakxx[..n], &f.qakxz[..n], &f.qakzz[..n]);
        // Dx, y, Dz, ∂Dx/∂x0, ∂y/∂x0, ∂Dx/∂z0 (= ∂Dz/∂x0), ∂y/∂z0, ∂Dz/∂z0.
        let mut acc = [[0.0f32; B]; 8];
        for w in 0..n {
            for l in 0..B {
                let u = reduce_turns(kx[w] * x[l] + kz[w] * z[l] + off[w]) as f32;
                // Only phases past 2⁵¹ turns (points ~10¹⁵ m out) leave [−½, ½]; clamp them so
                // the polynomials stay finite. Written as selects (minps/maxps); NaN passes.
                let u = if u > 0.5 { 0.5 } else { u };
                let u = if u < -0.5 { -0.5 } else { u };
                let (s, c) = sin_cos_turns_f32(u);
                acc[0][l] += qadx[w] * c;
                acc[1][l] += a[w] * s;
                acc[2][l] += qadz[w] * c;
                if D {
                    acc[3][l] -= qxx[w] * s;
                    acc[4][l] += akdx[w] * c;
                    acc[5][l] -= qxz[w] * s;
                    acc[6][l] += akdz[w] * c;
                    acc[7][l] -= qzz[w] * s;
                }
            }
        }
        for l in 0..B {
            out.disp[0][l] += acc[0][l];
            out.disp[1][l] += acc[1][l];
            out.disp[2][l] += acc[2][l];
            if D {
                out.d_dx[0][l] += acc[3][l];
                out.d_dx[1][l] += acc[4][l];
                out.d_dx[2][l] += acc[5][l];
                out.d_dz[0][l] += acc[5][l];
                out.d_dz[1][l] += acc[6][l];
                out.d_dz[2][l] += acc[7][l];
            }
        }
    }
}

/// 1/2π, for phases in turns.
const INV_TAU: f64 = 1.0 / TAU;

impl FastWaves {
    fn new(waves: &[Wave]) -> Self {
        let f64s = |f: &dyn Fn(&Wave) -> f64| waves.iter().map(f).collect::<Vec<f64>>();
        let f32s = |f: &dyn Fn(&Wave) -> f64| waves.iter().map(|w| f(w) as f32).collect();
        let qak = |w: &Wave| w.steepness * w.amplitude * w.wavenumber;
        Self {
            kx: f64s(&|w| w.wavenumber * INV_TAU * w.direction.x),
            kz: f64s(&|w| w.wavenumber * INV_TAU * w.direction.y),
            a: f32s(&|w| w.amplitude),
            qadx: f32s(&|w| w.steepness * w.amplitude * w.direction.x),
            qadz: f32s(&|w| w.steepness * w.amplitude * w.direction.y),
            akdx: f32s(&|w| w.amplitude * w.wavenumber * w.direction.x),
            akdz: f32s(&|w| w.amplitude * w.wavenumber * w.direction.y),
            qakxx: f32s(&|w| qak(w) * w.direction.x * w.direction.x),
            qakxz: f32s(&|w| qak(w) * w.direction.x * w.direction.y),
            qakzz: f32s(&|w| qak(w) * w.direction.y * w.direction.y),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(q: f64) -> Wave {
        Wave::build(
            "w",
            1.0,
            20.0,
            [1.0, 0.0],
            0.0,
            None,
            q,
            &Dispersion::default(),
        )
        .unwrap()
    }

    #[test]
    fn derivatives_match_central_differences() {
        let w = Wave::build(
            "w",
            0.7,
            13.0,
            [0.3, -0.8],
            0.4,
            None,
            0.8,
            &Dispersion::default(),
        )
        .unwrap();
        let p = DVec2::new(3.1, -7.4);
        let t = 12.5;
        let mut s = SurfaceSample::default();
        w.accumulate(p, t, true, &mut s);
        let e = 1e-6;
        let at = |q: DVec2| {
            let mut o = SurfaceSample::default();
            w.accumulate(q, t, false, &mut o);
            o.displacement
        };
        let fx = (at(p + DVec2::X * e) - at(p - DVec2::X * e)) / (2.0 * e);
        let fz = (at(p + DVec2::Y * e) - at(p - DVec2::Y * e)) / (2.0 * e);
        assert!((fx - s.d_dx).length() < 1e-7, "{fx} vs {}", s.d_dx);
        assert!((fz - s.d_dz).length() < 1e-7, "{fz} vs {}", s.d_dz);
    }

    /// The Gerstner sign convention: points crowd towards the crest, so the crest (where the
    /// surface is highest) is narrower than the trough. On the displaced profile the part above
    /// mid-height spans θ ∈ (0, π), whose ends move by `Q·A·cos θ`, so its width is exactly
    /// `λ/2 − 2·Q·A` (and the trough's `λ/2 + 2·Q·A`). A flipped sign would swap them.
    #[test]
    fn single_gerstner_crest_is_sharper_than_trough() {
        let w = wave(0.9);
        let n = 20_000;
        let lambda = w.wavelength();
        let mut above = 0.0;
        let mut prev: Option<(f64, f64)> = None;
        for i in 0..=n {
            let x0 = lambda * i as f64 / n as f64;
            let mut s = SurfaceSample::default();
            w.accumulate(DVec2::new(x0, 0.0), 0.0, false, &mut s);
            let (x, y) = (x0 + s.displacement.x, s.displacement.y);
            if let Some((px, py)) = prev
                && y > 0.0
                && py > 0.0
            {
                above += x - px;
            }
            prev = Some((x, y));
        }
        let expect = 0.5 * lambda - 2.0 * 0.9 * 1.0;
        assert!(
            (above - expect).abs() < 1e-2,
            "crest width {above}, expected {expect}"
        );
        // And with Q = 0 (a sine) both halves are equal.
        let w0 = wave(0.0);
        let mut above0 = 0.0;
        for i in 0..n {
            let x0 = lambda * (i as f64 + 0.5) / n as f64;
            let mut s = SurfaceSample::default();
            w0.accumulate(DVec2::new(x0, 0.0), 0.0, false, &mut s);
            if s.displacement.y > 0.0 {
                above0 += lambda / n as f64;
            }
        }
        assert!((above0 - 0.5 * lambda).abs() < 1e-3 * lambda);
    }

    #[test]
    fn wave_travels_along_its_direction() {
        let w = wave(0.0);
        // A crest at x = x_c at t moves to x_c + c·dt at t + dt.
        let c = w.omega / w.wavenumber;
        let y = |x: f64, t: f64| {
            let mut s = SurfaceSample::default();
            w.accumulate(DVec2::new(x, 0.0), t, false, &mut s);
            s.displacement.y
        };
        for &(x, t) in &[(1.0, 0.0), (4.5, 3.0), (-2.0, 10.0)] {
            assert!((y(x, t) - y(x + c * 0.7, t + 0.7)).abs() < 1e-12);
        }
    }

    #[test]
    fn far_positions_and_huge_times_match_reference() {
        let w = wave(0.8);
        for &(x, z, t) in &[
            (1e7, -1e7, 0.0),
            (-9.9e6, 3.3e6, 1e9),
            (0.5, 0.5, 1e9 + 0.25),
        ] {
            let p = DVec2::new(x, z);
            let mut a = SurfaceSample::default();
            let mut b = SurfaceSample::default();
            w.accumulate(p, t, true, &mut a);
            w.accumulate_reference(p, t, &mut b);
            assert!(
                (a.displacement - b.displacement).length() < 1e-6,
                "{x} {z} {t}"
            );
        }
    }

    fn bits(s: &SurfaceSample) -> [u64; 9] {
        let v = [s.displacement, s.d_dx, s.d_dz];
        std::array::from_fn(|i| v[i / 3][i % 3].to_bits())
    }

    /// The block kernel must give the scalar path's bits in every lane, at any block size.
    #[test]
    fn block_kernel_is_bit_identical_to_scalar_path() {
        let d = Dispersion::default();
        let mut rng = crate::math::SwellRng::new(3, 1);
        let waves: Vec<Wave> = (0..23)
            .map(|i| {
                let ang = TAU * rng.uniform();
                Wave::build(
                    "w",
                    0.05 + rng.uniform(),
                    2.0 + 80.0 * rng.uniform(),
                    [ang.cos(), ang.sin()],
                    TAU * rng.uniform(),
                    None,
                    if i % 3 == 0 { 0.0 } else { rng.uniform() },
                    &d,
                )
                .unwrap()
            })
            .collect();
        let soa = WaveSoA::new(&waves);
        for &t in &[0.0, 17.25, 1e9 + 0.5] {
            let mut x = [0.0; BLOCK];
            let mut z = [0.0; BLOCK];
            for l in 0..BLOCK {
                let scale = [1.0, 100.0, 1e7][l % 3];
                x[l] = (2.0 * rng.uniform() - 1.0) * scale;
                z[l] = (2.0 * rng.uniform() - 1.0) * scale;
            }
            for derivs in [false, true] {
                let mut lanes = Lanes::<BLOCK>::default();
                soa.accumulate_lanes(&x, &z, t, derivs, &mut lanes);
                for l in 0..BLOCK {
                    let mut one = SurfaceSample::default();
                    accumulate_all(&waves, DVec2::new(x[l], z[l]), t, derivs, &mut one);
                    let mut single = Lanes::<1>::default();
                    soa.accumulate_lanes(&[x[l]], &[z[l]], t, derivs, &mut single);
                    assert_eq!(bits(&lanes.get(l)), bits(&one), "lane {l} t {t}");
                    assert_eq!(bits(&single.get(0)), bits(&one), "lane {l} t {t}");
                }
            }
        }
    }

    #[test]
    fn validation_names_fields() {
        let d = Dispersion::default();
        let e = Wave::build("waves[2]", -1.0, 1.0, [1.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "waves[2].amplitude");
        let e = Wave::build("w", 1.0, 0.0, [1.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.wavelength");
        let e = Wave::build("w", 1.0, 1.0, [0.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert!(matches!(e, SpecError::ZeroDirection { .. }));
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], f64::NAN, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.phase");
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], 0.0, Some(0.0), 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.speed");
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], 0.0, None, 1.5, &d).unwrap_err();
        assert_eq!(e.field(), "w.steepness");
    }

    /// The bounds are what keeps every answer finite: the most extreme waves they allow, 1,024
    /// of them (a layer's most), evaluated at the server's largest coordinates and times, give
    /// finite heights, displacements and slopes; one step past each bound is refused.
    #[test]
    fn the_most_extreme_allowed_waves_stay_finite() {
        let d = Dispersion::default();
        let extremes = [
            (MAX_AMPLITUDE, MIN_WAVELENGTH, MAX_PHASE, Some(MAX_SPEED)),
            (MAX_AMPLITUDE, MIN_WAVELENGTH, -MAX_PHASE, None),
            (MAX_AMPLITUDE, MAX_WAVELENGTH, MAX_PHASE, Some(MAX_SPEED)),
        ];
        for (a, l, phase, speed) in extremes {
            let w = Wave::build("w", a, l, [1.0, 1.0], phase, speed, 0.0, &d).unwrap();
            let waves = vec![w; crate::sine::MAX_WAVES_PER_LAYER];
            for (x, t) in [(1e9, 1e10), (-1e9, -1e10), (0.3, 0.0)] {
                let mut s = SurfaceSample::default();
                accumulate_all(&waves, DVec2::new(x, -x), t, true, &mut s);
                let v = [s.displacement, s.d_dx, s.d_dz];
                assert!(
                    v.iter().all(|c| c.is_finite()),
                    "{a} {l} {phase} at {x}, {t}: {s:?}"
                );
                assert!(s.normal().is_finite());
            }
        }
        let up = |v: f64| v * (1.0 + 1e-15) + f64::MIN_POSITIVE;
        let build = |a, l, phase, speed| Wave::build("w", a, l, [1.0, 0.0], phase, speed, 0.0, &d);
        assert_eq!(
            build(up(MAX_AMPLITUDE), 1.0, 0.0, None)
                .unwrap_err()
                .field(),
            "w.amplitude"
        );
        assert_eq!(
            build(1.0, MIN_WAVELENGTH * 0.999, 0.0, None)
                .unwrap_err()
                .field(),
            "w.wavelength"
        );
        assert_eq!(
            build(1.0, up(MAX_WAVELENGTH), 0.0, None)
                .unwrap_err()
                .field(),
            "w.wavelength"
        );
        assert_eq!(
            build(1.0, 1.0, -up(MAX_PHASE), None).unwrap_err().field(),
            "w.phase"
        );
        assert_eq!(
            build(1.0, 1.0, 0.0, Some(up(MAX_SPEED)))
                .unwrap_err()
                .field(),
            "w.speed"
        );
    }

    #[test]
    fn speed_override_sets_omega() {
        let d = Dispersion::default();
        let w = Wave::build("w", 1.0, 10.0, [1.0, 0.0], 0.0, Some(3.0), 0.0, &d).unwrap();
        assert!((w.omega - 3.0 * TAU / 10.0).abs() < 1e-15);
    }
}
