//! Hydrostatic and hydrodynamic loads on a hull in one sea snapshot.
//!
//! For each cell (a vertical column of height h, volume V, width w = sqrt(V/h)) at world centre
//! c, with u the body's up axis in the world:
//! - its world vertical half-extent is `e = ½·(h·|u_y| + w·sqrt(1 − u_y²))` (the column's
//!   height when level, its width when on its side);
//! - its submerged fraction is `f = clamp((η − (c_y − e)) / (2e), 0, 1)`, with η the sea
//!   height above the cell's world (x, z) (inverting horizontal displacement);
//! - buoyancy `ρ·g·V·f·ŷ` acts at c, so a hull tilted or lifted unevenly feels a righting
//!   torque about the centre of mass;
//! - drag `−f·(V/ΣV)·(c₁ + c₂·|u_rel|)·u_rel` acts at c, where u_rel is the cell's velocity
//!   (`v + ω × r`) minus the water particle velocity there ([`crate::velocity`]).
//!
//! Angular damping adds `−c_ω·(V_sub/ΣV)·ω`.

use glam::{DMat3, DVec2, DVec3};

use super::spec::BodyModel;
use crate::surface::SurfaceAt;

/// Forces and torques about the centre of mass, world frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Loads {
    /// Buoyancy plus gravity, N.
    pub(crate) force: DVec3,
    /// Buoyancy torque about the centre of mass, N·m.
    pub(crate) torque: DVec3,
    /// Drag force, N.
    pub(crate) drag_force: DVec3,
    /// Drag and damping torque, N·m.
    pub(crate) drag_torque: DVec3,
    /// Translational drag rate `Σ f·(V/ΣV)·(c₁ + c₂·|u_rel|)`, N·s/m (for the limiter).
    pub(crate) drag_rate: f64,
    /// Rotational drag rate `Σ f·(V/ΣV)·(c₁ + c₂·|u_rel|)·|r|² + c_ω·V_sub/ΣV`, N·m·s.
    pub(crate) drag_rate_rot: f64,
    /// Submerged volume, m³.
    pub(crate) submerged: f64,
}

/// The loads on `model` with centre of mass at `com` (world), rotation matrix `rot`, velocity
/// `v` and angular velocity `w`, in `sea`, water density `rho`, gravity `g`.
///
/// `warm` holds one entry per cell: on return, what the cell's inversion found. With
/// `since = Some(h)` (the previous call was the body's previous substep, h seconds earlier, in
/// this tick or the last), each cell's inversion starts from a prediction made from that entry instead of
/// from the world point (see [`predicted_start`]): usually within the 1 mm tolerance already,
/// so Newton's first round is also its last. A pure function of the body's own substeps (and of
/// the [`super::WarmStart`] a restored body carries), so replays and restored worlds take the
/// same rounds.
#[allow(clippy::too_many_arguments)]
pub(crate) fn loads(
    model: &BodyModel,
    com: DVec3,
    rot: &DMat3,
    v: DVec3,
    w: DVec3,
    sea: &SurfaceAt<'_>,
    rho: f64,
    g: f64,
    warm: &mut [CellWater],
    since: Option<f64>,
) -> Loads {
    let mut out = Loads {
        force: DVec3::new(0.0, -model.mass * g, 0.0),
        ..Loads::default()
    };
    let up_y = rot.y_axis.y;
    let side = (1.0 - up_y * up_y).max(0.0).sqrt();
    let inv_vol = 1.0 / model.hull.volume;
    let cells = Cells {
        model,
        com,
        rot,
        v,
        w,
        sea,
        rho,
        g,
        up_y,
        side,
        inv_vol,
        since,
    };
    #[cfg(target_arch = "x86_64")]
    match crate::simd::simd_level() {
        // Eight cells a block pay where the sea is all analytic waves, whose kernel then runs
        // eight f64 lanes an instruction (`lake` and `calm` 18-32% faster a step). FFT layers
        // are read lane by lane and particle seas cell by cell: there eight measured no faster
        // than four, so those stay on the AVX2 path.
        // SAFETY: `simd_level` is Avx512 only where the CPU has AVX-512 F (detected at run time).
        crate::simd::SimdLevel::Avx512
            if !sea.surface.has_fft() && !sea.surface.has_particles() =>
        unsafe { cells_avx512(&cells, &mut out, warm) },
        // SAFETY: `simd_level` is Avx2 or wider only where the CPU has AVX2 (detected at run
        // time).
        crate::simd::SimdLevel::Avx2 | crate::simd::SimdLevel::Avx512 => unsafe {
            cells_avx2(&cells, &mut out, warm)
        },
        _ => cells.add_to::<LANES>(&mut out, warm),
    }
    #[cfg(not(target_arch = "x86_64"))]
    cells.add_to::<LANES>(&mut out, warm);
    let frac = out.submerged * inv_vol;
    out.drag_torque -= w * (model.angular_damping * frac);
    out.drag_rate_rot += model.angular_damping * frac;
    out
}

