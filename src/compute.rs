//! The compute pool: where request work too big for the reactor runs — batch queries, decoding
//! large bodies, encoding large answers — on a fixed set of threads at a lower CPU priority
//! than the reactor.
//!
//! Why not tokio's blocking pool: it starts a thread per task (up to 512), so a hundred
//! clients posting 20,000-point samples at once made a hundred CPU-bound threads that each got
//! the same share of the two cores as the two reactor threads. Every cheap request, probe and
//! tick write then waited its turn behind them: the good client of `.ci/hostile` saw 100–220 ms
//! stalls in the first second of the attack, and encoding those answers on the reactor cost it
//! 2–13 ms stalls after that. Here the work queues (in turns by client, below) for
//! [`Limits::compute_threads`](crate::Limits::compute_threads) threads, and those threads run
//! at niceness [`Limits::compute_nice`](crate::Limits::compute_nice): the kernel gives the
//! reactor the cores first, and the pool everything the reactor leaves, so a saturated pool
//! slows batch answers, not the cheap ones. Alone on a machine the pool has every core it
//! would have had.
//!
//! Waiting work is served in turns by client address, one job per client per turn, first come
//! first served within a client: a client with a hundred large queries waiting delays another
//! client's one query by at most one job per thread, not by all hundred. The client is the one
//! admission resolved (through trusted proxies), carried to [`run`] by [`for_client`] around the
//! request or session; work outside any client shares one turn.
//!
//! One pool per process, started at the first use with the settings of the first server that
//! configured it ([`configure`]); a later server in the same process (tests) shares it. A job
//! whose caller went away (a cancelled request) before a thread took it is skipped. A job that
//! panics is caught and reported to its caller as [`Lost`]; the thread lives on.

use std::collections::{HashMap, VecDeque};
use std::net::IpAddr;
use std::sync::{Condvar, Mutex, OnceLock};

type Job = Box<dyn FnOnce() + Send>;

/// Whose work a job is (`None`: no client).
type Client = Option<IpAddr>;

tokio::task_local! {
    static CLIENT: Client;
}

/// Runs `f` with `client` as the client of every [`run`] inside it (on this task).
pub async fn for_client<F: Future>(client: Client, f: F) -> F::Output {
    CLIENT.scope(client, f).await
}

/// The client [`for_client`] set around the running task, if any.
pub fn current_client() -> Client {
    CLIENT.try_with(|c| *c).ok().flatten()
}

/// Jobs waiting, by client, and the order in which clients take their turns.
#[derive(Default)]
struct Waiting {
    jobs: HashMap<Client, VecDeque<Job>>,
    /// Clients with jobs waiting, the next to be served first.
    turns: VecDeque<Client>,
    /// Jobs waiting, all clients (`swell_compute_queued`).
    len: usize,
    /// The client of each job taken since [`log_starts`] (tests).
    started: Option<Vec<Client>>,
}

impl Waiting {
    fn push(&mut self, client: Client, job: Job) {
        let q = self.jobs.entry(client).or_default();
        if q.is_empty() {
            self.turns.push_back(client);
        }
        q.push_back(job);
        self.len += 1;
        publish(self.len);
    }

    /// The next client's oldest job; the client goes to the back of the turns if it has more.
    fn pop(&mut self) -> Option<Job> {
        let client = self.turns.pop_front()?;
        let q = self.jobs.get_mut(&client)?;
        let job = q.pop_front()?;
        if let Some(log) = &mut self.started {
            log.push(client);
        }
        if q.is_empty() {
            self.jobs.remove(&client);
        } else {
            self.turns.push_back(client);
        }
        self.len -= 1;
        publish(self.len);
        Some(job)
    }
}

/// The pool's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Settings {
    /// Threads (at least 1).
    pub threads: usize,
    /// Their niceness, 0–19 (0: the server's own priority).
    pub nice: i32,
}

impl Settings {
    /// From the limits: `compute_threads` 0 means one thread per core.
    pub fn from_limits(limits: &crate::Limits) -> Settings {
        let threads = match limits.compute_threads {
            0 => std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
            n => n,
        };
        Settings {
            threads,
            nice: limits.compute_nice.clamp(0, 19),
        }
    }
}

struct Pool {
    settings: Settings,
    waiting: Mutex<Waiting>,
    ready: Condvar,
}

static POOL: OnceLock<Pool> = OnceLock::new();
static WANTED: OnceLock<Settings> = OnceLock::new();

/// Sets the settings the pool starts with (once per process; the first call wins). Returns
/// the settings the pool has or will have, which differ from `settings` when another server
/// in this process configured it first.
pub fn configure(settings: Settings) -> Settings {
    let wanted = *WANTED.get_or_init(|| settings);
    POOL.get().map_or(wanted, |p| p.settings)
}

