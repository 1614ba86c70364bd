//! Taking journal snapshots of the registry ([`crate::journal::snapshot`] has the policy and
//! the format): a snapshot is taken while the server runs, without stopping writers. Each part is
//! read under the lock its records are appended under, together with the journal position at
//! that moment (see [`Snapshot`]). Admin changes are folded by the journal itself; each scene's
//! body world is read under its own lock, so its `seq` is exactly the last body record it
//! includes.

use std::collections::BTreeMap;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use super::AppState;
use crate::journal::record::BodiesSnapshot;
use crate::journal::snapshot::{SnapshotPolicy, append_body_events};
use crate::journal::{AdminScene, Journal, Snapshot};
use crate::scene::store::unix_now;

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
        // A world made before a delete of its scene that the admin part already holds: the
        // delete is journaled but its apply, which drops the world, has not run yet. Kept, the
        // world would outlive its scene and come back on a restart under a scene re-put with
        // the same id (restore skips the delete: its seq is below the world's).
        if matches!(admin.scenes.get(&id), Some(AdminScene::Deleted))
            && b.created_seq() <= admin_seq
        {
            continue;
        }
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
    loop {
        tokio::select! {
            () = shutdown.cancelled() => return,
            () = tokio::time::sleep(check) => {}
        }
        // Every record the log holds beyond the last snapshot, those read back at start
        // included: a server restarted again and again (or killed within its first second)
        // still compacts, so replay at start stays bounded.
        let new_records = journal.tail_len() as u64;
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
            Ok(Ok(())) => last = tokio::time::Instant::now(),
            Ok(Err(e)) => tracing::error!(error = %e, "journal: snapshot failed; will retry"),
            Err(e) => tracing::error!(error = %e, "journal: snapshot task panicked"),
        }
    }
}
