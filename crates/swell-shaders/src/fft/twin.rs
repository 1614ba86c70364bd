//! A CPU twin of the exported FFT passes: the evolve pass and the Stockham butterflies, with the
//! shaders' arithmetic in the shaders' order, generic over the float type. In f64 it checks the
//! algorithm (indices, signs, packing) against the model's own frames; in f32 it measures what
//! the f32 transform costs, apart from GPU trig (the browser test measures the whole).

use std::ops::{Add, Mul, Neg, Sub};

use swell_waves::fft::FftLayer;
use swell_waves::spectrum::Dispersion;

/// The float operations the passes use.
pub(crate) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn of(v: f64) -> Self;
    fn to(self) -> f64;
    /// `(sin 2πu, cos 2πu)`: the shaders' turn kernel in f32, exact trig in f64.
    fn sin_cos_turns(self) -> (Self, Self);
    fn floor(self) -> Self;
    fn round(self) -> Self;
    fn inv_sqrt(self) -> Self;
    fn div(self, o: Self) -> Self;
}

macro_rules! real {
    ($t:ty, $turns:path) => {
        impl Real for $t {
            fn of(v: f64) -> Self {
                v as $t
            }
            fn to(self) -> f64 {
                self as f64
            }
            fn sin_cos_turns(self) -> (Self, Self) {
                $turns(self)
            }
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            // WGSL's round is half to even.
            fn round(self) -> Self {
                <$t>::round_ties_even(self)
            }
            fn inv_sqrt(self) -> Self {
                1.0 / <$t>::sqrt(self)
            }
            fn div(self, o: Self) -> Self {
                self / o
            }
        }
    };
}
fn turns_f32(u: f32) -> (f32, f32) {
    super::sin_cos_turns(u)
}
fn turns_f64(u: f64) -> (f64, f64) {
    (std::f64::consts::TAU * u).sin_cos()
}
real!(f32, turns_f32);
real!(f64, turns_f64);

type C<R> = [R; 2];

fn fract<R: Real>(x: R) -> R {
    x - x.floor()
}

fn cmul<R: Real>(a: C<R>, b: C<R>) -> C<R> {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

fn pack<R: Real>(x: C<R>, y: C<R>) -> C<R> {
    [x[0] - y[1], x[1] + y[0]]
}

fn times_i<R: Real>(r: R, h: C<R>) -> C<R> {
    [-(r * h[1]), r * h[0]]
}

/// The eight grids of `layer` at `t`, node (i, j) at `[j·N + i]`, in `FftGrid` order (h, Dx, Dz,
/// ∂h/∂x, ∂h/∂z, ∂Dx/∂x, ∂Dz/∂z, ∂Dx/∂z), computed as the exported passes compute them in `R`.
pub(crate) fn frame<R: Real>(layer: &FftLayer, dispersion: &Dispersion, t: f64) -> [Vec<f64>; 8] {
    let n = layer.resolution();
    let records = crate::spectrum::records(layer, dispersion);
    let q_max = super::max_frequency_index(layer, dispersion);
    let bits = super::cycle_bits(0, q_max).unwrap();
    let c = super::cycle(t, layer.repeat_period(), bits);
    let dk = R::of(swell_waves::math::TAU / layer.tile_size());
    let lam = R::of(layer.choppiness());
    let zero = [R::of(0.0); 2];
    // Two "textures" of two complex values each: a = (z0, z1), b = (z2, z3).
    let mut a = vec![[zero; 2]; n * n];
    let mut b = vec![[zero; 2]; n * n];
    let rec = |i: usize, j: usize| records[j * n + i];
    for v in 0..n {
        for u in 0..n {
            let (ri, rj) = ((u + n / 2) & (n - 1), (v + n / 2) & (n - 1));
            let (mi, mj) = ((n - ri) & (n - 1), (n - rj) & (n - 1));
            let s0 = rec(ri, rj);
            let s1 = rec(mi, mj);
            let q = R::of(super::frequency_index(s0[2], layer.repeat_period()));
            let mut cyc = fract(q * R::of(c[0] as f64)) + fract(q * R::of(c[1] as f64));
            cyc = cyc - cyc.round() + q * R::of(c[2] as f64);
            let (sn, cs) = (cyc - cyc.round()).sin_cos_turns();
            let (aa, bb, p, pq) = (R::of(s0[0]), R::of(s0[1]), R::of(s1[0]), R::of(s1[1]));
            let h = [
                (aa * cs + bb * sn) + (p * cs + pq * sn),
                (bb * cs - aa * sn) + (p * sn - pq * cs),
            ];
            let kx = R::of(ri as f64 - (n / 2) as f64) * dk;
            let kz = R::of(rj as f64 - (n / 2) as f64) * dk;
            let k2 = kx * kx + kz * kz;
            if k2.to() == 0.0 {
                continue;
            }
            let ik = k2.inv_sqrt();
            let dx = times_i(lam * kx * ik, h);
            let dz = times_i(lam * kz * ik, h);
            let sx = times_i(kx, h);
            let sz = times_i(kz, h);
            let sc = |r: R| [r * h[0], r * h[1]];
            let jxx = sc(-(lam * kx * kx * ik));
            let jzz = sc(-(lam * kz * kz * ik));
            let jxz = sc(-(lam * kx * kz * ik));
            a[v * n + u] = [pack(dx, h), pack(dz, jxx)];
            b[v * n + u] = [pack(sx, sz), pack(jzz, jxz)];
        }
    }
    for axis in 0..2 {
        let mut ns = 1;
        while ns < n {
            let (mut a2, mut b2) = (a.clone(), b.clone());
            for y in 0..n {
                for x0 in 0..n {
                    let x = if axis == 0 { x0 } else { y };
                    let k = x & (ns - 1);
                    let j = (x / (2 * ns)) * ns + k;
                    let (ia, ib) = if axis == 0 {
                        (y * n + j, y * n + j + n / 2)
                    } else {
                        (j * n + x0, (j + n / 2) * n + x0)
                    };
                    let (sn, cs) = R::of(k as f64).div(R::of((2 * ns) as f64)).sin_cos_turns();
                    let w = [cs, sn];
                    let sign = R::of(if x & ns != 0 { -1.0 } else { 1.0 });
                    let out = y * n + x0;
                    for (src, dst) in [(&a, &mut a2), (&b, &mut b2)] {
                        for z in 0..2 {
                            let wb = cmul(w, src[ib][z]);
                            dst[out][z] =
                                [src[ia][z][0] + sign * wb[0], src[ia][z][1] + sign * wb[1]];
                        }
                    }
                }
            }
            (a, b) = (a2, b2);
            ns *= 2;
        }
    }
    let g = |f: &dyn Fn(usize) -> R| (0..n * n).map(|i| f(i).to()).collect::<Vec<f64>>();
    // a = (Dx, h, Dz, ∂Dx/∂x), b = (∂h/∂x, ∂h/∂z, ∂Dz/∂z, ∂Dx/∂z).
    [
        g(&|i| a[i][0][1]),
        g(&|i| a[i][0][0]),
        g(&|i| a[i][1][0]),
        g(&|i| b[i][0][0]),
        g(&|i| b[i][0][1]),
        g(&|i| a[i][1][1]),
        g(&|i| b[i][1][0]),
        g(&|i| b[i][1][1]),
    ]
}