/// Everything [`loads`] sums over the cells of one hull.
struct Cells<'a, 's> {
    model: &'a BodyModel,
    com: DVec3,
    rot: &'a DMat3,
    v: DVec3,
    w: DVec3,
    sea: &'a SurfaceAt<'s>,
    rho: f64,
    g: f64,
    up_y: f64,
    side: f64,
    inv_vol: f64,
    /// Seconds since the body's previous substep, whose answers are in the cells'
    /// [`CellWater`]; `None` for cold starts (a body's first step, or after a rollback).
    since: Option<f64>,
}

/// What one hull cell's inversion found on a substep: the start of the next substep's (the
/// next tick's first, too: a body keeps its cells' last answers, see [`super::WarmStart`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct CellWater {
    /// The cell's world (x, z), m.
    pub(crate) world: DVec2,
    /// The inversion's source point there, m.
    pub(crate) source: DVec2,
    /// The water particle's horizontal velocity at the source, m/s.
    pub(crate) velocity: DVec2,
    /// The horizontal displacement's slopes at the source, `[∂Dx/∂x, ∂Dx/∂z, ∂Dz/∂x, ∂Dz/∂z]`
    /// (the Jacobian of the inversion's own last step).
    pub(crate) slopes: [f64; 4],
}

impl CellWater {
    /// As ten numbers: world x, z; source x, z; velocity x, z; the four slopes.
    pub(crate) fn to_array(self) -> [f64; 10] {
        let [a, b, c, d] = self.slopes;
        [
            self.world.x,
            self.world.y,
            self.source.x,
            self.source.y,
            self.velocity.x,
            self.velocity.y,
            a,
            b,
            c,
            d,
        ]
    }

    /// From [`CellWater::to_array`]'s ten numbers (the same bits back).
    pub(crate) fn from_array(v: [f64; 10]) -> CellWater {
        CellWater {
            world: DVec2::new(v[0], v[1]),
            source: DVec2::new(v[2], v[3]),
            velocity: DVec2::new(v[4], v[5]),
            slopes: [v[6], v[7], v[8], v[9]],
        }
    }
}

/// Where to start the inversion for a cell now at world `world`, `h` seconds after `prev`:
/// one Newton step for `p + D(p, t + h) = world` from the previous source `p₀`, with the
/// displacement extrapolated in time by the particle velocity,
/// `F = p₀ + D(p₀, t) + v·h − world ≈ (world₀ − world) + v·h` (the previous residual is within
/// the tolerance and left out), and the previous slopes for the Jacobian
/// ([`crate::query::inversion_step`], a fixed-point step where it is singular or with the
/// fixed-point method). The world point itself if the prediction is not finite.
#[inline(always)]
fn predicted_start(prev: &CellWater, world: DVec2, h: f64, newton: bool) -> DVec2 {
    let f = (prev.world - world) + prev.velocity * h;
    let start = prev.source - crate::query::inversion_step_slopes(prev.slopes, f, newton);
    if start.is_finite() { start } else { world }
}

/// [`Cells::add_to`] compiled for AVX2 and chosen at run time, as the batch queries are
/// ([`crate::surface::for_blocks`]): the sea's wave kernel inlines here and runs four f64 lanes
/// per instruction instead of two, with the same operations in the same order (no fused
/// multiply-add), so the same bits; `body_step_gives_the_same_bits_at_every_simd_level` compares
/// them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn cells_avx2(cells: &Cells<'_, '_>, out: &mut Loads, warm: &mut [CellWater]) {
    cells.add_to::<LANES>(out, warm);
}

/// [`cells_avx2`] compiled for AVX-512 F: eight cells a block ([`WIDE_LANES`], a default box
/// hull's 4 × 2 in one), eight f64 lanes per instruction, the same operations in the same order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn cells_avx512(cells: &Cells<'_, '_>, out: &mut Loads, warm: &mut [CellWater]) {
    cells.add_to::<WIDE_LANES>(out, warm);
}

