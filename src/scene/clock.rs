//! Scene time, anchored to wall time.
//!
//! `t = offset + rate·(now − anchor)` while running; `t = offset` while paused. `now` is Unix
//! time in seconds (f64), read through a [`WallClock`] that never goes backwards; the caller
//! supplies it (this struct never reads a clock, so its maths is tested without waiting). A
//! scene's clock starts from its *epoch*, the Unix time at which its `t = 0` at rate 1
//! ([`Clock::from_epoch`]): two processes with the same scene agree on `t` now, to within their
//! system clocks' skew, without talking to each other. Every change re-anchors
//! (`offset ← t(now)`, `anchor ← now`) first, so t is continuous through rate changes, pause and
//! resume; only a seek jumps.
//!
//! # Generation
//! Every admin change (seek, rate, pause: one `PUT …/clock` is one change) gives the clock the
//! next *generation*, a counter that clients read in every pong and `clock` event and use to
//! restart their clock fit (samples from before a change describe another clock). The
//! generation is part of the replicated clock record ([`crate::scene::store::ClockRecord`]):
//! the process that accepts the change computes `previous + 1` and writes it into the journal
//! or the fleet's feed, and every replay and every replica takes it from the record as it is.
//! So replicas and restarts agree on it without a counter of their own (a local counter would
//! count the changes each process happened to apply: a replica that joined later, or a restart
//! from a snapshot, would disagree).
//!
//! A new scene's clock, started from its epoch, is generation 0 (so is a deleted scene's when
//! it is put again: the delete took its clock with it). A scene put that moves the epoch of the
//! scene it replaces starts a fresh clock from the new epoch (rate 1, running) one generation
//! after the clock it replaces ([`Clock::restarted_from`]): for a client it is a clock change
//! like an admin's, and at the same generation the pongs of the two clocks could not be told
//! apart. The accepting process records that clock with the put (the journal's and the fleet
//! feed's `scene_put` op, and the fleet's stored clock record), so it is replicated as an admin
//! change's record is. A put that keeps the epoch keeps the clock.
//!
//! # The time limit
//! Every client time is bounded by `limits.max_time` ([`crate::Limits::check_time`]), so a
//! clock never runs past it either: a server gives its clocks that bound
//! ([`Clock::within`]), and a running clock that reaches ±bound *holds* there. It reads
//! exactly ±bound, as paused (its [`ClockReading::paused`] is true, so a client following the
//! clock stops too), with its rate and pause setting kept: a seek back inside, or a rate
//! towards the inside, runs it again from there. The hold is a pure function of the clock
//! record and the bound (no record marks it), so every replica with the same limits and every
//! restart reads the same `t`. A clock whose record lies beyond the bound (a bound lowered
//! since, an epoch far from now) reads ±bound, held, until its time comes back inside.
//!
//! When the hold starts or ends is a pure function too ([`Clock::next_hold_change`]): each
//! process times it on its own ([`Clock::until_hold_change`]), and every stream session of the
//! scene tells its client with a `clock` event ([`crate::stream`]), as for an admin change, so
//! a client following the clock stops at the bound instead of running past it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use std::time::Duration;

use serde::{Deserialize, Serialize};

/// The epoch of built-in and configured scenes that give none: 2026-01-01T00:00:00Z, Unix
/// seconds. Fixed, so every replica of a fleet (and every restart) agrees on their `t` now. Any
/// fixed past instant would do; this one keeps `t` well inside the f64 range where a scene
/// second has sub-nanosecond resolution for centuries.
pub const BUILTIN_EPOCH: f64 = 1_767_225_600.0;

/// A step back smaller than this (s) is not logged: concurrent readers of the system clock
/// race by microseconds, which the clamp absorbs silently.
const STEP_BACK_LOG_S: f64 = 0.01;

