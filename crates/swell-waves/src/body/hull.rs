//! Hull geometry: the vertical columns ("cells") buoyancy is computed on, and the inertia tensor
//! the hull implies.
//!
//! Body frame: +x forward (bow), +y up, +z to the side (the frame of [`super::BodyFootprint`]).
//! A cell is a vertical column in the body frame: centre `position`, `height` h, `volume` V, so
//! its cross-section is `a = V/h`.

use glam::{DMat3, DVec3};

use crate::error::{SpecError, field_path, finite, positive};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most cells a hull may have: each costs one height and velocity query per substep.
pub const MAX_CELLS: usize = 256;
/// Largest hull dimension (a box's length, beam or height; a cell column's height or width), m:
/// ten times the largest ship afloat.
pub const MAX_HULL_SIZE: f64 = 5000.0;
/// Smallest hull dimension, m.
pub const MIN_HULL_SIZE: f64 = 0.001;

/// Checks a hull dimension is in [[`MIN_HULL_SIZE`], [`MAX_HULL_SIZE`]] m.
fn size(field: &str, v: f64) -> Result<f64, SpecError> {
    crate::error::in_range(field, v, MIN_HULL_SIZE, MAX_HULL_SIZE)
}
/// Most columns along either axis of a box hull (16 × 16 = 256 = [`MAX_CELLS`]).
pub const MAX_BOX_CELLS_PER_SIDE: u32 = 16;
/// Default box subdivision, `[along length, along beam]`: 4 × 2 columns resolve pitch and roll
/// with 8 queries per substep; fewer cannot feel a wave crest moving along the hull.
pub const DEFAULT_BOX_CELLS: [u32; 2] = [4, 2];

/// A hull as written in a body spec.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(tag = "kind", rename_all = "snake_case"))]
pub enum HullSpec {
    /// A box centred on the body origin, split into `cells[0] × cells[1]` full-height columns
    /// (along length × along beam). Inertia: the uniform solid box,
    /// `I = m/12·diag(H² + B², L² + B², L² + H²)`.
    Box {
        /// Length L along +x, m (> 0).
        length: f64,
        /// Beam B along +z, m (> 0).
        beam: f64,
        /// Height H along +y, m (> 0).
        height: f64,
        /// Columns `[along length, along beam]`, each 1..=16. Default `[4, 2]`.
        #[cfg_attr(feature = "serde", serde(default))]
        cells: Option<[u32; 2]>,
    },
    /// Explicit cells. Inertia: each cell carries the mass share `m·V_i/ΣV` as a small uniform
    /// box of footprint `sqrt(a_i)²` and height `h_i` at its centre (parallel-axis theorem), so
    /// the tensor is never singular even for cells on a line.
    Cells {
        /// The cells, 1..=256.
        cells: Vec<CellSpec>,
    },
}

/// One explicit hull cell: a vertical column in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CellSpec {
    /// Centre of the column in the body frame `[x, y, z]`, m.
    pub position: [f64; 3],
    /// Displaced volume when fully submerged, m³ (> 0).
    pub volume: f64,
    /// Height of the column, m (> 0).
    pub height: f64,
}

/// A built hull cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Centre in the body frame, m.
    pub position: DVec3,
    /// Volume V, m³.
    pub volume: f64,
    /// Height h, m.
    pub height: f64,
    /// Side of the square cross-section, `sqrt(V/h)`, m (how far the column reaches sideways
    /// once tilted).
    pub width: f64,
}

