//! Snapshots: the state the journal's records build up to, written so that a restart replays
//! only a short tail, and then the log compacted to that tail. Here: when they are taken
//! ([`SnapshotPolicy`]) and journaling a world's body changes; taking one reads the registry,
//! so that is the state layer's ([`crate::state::snapshots`]).
//!
//! A snapshot is taken while the server runs, without stopping writers: each part is read
//! under the lock its records are appended under, together with the journal position at that
//! moment (see [`super::Snapshot`]). Admin changes are folded by the journal itself; each
//! scene's body world is read under its own lock, so its `seq` is exactly the last body record
//! it includes.

use super::{Journal, Op};
use crate::bodies::SceneBodies;

pub use crate::config::SnapshotPolicy;

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
    let mut last = 0;
    for event in events {
        let created = matches!(event, crate::bodies::BodyEvent::Created { .. });
        last = journal.append(Op::Body {
            scene: scene.to_owned(),
            event,
        })?;
        if created {
            bodies.set_created_seq(last);
        }
    }
    Ok(last)
}
