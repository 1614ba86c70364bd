//! Taking snapshots: the state the journal's records build up to, written so that a restart
//! replays only a short tail, and then the log compacted to that tail.
//!
//! A snapshot is taken while the server runs, without stopping writers: each part is read
//! under the lock its records are appended under, together with the journal position at that
//! moment (see [`Snapshot`]). Admin changes are folded by the journal itself; each scene's body
//! world is read under its own lock, so its `seq` is exactly the last body record it includes.

use std::collections::BTreeMap;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use super::record::BodiesSnapshot;
use super::{Journal, Op, Snapshot};
use crate::bodies::SceneBodies;
use crate::scene::store::unix_now;
use crate::state::AppState;

/// When snapshots are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotPolicy {
    /// A snapshot at least this often while anything was journaled. Bounds the replay after a
    /// crash to this much wall time of changes (body steps between changes are replayed too:
    /// an idle scene with bodies replays at most this long a stretch of its trajectory).
    pub interval: Duration,
    /// A snapshot as soon as this many records were journaled since the last: bounds the log.
    pub max_records: usize,
}

impl Default for SnapshotPolicy {
    /// Every 30 s or 10,000 records: a replay of at most ~900 ticks per scene at 30 Hz (well
    /// under a second for 100 bodies) and a log of a few MiB at most.
    fn default() -> Self {
        SnapshotPolicy {
            interval: Duration::from_secs(30),
            max_records: 10_000,
        }
    }
}

/// Journals a scene's body changes made under the lock the caller holds (`bodies`); returns the
/// seq of the last (0 if there were none). Call before releasing the lock.
///
/// # Errors
/// The journal could not be written.
pub fn append_body_events(
    journal: Option<&Journal>,
    scene: &str,
    bodies: &mut SceneBodies,
) -> std::io::Result<u64> {
    let events = bodies.take_events();
    let Some(journal) = journal else {
        return Ok(0);
    };
    journal.append_all(events.into_iter().map(|event| Op::Body {
        scene: scene.to_owned(),
        event,
    }))
}

/// Takes a snapshot and compacts the log. Blocking: call from `spawn_blocking`.
///
/// # Errors
/// I/O writing the snapshot or the compacted log (both are left as they were then).
pub fn take(state: &AppState, journal: &Journal) -> std::io::Result<()> {
    let (admin_seq, admin) = journal.admin();
    // Read before listing the worlds: a world made after the listing journals its `created`
    // after this position, so its records are all replayed.
    let bodies_seq = journal.last_seq();
    let mut bodies = BTreeMap::new();
    for (id, cell) in state.bodies.cells() {
        let mut b = cell.lock();
        append_body_events(Some(journal), &id, &mut b)?;
        let seq = journal.last_seq();
        bodies.insert(
            id,
            BodiesSnapshot {
                seq,
                world: b.world_record(),
            },
        );
    }
    let snap = Snapshot {
        unix: unix_now(),
        admin_seq,
        admin,
        bodies_seq,
        bodies,
    };
    // The snapshot's records must be durable before the log loses them; `write_snapshot`
    // rewrites (and fsyncs) the tail it keeps.
    journal.write_snapshot(&snap)
}

/// Takes snapshots by `policy` until `shutdown` fires. (The final snapshot at shutdown is the
/// server's, after the body loops have stopped.)
pub async fn run(
    state: AppState,
    journal: Journal,
    policy: SnapshotPolicy,
    shutdown: CancellationToken,
) {
    // Checking once a second is cheap (a counter under a lock) and keeps a burst of records
    // from growing the log for long.
    let check = policy.interval.min(Duration::from_secs(1));
    let mut last = tokio::time::Instant::now();
    let mut last_seq = journal.last_seq();
    loop {
        tokio::select! {
            () = shutdown.cancelled() => return,
            () = tokio::time::sleep(check) => {}
        }
        let seq = journal.last_seq();
        let new_records = seq.saturating_sub(last_seq);
        // Bodies move without records: a snapshot also bounds how far their replay steps.
        let moving = state
            .bodies
            .cells()
            .iter()
            .any(|(_, c)| !c.lock().is_empty());
        let due = new_records >= policy.max_records as u64
            || (last.elapsed() >= policy.interval && (new_records > 0 || moving));
        if !due {
            continue;
        }
        let (s, j) = (state.clone(), journal.clone());
        match tokio::task::spawn_blocking(move || take(&s, &j)).await {
            Ok(Ok(())) => {
                last = tokio::time::Instant::now();
                last_seq = journal.last_seq();
            }
            Ok(Err(e)) => tracing::error!(error = %e, "journal: snapshot failed; will retry"),
            Err(e) => tracing::error!(error = %e, "journal: snapshot task panicked"),
        }
    }
}
