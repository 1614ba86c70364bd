//! The wave-particle kernel: one smooth, compact bump.
//!
//! A particle of amplitude `a` and radius `r` centred at `c` raises the surface at `x` by
//!
//! ```text
//! K(x) = a·(1 − q²)³   for q² = |x − c|²/r² < 1,   0 beyond
//! ∇K(x) = −6·a·(1 − q²)²·(x − c)/r²
//! ```
//!
//! (the "poly6" kernel). Why this one: it is a polynomial in `|x − c|²`, so neither the value nor
//! the gradient needs a square root or any trigonometry (cheap, and bit-identical everywhere,
//! on the CPU and as plain `*`/`+` in a shader); it is C² at the rim (value, slope and curvature
//! all reach zero at q = 1, so normals have no crease there) and smooth at the centre. Its shape
//! is close to Yuksel's raised cosine `½(1 + cos πq)`: both have half their height at q ≈ 0.5.
//! Its integrals, used by the docs and the accuracy report: over the plane `π·a·r²/4`; along a
//! line through the centre `32/35·a·r`.

use glam::DVec2;

/// Height and gradient of one particle of amplitude `a`, for the offset `delta = x − c` and
/// `inv_r2 = 1/r²`: `(a·w³, −6·a·w²·delta/r²)` with `w = 1 − |delta|²/r²`, or `None` outside the
/// support (`|delta| ≥ r`), where both are exactly zero.
///
/// The operations and their order are part of the model (every path that sums particles calls
/// this): `q2 = (dx·dx + dz·dz)·inv_r2`, `w = 1 − q2`, `w2 = w·w`, height `a·(w2·w)`, gradient
/// `(−6·a·w2·inv_r2)·delta`.
#[inline(always)]
pub fn kernel(a: f64, delta: DVec2, inv_r2: f64) -> Option<(f64, DVec2)> {
    let q2 = (delta.x * delta.x + delta.y * delta.y) * inv_r2;
    if q2 >= 1.0 {
        return None;
    }
    let w = 1.0 - q2;
    let w2 = w * w;
    let g = -6.0 * a * w2 * inv_r2;
    Some((a * (w2 * w), DVec2::new(g * delta.x, g * delta.y)))
}

/// Height only of [`kernel`] (the same bits as its first value).
#[inline(always)]
pub fn kernel_height(a: f64, delta: DVec2, inv_r2: f64) -> f64 {
    kernel(a, delta, inv_r2).map_or(0.0, |(h, _)| h)
}

/// The area integral of one kernel of amplitude `a` and radius `r`: `π·a·r²/4`, m³.
pub fn kernel_volume(a: f64, r: f64) -> f64 {
    std::f64::consts::PI * a * r * r / 4.0
}

/// The integral of one kernel of amplitude `a` and radius `r` along a straight line through its
/// centre: `32/35·a·r`, m². A line of particles spaced `s` apart (s ≤ r) is about this divided by
/// `s` high.
pub fn kernel_line_integral(a: f64, r: f64) -> f64 {
    32.0 / 35.0 * a * r
}
