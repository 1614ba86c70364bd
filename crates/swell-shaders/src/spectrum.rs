//! The binary export of an FFT layer: its initial spectrum h0(k) and quantised ω(k), exactly as
//! the model draws them, so a GPU client runs the evolution and inverse FFT itself.
//!
//! # Format (`swell-spectrum/1`)
//!
//! | bytes | content |
//! |---|---|
//! | 0..4 | magic `SWSP` |
//! | 4..8 | u32 little-endian: H, the header's length in bytes |
//! | 8..8+H | the header, UTF-8 JSON (fields below) |
//! | … | zero bytes up to `data_offset` (a multiple of 8) |
//! | data_offset.. | N·N records of three f64 little-endian: `h0.re`, `h0.im`, `omega` |
//!
//! Record (i, j), for i, j in 0..N, is at `data_offset + 24·(j·N + i)` and holds the mode
//! `(m, n) = (i − N/2, j − N/2)`, wave vector `k = (2π/L)·(m, n)` (rad/m, x and z): `h0(k)` in
//! metres and `ω_q(|k|)` in rad/s. Row and column 0 (m or n = −N/2, the Nyquist modes) and the
//! centre (k = 0) are zero, as are modes outside the layer's band (h0 = 0; their ω is still
//! written).
//!
//! # Conventions (the model's, `swell_waves::fft`)
//! - `ω_q = floor(ω(|k|)/ω0)·ω0`, `ω0 = 2π/T`, `ω(k) = sqrt(g·k·tanh(k·h))` (deep: `sqrt(g·k)`):
//!   the sea repeats exactly every T s. Reduce t modulo T in f64 before forming `ω_q·t`.
//! - `h̃(k, t) = h0(k)·e^{−iω_q t} + conj(h0(−k))·e^{+iω_q t}` (the h0(k) part travels along +k,
//!   phase `k·x − ω·t`, as Gerstner waves do).
//! - Height `h(x, t) = Σ_k h̃(k, t)·e^{i k·x}` over every record, **unnormalised** (no 1/N²: h0
//!   carries the physical amplitude). Equivalently `h = Σ_k 2·Re[h0(k)·e^{i(k·x − ω_q t)}]`.
//! - Horizontal displacement `D = Σ_k i·λ·(k/|k|)·h̃·e^{i k·x}` (λ = `choppiness`; a point moves
//!   towards crests: sharp crests), slopes `∂h/∂x = Σ_k i·k_x·h̃·e^{i k·x}` (z likewise).
//! - Time grid: the server's default answers (`accuracy.time = "grid"`) read the frames at
//!   `t_n = n·time_step` around t and interpolate linearly (header `time_step`, `grid_steps`,
//!   `swell_waves::fft` step 7); a client evaluating at t itself matches `"exact"`, a few tenths
//!   of a millimetre away.
//! - The tile is periodic with side L: sample at `x mod L`. Grid node (i, j) of an inverse FFT
//!   of size N is the point `(i·L/N, j·L/N)`.

use glam::DVec2;
use swell_waves::fft::FftLayer;
use swell_waves::spectrum::Dispersion;
use swell_waves::{Layer, Surface};

use crate::error::ShaderError;

/// Bytes per record: three f64.
pub const RECORD_BYTES: usize = 24;

/// The format name in the header.
pub const FORMAT: &str = "swell-spectrum/1";

/// Who the export is for, written into the header (the server fills these in).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumMeta {
    /// Scene id.
    pub scene: String,
    /// The scene's spec hash.
    pub spec_hash: String,
    /// The layer's resolved seed.
    pub seed: u64,
}

/// One record: `[h0.re, h0.im, ω_q]`.
pub type Record = [f64; 3];

/// The records of `layer` (see the [module docs](self)): N·N, record (i, j) at `j·N + i`.
///
/// h0 comes from [`FftLayer::h0`]; ω_q is formed as the model forms it when it builds the layer
/// (`dispersion.omega(|k|)`, `|k|` of the f64 vector `(m·Δk, n·Δk)`, then `floor(ω/ω0)·ω0`), so
/// both are the model's bits.
pub fn records(layer: &FftLayer, dispersion: &Dispersion) -> Vec<Record> {
    let n = layer.resolution();
    let h = (n / 2) as i32;
    let dk = swell_waves::math::TAU / layer.tile_size();
    let omega0 = swell_waves::math::TAU / layer.repeat_period();
    let mut out = vec![[0.0; 3]; n * n];
    for j in 0..n {
        for i in 0..n {
            let (m, q) = (i as i32 - h, j as i32 - h);
            if m == -h || q == -h || (m, q) == (0, 0) {
                continue;
            }
            let len = DVec2::new(f64::from(m) * dk, f64::from(q) * dk).length();
            let omega = (dispersion.omega(len) / omega0).floor() * omega0;
            let h0 = layer.h0(m, q);
            out[j * n + i] = [h0.re, h0.im, omega];
        }
    }
    out
}

