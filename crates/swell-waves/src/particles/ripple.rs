//! Interaction ripples: rings of wave particles from impact events, in closed form.
//!
//! An [`Impact`] `(t0, c, strength, radius r)` emits `N0` particles (the layer's
//! [`RippleSpec::particles`]) from `c` at `t0`, one per direction `2π·i/N0`, each of radius r
//! and amplitude `a0 = strength/N0` (so the splash is `strength` high at `c` at `t0`). They
//! travel outwards at the phase speed of a wave as wide as a particle,
//! `s = ω(k)/k` with `k = π/(2r)` (wavelength 4r, the dispersion relation of the surface: larger
//! rings run faster). At time t the ring has radius `d = s·(t − t0)`.
//!
//! **Subdivision** (Yuksel's wave particles): a particle spanning the angle θ leaves a gap of
//! `d·θ` (arc length) to its neighbours; when the gap exceeds r it splits into three of angle θ/3
//! at `φ − θ/3, φ, φ + θ/3`, each with a third of its amplitude. Every particle of a ring splits
//! at the same moment, so generation g (after g splits) holds `N_g = N0·3^g` particles at the
//! angles `2π·i/N_g` with amplitude `a0/3^g`, and the split times are closed form:
//!
//! ```text
//! D_g = r·N_g/(2π) = r·N0·3^g/(2π)          (the ring radius at which generation g splits)
//! t_g = t0 + D_g/s
//! g(d) = #{ j ≥ 0 : D_j < d }                (the generation at radius d)
//! ```
//!
//! Subdivision conserves the ring's total amplitude `N_g·a_g = strength` exactly.
//! **Amplitude loss with distance**: every particle's amplitude is multiplied by
//! `exp(−d/decay)`. **Death**: a ring contributes nothing before `t0`; it dies once
//! `t − t0 > lifetime`, once its particles' amplitude `a0/3^g·exp(−d/decay)` is below the
//! amplitude floor, or at the split that would take it past `max_ring_particles`
//! ([`Ring::death_time`] gives the moment in closed form).
//!
//! So the ripples at t are a pure function of the impact list and t: no state is stepped, and a
//! query at any t — seeking, reversing, replaying — gives the same bits.

use glam::DVec2;

use crate::error::{SpecError, in_range, positive_at_most};
use crate::math::{TAU, exp, ln, sin_cos};
use crate::spectrum::Dispersion;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most impacts one [`Impacts`] set may hold.
pub const MAX_IMPACTS: usize = 1 << 20;
/// Most rings alive at one time in a snapshot ([`crate::SurfaceAt::with_impacts`]).
pub const MAX_LIVE_RINGS: usize = 4096;
/// Largest impact strength, m.
pub const MAX_STRENGTH: f64 = 100.0;
/// Smallest impact radius, m (a 1 cm ripple; smaller ones split too often to be worth it).
pub const MIN_IMPACT_RADIUS: f64 = 0.01;
/// Largest impact radius, m.
pub const MAX_IMPACT_RADIUS: f64 = 1000.0;
/// Largest impact coordinate magnitude, m (positions are f64; beyond this a ring's particle
/// positions would lose centimetres).
pub const MAX_IMPACT_COORD: f64 = 1e9;
/// Largest impact time magnitude, s.
pub const MAX_IMPACT_TIME: f64 = 1e12;

/// One impact event: something hit the water.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Impact {
    /// Scene time of the impact t0, s.
    pub t: f64,
    /// Where, world `[x, z]`, m.
    pub position: [f64; 2],
    /// Height of the splash at the impact point at t0, m, in (0, 100]: the ring's total
    /// amplitude.
    pub strength: f64,
    /// Radius r of the ring's particles, m, in [0.01, 1000]: their width, which sets the ring's
    /// speed and how often it subdivides.
    pub radius: f64,
}

