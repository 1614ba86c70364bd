//! Which of the eight real FFT fields a frame computes, and how each is made from h̃(k, t).

use rustfft::num_complex::Complex;

/// A set of FFT output fields; a frame computes only the fields in its set.
///
/// Each flag stands for one or more real grids (see [`FftGrid`]), and each grid costs one 2-D
/// inverse real transform: `HEIGHT` 1, `DISPLACEMENT` 2, `SLOPES` 2, `JACOBIAN` 3, `ALL` 8.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct FftFields {
    /// Height h (one grid).
    pub height: bool,
    /// Horizontal displacement Dx, Dz (two grids).
    pub displacement: bool,
    /// Slopes ∂h/∂x, ∂h/∂z (two grids).
    pub slopes: bool,
    /// Jacobian terms ∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z (three grids).
    pub jacobian: bool,
}

impl FftFields {
    /// No field at all: a frame with nothing in it costs no transform.
    pub const NONE: Self = Self {
        height: false,
        displacement: false,
        slopes: false,
        jacobian: false,
    };
    /// Height only.
    pub const HEIGHT: Self = Self {
        height: true,
        ..Self::NONE
    };
    /// Horizontal displacement only.
    pub const DISPLACEMENT: Self = Self {
        displacement: true,
        ..Self::NONE
    };
    /// Slopes only.
    pub const SLOPES: Self = Self {
        slopes: true,
        ..Self::NONE
    };
    /// Jacobian terms only.
    pub const JACOBIAN: Self = Self {
        jacobian: true,
        ..Self::NONE
    };
    /// All eight grids.
    pub const ALL: Self = Self {
        height: true,
        displacement: true,
        slopes: true,
        jacobian: true,
    };

    /// The fields in either set.
    #[must_use]
    pub const fn union(self, other: Self) -> Self {
        Self {
            height: self.height || other.height,
            displacement: self.displacement || other.displacement,
            slopes: self.slopes || other.slopes,
            jacobian: self.jacobian || other.jacobian,
        }
    }

    /// Whether every field of `other` is in `self`.
    pub const fn contains(self, other: Self) -> bool {
        (self.height || !other.height)
            && (self.displacement || !other.displacement)
            && (self.slopes || !other.slopes)
            && (self.jacobian || !other.jacobian)
    }

    /// Whether the set holds the given grid.
    pub const fn has(self, grid: FftGrid) -> bool {
        match grid {
            FftGrid::Height => self.height,
            FftGrid::DisplacementX | FftGrid::DisplacementZ => self.displacement,
            FftGrid::SlopeX | FftGrid::SlopeZ => self.slopes,
            FftGrid::DxDx | FftGrid::DzDz | FftGrid::DxDz => self.jacobian,
        }
    }

    /// Number of real grids, i.e. of 2-D inverse transforms a frame with these fields costs.
    pub fn grid_count(self) -> usize {
        FftGrid::ALL.iter().filter(|&&g| self.has(g)).count()
    }
}

impl std::ops::BitOr for FftFields {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        self.union(rhs)
    }
}

/// One of the eight real grids of an FFT frame, and the multiplier c(k) that makes its spectrum
/// from the height spectrum: grid(x) = Σ_k c(k)·h̃(k, t)·e^{i k·x}.
///
/// With λ the choppiness, k = (kx, kz), k = |k|:
///
/// | grid | c(k) | single wave h = A sin θ |
/// |---|---|---|
/// | `Height` h | 1 | A sin θ |
/// | `DisplacementX` Dx | i·λ·kx/k | λ·A·k̂x·cos θ |
/// | `DisplacementZ` Dz | i·λ·kz/k | λ·A·k̂z·cos θ |
/// | `SlopeX` ∂h/∂x | i·kx | A·kx·cos θ |
/// | `SlopeZ` ∂h/∂z | i·kz | A·kz·cos θ |
/// | `DxDx` ∂Dx/∂x | −λ·kx²/k | −λ·A·kx²/k·sin θ |
/// | `DzDz` ∂Dz/∂z | −λ·kz²/k | −λ·A·kz²/k·sin θ |
/// | `DxDz` ∂Dx/∂z (= ∂Dz/∂x) | −λ·kx·kz/k | −λ·A·kx·kz/k·sin θ |
///
/// The displacement sign gives the Gerstner shape of the crate's convention
/// (`x = x0 + Q·A·d·cos θ`, `y = A sin θ`): points crowd together under crests. Every c(k)
/// satisfies c(−k) = conj(c(k)), so every grid is real. The horizontal Jacobian of the displaced
/// surface is `(1 + DxDx)·(1 + DzDz) − DxDz²`; it is negative where the surface folds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FftGrid {
    /// Height h, m.
    Height,
    /// Horizontal displacement along x, m.
    DisplacementX,
    /// Horizontal displacement along z, m.
    DisplacementZ,
    /// Slope ∂h/∂x (dimensionless).
    SlopeX,
    /// Slope ∂h/∂z (dimensionless).
    SlopeZ,
    /// Jacobian term ∂Dx/∂x (dimensionless).
    DxDx,
    /// Jacobian term ∂Dz/∂z (dimensionless).
    DzDz,
    /// Jacobian term ∂Dx/∂z = ∂Dz/∂x (dimensionless).
    DxDz,
}

