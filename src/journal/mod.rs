//! The journal: every acknowledged change, durable before its answer goes out.
//!
//! An append-only log (`<data dir>/journal/journal.log`) of [`Record`]s plus a snapshot
//! (`snapshot.bin`) of the state they build up to. A change is applied in memory and appended
//! while its lock is held (so the log's order is the order changes were made), then the
//! request waits in [`Journal::commit`] until an fsync covers it. Commits are grouped: one
//! fsync covers every record written before it, and concurrent requests wait for the same one.
//!
//! A snapshot ([`crate::state::snapshots::take`]) folds the log into `snapshot.bin` (written atomically) and
//! then compacts: the log is rewritten with only the records the snapshot does not include. A
//! restart loads the snapshot and replays the short tail ([`crate::state::restore`]). Bodies are stepped on
//! replay exactly as they were live (see [`crate::bodies::event`]), so a restarted server
//! continues the same trajectories to the bit.
//!
//! # Files ([`FORMAT`] = 1)
//! Both files are framed by [`frame`]: a 16-byte header (magic `SWELLJNL` for the log,
//! `SWELLSNP` for the snapshot, then the format as u32 LE and four zero bytes), then records of
//! `A5 53 57 52 | len u32 LE | CRC-32 u32 LE | payload`. A payload is one JSON [`Record`]
//! (`{"seq":7,"op":{"body":{"scene":"calm","event":{"input":{...}}}}}`); the snapshot holds one
//! record whose payload is a JSON [`Snapshot`].
//!
//! # Damage
//! Nothing read from disk stops the server from starting. A torn or corrupt record is found by
//! its checksum, logged with its offset, and skipped (with the records after it); a file whose
//! header is not ours or is of an unknown format, and a snapshot that does not decode, is moved
//! aside (`<name>.damaged-<unix seconds>`) for an operator to look at, and the server starts
//! from what is left. A log with damage is rewritten clean at start-up, so new records never
//! land after garbage.
//!
//! All I/O here blocks: call it from `spawn_blocking` ([`Journal::commit`] does).

pub mod frame;
pub mod record;
pub mod snapshot;

use std::collections::VecDeque;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

pub use record::{AdminScene, AdminState, Op, Record, Snapshot};

use crate::scene::store::{unix_now, write_atomic};

/// Version of the journal's files. A change to the framing or to the meaning of a record is a
/// new version; an older server moves a file of a newer version aside instead of misreading it.
pub const FORMAT: u32 = 1;
/// Magic of the log file.
pub const LOG_MAGIC: &[u8; 8] = b"SWELLJNL";
/// Magic of the snapshot file.
pub const SNAPSHOT_MAGIC: &[u8; 8] = b"SWELLSNP";
const LOG_FILE: &str = "journal.log";
const SNAPSHOT_FILE: &str = "snapshot.bin";

/// The journal of one data dir. Cheap to clone.
#[derive(Debug, Clone)]
pub struct Journal(Arc<Inner>);

#[derive(Debug)]
struct Inner {
    dir: PathBuf,
    /// `<dir>/lock`, held with an exclusive `flock` for the journal's life: a second process
    /// on the same data dir would interleave its records and compactions with ours and lose
    /// acknowledged writes, so it is refused at open ([`lock_dir`]).
    _lock: File,
    /// Appends. Held for a `write` of one record; taken after any domain lock (scene admin
    /// lock, a scene's body lock), never before one.
    writer: Mutex<Writer>,
    /// The last seq an fsync covered. Held across the fsync, so waiting committers queue here
    /// and find their record covered when they get it (group commit). Taken before `writer`.
    synced: Mutex<u64>,
}

#[derive(Debug)]
struct Writer {
    file: Arc<File>,
    /// Bytes in the file (where the next record goes).
    len: u64,
    /// The seq of the last record written.
    last_seq: u64,
    /// Records written since the last compaction, `(seq, framed bytes)`: what compaction keeps
    /// of them is rewritten from here, without reading the file back.
    tail: VecDeque<(u64, Vec<u8>)>,
    /// Admin changes folded, for the next snapshot.
    admin: AdminState,
    /// Whether the last write failed (the file was cut back; the next write tries again).
    failed: bool,
}