/// Unix time that never runs backwards: a system clock stepped back (NTP, an operator) is
/// clamped to the latest time already seen, and logged, so scene time at rate > 0 never runs
/// backwards and bodies never see time reverse.
///
/// Lock-free (it is read on every query without `t` and every tick): the latest time is kept
/// as f64 bits in an atomic, and for non-negative f64 the bit patterns order as the numbers do,
/// so `fetch_max` on the bits is a max on the times.
#[derive(Debug, Default)]
pub struct WallClock {
    /// Bits of the latest Unix time handed out (0 = 0.0).
    last: AtomicU64,
    /// Whether the clock is held (the system clock is behind `last`): logs once per step back.
    held: AtomicBool,
}

impl WallClock {
    /// Unix seconds now, never less than any earlier answer.
    pub fn now(&self) -> f64 {
        self.observe(crate::scene::store::unix_now())
    }

    /// `unix` clamped to never be less than an earlier answer (the clock logic of
    /// [`WallClock::now`], with the system time injected).
    pub fn observe(&self, unix: f64) -> f64 {
        // Before 1970 or NaN (a broken clock) counts as 0: the bit order holds for +0.0 up.
        let unix = if unix >= 0.0 { unix } else { 0.0 };
        let prev = f64::from_bits(self.last.fetch_max(unix.to_bits(), Ordering::AcqRel));
        if unix >= prev {
            if self.held.swap(false, Ordering::Relaxed) {
                tracing::info!(unix, "system clock caught up; scene clocks run again");
            }
            unix
        } else {
            // Two threads reading the system clock microseconds apart race here too; only a
            // real step back is worth a log line.
            if prev - unix > STEP_BACK_LOG_S && !self.held.swap(true, Ordering::Relaxed) {
                tracing::warn!(
                    back_s = prev - unix,
                    "system clock stepped backwards; scene clocks hold until it catches up"
                );
            }
            prev
        }
    }
}

/// A scene clock. Pure arithmetic on a caller-supplied `now` (Unix seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    anchor: f64,
    offset: f64,
    rate: f64,
    paused: bool,
    generation: u64,
    /// Largest |t| the clock reads (see the module docs); infinite until [`Clock::within`].
    bound: f64,
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
    /// Whether t is frozen: paused by an admin, or held at ±`limits.max_time` (see the module
    /// docs: t reads exactly ±`max_time` then).
    pub paused: bool,
    /// Unix time of the reading, s: `t` at another Unix time `u` is
    /// `t + rate·(u − unix)` (unless paused), so a client can follow the clock on its own.
    pub unix: f64,
    /// The clock's generation: one more after every admin change and every scene put that moves
    /// the scene's epoch (see the module docs).
    pub generation: u64,
}

impl Clock {
    /// A running clock at rate 1 that reads `t` at `now`.
    pub fn starting_at(now: f64, t: f64) -> Clock {
        Clock {
            anchor: now,
            offset: t,
            rate: 1.0,
            paused: false,
            generation: 0,
            bound: f64::INFINITY,
        }
    }

    /// A clock reading `t` at `now` with the given rate and pause state (generation 0; see
    /// [`Clock::with_generation`]).
    pub fn with_state(now: f64, t: f64, rate: f64, paused: bool) -> Clock {
        Clock {
            anchor: now,
            offset: t,
            rate,
            paused,
            generation: 0,
            bound: f64::INFINITY,
        }
    }

    /// The same clock at generation `generation` (as a replicated record gives it).
    #[must_use]
    pub fn with_generation(self, generation: u64) -> Clock {
        Clock { generation, ..self }
    }

    /// The same clock, holding at ±`max_t` (the server's `limits.max_time`; see the module
    /// docs). A `max_t` that is not a positive number leaves it unbounded.
    #[must_use]
    pub fn within(self, max_t: f64) -> Clock {
        let bound = if max_t > 0.0 { max_t } else { f64::INFINITY };
        Clock { bound, ..self }
    }

    /// The clock's generation (see the module docs).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Counts one admin change: the next generation (the accepting process calls this once
    /// per change, before recording it).
    pub fn next_generation(&mut self) {
        self.generation = self.generation.wrapping_add(1);
    }