/// A built, validated hull.
#[derive(Debug, Clone, PartialEq)]
pub struct Hull {
    pub(crate) cells: Vec<Cell>,
    pub(crate) volume: f64,
    pub(crate) waterplane_area: f64,
    pub(crate) length: f64,
    pub(crate) height: f64,
    pub(crate) min: DVec3,
    pub(crate) max: DVec3,
    /// Inertia per unit mass about the body origin for `Box`, or the cell form (see
    /// [`Hull::inertia`]).
    kind: HullKind,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum HullKind {
    Box { length: f64, beam: f64, height: f64 },
    Cells,
}

impl HullSpec {
    /// Validates and builds the hull. `field` prefixes error paths (e.g. `bodies[3].hull`); an
    /// empty `field` names them from the hull's root (`length`, `cells[0].volume`).
    ///
    /// # Errors
    /// A box dimension outside [[`MIN_HULL_SIZE`], [`MAX_HULL_SIZE`]] m (`{field}.length`,
    /// `.beam`, `.height`); a box
    /// subdivision outside 1..=16 (`{field}.cells`); an empty or over-long cell list
    /// (`{field}.cells`); a cell position not finite, a cell volume not finite and > 0, or a
    /// cell height or width (`sqrt(volume/height)`) outside the box's bounds
    /// (`{field}.cells[i].…`).
    pub fn build(&self, field: &str) -> Result<Hull, SpecError> {
        match self {
            HullSpec::Box {
                length,
                beam,
                height,
                cells,
            } => {
                let l = size(&field_path(field, "length"), *length)?;
                let b = size(&field_path(field, "beam"), *beam)?;
                let h = size(&field_path(field, "height"), *height)?;
                let [nx, nz] = cells.unwrap_or(DEFAULT_BOX_CELLS);
                for (i, n) in [nx, nz].into_iter().enumerate() {
                    if !(1..=MAX_BOX_CELLS_PER_SIDE).contains(&n) {
                        return Err(SpecError::OutOfRange {
                            field: field_path(field, &format!("cells[{i}]")),
                            value: f64::from(n),
                            allowed: format!("an integer in 1..={MAX_BOX_CELLS_PER_SIDE}"),
                        });
                    }
                }
                let (dx, dz) = (l / f64::from(nx), b / f64::from(nz));
                let mut cells = Vec::with_capacity((nx * nz) as usize);
                for i in 0..nx {
                    for j in 0..nz {
                        let x = -0.5 * l + (f64::from(i) + 0.5) * dx;
                        let z = -0.5 * b + (f64::from(j) + 0.5) * dz;
                        let v = dx * dz * h;
                        if !(v > 0.0 && v.is_finite()) {
                            return Err(SpecError::Inconsistent {
                                field: field.to_string(),
                                reason: format!("cell volume {v} m³ is not finite and > 0"),
                            });
                        }
                        cells.push(cell(DVec3::new(x, 0.0, z), v, h));
                    }
                }
                Ok(finish(
                    cells,
                    l,
                    HullKind::Box {
                        length: l,
                        beam: b,
                        height: h,
                    },
                ))
            }
            HullSpec::Cells { cells } => {
                if cells.is_empty() || cells.len() > MAX_CELLS {
                    return Err(SpecError::BadLength {
                        field: field_path(field, "cells"),
                        len: cells.len(),
                        allowed: format!("1..={MAX_CELLS}"),
                    });
                }
                let mut out = Vec::with_capacity(cells.len());
                for (i, c) in cells.iter().enumerate() {
                    let f = field_path(field, &format!("cells[{i}]"));
                    for (k, p) in c.position.iter().enumerate() {
                        finite(&format!("{f}.position[{k}]"), *p)?;
                    }
                    let v = positive(&format!("{f}.volume"), c.volume)?;
                    let h = size(&format!("{f}.height"), c.height)?;
                    // The column's width sqrt(V/h), bounded as a box's sides are.
                    size(&format!("{f}.volume"), (v / h).sqrt()).map_err(|_| {
                        SpecError::OutOfRange {
                            field: format!("{f}.volume"),
                            value: v,
                            allowed: format!(
                                "a column at most {MAX_HULL_SIZE} m and at least \
                                 {MIN_HULL_SIZE} m wide: volume/height in [{}, {}] m²",
                                MIN_HULL_SIZE * MIN_HULL_SIZE,
                                MAX_HULL_SIZE * MAX_HULL_SIZE
                            ),
                        }
                    })?;
                    out.push(cell(DVec3::from_array(c.position), v, h));
                }
                // Length along x: the extent of the columns' footprints.
                let lo = out
                    .iter()
                    .map(|c| c.position.x - 0.5 * c.width)
                    .fold(f64::INFINITY, f64::min);
                let hi = out
                    .iter()
                    .map(|c| c.position.x + 0.5 * c.width)
                    .fold(f64::NEG_INFINITY, f64::max);
                Ok(finish(out, hi - lo, HullKind::Cells))
            }
        }
    }
}

fn cell(position: DVec3, volume: f64, height: f64) -> Cell {
    Cell {
        position,
        volume,
        height,
        width: (volume / height).sqrt(),
    }
}

fn finish(cells: Vec<Cell>, length: f64, kind: HullKind) -> Hull {
    let mut volume = 0.0;
    let mut area = 0.0;
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for c in &cells {
        volume += c.volume;
        area += c.volume / c.height;
        let half = DVec3::new(0.5 * c.width, 0.5 * c.height, 0.5 * c.width);
        min = min.min(c.position - half);
        max = max.max(c.position + half);
    }
    Hull {
        cells,
        volume,
        waterplane_area: area,
        length,
        height: max.y - min.y,
        min,
        max,
        kind,
    }
}

impl Hull {
    /// The cells, in build order (box: along length outer, along beam inner).
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// Total volume ΣV, m³ (the displacement when fully submerged).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Waterplane area `A_wp = Σ V_i/h_i`, m²: the area cut by a level waterline crossing
    /// every column (L·B for a box).
    pub fn waterplane_area(&self) -> f64 {
        self.waterplane_area
    }

