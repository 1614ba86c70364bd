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
/// `offsets` holds one entry per cell: on return, the cell's inversion answer relative to its
/// world point (`source − world`). With `warm`, each cell's inversion starts from its world
/// point plus the entry left by the previous call (the previous substep of the same tick)
/// instead of from the world point: the surface moved for one substep, so the start is a few
/// millimetres off and Newton needs a round less. A pure function of the tick's own substeps,
/// so replays and restored worlds take the same rounds.
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
    offsets: &mut [DVec2],
    warm: bool,
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
        warm,
    };
    #[cfg(target_arch = "x86_64")]
    if crate::surface::simd_enabled() && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked on the line above.
        unsafe { cells_avx2(&cells, &mut out, offsets) };
    } else {
        cells.add_to(&mut out, offsets);
    }
    #[cfg(not(target_arch = "x86_64"))]
    cells.add_to(&mut out, offsets);
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
    /// Start each cell's inversion from the offset the previous substep left.
    warm: bool,
}

/// [`Cells::add_to`] compiled for AVX2 and chosen at run time, as the batch queries are
/// ([`crate::surface::for_blocks`]): the sea's wave kernel inlines here and runs four f64 lanes
/// per instruction instead of two, with the same operations in the same order (no fused
/// multiply-add), so the same bits; `body_step_uses_the_same_bits_with_and_without_avx2` compares
/// the two.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn cells_avx2(cells: &Cells<'_, '_>, out: &mut Loads, offsets: &mut [DVec2]) {
    cells.add_to(out, offsets);
}

impl Cells<'_, '_> {
    /// Adds every cell's buoyancy and drag to `out`, and leaves each cell's source offset in
    /// `offsets` (see [`loads`]).
    #[inline(always)]
    fn add_to(&self, out: &mut Loads, offsets: &mut [DVec2]) {
        let Cells {
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
            warm,
        } = *self;
        // Cells in blocks of LANES for the vectorised sea ([`SurfaceAt::water_lanes_from`],
        // bit-identical to one cell at a time); the sums below still run cell by cell, in order.
        for (block, offsets) in model
            .hull
            .cells
            .chunks(LANES)
            .zip(offsets.chunks_mut(LANES))
        {
            let last = block.len() - 1;
            let r: [DVec3; LANES] =
                std::array::from_fn(|l| *rot * (block[l.min(last)].position - model.com));
            let at: [DVec2; LANES] = std::array::from_fn(|l| {
                let c = com + r[l];
                DVec2::new(c.x, c.z)
            });
            let starts: [DVec2; LANES] = if warm {
                std::array::from_fn(|l| at[l] + offsets[l.min(last)])
            } else {
                at
            };
            let waters = sea.water_lanes_from(&at, &starts, model.min_wavelength);
            for (l, cell) in block.iter().enumerate() {
                offsets[l] = waters[l].source - at[l];
                let (r, water) = (r[l], waters[l]);
                let c = com + r;
                let half = 0.5 * (cell.height * up_y.abs() + cell.width * side);
                loads_of_cell(out, model, cell, r, c, half, water, v, w, rho, g, inv_vol);
            }
        }
    }
}

/// Cells evaluated together by [`loads`].
const LANES: usize = 4;

/// Adds one cell's buoyancy and drag to `out` (see the module docs).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn loads_of_cell(
    out: &mut Loads,
    model: &BodyModel,
    cell: &super::hull::Cell,
    r: DVec3,
    c: DVec3,
    half: f64,
    water: super::water::WaterPoint,
    v: DVec3,
    w: DVec3,
    rho: f64,
    g: f64,
    inv_vol: f64,
) {
    {
        let f = ((water.height - (c.y - half)) / (2.0 * half)).clamp(0.0, 1.0);
        if f.is_nan() || f > 0.0 {
            // NaN falls through to the sums, so the step's finiteness check catches it.
            let fb = DVec3::new(0.0, rho * g * cell.volume * f, 0.0);
            out.force += fb;
            out.torque += r.cross(fb);
            out.submerged += f * cell.volume;
            let u = v + w.cross(r) - water.velocity;
            let rate = f
                * (cell.volume * inv_vol)
                * (model.linear_drag + model.quadratic_drag * u.length());
            let fd = u * -rate;
            out.drag_force += fd;
            out.drag_torque += r.cross(fd);
            out.drag_rate += rate;
            out.drag_rate_rot += rate * r.length_squared();
        }
    }
}