    /// A running clock at rate 1 that reads `t = 0` at Unix time `epoch`.
    pub fn from_epoch(epoch: f64) -> Clock {
        Clock::starting_at(epoch, 0.0)
    }

    /// The clock a scene put that moves the scene's epoch leaves in place of this one: a fresh
    /// clock from `epoch` ([`Clock::from_epoch`], unbounded), one generation on (see the module
    /// docs).
    #[must_use]
    pub fn restarted_from(&self, epoch: f64) -> Clock {
        Clock::from_epoch(epoch).with_generation(self.generation.wrapping_add(1))
    }

    /// Scene time at `now`, s, within ±the bound ([`Clock::within`]).
    pub fn t(&self, now: f64) -> f64 {
        // min/max rather than clamp: no panic whatever the numbers.
        self.unbounded(now).min(self.bound).max(-self.bound)
    }

    /// Scene time at `now` from the record alone, before the bound.
    fn unbounded(&self, now: f64) -> f64 {
        if self.paused {
            self.offset
        } else {
            self.offset + self.rate * (now - self.anchor)
        }
    }

    /// Whether the clock runs but is held at ±the bound at `now` (see the module docs): it has
    /// reached the bound in the direction it runs, or its record lies beyond the bound.
    pub fn held(&self, now: f64) -> bool {
        if self.paused {
            return false;
        }
        let raw = self.unbounded(now);
        (raw >= self.bound && self.rate > 0.0)
            || (raw <= -self.bound && self.rate < 0.0)
            || raw.abs() > self.bound
    }

    /// Unix time at which [`Clock::held`] next changes after `now`, while the record stays as it
    /// is: when a running clock reaches the bound in its direction (`offset + rate·(u − anchor)
    /// = ±bound`), or when one whose record lies beyond the bound behind it comes back inside.
    /// `None` when it never changes: paused, rate 0, unbounded, or held at the bound ahead.
    /// Rounding may put the answer a hair before the change (or before `now`): a caller looks
    /// again at the time it gives, and again after that if the hold has not changed yet.
    pub fn next_hold_change(&self, now: f64) -> Option<f64> {
        if self.paused || self.rate == 0.0 || !self.bound.is_finite() {
            return None;
        }
        // The bound the clock runs towards, and the one it runs away from.
        let (ahead, behind) = if self.rate > 0.0 {
            (self.bound, -self.bound)
        } else {
            (-self.bound, self.bound)
        };
        let target = if !self.held(now) {
            ahead
        } else if (self.unbounded(now) - behind) * self.rate < 0.0 {
            // Beyond the bound behind it: comes back inside there.
            behind
        } else {
            return None;
        };
        Some(self.anchor + (target - self.offset) / self.rate)
    }

    /// Real time until a look at whether the hold changed ([`Clock::next_hold_change`]): a hair
    /// past the change, at least [`MIN_SLEEP`] (a change rounding put before `now` is looked at
    /// again without spinning) and at most [`HOLD_RECHECK`]. `None` when it never changes while
    /// the record stays as it is.
    pub fn until_hold_change(&self, now: f64) -> Option<Duration> {
        let at = self.next_hold_change(now)?;
        // Past the change by as much as a tick wait is (`until_next_tick`); a span that does not
        // fit a Duration is either behind `now` or far ahead.
        let wait = Duration::try_from_secs_f64(at - now + 1e-4).unwrap_or(if at > now {
            HOLD_RECHECK
        } else {
            MIN_SLEEP
        });
        Some(wait.clamp(MIN_SLEEP, HOLD_RECHECK))
    }

    /// The rate.
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Whether the clock is paused.
    pub fn paused(&self) -> bool {
        self.paused
    }

    fn reanchor(&mut self, now: f64) {
        self.offset = self.t(now);
        self.anchor = now;
    }

    /// Sets the rate, keeping t continuous at `now`.
    pub fn set_rate(&mut self, now: f64, rate: f64) {
        self.reanchor(now);
        self.rate = rate;
    }

