//! Where acknowledged admin changes live, and how every replica learns of them.
//!
//! Two backends share the server code ([`crate::state::AppState`] calls [`Backend`] through
//! one `match` per admin operation):
//!
//! - [`Backend::Local`] — the data dir's journal ([`crate::journal`]): one process, every change
//!   fsynced before its answer. The embedded default (`swell serve` needs nothing else).
//! - [`Backend::Redis`] — a [`fleet::Fleet`]: scene specs, deletions and clock anchors live in
//!   Redis, written atomically with an entry of a change feed (a Redis Stream) that every replica
//!   reads and applies in stream order, the writer included (read-your-writes: an admin request
//!   is answered once its own replica has applied it). `swell serve --store redis://…`.
//!
//! # Layout
//! - [`fleet`] — the Redis backend: connection pooling (one multiplexed connection manager for
//!   writes, one dedicated connection for the feed), timeouts, reconnects with backoff, the
//!   feed loop and the full re-read on every (re)connect.
//! - [`bodies`] — floating bodies across a fleet: a sequenced per-scene log in Redis (a lease
//!   holder appends watermarks), every replica stepping its copy from it to the same bits.
//! - [`apply`] — applying one admin change to the in-memory registry (shared by the feed and
//!   the full re-read).
//! - [`url`] — parsing `--store`.

pub mod apply;
pub mod bodies;
pub mod fleet;
pub mod url;

pub use bodies::FleetBodies;
pub use fleet::Fleet;
pub use url::StoreUrl;

/// The backend admin changes go through.
#[derive(Debug, Clone, Copy)]
pub enum Backend<'a> {
    /// The data dir journal, or nothing (in memory only) without a data dir.
    Local(Option<&'a crate::journal::Journal>),
    /// Redis, shared by the fleet.
    Redis(&'a Fleet),
}