/// What [`Journal::open`] found on disk.
#[derive(Debug, Default)]
pub struct Recovered {
    /// The snapshot, if one was readable.
    pub snapshot: Option<Snapshot>,
    /// Valid log records after what the snapshot fully includes, in order.
    pub records: Vec<Record>,
    /// Problems found (each already logged), for tests and the start-up summary.
    pub problems: Vec<String>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // Every critical section leaves its data consistent before anything that can panic.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Journal {
    /// Opens (creating) `<data_dir>/journal` and reads what is there. Never fails on what it
    /// reads (see the module docs); fails only if the directory or a fresh log cannot be made.
    ///
    /// # Errors
    /// I/O creating the directory or writing the log.
    pub fn open(data_dir: &Path) -> std::io::Result<(Journal, Recovered)> {
        let dir = data_dir.join("journal");
        fs::create_dir_all(&dir)?;
        let lock = lock_dir(&dir)?;
        let mut rec = Recovered::default();
        let snapshot = read_snapshot(&dir, &mut rec.problems);
        let log_path = dir.join(LOG_FILE);
        let (frames, clean, keep_copy) = read_log(&log_path, &mut rec.problems);
        if keep_copy {
            // The log is rewritten from what could be read below: keep what could not.
            copy_aside(&log_path, &mut rec.problems);
        }
        let mut admin = snapshot
            .as_ref()
            .map(|s| s.admin.clone())
            .unwrap_or_default();
        let base = snapshot.as_ref().map_or(0, Snapshot::cut);
        let mut last_seq = snapshot.as_ref().map_or(0, Snapshot::max_seq);
        let mut tail = VecDeque::new();
        let mut prev: Option<u64> = None;
        for (record, bytes) in frames {
            if record.seq <= base {
                continue; // Already in the snapshot (a crash between snapshot and compaction).
            }
            if prev.is_some_and(|p| record.seq <= p) {
                let why = format!("record seq {} out of order; skipped", record.seq);
                tracing::error!(path = %log_path.display(), "journal: {why}");
                rec.problems.push(why);
                continue;
            }
            // (A gap in a clean log was reported when the damage that made it was found.)
            if let Some(p) = prev
                && record.seq > p + 1
                && !clean
            {
                let why = format!("records {}..={} are missing", p + 1, record.seq - 1);
                tracing::error!(path = %log_path.display(), "journal: {why}");
                rec.problems.push(why);
            }
            prev = Some(record.seq);
            if record.op.is_admin() && snapshot.as_ref().is_none_or(|s| record.seq > s.admin_seq) {
                admin.apply(&record.op);
            }
            last_seq = last_seq.max(record.seq);
            tail.push_back((record.seq, bytes));
            rec.records.push(record);
        }
        // A clean log is appended to; anything else is rewritten from the records that were
        // read, so new records never land after damage.
        let file = if clean {
            OpenOptions::new().append(true).open(&log_path)?
        } else {
            rewrite_log(&log_path, tail.iter().map(|(_, b)| b.as_slice()))?
        };
        let len = file.metadata()?.len();
        rec.snapshot = snapshot;
        let journal = Journal(Arc::new(Inner {
            dir,
            _lock: lock,
            writer: Mutex::new(Writer {
                file: Arc::new(file),
                len,
                last_seq,
                tail,
                admin,
                failed: false,
            }),
            synced: Mutex::new(last_seq),
        }));
        Ok((journal, rec))
    }

    /// Appends a change (written to the file, not yet fsynced) and returns its seq. Call while
    /// holding the lock under which the change was made.
    ///
    /// # Errors
    /// The write failed; the file is cut back to before the record, so the log stays readable.
    pub fn append(&self, op: Op) -> std::io::Result<u64> {
        let mut w = lock(&self.0.writer);
        let seq = w.last_seq + 1;
        let record = Record { seq, op };
        let payload = serde_json::to_vec(&record).map_err(std::io::Error::other)?;
        let bytes = frame::encode(&payload);
        let result = (&*w.file).write_all(&bytes);
        if let Err(e) = result {
            // A partial write would hide every later record behind damage: cut it off.
            let len = w.len;
            if let Err(e2) = w.file.set_len(len) {
                tracing::error!(error = %e2, "journal: could not cut a failed write back");
            }
            w.failed = true;
            return Err(e);
        }
        if w.failed {
            tracing::info!("journal: writing again");
            w.failed = false;
        }
        w.len += bytes.len() as u64;
        w.last_seq = seq;
        w.admin.apply(&record.op);
        w.tail.push_back((seq, bytes));
        metrics::counter!("swell_journal_records_total").increment(1);
        Ok(seq)
    }

    /// Appends several changes; the seq of the last (0 for none).
    ///
    /// # Errors
    /// As [`Journal::append`]; the ones before the failure stay written.
    pub fn append_all(&self, ops: impl IntoIterator<Item = Op>) -> std::io::Result<u64> {
        let mut last = 0;
        for op in ops {
            last = self.append(op)?;
        }
        Ok(last)
    }