    /// Pauses (t frozen at its value at `now`) or resumes (t continues from there).
    pub fn set_paused(&mut self, now: f64, paused: bool) {
        self.reanchor(now);
        self.paused = paused;
    }

    /// Jumps to scene time `t` at `now` (rate and pause state unchanged).
    pub fn seek(&mut self, now: f64, t: f64) {
        self.anchor = now;
        self.offset = t;
    }

    /// The reading at `now`: `paused` while the clock is paused or held ([`Clock::held`]).
    pub fn read(&self, now: f64, tick_hz: f64) -> ClockReading {
        let t = self.t(now);
        ClockReading {
            t,
            tick: tick_of(t, tick_hz),
            tick_hz,
            rate: self.rate,
            paused: self.paused || self.held(now),
            unix: now,
            generation: self.generation,
        }
    }
}

/// `floor(t·tick_hz)`, saturating at the ends of i64.
pub fn tick_of(t: f64, tick_hz: f64) -> i64 {
    // `as` saturates for out-of-range floats (and maps NaN to 0).
    (t * tick_hz).floor() as i64
}

// Tick timing: when the next tick boundary comes in real time. The tick loop
// ([`crate::stream::ticks`]), the body loop and a fleet's sequencer all wake on it.

/// Longest real time between two looks at the clock, so an admin clock change (resume, seek,
/// rate) shows within this delay even when the next tick is far away or the clock is paused.
pub const MAX_SLEEP: Duration = Duration::from_millis(50);
/// Shortest sleep: bounds the loop's wake-ups at 1 kHz (the highest tick rate a scene may ask
/// for) even when the clock is fast-forwarded.
pub const MIN_SLEEP: Duration = Duration::from_millis(1);
/// Longest real time between two looks at whether a clock's hold changed
/// ([`Clock::until_hold_change`]). The timer runs on the monotonic clock and the scene clock on
/// the system's, so a system clock stepped forwards brings a hold nearer than the timer planned:
/// the look after that is at most this late. One wake-up per 10 s per stream session costs
/// nothing beside its traffic; a shorter bound only makes that rare case less late.
pub const HOLD_RECHECK: Duration = Duration::from_secs(10);

/// Real time until the clock crosses the next tick boundary in its direction, clamped to
/// [`MIN_SLEEP`, `MAX_SLEEP`]. The body loop sleeps the same way, so both wake together.
pub fn until_next_tick(t: f64, tick: i64, tick_hz: f64, rate: f64, paused: bool) -> Duration {
    if paused || rate == 0.0 {
        return MAX_SLEEP;
    }
    let boundary = if rate > 0.0 {
        (tick + 1) as f64 / tick_hz
    } else {
        tick as f64 / tick_hz
    };
    let secs = (boundary - t) / rate;
    // Sleep a hair past the boundary so the reading after waking is in the new tick.
    Duration::try_from_secs_f64(secs + 1e-4)
        .unwrap_or(MIN_SLEEP)
        .clamp(MIN_SLEEP, MAX_SLEEP)
}

/// How early the async timer is asked to wake before a tick boundary. Its resolution is a
/// millisecond, and it rounds deadlines up, so a plain `tokio::time::sleep` to the boundary woke
/// 1.3 ms late on average (`swell_tick_lateness_seconds` under `swell-load stream`), and every
/// frame carried that delay. The body loop sleeps the rest on the blocking thread that then
/// steps ([`crate::state::bodies`]); the tick loop of a scene without bodies in
/// [`crate::stream::ticks::sleep_to_boundary`].
pub const COARSE_WAKE: Duration = Duration::from_millis(2);

