//! The sea as a body sees it: height and water velocity above a world point, with the body's
//! wavelength filter applied to analytic layers.
//!
//! This path always evaluates in f64, one wave at a time ([`crate::wave::Wave::accumulate`]),
//! whatever the snapshot's [`crate::Precision`]: bodies are stepped in f64 on every replica.
//! With no filter (`min_wavelength = 0`) it reproduces the plain queries bit for bit at
//! [`crate::Precision::F64`]; under [`crate::Precision::F32`] the plain queries take the
//! single-precision path and differ from it by that path's error (about 10⁻⁶ of the amplitudes).

use glam::{DVec2, DVec3};

use crate::query::InversionMethod;
use crate::surface::{Layer, SurfaceAt};
use crate::velocity::keeps;
use crate::wave::SurfaceSample;

/// Height and velocity of the water at one world point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaterPoint {
    /// Surface elevation above the world point, m.
    pub height: f64,
    /// Velocity of the surface particle there, m/s.
    pub velocity: DVec3,
    /// The undisplaced point whose particle is above the world point (the inversion's answer;
    /// the world point itself on a surface without horizontal motion), m.
    pub source: DVec2,
    /// The derivatives of the displacement at `source` from the inversion's best round (zero
    /// where it took none: fixed-point steps, no horizontal motion); only `d_dx` and `d_dz` are
    /// meaningful. A body predicts its next substep's start from them.
    pub(crate) derivatives: SurfaceSample,
}

impl WaterPoint {
    /// All zero (an array's filler before its lanes are written).
    const ZERO: WaterPoint = WaterPoint {
        height: 0.0,
        velocity: DVec3::ZERO,
        source: DVec2::ZERO,
        derivatives: SurfaceSample {
            displacement: DVec3::ZERO,
            d_dx: DVec3::ZERO,
            d_dz: DVec3::ZERO,
        },
    };
}

