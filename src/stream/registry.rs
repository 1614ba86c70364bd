//! The registry of running tick loops, by scene id: the one piece of the stream that
//! [`crate::state::AppState`] holds ([`crate::stream::ticks`] starts and ends the loops).

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use super::fanout::TickLoop;

/// The registry of running tick loops, by scene id.
#[derive(Debug, Default)]
pub struct Tickers {
    loops: Mutex<BTreeMap<String, Arc<TickLoop>>>,
}

impl Tickers {
    /// The loops, locked.
    pub(crate) fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<String, Arc<TickLoop>>> {
        // Entries are inserted and removed whole: a poisoned map is still consistent.
        self.loops.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Number of running loops.
    pub fn running(&self) -> usize {
        self.lock().len()
    }

    /// Scene `id`'s loop, if one runs.
    pub fn get(&self, id: &str) -> Option<Arc<TickLoop>> {
        self.lock().get(id).cloned()
    }
}