fn pool() -> &'static Pool {
    POOL.get_or_init(|| {
        let settings = *WANTED.get_or_init(|| Settings::from_limits(&crate::Limits::default()));
        // The threads wait on the pool itself, which is `'static` once this returns: they
        // take their first job only through `POOL`, after it is set.
        for i in 0..settings.threads.max(1) {
            let spawned = std::thread::Builder::new()
                .name(format!("swell-compute-{i}"))
                .spawn(move || worker(POOL.wait(), settings.nice));
            if let Err(e) = spawned {
                tracing::error!(error = %e, "could not start a compute thread");
            }
        }
        Pool {
            settings,
            waiting: Mutex::new(Waiting::default()),
            ready: Condvar::new(),
        }
    })
}

fn worker(pool: &Pool, nice: i32) {
    set_thread_nice(nice);
    loop {
        let job = {
            let Ok(mut w) = pool.waiting.lock() else {
                return;
            };
            loop {
                if let Some(job) = w.pop() {
                    break job;
                }
                w = match pool.ready.wait(w) {
                    Ok(w) => w,
                    Err(_) => return,
                };
            }
        };
        job();
    }
}

fn publish(queued: usize) {
    #[allow(clippy::cast_precision_loss)]
    metrics::gauge!("swell_compute_queued").set(queued as f64);
}

/// Lowers the calling thread's priority by `nice` steps below what it has (Linux:
/// `setpriority` on a thread id applies to that thread, and threads it starts inherit it), at
/// most to 19. Best effort: where it is refused the thread keeps the server's priority, and the
/// log says so once.
fn set_thread_nice(nice: i32) {
    if nice <= 0 {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        let r = thread_nice().and_then(|now| {
            let to = (now + nice).min(19);
            // SAFETY: gettid has no preconditions; setpriority takes plain integers.
            let r = unsafe {
                #[allow(clippy::cast_sign_loss)]
                libc::setpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t, to)
            };
            if r == 0 {
                Ok(())
            } else {
                Err(std::io::Error::last_os_error())
            }
        });
        if let Err(e) = r {
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| {
                tracing::warn!(error = %e, nice, "compute threads keep the server's priority (compute_nice)");
            });
        }
    }
}

/// The calling thread's niceness.
#[cfg(target_os = "linux")]
fn thread_nice() -> std::io::Result<i32> {
    // SAFETY: errno is the calling thread's; getpriority takes plain integers. -1 is a valid
    // niceness, so errno tells an error apart.
    unsafe {
        *libc::__errno_location() = 0;
        #[allow(clippy::cast_sign_loss)]
        let n = libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t);
        if n == -1 && *libc::__errno_location() != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(n)
    }
}

/// The job's thread panicked, or the pool could not take it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lost;

impl std::fmt::Display for Lost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the compute job panicked")
    }
}

impl std::error::Error for Lost {}

/// Runs `f` on the pool, in the turn of the client [`for_client`] set (if any), and waits for
/// its result without blocking the caller's thread. Dropping the returned future before a
/// thread took the job skips it.
///
/// # Errors
/// [`Lost`] when `f` panicked.
pub async fn run<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> Result<T, Lost> {
    run_for(current_client(), f).await
}

/// [`run`] in `client`'s turn.
///
/// # Errors
/// [`Lost`] when `f` panicked.
pub async fn run_for<T: Send + 'static>(
    client: Client,
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<T, Lost> {
    let (tx, rx) = tokio::sync::oneshot::channel();
    let job: Job = Box::new(move || {
        if tx.is_closed() {
            return;
        }
        if let Ok(v) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
            let _ = tx.send(v);
        }
    });
    let pool = pool();
    {
        let Ok(mut w) = pool.waiting.lock() else {
            return Err(Lost);
        };
        w.push(client, job);
        pool.ready.notify_one();
    }
    rx.await.map_err(|_| Lost)
}

/// Jobs waiting for a thread now (all clients).
pub fn queued() -> usize {
    pool().waiting.lock().map_or(0, |w| w.len)
}

/// Jobs of `client` waiting for a thread now (tests).
#[doc(hidden)]
pub fn queued_by(client: Client) -> usize {
    pool()
        .waiting
        .lock()
        .map_or(0, |w| w.jobs.get(&client).map_or(0, VecDeque::len))
}

/// Starts logging the client of every job a thread takes, in the order taken (tests: what the
/// turns do, seen from outside).
#[doc(hidden)]
pub fn log_starts() {
    if let Ok(mut w) = pool().waiting.lock() {
        w.started = Some(Vec::new());
    }
}

/// The log [`log_starts`] began, which ends here.
#[doc(hidden)]
pub fn take_starts() -> Vec<Client> {
    pool()
        .waiting
        .lock()
        .ok()
        .and_then(|mut w| w.started.take())
        .unwrap_or_default()
}

/// The pool's settings (starting it if it has not started).
pub fn settings() -> Settings {
    pool().settings
}

/// Every compute thread held by a job that waits for [`Held::release`], so that work sent
/// meanwhile queues: for tests of what the queue does. (Jobs queued before it may run first;
/// none runs for long.)
#[doc(hidden)]
pub struct Held {
    gate: std::sync::Arc<(Mutex<bool>, Condvar)>,
    holds: Vec<tokio::task::JoinHandle<Result<(), Lost>>>,
}