    /// Blocks until an fsync covers record `seq` (group commit: one fsync covers every record
    /// written before it).
    ///
    /// # Errors
    /// The fsync failed.
    pub fn sync_blocking(&self, seq: u64) -> std::io::Result<()> {
        let mut synced = lock(&self.0.synced);
        if *synced >= seq {
            return Ok(());
        }
        let (file, upto) = {
            let w = lock(&self.0.writer);
            (w.file.clone(), w.last_seq)
        };
        let start = std::time::Instant::now();
        file.sync_data()?;
        metrics::histogram!("swell_journal_fsync_seconds").record(start.elapsed().as_secs_f64());
        *synced = upto;
        Ok(())
    }

    /// Waits until record `seq` is durable (off the reactor).
    ///
    /// # Errors
    /// The fsync failed or its task panicked.
    pub async fn commit(&self, seq: u64) -> std::io::Result<()> {
        if seq == 0 {
            return Ok(());
        }
        let j = self.clone();
        tokio::task::spawn_blocking(move || j.sync_blocking(seq))
            .await
            .map_err(std::io::Error::other)?
    }

    /// The seq of the last record written.
    pub fn last_seq(&self) -> u64 {
        lock(&self.0.writer).last_seq
    }

    /// Records written since the last compaction.
    pub fn tail_len(&self) -> usize {
        lock(&self.0.writer).tail.len()
    }

    /// Admin changes folded so far and the seq they include.
    pub fn admin(&self) -> (u64, AdminState) {
        let w = lock(&self.0.writer);
        (w.last_seq, w.admin.clone())
    }

    /// Writes `snap` atomically as the snapshot, then compacts the log to the records after
    /// [`Snapshot::cut`]. A crash between the two leaves records the snapshot includes in the
    /// log; replay skips them by seq.
    ///
    /// # Errors
    /// I/O; on failure the old snapshot and log are left as they were.
    pub fn write_snapshot(&self, snap: &Snapshot) -> std::io::Result<()> {
        let payload = serde_json::to_vec(snap).map_err(std::io::Error::other)?;
        let mut bytes = frame::header(SNAPSHOT_MAGIC, FORMAT).to_vec();
        bytes.extend_from_slice(&frame::encode(&payload));
        write_atomic(&self.0.dir.join(SNAPSHOT_FILE), &bytes)?;
        // Compaction: `synced` first, then `writer` (the order `sync_blocking` takes them).
        let cut = snap.cut();
        let mut synced = lock(&self.0.synced);
        let mut w = lock(&self.0.writer);
        while w.tail.front().is_some_and(|(seq, _)| *seq <= cut) {
            w.tail.pop_front();
        }
        let path = self.0.dir.join(LOG_FILE);
        let file = rewrite_log(&path, w.tail.iter().map(|(_, b)| b.as_slice()))?;
        w.len = file.metadata()?.len();
        w.file = Arc::new(file);
        // The rewritten log was fsynced whole.
        *synced = w.last_seq;
        metrics::counter!("swell_journal_snapshots_total").increment(1);
        tracing::debug!(
            cut,
            kept = w.tail.len(),
            bytes = payload.len(),
            "journal: snapshot written, log compacted"
        );
        Ok(())
    }
}

/// Writes a fresh log (header + `frames`) beside `path`, fsyncs it and renames it over `path`;
/// returns it opened for appending.
fn rewrite_log<'a>(path: &Path, frames: impl Iterator<Item = &'a [u8]>) -> std::io::Result<File> {
    let mut bytes = frame::header(LOG_MAGIC, FORMAT).to_vec();
    for f in frames {
        bytes.extend_from_slice(f);
    }
    write_atomic(path, &bytes)?;
    OpenOptions::new().append(true).open(path)
}

/// Opens `<dir>/lock` and takes an exclusive, non-blocking `flock` on it (released when the
/// file closes, also when the process dies).
///
/// # Errors
/// Another process (or another journal in this one) holds it: [`std::io::ErrorKind::WouldBlock`]
/// with a message naming the dir; or the file cannot be opened.
fn lock_dir(dir: &Path) -> std::io::Result<File> {
    let path = dir.join("lock");
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: a valid open descriptor; flock only changes the lock on its open file.
        let rc = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if rc != 0 {
            let e = std::io::Error::last_os_error();
            return Err(if e.kind() == std::io::ErrorKind::WouldBlock {
                std::io::Error::new(
                    std::io::ErrorKind::WouldBlock,
                    format!(
                        "{} is in use by another swell process (one data dir per process: two \
                         would overwrite each other's records)",
                        dir.parent().unwrap_or(dir).display()
                    ),
                )
            } else {
                e
            });
        }
    }
    Ok(file)
}

/// Copies a file aside (`<name>.damaged-<unix seconds>`) before it is rewritten without the
/// parts that could not be read, and says so.
fn copy_aside(path: &Path, problems: &mut Vec<String>) {
    let mut aside = path.as_os_str().to_owned();
    aside.push(format!(".damaged-{}", unix_now() as u64));
    let aside = PathBuf::from(aside);
    match fs::copy(path, &aside) {
        Ok(_) => {
            let msg = format!(
                "{}: the unreadable parts are kept in {}",
                path.display(),
                aside.display()
            );
            tracing::error!("journal: {msg}");
            problems.push(msg);
        }
        Err(e) => tracing::error!(error = %e, "journal: could not copy a damaged log aside"),
    }
}