impl FftGrid {
    /// The eight grids, in the order a frame computes them.
    pub const ALL: [FftGrid; 8] = [
        FftGrid::Height,
        FftGrid::DisplacementX,
        FftGrid::DisplacementZ,
        FftGrid::SlopeX,
        FftGrid::SlopeZ,
        FftGrid::DxDx,
        FftGrid::DzDz,
        FftGrid::DxDz,
    ];

    /// Position in [`FftGrid::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// `c(k)·h` for wave vector `(kx, kz)` with `inv_k = 1/|k|` and choppiness `lambda`.
    ///
    /// Bit-level recipe (so other implementations round identically): the real factor `r` is
    /// formed left to right as written in the table (`lambda * kx * inv_k`, `kx`,
    /// `-(lambda * kx * kx * inv_k)`, …, see [`FftGrid::factor`]); a real c = r gives
    /// `(r·h.re, r·h.im)` and an imaginary c = i·r gives `(−(r·h.im), r·h.re)`. No general
    /// complex product is formed.
    #[inline]
    pub(crate) fn apply(
        self,
        kx: f64,
        kz: f64,
        inv_k: f64,
        lambda: f64,
        h: Complex<f64>,
    ) -> Complex<f64> {
        match self {
            FftGrid::Height => h,
            _ => self.apply_factor(self.factor(kx, kz, inv_k, lambda), h),
        }
    }

    /// The real factor r of c(k): c = i·r for the displacement and slope grids, c = r for the
    /// Jacobian grids, formed exactly as [`FftGrid::apply`] documents; 1 for `Height`.
    #[inline]
    pub(crate) fn factor(self, kx: f64, kz: f64, inv_k: f64, lambda: f64) -> f64 {
        match self {
            FftGrid::Height => 1.0,
            FftGrid::DisplacementX => lambda * kx * inv_k,
            FftGrid::DisplacementZ => lambda * kz * inv_k,
            FftGrid::SlopeX => kx,
            FftGrid::SlopeZ => kz,
            FftGrid::DxDx => -(lambda * kx * kx * inv_k),
            FftGrid::DzDz => -(lambda * kz * kz * inv_k),
            FftGrid::DxDz => -(lambda * kx * kz * inv_k),
        }
    }

    /// Whether c(k) is imaginary (c = i·r): the displacement and slope grids.
    #[inline]
    pub(crate) const fn is_imaginary(self) -> bool {
        matches!(
            self,
            FftGrid::DisplacementX | FftGrid::DisplacementZ | FftGrid::SlopeX | FftGrid::SlopeZ
        )
    }

    /// `c·h` from the factor r of [`FftGrid::factor`] (not for `Height`): `(−(r·h.im), r·h.re)`
    /// if c is imaginary, else `(r·h.re, r·h.im)`.
    #[inline]
    fn apply_factor(self, r: f64, h: Complex<f64>) -> Complex<f64> {
        if self.is_imaginary() {
            Complex::new(-(r * h.im), r * h.re)
        } else {
            Complex::new(r * h.re, r * h.im)
        }
    }