/// Largest |rate| of a clock: a day per second is beyond any fast-forward a game needs.
pub const MAX_RATE: f64 = 86_400.0;

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

    /// A scene clock started from an epoch reads the same t in any process at the same Unix
    /// time, whenever that process started.
    #[test]
    fn clocks_from_the_same_epoch_agree_whenever_they_were_made() {
        let a = Clock::from_epoch(BUILTIN_EPOCH);
        let b = Clock::from_epoch(BUILTIN_EPOCH);
        let now = BUILTIN_EPOCH + 86_400.0 * 300.0 + 0.25;
        assert_eq!(a.t(now), b.t(now));
        assert_eq!(a.t(now), 86_400.0 * 300.0 + 0.25);
        assert_eq!(a.t(BUILTIN_EPOCH), 0.0);
    }

    /// A put that moves the epoch leaves a fresh clock one generation on: from the new epoch at
    /// rate 1, running and unbounded, whatever the replaced clock's rate, pause and bound.
    #[test]
    fn a_clock_restarted_from_an_epoch_is_fresh_and_one_generation_on() {
        let mut old = Clock::from_epoch(1000.0).within(50.0);
        old.set_rate(1010.0, -3.0);
        old.set_paused(1010.0, true);
        old.next_generation();
        let fresh = old.restarted_from(5000.0);
        assert_eq!(fresh, Clock::from_epoch(5000.0).with_generation(2));
        assert_eq!(fresh.t(1e6), 1e6 - 5000.0, "unbounded");
        assert_eq!(Clock::from_epoch(0.0).restarted_from(1.0).generation(), 1);
    }

    /// A system clock stepped back is held at the latest time seen (and runs again once it
    /// catches up), so a running scene clock never reads an earlier t than it already has.
    #[test]
    fn a_system_clock_stepped_back_never_runs_scene_time_backwards() {
        let w = WallClock::default();
        let c = Clock::from_epoch(1000.0);
        let mut last_t = f64::NEG_INFINITY;
        for unix in [
            1000.0, 1005.0, 1010.0, 1002.0, 1003.0, 1009.5, 1010.0, 1011.0, 1500.0,
        ] {
            let t = c.t(w.observe(unix));
            assert!(t >= last_t, "t went back from {last_t} to {t} at {unix}");
            last_t = t;
        }
        assert_eq!(w.observe(1004.0), 1500.0);
        assert_eq!(
            c.t(w.observe(1600.0)),
            600.0,
            "runs again after catching up"
        );
    }

    /// A running clock that reaches its bound holds there and reads as paused, keeping its
    /// rate; it used to run on past `limits.max_time`, so a client that echoed its `t` was
    /// refused. A rate back towards the inside runs it again from the bound.
    #[test]
    fn a_clock_holds_at_its_bound_and_a_rate_inwards_runs_it_again() {
        let mut c = Clock::starting_at(0.0, 90.0).within(100.0);
        assert_eq!((c.t(5.0), c.held(5.0)), (95.0, false));
        assert_eq!((c.t(10.0), c.held(10.0)), (100.0, true), "reached");
        assert_eq!((c.t(1e6), c.held(1e6)), (100.0, true), "holds");
        let r = c.read(1e6, 10.0);
        assert_eq!((r.t, r.tick, r.rate, r.paused), (100.0, 1000, 1.0, true));
        c.set_rate(1e6, -2.0);
        assert_eq!((c.t(1e6 + 1.0), c.held(1e6 + 1.0)), (98.0, false));
        // Backwards to the lower bound, exactly.
        assert_eq!((c.t(1e6 + 100.0), c.held(1e6 + 100.0)), (-100.0, true));
        assert_eq!(c.t(1e9), -100.0);
        // A seek to exactly the bound at rate 0 is frozen, not held; paused is paused.
        c.seek(1e9, 100.0);
        c.set_rate(1e9, 0.0);
        assert_eq!((c.t(2e9), c.held(2e9)), (100.0, false));
        c.set_rate(2e9, 5.0);
        c.set_paused(2e9, true);
        let r = c.read(3e9, 10.0);
        assert_eq!((r.t, r.paused, c.held(3e9)), (100.0, true, false));
        // Unbounded by default, and a bound that is not positive leaves it unbounded.
        let free = Clock::starting_at(0.0, 90.0);
        assert_eq!(free.t(1e6), 1e6 + 90.0);
        assert_eq!(free.within(0.0).t(1e6), 1e6 + 90.0);
        assert_eq!(free.within(f64::NAN).t(1e6), 1e6 + 90.0);
    }

    /// A record beyond the bound (an epoch far from now, a bound lowered since) reads the bound,
    /// held, whichever way it runs, until its time comes back inside.
    #[test]
    fn a_record_beyond_the_bound_reads_the_bound_until_it_comes_back() {
        let c = Clock::with_state(0.0, 150.0, -1.0, false).within(100.0);
        assert_eq!((c.t(10.0), c.held(10.0)), (100.0, true));
        assert_eq!((c.t(60.0), c.held(60.0)), (90.0, false));
        let c = Clock::from_epoch(1e11).within(1e10);
        assert_eq!((c.t(BUILTIN_EPOCH), c.held(BUILTIN_EPOCH)), (-1e10, true));
    }

    /// When the hold starts and ends, as a pure function of the record: the time a running
    /// clock reaches the bound ahead, or a record beyond the bound behind comes back inside;
    /// none while paused, frozen, unbounded or held at the bound ahead. `held` changes there.
    #[test]
    fn the_hold_changes_when_the_record_reaches_a_bound() {
        let flips = |c: &Clock, at: f64| !c.held(at - 1e-6) && c.held(at + 1e-6);
        // Forwards from 90 towards 100 at rate 2: held from now + 5.
        let c = Clock::with_state(1000.0, 90.0, 2.0, false).within(100.0);
        assert_eq!(c.next_hold_change(1000.0), Some(1005.0));
        assert_eq!(c.next_hold_change(1004.0), Some(1005.0));
        assert!(flips(&c, 1005.0));
        assert_eq!(c.next_hold_change(1005.0), None, "held at the bound ahead");
        assert_eq!(c.next_hold_change(2000.0), None);
        // Backwards to the lower bound, from exactly the upper one (not held: it runs inwards).
        let c = Clock::with_state(0.0, 100.0, -4.0, false).within(100.0);
        assert_eq!(c.next_hold_change(0.0), Some(50.0));
        assert!(flips(&c, 50.0));
        // Beyond the bound behind: held until it comes back inside, then the bound ahead.
        let c = Clock::with_state(0.0, -150.0, 1.0, false).within(100.0);
        assert!(c.held(10.0));
        assert_eq!(c.next_hold_change(10.0), Some(50.0));
        assert!(
            c.held(50.0 - 1e-6) && !c.held(50.0 + 1e-6),
            "runs again there"
        );
        assert_eq!(c.next_hold_change(60.0), Some(250.0));
        // Beyond the bound ahead: held, for good.
        let c = Clock::with_state(0.0, 150.0, 1.0, false).within(100.0);
        assert_eq!(c.next_hold_change(0.0), None);
        // Never: paused, rate 0, unbounded.
        for c in [
            Clock::with_state(0.0, 90.0, 1.0, true).within(100.0),
            Clock::with_state(0.0, 90.0, 0.0, false).within(100.0),
            Clock::with_state(0.0, 90.0, 1.0, false),
        ] {
            assert_eq!(c.next_hold_change(0.0), None, "{c:?}");
            assert_eq!(c.until_hold_change(0.0), None, "{c:?}");
        }
        // The timer: a hair past the change, clamped to [MIN_SLEEP, HOLD_RECHECK].
        let c = Clock::with_state(0.0, 99.0, 1.0, false).within(100.0);
        let d = c.until_hold_change(0.5).unwrap().as_secs_f64();
        assert!((d - (0.5 + 1e-4)).abs() < 1e-9, "{d}");
        assert_eq!(c.until_hold_change(0.99995), Some(MIN_SLEEP));
        assert_eq!(c.until_hold_change(2.0), None, "held by then");
        let far = Clock::from_epoch(0.0).within(1e10);
        assert_eq!(far.until_hold_change(1.0), Some(HOLD_RECHECK));
        let slow = Clock::with_state(0.0, 0.0, 1e-300, false).within(1e10);
        assert_eq!(
            slow.until_hold_change(0.0),
            Some(HOLD_RECHECK),
            "beyond a Duration"
        );
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
