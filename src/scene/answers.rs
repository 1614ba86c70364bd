//! Encoded answers a scene build shares with every request for them: the bytes of an answer
//! that is a pure function of the build (an FFT layer's `/spectrum` export), made once and
//! handed out as one [`Bytes`], instead of built and held whole per request.
//!
//! - **Keyed by build**: the cache lives on its [`super::Scene`], and a scene is immutable, so a
//!   replaced scene's answers can never be read for its successor (which starts with an empty
//!   cache). Within a build an [`AnswerKey`] names the answer and every query parameter that
//!   changes its bytes.
//! - **Made once**: requests that arrive while an answer is being made wait for it rather than
//!   make their own (single flight); a failed build leaves nothing behind, so the next request
//!   tries again.
//! - **Charged**: each answer's bytes are charged to the server's byte budget
//!   ([`crate::peers::Budget`], the one that holds bodies and answers not yet sent, in total
//!   only: the bytes are nobody's in particular) for as long as it is cached. An answer the
//!   budget cannot take is still served, uncached, to the request that made it.
//! - **Freed**: [`SceneAnswers::retire`] (called when the scene is replaced or deleted) drops
//!   every answer and its charge at once, and nothing is cached for a retired build after it,
//!   even by a request that was already making one. Bytes still being written to a client stay
//!   alive until that write ends, as any answer does.
//!
//! Bounded: at most one answer per key, and the keys of a build are its FFT layers (at most
//! [`swell_waves::surface::MAX_LAYERS`]); their bytes are within the byte budget.

use std::collections::BTreeMap;
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use bytes::Bytes;
use tokio::sync::OnceCell;

use crate::peers::{Budget, Charge};

/// Which answer of a build: the kind and the query parameters that change its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum AnswerKey {
    /// `GET …/spectrum?layer=N`: FFT layer N's `swell-spectrum/1` export.
    Spectrum {
        /// The layer index.
        layer: usize,
    },
}

/// One cached answer and its charge on the byte budget (given back when it drops).
#[derive(Debug)]
struct Cached {
    bytes: Bytes,
    _charge: Charge,
}

/// Why a build left nothing in the cache.
enum Miss<E> {
    /// The build failed.
    Failed(E),
    /// Built, but not cached (over the budget, or the build was retired meanwhile).
    Uncached(Bytes),
}

/// Counts a cache outcome in `swell_answer_cache_total{result}` and passes the bytes on.
fn count(result: &'static str, bytes: Bytes) -> Bytes {
    metrics::counter!("swell_answer_cache_total", "result" => result).increment(1);
    bytes
}

/// A scene build's cached answers (see the [module docs](self)).
#[derive(Debug, Default)]
pub struct SceneAnswers {
    inner: Mutex<Inner>,
    built: AtomicU64,
}

#[derive(Debug, Default)]
struct Inner {
    /// Set by [`SceneAnswers::retire`]: nothing is cached from then on.
    retired: bool,
    answers: BTreeMap<AnswerKey, Arc<OnceCell<Cached>>>,
}

impl SceneAnswers {
    /// The answer `key`: the cached bytes, or those `build` makes (once, whoever asks at the
    /// same time), cached while `budget` can hold them. The caller checks that `key` names an
    /// answer the build has (a layer it holds): that is what bounds the keys.
    ///
    /// # Errors
    /// `build`'s error (nothing is cached; the next request builds again).
    pub async fn get_or_build<E, F, Fut>(
        &self,
        key: AnswerKey,
        budget: &Arc<Budget>,
        build: F,
    ) -> Result<Bytes, E>
    where
        F: FnOnce() -> Fut,
        Fut: Future<Output = Result<Bytes, E>>,
    {
        let cell = {
            let mut inner = self.lock();
            if inner.retired {
                None
            } else {
                Some(Arc::clone(inner.answers.entry(key).or_default()))
            }
        };
        let Some(cell) = cell else {
            self.built.fetch_add(1, Ordering::Relaxed);
            return build().await.map(|b| count("uncached", b));
        };
        let mut made_here = false;
        let made = cell
            .get_or_try_init(|| async {
                let bytes = build().await.map_err(Miss::Failed)?;
                made_here = true;
                self.built.fetch_add(1, Ordering::Relaxed);
                let mut charge = budget.charge(None);
                // Under the lock, so a retire either sees this answer (and drops it) or ran
                // first (and this one is not kept).
                let inner = self.lock();
                if inner.retired || charge.grow(bytes.len()).is_err() {
                    return Err(Miss::Uncached(bytes));
                }
                drop(inner);
                Ok(Cached {
                    bytes,
                    _charge: charge,
                })
            })
            .await;
        let result = match made {
            Ok(c) => {
                let bytes = c.bytes.clone();
                return Ok(count(if made_here { "built" } else { "hit" }, bytes));
            }
            Err(Miss::Failed(e)) => Err(e),
            Err(Miss::Uncached(bytes)) => Ok(count("uncached", bytes)),
        };
        // An empty cell would be tried again by the next request anyway; dropping it keeps a
        // retired or over-budget build from holding cells.
        let mut inner = self.lock();
        if inner
            .answers
            .get(&key)
            .is_some_and(|c| Arc::ptr_eq(c, &cell) && !c.initialized())
        {
            inner.answers.remove(&key);
        }
        result
    }

    /// Drops every answer and its charge, and caches nothing more: the build was replaced or
    /// deleted.
    pub fn retire(&self) {
        let answers = {
            let mut inner = self.lock();
            inner.retired = true;
            std::mem::take(&mut inner.answers)
        };
        drop(answers);
    }

    /// Answers built so far (cached or not): what the cache saved is the requests beyond it.
    pub fn builds(&self) -> u64 {
        self.built.load(Ordering::Relaxed)
    }

    /// Bytes cached now.
    pub fn cached_bytes(&self) -> usize {
        self.lock()
            .answers
            .values()
            .filter_map(|c| c.get())
            .map(|c| c.bytes.len())
            .sum()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // Each operation leaves the map consistent, so a poisoned lock is still usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }
}