impl Cells<'_, '_> {
    /// Adds every cell's buoyancy and drag to `out`, and leaves what each cell's inversion
    /// found in `warm` (see [`loads`]).
    #[inline(always)]
    fn add_to<const B: usize>(&self, out: &mut Loads, warm: &mut [CellWater]) {
        let (model, sea) = (self.model, self.sea);
        let newton = sea.options.inversion.method == crate::query::InversionMethod::Newton;
        // Cells in blocks of LANES for the vectorised sea ([`SurfaceAt::water_lanes_from`],
        // bit-identical to one cell at a time); the sums below still run cell by cell, in order.
        for (block, warm) in model.hull.cells.chunks(B).zip(warm.chunks_mut(B)) {
            let last = block.len() - 1;
            let r: [DVec3; B] =
                std::array::from_fn(|l| *self.rot * (block[l.min(last)].position - model.com));
            let at: [DVec2; B] = std::array::from_fn(|l| {
                let c = self.com + r[l];
                DVec2::new(c.x, c.z)
            });
            let starts: [DVec2; B] = match self.since {
                Some(h) => {
                    std::array::from_fn(|l| predicted_start(&warm[l.min(last)], at[l], h, newton))
                }
                None => at,
            };
            let waters = sea.water_lanes_from(&at, &starts, model.min_wavelength);
            for (l, cell) in block.iter().enumerate() {
                let found = &waters[l];
                let d = &found.derivatives;
                warm[l] = CellWater {
                    world: at[l],
                    source: found.source,
                    velocity: DVec2::new(found.velocity.x, found.velocity.z),
                    slopes: [d.d_dx.x, d.d_dz.x, d.d_dx.z, d.d_dz.z],
                };
                self.add_cell(out, cell, r[l], found);
            }
        }
    }

    /// Adds one cell's buoyancy and drag to `out` (see the module docs): the cell at `r` from
    /// the centre of mass (world frame), with `water` above it.
    #[inline(always)]
    fn add_cell(
        &self,
        out: &mut Loads,
        cell: &super::hull::Cell,
        r: DVec3,
        water: &super::water::WaterPoint,
    ) {
        let (model, v, w) = (self.model, self.v, self.w);
        let c = self.com + r;
        let half = 0.5 * (cell.height * self.up_y.abs() + cell.width * self.side);
        let f = ((water.height - (c.y - half)) / (2.0 * half)).clamp(0.0, 1.0);
        if f.is_nan() || f > 0.0 {
            // NaN falls through to the sums, so the step's finiteness check catches it.
            let fb = DVec3::new(0.0, self.rho * self.g * cell.volume * f, 0.0);
            out.force += fb;
            out.torque += r.cross(fb);
            out.submerged += f * cell.volume;
            let u = v + w.cross(r) - water.velocity;
            let rate = f
                * (cell.volume * self.inv_vol)
                * (model.linear_drag + model.quadratic_drag * u.length());
            let fd = u * -rate;
            out.drag_force += fd;
            out.drag_torque += r.cross(fd);
            out.drag_rate += rate;
            out.drag_rate_rot += rate * r.length_squared();
        }
    }
}

/// Cells evaluated together by [`loads`] (below the AVX-512 level).
const LANES: usize = 4;
/// Cells evaluated together at the AVX-512 level.
#[cfg(target_arch = "x86_64")]
const WIDE_LANES: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SwellRng;
    use crate::query::{QueryFields, QueryOptions};
    use crate::surface::Surface;

    /// The warm start of a later substep: for cells moving at boat speeds on a lake-like
    /// Gerstner cascade (fold ≈ 0.5), the predicted start lands within the bodies' 1 mm
    /// tolerance of the next substep's answer nearly always, and is always far closer to it
    /// than the cold start (the world point) is.
    #[test]
    fn the_predicted_start_is_within_a_millimetre_of_the_next_answer() {
        let spec: crate::SurfaceSpec = serde_json::from_value(serde_json::json!({"seed": 7,
            "layers": [{"kind": "gerstner",
                "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
                "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}]}))
        .unwrap();
        let surface = Surface::new(&spec).unwrap();
        let mut options = QueryOptions::default();
        options.inversion.tolerance = 1e-12;
        let (t, h) = (1000.0, 1.0 / 60.0);
        let now = surface.at(t, QueryFields::HEIGHT, &options).unwrap();
        let next = surface.at(t + h, QueryFields::HEIGHT, &options).unwrap();
        let mut rng = SwellRng::new(3, 1);
        let (mut within, n) = (0, 500);
        for _ in 0..n {
            let (a, b) = rng.gaussian_pair();
            let world = DVec2::new(a * 100.0, b * 100.0);
            let (c, d) = rng.gaussian_pair();
            let moved = world + DVec2::new(c, d) * h; // ~1 m/s
            let found = now.water_at(world, 0.0);
            let d = &found.derivatives;
            let prev = CellWater {
                world,
                source: found.source,
                velocity: DVec2::new(found.velocity.x, found.velocity.z),
                slopes: [d.d_dx.x, d.d_dz.x, d.d_dx.z, d.d_dz.z],
            };
            let start = predicted_start(&prev, moved, h, true);
            let answer = next.water_at(moved, 0.0).source;
            let (warm, cold) = ((start - answer).length(), (moved - answer).length());
            assert!(warm < 0.2 * cold, "{world}: warm {warm} m, cold {cold} m");
            within += usize::from(warm <= 1e-3);
        }
        eprintln!("{within} of {n} within 1 mm");
        assert!(within * 100 >= n * 95, "{within} of {n} within 1 mm");
    }
}
