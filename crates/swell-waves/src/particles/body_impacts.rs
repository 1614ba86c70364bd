//! Impacts made by floating bodies: a splash when a hull hits the water fast, a wake behind a
//! moving hull. The `body_impacts` object of a particle layer spec turns them on.
//!
//! Both rules are pure functions of one body's fixed step (its state and submerged fraction
//! before and after the tick, the tick's end time) and, for the wake, of one number carried from
//! step to step (the distance travelled since the last wake impact). A body simulation is
//! deterministic per tick ([`crate::body::World`]), so whoever steps the same bodies derives the
//! same impacts at the same ticks, to the bit: nothing needs to be shipped or logged.
//!
//! - **Splash**: the hull was dry at the end of the previous tick (submerged fraction exactly 0)
//!   and is wet at the end of this one, and it was sinking at least `splash_speed` when the tick
//!   began (`−v_y ≥ splash_speed`, the speed it hit the water with). One impact of
//!   `splash_strength` and `splash_radius` at the body origin's `[x, z]` at the tick's end.
//! - **Wake**: while the hull is wet and its horizontal speed over the tick
//!   (`|Δ[x, z]|·tick_hz`) is at least `wake_speed`, the horizontal distance it covers is added
//!   up; each time the sum reaches `wake_spacing` one impact of `wake_strength` and
//!   `wake_radius` is dropped at the body origin's `[x, z]` at the tick's end and the sum loses
//!   `wake_spacing`. At most one wake impact per body per tick (a hull faster than one spacing
//!   per tick drops one every tick, and its sum restarts from 0).
//!
//! Only IEEE `+ − × ÷` and `sqrt` (correctly rounded) are used.

use glam::DVec2;

use super::ripple::{Impact, MAX_IMPACT_RADIUS, MAX_STRENGTH, MIN_IMPACT_RADIUS};
use crate::body::BodyState;
use crate::error::{SpecError, in_range, positive_at_most};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// When floating bodies make impacts. Every field has a default, so `"body_impacts": {}` turns
/// splashes and wakes on with the values below; a strength of 0 turns one of them off.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct BodyImpactSpec {
    /// Sinking speed at water entry from which a hull splashes, m/s, in (0, 100]. Default
    /// 2 m/s: a drop of about 0.2 m (`v = sqrt(2·g·h)`), so a boat riding a swell, whose hull
    /// never leaves the water, never splashes.
    pub splash_speed: f64,
    /// Height of a splash, m, in [0, 100] (0: no splashes). Default 0.3 m.
    pub splash_strength: f64,
    /// Particle radius of a splash ring, m, in [0.01, 1000]. Default 1 m (a ring that runs at
    /// 2.5 m/s in deep water).
    pub splash_radius: f64,
    /// Distance a moving hull travels between two wake impacts, m, in (0, 10000]. Default 4 m:
    /// a few impacts per boat length, so the wake reads as a trail rather than dots.
    pub wake_spacing: f64,
    /// Horizontal speed from which a hull leaves a wake, m/s, in [0, 1000]. Default 1 m/s:
    /// above the orbital drift of a boat in a swell (a few tenths of a m/s), so only driven
    /// hulls leave wakes.
    pub wake_speed: f64,
    /// Height of a wake impact, m, in [0, 100] (0: no wake). Default 0.05 m.
    pub wake_strength: f64,
    /// Particle radius of a wake ring, m, in [0.01, 1000]. Default 0.5 m.
    pub wake_radius: f64,
}

impl Default for BodyImpactSpec {
    fn default() -> Self {
        Self {
            splash_speed: 2.0,
            splash_strength: 0.3,
            splash_radius: 1.0,
            wake_spacing: 4.0,
            wake_speed: 1.0,
            wake_strength: 0.05,
            wake_radius: 0.5,
        }
    }
}

/// One body's fixed step as the impact rules see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyStep {
    /// State at the start of the tick.
    pub before: BodyState,
    /// Submerged fraction at the end of the previous tick, [0, 1] (0 for a body never stepped).
    pub submerged_before: f64,
    /// State at the end of the tick.
    pub after: BodyState,
    /// Submerged fraction at the end of this tick, [0, 1].
    pub submerged_after: f64,
}

impl BodyImpactSpec {
    /// Checks the settings; `field` is the path of the `body_impacts` object.
    ///
    /// # Errors
    /// Any setting outside the range its doc gives, named with its path.
    pub fn validate(&self, field: &str) -> Result<(), SpecError> {
        let f = |name: &str| format!("{field}.{name}");
        positive_at_most(&f("splash_speed"), self.splash_speed, 100.0)?;
        in_range(
            &f("splash_strength"),
            self.splash_strength,
            0.0,
            MAX_STRENGTH,
        )?;
        in_range(
            &f("splash_radius"),
            self.splash_radius,
            MIN_IMPACT_RADIUS,
            MAX_IMPACT_RADIUS,
        )?;
        positive_at_most(&f("wake_spacing"), self.wake_spacing, 10_000.0)?;
        in_range(&f("wake_speed"), self.wake_speed, 0.0, 1000.0)?;
        in_range(&f("wake_strength"), self.wake_strength, 0.0, MAX_STRENGTH)?;
        in_range(
            &f("wake_radius"),
            self.wake_radius,
            MIN_IMPACT_RADIUS,
            MAX_IMPACT_RADIUS,
        )?;
        Ok(())
    }

