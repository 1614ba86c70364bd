//! The registry of running tick loops, by scene id: the one piece of the stream that
//! [`crate::state::AppState`] holds ([`crate::stream::ticks`] starts and ends the loops).

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use tokio::sync::broadcast;

use super::frame::SharedTick;

/// The registry of running tick loops, by scene id.
#[derive(Debug, Default)]
pub struct Tickers {
    loops: Mutex<BTreeMap<String, broadcast::Sender<Arc<SharedTick>>>>,
}

impl Tickers {
    /// The loops, locked.
    pub(crate) fn lock(
        &self,
    ) -> std::sync::MutexGuard<'_, BTreeMap<String, broadcast::Sender<Arc<SharedTick>>>> {
        // Entries are inserted and removed whole: a poisoned map is still consistent.
        self.loops.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Number of running loops.
    pub fn running(&self) -> usize {
        self.lock().len()
    }
}