/// The FFT layer at index `layer` of `surface`.
///
/// # Errors
/// [`ShaderError::BadLayer`] when there is no such layer or it is not an FFT layer.
pub fn fft_layer(surface: &Surface, layer: usize) -> Result<&FftLayer, ShaderError> {
    match surface.layers().get(layer) {
        Some(Layer::Fft(f)) => Ok(f),
        Some(other) => Err(ShaderError::BadLayer {
            layer,
            reason: format!(
                "is a {} layer; only FFT layers have a spectrum (its waves are in the scene detail and the shader)",
                match other {
                    Layer::Sine(_) => "sine",
                    _ => "gerstner",
                }
            ),
        }),
        None => Err(ShaderError::BadLayer {
            layer,
            reason: format!(
                "out of range: the surface has {} layers (0..{})",
                surface.layers().len(),
                surface.layers().len()
            ),
        }),
    }
}

/// The whole export of layer `index` of `surface`: magic, header, padding, records.
///
/// # Errors
/// As [`fft_layer`].
pub fn export(
    surface: &Surface,
    index: usize,
    meta: &SpectrumMeta,
) -> Result<Vec<u8>, ShaderError> {
    let layer = fft_layer(surface, index)?;
    let dispersion = surface.dispersion();
    let n = layer.resolution();
    let records = records(layer, &dispersion);
    // The header's length decides the data offset, which the header states: the offset is
    // rounded up to a multiple of 64 with room for its own digits, so one pass suffices.
    let header = |data_offset: usize| {
        serde_json::json!({
            "format": FORMAT,
            "scene": meta.scene,
            "spec_hash": meta.spec_hash,
            "model_version": swell_waves::MODEL_VERSION,
            "layer": index,
            "seed": meta.seed.to_string(),
            "resolution": n,
            "tile_size": layer.tile_size(),
            "choppiness": layer.choppiness(),
            "repeat_period": layer.repeat_period(),
            "time_step": layer.time_step(),
            "grid_steps": layer.grid_steps(),
            "time_sampling": "the server's default answers read frames at grid times t_n = n*time_step (n in 0..grid_steps, t reduced modulo repeat_period), linear in time between the two around t: a + (b - a)*w, w = (t_r - t_n)/time_step; a client evaluating at t itself matches accuracy.time = exact",
            "gravity": dispersion.gravity,
            "depth": dispersion.depth,
            "modes": layer.modes(),
            "variance": layer.variance(),
            "data_offset": data_offset,
            "record_count": n * n,
            "record_bytes": RECORD_BYTES,
            "record_fields": ["h0_re", "h0_im", "omega"],
            "dtype": "f64-le",
            "index": "record (i, j) at data_offset + 24*(j*N + i); mode (m, n) = (i - N/2, j - N/2); k = (2*pi/tile_size)*(m, n) rad/m along (x, z)",
            "omega": "omega_q = floor(omega(|k|)/omega0)*omega0, omega0 = 2*pi/repeat_period, omega(k) = sqrt(g*k*tanh(k*depth)) (deep: sqrt(g*k)); reduce t modulo repeat_period first",
            "evolution": "htilde(k,t) = h0(k)*exp(-i*omega*t) + conj(h0(-k))*exp(+i*omega*t)",
            "normalisation": "unnormalised inverse sums: h(x,t) = sum_k htilde(k,t)*exp(i*k.x), no 1/N^2; h0 carries metres",
            "displacement": "D(x,t) = sum_k i*choppiness*(k/|k|)*htilde*exp(i*k.x) (x and z), added to the undisplaced point",
            "slopes": "dh/dx = sum_k i*k_x*htilde*exp(i*k.x), dh/dz likewise",
            "axes": "right-handed, y up, sea in x/z; the tile is periodic with side tile_size",
        })
        .to_string()
    };
    let probe = header(0).len() + 8 + 16;
    let data_offset = (8 + probe).div_ceil(64) * 64;
    let text = header(data_offset);
    debug_assert!(8 + text.len() <= data_offset);
    let mut out = Vec::with_capacity(data_offset + records.len() * RECORD_BYTES);
    out.extend_from_slice(b"SWSP");
    // The header is a few kilobytes at most, far below u32::MAX.
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out.resize(data_offset, 0);
    for r in &records {
        for v in r {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}
