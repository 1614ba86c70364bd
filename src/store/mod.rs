//! A fleet's store: acknowledged changes in Redis, and how every replica learns of them
//! ([`shared::Shared`], one implementation of [`crate::state::store::Store`]; the other is the
//! data dir's journal, [`crate::state::store::Local`]).
//!
//! Scene specs, deletions and clock anchors live in Redis, written atomically with an entry of a
//! change feed (a Redis Stream) that every replica reads and applies in stream order
//! ([`crate::state::AppState::apply`]), the writer included (read-your-writes: an admin request
//! is answered once its own replica has applied it). `swell serve --store redis://…`.
//!
//! # Layout
//! - [`fleet`] — admin changes and impacts: connection pooling (one multiplexed connection
//!   manager for writes, one dedicated connection for the feed), timeouts, reconnects with
//!   backoff, the feed loop and the full re-read on every (re)connect.
//! - [`bodies`] — floating bodies across a fleet: a sequenced per-scene log in Redis (a lease
//!   holder appends watermarks), every replica stepping its copy from it to the same bits.
//! - [`shared`] — the two as the store of a replica.
//! - [`url`] — parsing `--store`.

pub mod bodies;
pub mod fleet;
pub mod shared;
pub mod url;

pub use bodies::FleetBodies;
pub use fleet::Fleet;
pub use url::StoreUrl;