    /// Length along the body x axis, m (the box length, or the cells' footprint extent). The
    /// scale the wavelength filter ([`super::BodySpec::min_wavelength_factor`]) compares with.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Vertical extent of the hull in the body frame, m.
    pub fn height(&self) -> f64 {
        self.height
    }

    /// Body-frame bounding box `(min, max)` of the cells, m.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.min, self.max)
    }

    /// Inertia tensor, kg·m², for total mass `mass` about body-frame point `com`.
    ///
    /// - Box: the uniform solid box about its centre, `m/12·diag(H² + B², L² + B², L² + H²)`,
    ///   used as is about `com` (a centre of mass moved by ballast is modelled as moving the
    ///   whole mass distribution, which keeps the tensor positive definite).
    /// - Cells: `Σ m_i·(box_i + |r_i|²·1 − r_i r_iᵀ)` with `m_i = m·V_i/ΣV`, `r_i` the cell
    ///   centre relative to `com` and `box_i = 1/12·diag(w² + h², 2w², w² + h²)` the cell's own
    ///   column (w = its width, h its height).
    pub fn inertia(&self, mass: f64, com: DVec3) -> DMat3 {
        match self.kind {
            HullKind::Box {
                length,
                beam,
                height,
            } => {
                let k = mass / 12.0;
                DMat3::from_diagonal(DVec3::new(
                    k * (height * height + beam * beam),
                    k * (length * length + beam * beam),
                    k * (length * length + height * height),
                ))
            }
            HullKind::Cells => {
                let mut i = DMat3::ZERO;
                for c in &self.cells {
                    let mi = mass * (c.volume / self.volume);
                    let (w2, h2) = (c.width * c.width, c.height * c.height);
                    let own = DMat3::from_diagonal(DVec3::new(w2 + h2, 2.0 * w2, w2 + h2)) / 12.0;
                    let r = c.position - com;
                    let outer = DMat3::from_cols(r * r.x, r * r.y, r * r.z);
                    let pa = DMat3::from_diagonal(DVec3::splat(r.dot(r))) - outer;
                    i += (own + pa) * mi;
                }
                i
            }
        }
    }
}