    /// [`FftGrid::apply`] over one half-plane column (fixed m), the multiplier pass of frames
    /// and velocity frames: `out[i] = c(k_i)·h[i]`, the wave vector read from its parts — `kx`
    /// for the whole column, `kz[i]` per row (`q·Δk`, the same in every column) and
    /// `inv_k[i] = 1/|k|`, which the layer stores as 0 for an empty entry. For a kept entry these
    /// are exactly the mode's `kx`, `kz`, `1/|k|`, so the bits are `apply`'s; an empty entry
    /// (a mode stored as k = 0, 1/|k| = 0, h = 0) gets the constant `apply(0, 0, 0, λ, 0)` by a
    /// select. The match on the grid is taken once, outside the loop (inside, it costs an
    /// indirect jump per entry and blocks vectorisation).
    #[inline(always)]
    pub(crate) fn apply_column(
        self,
        kx: f64,
        kz: &[f64],
        inv_k: &[f64],
        lambda: f64,
        h: &[Complex<f64>],
        out: &mut [Complex<f64>],
    ) {
        #[inline(always)]
        fn run(
            g: FftGrid,
            kx: f64,
            kz: &[f64],
            inv_k: &[f64],
            lambda: f64,
            h: &[Complex<f64>],
            out: &mut [Complex<f64>],
        ) {
            let zero = Complex::new(0.0, 0.0);
            let empty = g.apply(0.0, 0.0, 0.0, lambda, zero);
            let n = out.len();
            let (kz, inv_k, h) = (&kz[..n], &inv_k[..n], &h[..n]);
            for i in 0..n {
                let v = g.apply_factor(g.factor(kx, kz[i], inv_k[i], lambda), h[i]);
                out[i] = if inv_k[i] == 0.0 { empty } else { v };
            }
        }
        match self {
            FftGrid::Height => out.copy_from_slice(h),
            FftGrid::DisplacementX => run(FftGrid::DisplacementX, kx, kz, inv_k, lambda, h, out),
            FftGrid::DisplacementZ => run(FftGrid::DisplacementZ, kx, kz, inv_k, lambda, h, out),
            FftGrid::SlopeX => run(FftGrid::SlopeX, kx, kz, inv_k, lambda, h, out),
            FftGrid::SlopeZ => run(FftGrid::SlopeZ, kx, kz, inv_k, lambda, h, out),
            FftGrid::DxDx => run(FftGrid::DxDx, kx, kz, inv_k, lambda, h, out),
            FftGrid::DzDz => run(FftGrid::DzDz, kx, kz, inv_k, lambda, h, out),
            FftGrid::DxDz => run(FftGrid::DxDz, kx, kz, inv_k, lambda, h, out),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SwellRng;

    /// The column form must give `apply`'s bits for every grid (it is the frames' hot loop),
    /// empty entries included.
    #[test]
    fn apply_column_equals_apply_bit_for_bit() {
        let mut rng = SwellRng::new(5, 0);
        let n = 257;
        let kx = rng.gaussian_pair().0.abs();
        let (mut kz, mut inv_k, mut h) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..n {
            let (z, _) = rng.gaussian_pair();
            let (a, b) = rng.gaussian_pair();
            kz.push(z);
            inv_k.push(1.0 / (kx * kx + z * z).sqrt());
            h.push(Complex::new(a, b));
        }
        // Empty entries as the layer stores them: 1/|k| = 0 and h = 0 (the mode's k is 0).
        for i in [3, 4] {
            inv_k[i] = 0.0;
            h[i] = Complex::new(0.0, 0.0);
        }
        let mut out = vec![Complex::new(0.0, 0.0); n];
        for grid in FftGrid::ALL {
            for lambda in [0.0, 1.0, 1.3] {
                grid.apply_column(kx, &kz, &inv_k, lambda, &h, &mut out);
                for i in 0..n {
                    let want = if inv_k[i] == 0.0 {
                        grid.apply(0.0, 0.0, 0.0, lambda, h[i])
                    } else {
                        grid.apply(kx, kz[i], inv_k[i], lambda, h[i])
                    };
                    assert_eq!(
                        (out[i].re.to_bits(), out[i].im.to_bits()),
                        (want.re.to_bits(), want.im.to_bits()),
                        "{grid:?} {i}"
                    );
                }
            }
        }
    }
}