impl Impact {
    /// Checks the impact; `field` prefixes the error path (e.g. `impacts[3]`).
    ///
    /// # Errors
    /// A non-finite or out-of-range `t` (|t| ≤ 1e12), `position` (|x|, |z| ≤ 1e9), `strength` or
    /// `radius`.
    pub fn validate(&self, field: &str) -> Result<(), SpecError> {
        let f = |name: &str| {
            if field.is_empty() {
                name.to_string()
            } else {
                format!("{field}.{name}")
            }
        };
        in_range(&f("t"), self.t, -MAX_IMPACT_TIME, MAX_IMPACT_TIME)?;
        for (i, &v) in self.position.iter().enumerate() {
            in_range(
                &f(&format!("position[{i}]")),
                v,
                -MAX_IMPACT_COORD,
                MAX_IMPACT_COORD,
            )?;
        }
        positive_at_most(&f("strength"), self.strength, MAX_STRENGTH)?;
        in_range(
            &f("radius"),
            self.radius,
            MIN_IMPACT_RADIUS,
            MAX_IMPACT_RADIUS,
        )?;
        Ok(())
    }

    /// The canonical order of impacts: by time, then x, z, strength and radius (IEEE total
    /// order). A set's ripples are summed in this order, so the same set of impacts gives the
    /// same bits whatever order it arrived in.
    pub fn canonical_cmp(&self, o: &Impact) -> std::cmp::Ordering {
        self.t
            .total_cmp(&o.t)
            .then(self.position[0].total_cmp(&o.position[0]))
            .then(self.position[1].total_cmp(&o.position[1]))
            .then(self.strength.total_cmp(&o.strength))
            .then(self.radius.total_cmp(&o.radius))
    }
}

/// A validated set of impacts, kept in canonical order ([`Impact::canonical_cmp`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Impacts {
    events: Vec<Impact>,
}

impl Impacts {
    /// An empty set.
    pub fn new() -> Impacts {
        Impacts::default()
    }

    /// Validates every impact and sorts them canonically.
    ///
    /// # Errors
    /// More than [`MAX_IMPACTS`] (field `impacts`); an invalid impact (field `impacts[i]...`,
    /// `i` its index in `events`).
    pub fn from_events(mut events: Vec<Impact>) -> Result<Impacts, SpecError> {
        if events.len() > MAX_IMPACTS {
            return Err(SpecError::BadLength {
                field: "impacts".into(),
                len: events.len(),
                allowed: format!("at most {MAX_IMPACTS}"),
            });
        }
        for (i, e) in events.iter().enumerate() {
            e.validate(&format!("impacts[{i}]"))?;
        }
        events.sort_by(Impact::canonical_cmp);
        Ok(Impacts { events })
    }

    /// This set with `impact` added at its canonical place.
    ///
    /// # Errors
    /// An invalid impact (field names without prefix: `t`, `position[0]`, ...), or the set is
    /// full (field `impacts`).
    pub fn with(&self, impact: Impact) -> Result<Impacts, SpecError> {
        impact.validate("")?;
        if self.events.len() >= MAX_IMPACTS {
            return Err(SpecError::BadLength {
                field: "impacts".into(),
                len: self.events.len() + 1,
                allowed: format!("at most {MAX_IMPACTS}"),
            });
        }
        let at = self
            .events
            .partition_point(|e| e.canonical_cmp(&impact).is_le());
        let mut events = Vec::with_capacity(self.events.len() + 1);
        events.extend_from_slice(&self.events[..at]);
        events.push(impact);
        events.extend_from_slice(&self.events[at..]);
        Ok(Impacts { events })
    }

    /// The union of two sets (every impact of both, duplicates kept), in canonical order: a
    /// merge, O(n), no re-validation (both are valid sets already).
    ///
    /// # Errors
    /// More than [`MAX_IMPACTS`] together (field `impacts`).
    pub fn merged(a: &Impacts, b: &Impacts) -> Result<Impacts, SpecError> {
        let n = a.events.len() + b.events.len();
        if n > MAX_IMPACTS {
            return Err(SpecError::BadLength {
                field: "impacts".into(),
                len: n,
                allowed: format!("at most {MAX_IMPACTS}"),
            });
        }
        let mut events = Vec::with_capacity(n);
        let (mut i, mut j) = (0, 0);
        while i < a.events.len() && j < b.events.len() {
            if b.events[j].canonical_cmp(&a.events[i]).is_lt() {
                events.push(b.events[j]);
                j += 1;
            } else {
                events.push(a.events[i]);
                i += 1;
            }
        }
        events.extend_from_slice(&a.events[i..]);
        events.extend_from_slice(&b.events[j..]);
        Ok(Impacts { events })
    }