impl SurfaceAt<'_> {
    /// [`SurfaceAt::sample`] leaving out analytic (sine and Gerstner) waves shorter than
    /// `min_wavelength`, m, and particles narrower than it (`4r < min_wavelength`); FFT layers
    /// are never filtered. Always f64 (see the module docs):
    /// `min_wavelength = 0` gives exactly the bits of [`SurfaceAt::sample`] on a
    /// [`crate::Precision::F64`] snapshot, not on an `F32` one.
    pub fn sample_filtered(
        &self,
        p0: DVec2,
        derivatives: bool,
        min_wavelength: f64,
    ) -> SurfaceSample {
        let reads = crate::fft::FftReads::every(derivatives);
        self.sample_filtered_reads(p0, reads, min_wavelength)
    }

    /// [`SurfaceAt::sample_filtered`] reading FFT layers as `reads` says (derivatives unless
    /// `Displacement`; an inversion round reads `Newton`).
    fn sample_filtered_reads(
        &self,
        p0: DVec2,
        reads: crate::fft::FftReads,
        min_wavelength: f64,
    ) -> SurfaceSample {
        let derivatives = reads != crate::fft::FftReads::Displacement;
        let mut out = SurfaceSample::default();
        for (i, (layer, frame)) in self.surface.layers().iter().zip(&self.frames).enumerate() {
            match layer {
                Layer::Particles(p) => {
                    if let Some(field) = self.particle_field(i) {
                        let (h, g) = field.sample(p, p0, min_wavelength);
                        out.displacement.y += h;
                        if derivatives {
                            out.d_dx.y += g.x;
                            out.d_dz.y += g.y;
                        }
                    }
                }
                Layer::Sine(_) | Layer::Gerstner(_) => {
                    for w in layer.waves() {
                        if keeps(w, min_wavelength) {
                            w.accumulate(p0, self.t, derivatives, &mut out);
                        }
                    }
                }
                Layer::Fft(f) => {
                    let s = self.fft_sample(f, frame, p0, reads);
                    out.displacement += s.displacement;
                    if derivatives {
                        out.d_dx += DVec3::new(s.jacobian.x, s.slope.x, s.jacobian.z);
                        out.d_dz += DVec3::new(s.jacobian.z, s.slope.y, s.jacobian.y);
                    }
                }
            }
        }
        out
    }

    /// Height and water velocity above world `(x, z)` with analytic waves shorter than
    /// `min_wavelength` left out: solves `p0 + D(p0) = world` on the filtered surface with the
    /// snapshot's inversion settings (the same iteration as [`SurfaceAt::invert`]: best iterate
    /// kept, Newton falling back to a fixed-point step where the Jacobian is singular), then
    /// reads the elevation and the particle velocity at the source point.
    /// `min_wavelength = 0` gives the same height bits as [`SurfaceAt::height`] on a
    /// [`crate::Precision::F64`] snapshot (not on an `F32` one, see the module docs), NaN
    /// included: a point whose first iterate is already non-finite answers NaN, as `height`
    /// does, so a body's step sees it and is rolled back instead of reading calm water.
    pub fn water_at(&self, world: DVec2, min_wavelength: f64) -> WaterPoint {
        self.water_at_from(world, world, min_wavelength)
    }

    /// [`SurfaceAt::water_at`] with the inversion started from `start` instead of the world
    /// point itself: a body passes where its cell's source was a substep ago, a few millimetres
    /// from the answer, which saves a Newton round. The answer is the same solution within the
    /// tolerance, not the same bits as a cold start.
    pub fn water_at_from(&self, world: DVec2, start: DVec2, min_wavelength: f64) -> WaterPoint {
        let (source, height, derivatives) = if self.surface.has_horizontal_motion() {
            self.invert_filtered(world, start, min_wavelength)
        } else {
            let s = self.sample_filtered(world, false, min_wavelength);
            (world, s.displacement.y, SurfaceSample::default())
        };
        WaterPoint {
            height,
            velocity: self.velocity_filtered(source, min_wavelength),
            source,
            derivatives,
        }
    }

    /// The source point and its elevation. Keeps the best iterate exactly as
    /// [`SurfaceAt::invert_lanes`] does: the first one always (even a NaN one, so a NaN is
    /// reported rather than replaced by a made-up 0), then any with a lower residual.
    fn invert_filtered(
        &self,
        target: DVec2,
        start: DVec2,
        min_wavelength: f64,
    ) -> (DVec2, f64, SurfaceSample) {
        let inv = self.options.inversion;
        let newton = inv.method == InversionMethod::Newton;
        let mut p = start;
        let (mut best, mut best_s, mut best_r) = (start, SurfaceSample::default(), f64::INFINITY);
        let mut it = 0;
        let reads = if newton {
            crate::fft::FftReads::Newton
        } else {
            crate::fft::FftReads::Displacement
        };
        loop {
            let s = self.sample_filtered_reads(p, reads, min_wavelength);
            let f = p + DVec2::new(s.displacement.x, s.displacement.z) - target;
            let r = f.length();
            if it == 0 || r < best_r {
                (best, best_s, best_r) = (p, s, r);
            }
            if r <= inv.tolerance || it >= inv.iterations || !r.is_finite() {
                break;
            }
            let step = crate::query::inversion_step(&s, f, newton);
            p -= step;
            it += 1;
        }
        (best, best_s.displacement.y, best_s)
    }

    /// [`SurfaceAt::water_at`] for `B` world points at once, bit-identical per lane: when the
    /// filter keeps every analytic wave and the snapshot is [`crate::Precision::F64`], the
    /// heights come from the vectorised [`SurfaceAt::invert_lanes`] (the same iteration and
    /// best-iterate rule, lane by lane), and so do the analytic layers' velocities when those
    /// layers come first (taken from the best round's `sin_cos`, in the order
    /// [`SurfaceAt::velocity_filtered`] sums them; other layers' velocities are added per point
    /// after); otherwise each lane is [`SurfaceAt::water_at`].
    #[inline(always)]
    pub fn water_lanes<const B: usize>(
        &self,
        worlds: &[DVec2; B],
        min_wavelength: f64,
    ) -> [WaterPoint; B] {
        self.water_lanes_from(worlds, worlds, min_wavelength)
    }

    /// [`SurfaceAt::water_lanes`] with each lane's inversion started from `starts[l]`: lane by
    /// lane the bits of [`SurfaceAt::water_at_from`].
    #[inline(always)]
    pub fn water_lanes_from<const B: usize>(
        &self,
        worlds: &[DVec2; B],
        starts: &[DVec2; B],
        min_wavelength: f64,
    ) -> [WaterPoint; B] {
        // The filter also drops particles narrower than `min_wavelength` (see
        // `sample_filtered`): with particles, only no filter at all is the plain sea.
        let unfiltered = self.options.precision == crate::Precision::F64
            && (min_wavelength == 0.0 || !self.surface.has_particles())
            && self
                .surface
                .layers()
                .iter()
                .all(|l| l.waves().iter().all(|w| keeps(w, min_wavelength)));
        if !unfiltered {
            return std::array::from_fn(|l| {
                self.water_at_from(worlds[l], starts[l], min_wavelength)
            });
        }
        // Analytic layers first (every built-in scene but `open-sea`): their velocities come out
        // of the inversion's own `sin_cos`, summed in the order `velocity_filtered` sums them,
        // and the other layers' are added after, at the source point, in layer order.
        let analytic = |l: &Layer| matches!(l, Layer::Sine(_) | Layer::Gerstner(_));
        let layers = self.surface.layers();
        let analytic_first = layers
            .iter()
            .skip_while(|l| analytic(l))
            .all(|l| !analytic(l));
        if !analytic_first {
            let inverted =
                self.invert_lanes_v::<B, false>(worlds, starts, false, &mut [[0.0; B]; 3]);
            // A plain loop, not `std::array::from_fn`: its closure is not inlined, so the
            // velocity sum ran out of line, in baseline (non-AVX2) code, outside the hull kernel
            // (11% of an `open-sea` body step). The same operations in the same order.
            let mut out = [WaterPoint::ZERO; B];
            for (o, inv) in out.iter_mut().zip(&inverted) {
                *o = WaterPoint {
                    height: inv.sample.displacement.y,
                    // `velocity_filtered`'s own sum, inlined (into the AVX2 hull kernel too).
                    velocity: self.velocity_layers(inv.source, min_wavelength, DVec3::ZERO, true),
                    source: inv.source,
                    derivatives: inv.sample,
                };
            }
            return out;
        }
        let mut v = [[0.0; B]; 3];
        let inverted = self.invert_lanes_v::<B, true>(worlds, starts, false, &mut v);
        let only_analytic = layers.iter().all(analytic);
        let mut out = [WaterPoint::ZERO; B];
        for (l, (o, inv)) in out.iter_mut().zip(&inverted).enumerate() {
            let summed = DVec3::new(v[0][l], v[1][l], v[2][l]);
            *o = WaterPoint {
                height: inv.sample.displacement.y,
                velocity: if only_analytic {
                    summed
                } else {
                    self.velocity_layers(inv.source, min_wavelength, summed, false)
                },
                source: inv.source,
                derivatives: inv.sample,
            };
        }
        out
    }
}
