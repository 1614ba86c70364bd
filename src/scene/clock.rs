//! Scene time.
//!
//! `t = rate·(now − epoch) + offset` while running; `t = offset` while paused. `now` is seconds
//! on a monotonic clock (the caller supplies it: this struct never reads a clock, so its maths is
//! tested without waiting). Every change re-anchors (`offset ← t(now)`, `epoch ← now`) first, so
//! t is continuous through rate changes, pause and resume; only a seek jumps.

use serde::{Deserialize, Serialize};

/// A scene clock. Pure arithmetic on a caller-supplied `now` (seconds, monotonic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    epoch: f64,
    offset: f64,
    rate: f64,
    paused: bool,
}

/// A clock's state at one instant, as the API reports it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClockReading {
    /// Scene time, s.
    pub t: f64,
    /// `floor(t·tick_hz)`.
    pub tick: i64,
    /// Ticks per scene second.
    pub tick_hz: f64,
    /// Scene seconds per real second (negative runs backwards).
    pub rate: f64,
    /// Whether t is frozen.
    pub paused: bool,
}

impl Clock {
    /// A running clock at rate 1 that reads `t` at `now`.
    pub fn starting_at(now: f64, t: f64) -> Clock {
        Clock {
            epoch: now,
            offset: t,
            rate: 1.0,
            paused: false,
        }
    }

    /// A clock reading `t` at `now` with the given rate and pause state.
    pub fn with_state(now: f64, t: f64, rate: f64, paused: bool) -> Clock {
        Clock {
            epoch: now,
            offset: t,
            rate,
            paused,
        }
    }

    /// Scene time at `now`, s.
    pub fn t(&self, now: f64) -> f64 {
        if self.paused {
            self.offset
        } else {
            self.offset + self.rate * (now - self.epoch)
        }
    }

    /// The rate.
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Whether the clock is paused.
    pub fn paused(&self) -> bool {
        self.paused
    }

    fn anchor(&mut self, now: f64) {
        self.offset = self.t(now);
        self.epoch = now;
    }

    /// Sets the rate, keeping t continuous at `now`.
    pub fn set_rate(&mut self, now: f64, rate: f64) {
        self.anchor(now);
        self.rate = rate;
    }

    /// Pauses (t frozen at its value at `now`) or resumes (t continues from there).
    pub fn set_paused(&mut self, now: f64, paused: bool) {
        self.anchor(now);
        self.paused = paused;
    }

    /// Jumps to scene time `t` at `now` (rate and pause state unchanged).
    pub fn seek(&mut self, now: f64, t: f64) {
        self.epoch = now;
        self.offset = t;
    }

    /// The reading at `now`.
    pub fn read(&self, now: f64, tick_hz: f64) -> ClockReading {
        let t = self.t(now);
        ClockReading {
            t,
            tick: tick_of(t, tick_hz),
            tick_hz,
            rate: self.rate,
            paused: self.paused,
        }
    }
}

/// `floor(t·tick_hz)`, saturating at the ends of i64.
pub fn tick_of(t: f64, tick_hz: f64) -> i64 {
    // `as` saturates for out-of-range floats (and maps NaN to 0).
    (t * tick_hz).floor() as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_at_rate_one_from_start() {
        let c = Clock::starting_at(100.0, 5.0);
        assert_eq!(c.t(100.0), 5.0);
        assert_eq!(c.t(102.5), 7.5);
    }

    #[test]
    fn pause_then_resume_continues_from_paused_t() {
        let mut c = Clock::starting_at(0.0, 0.0);
        c.set_paused(10.0, true);
        assert_eq!(c.t(10.0), 10.0);
        assert_eq!(c.t(50.0), 10.0, "frozen while paused");
        c.set_paused(50.0, false);
        assert_eq!(c.t(50.0), 10.0, "resumes where it stopped");
        assert_eq!(c.t(53.0), 13.0);
    }

    #[test]
    fn rate_change_keeps_t_continuous() {
        let mut c = Clock::starting_at(0.0, 0.0);
        c.set_rate(4.0, 3.0);
        assert_eq!(c.t(4.0), 4.0);
        assert_eq!(c.t(6.0), 10.0);
        c.set_rate(6.0, -1.0);
        assert_eq!(c.t(6.0), 10.0);
        assert_eq!(c.t(8.0), 8.0, "negative rate runs backwards");
    }

    #[test]
    fn rate_change_while_paused_applies_on_resume() {
        let mut c = Clock::starting_at(0.0, 1.0);
        c.set_paused(1.0, true);
        c.set_rate(2.0, 2.0);
        assert_eq!(c.t(5.0), 2.0);
        c.set_paused(5.0, false);
        assert_eq!(c.t(6.0), 4.0);
    }

    #[test]
    fn seek_jumps_and_keeps_rate() {
        let mut c = Clock::starting_at(0.0, 0.0);
        c.set_rate(0.0, 2.0);
        c.seek(10.0, 100.0);
        assert_eq!(c.t(10.0), 100.0);
        assert_eq!(c.t(11.0), 102.0);
        c.set_paused(11.0, true);
        c.seek(12.0, -3.0);
        assert_eq!(c.t(20.0), -3.0);
    }

    #[test]
    fn tick_is_floor_of_t_times_rate() {
        assert_eq!(tick_of(1.0, 30.0), 30);
        assert_eq!(tick_of(1.01, 30.0), 30);
        assert_eq!(tick_of(-0.01, 30.0), -1);
        assert_eq!(tick_of(1e300, 30.0), i64::MAX);
        let r = Clock::starting_at(0.0, 2.0).read(0.5, 10.0);
        assert_eq!((r.t, r.tick, r.rate, r.paused), (2.5, 25, 1.0, false));
    }
}