    /// The impacts, in canonical order.
    pub fn events(&self) -> &[Impact] {
        &self.events
    }

    /// Number of impacts.
    pub fn len(&self) -> usize {
        self.events.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }

    /// The impacts whose time t0 lies in `[t − lifetime, t]` (the only ones that can be alive
    /// at t), as a slice of the canonical list. Found by binary search: O(log n).
    pub fn window(&self, t: f64, lifetime: f64) -> &[Impact] {
        let hi = self.events.partition_point(|e| e.t <= t);
        let lo = self.events[..hi].partition_point(|e| t - e.t > lifetime);
        &self.events[lo..hi]
    }
}

/// How impact rings behave: the `ripples` object of a particle layer spec.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct RippleSpec {
    /// Particles a ring starts with, N0, in [3, 256]. Default 8: fewer and the first ring is
    /// visibly polygonal, more and small splashes cost more before their first split.
    pub particles: u32,
    /// Distance over which a ring's amplitude falls by e, m, in (0, 1e6]. Default 30 m: a
    /// splash fades within a harbour basin.
    pub decay: f64,
    /// Amplitude below which a ring's particles die, m, in (0, 1]. Default 1e-4 m (0.1 mm):
    /// below anything a renderer shows; the ring's height jumps by at most about this when it
    /// dies.
    pub floor: f64,
    /// Longest life of a ring, s, in (0, 3600]. Default 60 s. Also how far back in time a
    /// snapshot looks for impacts.
    pub lifetime: f64,
    /// Most particles one ring may hold, in [particles, 65536]; a ring dies at the split that
    /// would take it past this. Default 2048 (bounds the cost of a big, long-lived ring).
    pub max_ring_particles: u32,
}

impl Default for RippleSpec {
    fn default() -> Self {
        Self {
            particles: 8,
            decay: 30.0,
            floor: 1e-4,
            lifetime: 60.0,
            max_ring_particles: 2048,
        }
    }
}

impl RippleSpec {
    /// Checks the settings; `field` is the path of the `ripples` object.
    ///
    /// # Errors
    /// Any setting outside the range its doc gives.
    pub fn validate(&self, field: &str) -> Result<(), SpecError> {
        in_range(
            &format!("{field}.particles"),
            f64::from(self.particles),
            3.0,
            256.0,
        )?;
        positive_at_most(&format!("{field}.decay"), self.decay, 1e6)?;
        positive_at_most(&format!("{field}.floor"), self.floor, 1.0)?;
        positive_at_most(&format!("{field}.lifetime"), self.lifetime, 3600.0)?;
        in_range(
            &format!("{field}.max_ring_particles"),
            f64::from(self.max_ring_particles),
            f64::from(self.particles),
            65536.0,
        )?;
        Ok(())
    }
}

/// The phase speed of a wave as wide as a particle of radius `r`: `ω(k)/k`, `k = π/(2r)`
/// (wavelength 4r), m/s.
pub fn particle_speed(r: f64, dispersion: &Dispersion) -> f64 {
    let k = std::f64::consts::PI / (2.0 * r);
    dispersion.omega(k) / k
}

/// One impact's ring under a layer's [`RippleSpec`]: everything about it in closed form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    /// Impact time t0, s.
    pub t0: f64,
    /// Centre, m.
    pub center: DVec2,
    /// Particle radius r, m.
    pub radius: f64,
    /// Speed of the ring s, m/s ([`particle_speed`]).
    pub speed: f64,
    /// Initial particle count N0.
    pub n0: u32,
    /// Initial particle amplitude a0 = strength/N0, m.
    pub a0: f64,
    /// `D_0 = r·N0/(2π)`, m: the radius at which the first split happens.
    pub split0: f64,
    /// Last generation allowed by `max_ring_particles`.
    pub max_generation: u32,
    decay: f64,
    floor: f64,
    lifetime: f64,
}

/// A ring at one time: its radius, generation, particle count and per-particle amplitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingState {
    /// Ring radius d = s·(t − t0), m.
    pub distance: f64,
    /// Splits so far, g.
    pub generation: u32,
    /// Particles, `N0·3^g`.
    pub count: u32,
    /// Amplitude of each particle, `a0/3^g·exp(−d/decay)`, m.
    pub amplitude: f64,
}