impl Held {
    /// Returns once every thread is held.
    pub async fn every_thread() -> Held {
        use std::sync::Arc;
        use std::sync::atomic::{AtomicUsize, Ordering};
        let threads = settings().threads;
        let gate = Arc::new((Mutex::new(false), Condvar::new()));
        let started = Arc::new(AtomicUsize::new(0));
        let holds = (0..threads)
            .map(|_| {
                let (g, n) = (Arc::clone(&gate), Arc::clone(&started));
                tokio::spawn(run(move || {
                    n.fetch_add(1, Ordering::SeqCst);
                    let (m, c) = &*g;
                    let mut open = m.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                    while !*open {
                        open = c
                            .wait(open)
                            .unwrap_or_else(std::sync::PoisonError::into_inner);
                    }
                }))
            })
            .collect();
        while started.load(Ordering::SeqCst) < threads {
            tokio::time::sleep(std::time::Duration::from_millis(1)).await;
        }
        Held { gate, holds }
    }

    /// Lets the threads go and waits until each holding job has ended.
    ///
    /// # Panics
    /// If a holding job was lost.
    pub async fn release(self) {
        {
            let (m, c) = &*self.gate;
            *m.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = true;
            c.notify_all();
        }
        for h in self.holds {
            h.await
                .expect("a holding job's task")
                .expect("a holding job");
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::Ordering;

    use super::*;

    #[tokio::test]
    async fn jobs_run_and_a_panic_is_reported_without_losing_the_thread() {
        assert_eq!(run(|| 6 * 7).await, Ok(42));
        let r = run(|| -> u32 { panic!("boom") }).await;
        assert_eq!(r, Err(Lost));
        // Every thread still takes work: more jobs than threads, all answered.
        let n = settings().threads * 4;
        let all = futures_util::future::join_all((0..n).map(|i| run(move || i * 2))).await;
        assert_eq!(all, (0..n).map(|i| Ok(i * 2)).collect::<Vec<_>>());
    }

    #[cfg(target_os = "linux")]
    #[tokio::test]
    async fn compute_threads_run_below_the_servers_priority() {
        let step = settings().nice;
        // Every thread of the test process has the niceness it started with, as the thread
        // that started the pool had.
        let here = thread_nice().unwrap();
        let got = run(|| thread_nice().unwrap()).await.unwrap();
        assert_eq!(got, (here + step).min(19));
        assert!(step > 0, "the default is a lower priority");
        assert_eq!(thread_nice().unwrap(), here, "the caller's priority moved");
    }

    /// Turns by client: one job each per turn, each client's own in the order sent.
    #[test]
    fn waiting_work_is_served_in_turns_by_client() {
        let order = Arc::new(Mutex::new(Vec::new()));
        let job = |name: &'static str| -> Job {
            let order = Arc::clone(&order);
            Box::new(move || order.lock().unwrap().push(name))
        };
        let (a, b) = (
            Some(IpAddr::from([10, 0, 0, 1])),
            Some(IpAddr::from([10, 0, 0, 2])),
        );
        let mut w = Waiting::default();
        for name in ["a1", "a2", "a3", "a4"] {
            w.push(a, job(name));
        }
        w.push(b, job("b1"));
        w.push(None, job("n1"));
        w.push(b, job("b2"));
        assert_eq!(w.len, 7);
        while let Some(j) = w.pop() {
            j();
        }
        assert_eq!(
            *order.lock().unwrap(),
            ["a1", "b1", "n1", "a2", "b2", "a3", "a4"]
        );
        assert!(w.jobs.is_empty() && w.turns.is_empty() && w.len == 0);
    }

    #[tokio::test]
    async fn the_client_set_around_a_task_is_its_jobs_client() {
        let ip = Some(IpAddr::from([192, 0, 2, 7]));
        assert_eq!(current_client(), None);
        assert_eq!(for_client(ip, async { current_client() }).await, ip);
        let seen = for_client(ip, async { run(current_client).await }).await;
        // The job itself runs on a pool thread, outside the task: it sees no client.
        assert_eq!(seen, Ok(None));
    }

    #[tokio::test]
    async fn a_job_whose_caller_left_is_skipped() {
        use std::sync::atomic::AtomicBool;
        // Fill every thread with a job that waits, so the next one queues.
        let threads = settings().threads;
        let held = Held::every_thread().await;
        let ran = Arc::new(AtomicBool::new(false));
        let r = Arc::clone(&ran);
        let queued = run(move || r.store(true, Ordering::SeqCst));
        // Polled once (so it is sent), then dropped: the caller left.
        let mut queued = Box::pin(queued);
        let waited = tokio::time::timeout(std::time::Duration::from_millis(20), queued.as_mut());
        assert!(
            waited.await.is_err(),
            "the job ran while every thread was held"
        );
        drop(queued);
        held.release().await;
        // Jobs sent after it run, so the skipped one was taken by then (first come, first
        // served), by a thread that has since taken another.
        for _ in 0..2 * threads {
            run(|| ()).await.unwrap();
        }
        assert!(!ran.load(Ordering::SeqCst), "the abandoned job ran");
    }
}