/// Moves a damaged file aside (never deletes it) and says so.
fn move_aside(path: &Path, why: &str, problems: &mut Vec<String>) {
    let mut aside = path.as_os_str().to_owned();
    aside.push(format!(".damaged-{}", unix_now() as u64));
    let aside = PathBuf::from(aside);
    let msg = format!("{}: {why}; moved to {}", path.display(), aside.display());
    tracing::error!("journal: {msg}");
    if let Err(e) = fs::rename(path, &aside) {
        tracing::error!(error = %e, "journal: could not move a damaged file aside");
    }
    problems.push(msg);
}

fn read_snapshot(dir: &Path, problems: &mut Vec<String>) -> Option<Snapshot> {
    let path = dir.join(SNAPSHOT_FILE);
    let bytes = match fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
        Err(e) => {
            let msg = format!("{}: {e}", path.display());
            tracing::error!("journal: {msg}");
            problems.push(msg);
            return None;
        }
    };
    match frame::read_header(&bytes, SNAPSHOT_MAGIC) {
        frame::Header::Version(FORMAT) => {}
        frame::Header::Version(v) => {
            move_aside(&path, &format!("unknown format {v}"), problems);
            return None;
        }
        frame::Header::Unrecognised => {
            move_aside(&path, "not a swell snapshot", problems);
            return None;
        }
    }
    let decoded = frame::decode(&bytes, frame::HEADER_LEN);
    let parsed = match decoded.records.first() {
        Some((_, payload)) if decoded.damage.is_empty() => {
            serde_json::from_slice::<Snapshot>(payload).map_err(|e| e.to_string())
        }
        _ => Err("checksum mismatch or torn".into()),
    };
    match parsed {
        Ok(s) => Some(s),
        Err(why) => {
            move_aside(&path, &why, problems);
            None
        }
    }
}

/// The log's valid records with their framed bytes, whether the file was clean (absent counts
/// as not clean: a fresh one is written), and whether it holds bytes that rewriting it would
/// drop beyond a torn tail (a damaged header, damage mid-log, a record that does not decode):
/// those are copied aside first. A torn tail, what a crash mid-append leaves, is not.
fn read_log(path: &Path, problems: &mut Vec<String>) -> (Vec<(Record, Vec<u8>)>, bool, bool) {
    let bytes = match fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (Vec::new(), false, false),
        Err(e) => {
            move_aside(path, &e.to_string(), problems);
            return (Vec::new(), false, false);
        }
    };
    let mut keep_copy = false;
    match frame::read_header(&bytes, LOG_MAGIC) {
        frame::Header::Version(FORMAT) => {}
        frame::Header::Version(v) => {
            move_aside(path, &format!("unknown format {v}"), problems);
            return (Vec::new(), false, false);
        }
        frame::Header::Unrecognised if bytes.len() < frame::HEADER_LEN => {
            // A crash while the first header was written: nothing was ever acknowledged.
            return (Vec::new(), false, false);
        }
        frame::Header::Unrecognised => {
            keep_copy = true;
            // Read it anyway: only the header may be damaged. The file is rewritten below.
            let msg = format!("{}: damaged header", path.display());
            tracing::error!("journal: {msg}");
            problems.push(msg);
        }
    }
    let decoded = frame::decode(&bytes, frame::HEADER_LEN);
    let mut clean = decoded.damage.is_empty()
        && frame::read_header(&bytes, LOG_MAGIC) == frame::Header::Version(FORMAT);
    keep_copy |= decoded.damage.iter().any(|d| !d.at_end);
    for d in &decoded.damage {
        let msg = format!(
            "{}: {} damaged bytes at offset {}{}; skipped",
            path.display(),
            d.len,
            d.offset,
            if d.at_end { " (torn tail)" } else { "" }
        );
        tracing::error!("journal: {msg}");
        problems.push(msg);
    }
    let mut out = Vec::with_capacity(decoded.records.len());
    for (offset, payload) in decoded.records {
        match serde_json::from_slice::<Record>(payload) {
            Ok(r) => out.push((r, frame::encode(payload))),
            Err(e) => {
                clean = false;
                keep_copy = true;
                let msg = format!(
                    "{}: record at offset {offset} does not decode ({e}); skipped",
                    path.display()
                );
                tracing::error!("journal: {msg}");
                problems.push(msg);
            }
        }
    }
    (out, clean, keep_copy)
}

#[cfg(test)]
mod tests;