/// 3^g as f64 (exact for the generations a ring can reach).
fn pow3(g: u32) -> f64 {
    let mut p = 1.0;
    for _ in 0..g {
        p *= 3.0;
    }
    p
}

impl Ring {
    /// The ring of `impact` under `spec` on a surface with `dispersion`. The impact and spec
    /// are assumed valid ([`Impact::validate`], [`RippleSpec::validate`]).
    pub fn new(impact: &Impact, spec: &RippleSpec, dispersion: &Dispersion) -> Ring {
        let n0 = spec.particles;
        let mut max_generation = 0;
        while u64::from(n0) * 3u64.pow(max_generation + 1) <= u64::from(spec.max_ring_particles) {
            max_generation += 1;
        }
        Ring {
            t0: impact.t,
            center: DVec2::new(impact.position[0], impact.position[1]),
            radius: impact.radius,
            speed: particle_speed(impact.radius, dispersion),
            n0,
            a0: impact.strength / f64::from(n0),
            split0: impact.radius * f64::from(n0) / TAU,
            max_generation,
            decay: spec.decay,
            floor: spec.floor,
            lifetime: spec.lifetime,
        }
    }

    /// `D_g = D_0·3^g`, m: the ring radius past which generation g splits.
    pub fn split_distance(&self, g: u32) -> f64 {
        self.split0 * pow3(g)
    }

    /// `t_g = t0 + D_g/s`, s: when generation g splits (into generation g + 1).
    pub fn split_time(&self, g: u32) -> f64 {
        self.t0 + self.split_distance(g) / self.speed
    }

    /// The ring at time t, or `None` when it is not alive (before t0, after its lifetime,
    /// below the amplitude floor, or past the particle cap). This is the definition of being
    /// alive; [`Ring::death_time`] is its closed form.
    pub fn state(&self, t: f64) -> Option<RingState> {
        let age = t - self.t0;
        if !(age >= 0.0 && age <= self.lifetime) {
            return None;
        }
        let d = self.speed * age;
        let mut g = 0;
        while d > self.split_distance(g) {
            if g == self.max_generation {
                return None;
            }
            g += 1;
        }
        let amplitude = self.a0 / pow3(g) * exp(-d / self.decay);
        if amplitude < self.floor {
            return None;
        }
        Some(RingState {
            distance: d,
            generation: g,
            count: self.n0 * 3u32.pow(g),
            amplitude,
        })
    }

    /// When the ring dies, s, in closed form: the first of `t0 + lifetime`, the moment its
    /// particles' amplitude falls below the floor (within generation g at the radius
    /// `decay·ln(a0/(3^g·floor))`, or at the split into g if it is already below then), and the
    /// split past the particle cap. [`Ring::state`] is `None` from (about) this time on;
    /// rounding may move the boundary by an ulp or so.
    pub fn death_time(&self) -> f64 {
        let mut death = f64::INFINITY;
        let mut lo = 0.0;
        for g in 0..=self.max_generation {
            let hi = self.split_distance(g);
            let d_floor = self.decay * ln(self.a0 / (pow3(g) * self.floor));
            if d_floor < hi {
                death = if d_floor > lo { d_floor } else { lo };
                break;
            }
            lo = hi;
        }
        if death == f64::INFINITY {
            death = lo;
        }
        let life = self.speed * self.lifetime;
        let d = if death < life { death } else { life };
        self.t0 + d / self.speed
    }

    /// Every particle of the ring at t: `(position, amplitude)`, particle i at angle
    /// `2π·i/N_g` (empty when the ring is not alive). For tests and reports: queries never list
    /// a whole ring.
    pub fn particles(&self, t: f64) -> Vec<(DVec2, f64)> {
        let Some(s) = self.state(t) else {
            return Vec::new();
        };
        (0..s.count)
            .map(|i| {
                (
                    self.center + s.distance * direction(i, s.count),
                    s.amplitude,
                )
            })
            .collect()
    }
}

/// The unit direction of particle `i` of `n`: `(cos, sin)(2π·i/n)`.
#[inline]
pub(crate) fn direction(i: u32, n: u32) -> DVec2 {
    let (s, c) = sin_cos(TAU * (f64::from(i) / f64::from(n)));
    DVec2::new(c, s)
}