    /// The splash of `step`, if it is one (see the module docs); `t` is the tick's end, s.
    pub fn splash(&self, step: &BodyStep, t: f64) -> Option<Impact> {
        let hit = step.submerged_before == 0.0
            && step.submerged_after > 0.0
            && -step.before.velocity.y >= self.splash_speed;
        (hit && self.splash_strength > 0.0).then_some(Impact {
            t,
            position: [step.after.position.x, step.after.position.z],
            strength: self.splash_strength,
            radius: self.splash_radius,
        })
    }

    /// The wake impact of `step`, if one is due (see the module docs). `travel` is the body's
    /// distance since its last wake impact, m (0 for a new body), updated here; `dt` the tick
    /// length, s; `t` the tick's end, s.
    pub fn wake(&self, step: &BodyStep, dt: f64, travel: &mut f64, t: f64) -> Option<Impact> {
        if self.wake_strength <= 0.0 || step.submerged_after <= 0.0 {
            return None;
        }
        let a = DVec2::new(step.before.position.x, step.before.position.z);
        let b = DVec2::new(step.after.position.x, step.after.position.z);
        let d = (b - a).length();
        if !(d.is_finite() && d / dt >= self.wake_speed && d > 0.0) {
            return None;
        }
        *travel += d;
        if *travel < self.wake_spacing {
            return None;
        }
        *travel -= self.wake_spacing;
        if *travel >= self.wake_spacing {
            *travel = 0.0;
        }
        Some(Impact {
            t,
            position: [b.x, b.y],
            strength: self.wake_strength,
            radius: self.wake_radius,
        })
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn state(x: f64, y: f64, vy: f64) -> BodyState {
        BodyState {
            velocity: DVec3::new(0.0, vy, 0.0),
            ..BodyState::at_rest(DVec3::new(x, y, 2.0), 0.0)
        }
    }

    #[test]
    fn a_fast_entry_splashes_and_a_slow_one_does_not() {
        let s = BodyImpactSpec::default();
        let step = |vy: f64, before: f64, after: f64| BodyStep {
            before: state(1.0, 0.5, vy),
            submerged_before: before,
            after: state(1.0, 0.4, vy),
            submerged_after: after,
        };
        let hit = s.splash(&step(-3.0, 0.0, 0.2), 10.0).unwrap();
        assert_eq!(hit.position, [1.0, 2.0]);
        assert_eq!((hit.t, hit.strength, hit.radius), (10.0, 0.3, 1.0));
        assert!(s.splash(&step(-1.0, 0.0, 0.2), 10.0).is_none(), "too slow");
        assert!(
            s.splash(&step(-3.0, 0.1, 0.2), 10.0).is_none(),
            "wet before"
        );
        assert!(s.splash(&step(-3.0, 0.0, 0.0), 10.0).is_none(), "still dry");
        let off = BodyImpactSpec {
            splash_strength: 0.0,
            ..s
        };
        assert!(off.splash(&step(-3.0, 0.0, 0.2), 10.0).is_none());
    }

    #[test]
    fn a_wake_drops_one_impact_per_spacing_travelled() {
        let s = BodyImpactSpec::default();
        let dt = 1.0 / 30.0;
        // 3 m/s along x: 0.1 m per tick, a wake impact every 40 ticks (4 m).
        let mut travel = 0.0;
        let mut drops = Vec::new();
        for k in 0..200 {
            let step = BodyStep {
                before: state(k as f64 * 0.1, 0.0, 0.0),
                submerged_before: 0.3,
                after: state((k + 1) as f64 * 0.1, 0.0, 0.0),
                submerged_after: 0.3,
            };
            if let Some(i) = s.wake(&step, dt, &mut travel, k as f64) {
                drops.push(i);
            }
        }
        assert_eq!(drops.len(), 5, "{drops:?}");
        for w in drops.windows(2) {
            let gap = w[1].position[0] - w[0].position[0];
            assert!((gap - 4.0).abs() < 0.1 + 1e-9, "gap {gap}");
        }
        // Slower than wake_speed, or out of the water: nothing, and the sum does not grow.
        let slow = BodyStep {
            before: state(0.0, 0.0, 0.0),
            submerged_before: 0.3,
            after: state(0.01, 0.0, 0.0),
            submerged_after: 0.3,
        };
        let before = travel;
        assert!(s.wake(&slow, dt, &mut travel, 0.0).is_none());
        assert_eq!(travel, before);
    }

    #[test]
    fn bad_settings_name_their_field() {
        let bad = BodyImpactSpec {
            wake_spacing: 0.0,
            ..Default::default()
        };
        let e = bad.validate("layers[1].body_impacts").unwrap_err();
        assert_eq!(e.field(), "layers[1].body_impacts.wake_spacing");
        let bad = BodyImpactSpec {
            splash_radius: f64::NAN,
            ..Default::default()
        };
        assert_eq!(bad.validate("b").unwrap_err().field(), "b.splash_radius");
        BodyImpactSpec::default().validate("b").unwrap();
    }
}
