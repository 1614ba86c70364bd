//! Persistence of admin changes in the data dir, so scenes and clocks survive a restart.
//!
//! Layout: `scenes/<id>.json` holds `{"format":1,"id","spec"}` for a scene put by an admin, or
//! `{"format":1,"id","deleted":true}` for a deleted one (so a deleted built-in stays deleted);
//! `clocks/<id>.json` holds `{"format":1,"t","rate","paused","unix"}`: the clock's reading at
//! wall-clock `unix` seconds; restored anchored there ([`ClockRecord::restore`]), so a running
//! clock has advanced by the wall time that passed and a paused one reads the same t.
//!
//! This per-file layout is what servers before the journal ([`crate::journal`]) wrote; it is
//! now only read, to import an old data dir. [`ClockRecord`] is also the journal's clock record.
//!
//! Every write is atomic: write `<name>.tmp`, fsync it, rename over `<name>`, fsync the directory.
//! A crash leaves either the old file or the new one, never half of one. All functions here do
//! blocking I/O: call them from `spawn_blocking`.

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Version of the files' layout.
const FORMAT: u32 = 1;

/// A persisted scene record.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneRecord {
    /// The scene's spec JSON (parsed again on restore, with today's rules).
    Put(Value),
    /// Deleted by an admin.
    Deleted,
}

/// A persisted clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClockRecord {
    /// Scene time at `unix`, s.
    pub t: f64,
    /// Rate.
    pub rate: f64,
    /// Paused.
    pub paused: bool,
    /// Wall-clock time of the reading, seconds since the Unix epoch.
    pub unix: f64,
    /// The clock's generation after this change ([`crate::scene::clock`]): written by the
    /// process that accepted the change, taken as it is by every replay and replica. Records
    /// written before generations existed read as 0.
    #[serde(default)]
    pub generation: u64,
}

impl ClockRecord {
    /// The record of `clock` read at Unix time `now` ([`ClockRecord::restore`] gives the clock
    /// back, anchored at `now`). `t` is as `clock` reads it, within its own bound: a clock that
    /// must keep a reading beyond the server's bound (a fresh clock from a far epoch) is
    /// recorded unbounded, and bounded again where it is restored.
    pub fn of(clock: &crate::scene::clock::Clock, now: f64) -> ClockRecord {
        ClockRecord {
            t: clock.t(now),
            rate: clock.rate(),
            paused: clock.paused(),
            unix: now,
            generation: clock.generation(),
        }
    }

    /// The clock this reading gives: anchored at the reading's own Unix time, so every process
    /// that loads it agrees on `t` at any instant. A wall clock now behind the reading (stepped
    /// back, or another machine's) anchors it at `now` instead, so it never reads a `t` earlier
    /// than the one recorded.
    pub fn restore(&self, now: f64) -> crate::scene::clock::Clock {
        crate::scene::clock::Clock::with_state(self.unix.min(now), self.t, self.rate, self.paused)
            .with_generation(self.generation)
    }
}

#[derive(Serialize, Deserialize)]
struct SceneFile {
    format: u32,
    id: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    spec: Option<Value>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    deleted: bool,
}

#[derive(Serialize, Deserialize)]
struct ClockFile {
    format: u32,
    #[serde(flatten)]
    clock: ClockRecord,
}

/// What [`Store::load_scenes`] found.
#[derive(Debug, Clone, Default)]
pub struct LoadedScenes {
    /// `(id, record)`, sorted by id.
    pub records: Vec<(String, SceneRecord)>,
    /// `(file, reason)` of files that could not be used.
    pub bad: Vec<(PathBuf, String)>,
}

/// The data dir.
#[derive(Debug, Clone)]
pub struct Store {
    root: PathBuf,
}

/// Seconds since the Unix epoch, now.
pub fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

impl Store {
    /// Opens (creating) the data dir.
    ///
    /// # Errors
    /// The directories cannot be created.
    pub fn open(root: &Path) -> std::io::Result<Store> {
        fs::create_dir_all(root.join("scenes"))?;
        fs::create_dir_all(root.join("clocks"))?;
        Ok(Store {
            root: root.to_owned(),
        })
    }

    fn scene_path(&self, id: &str) -> PathBuf {
        self.root.join("scenes").join(format!("{id}.json"))
    }

    fn bodies_path(&self, id: &str) -> PathBuf {
        self.root.join("bodies").join(format!("{id}.json"))
    }

    /// Persists a scene's bodies (written at graceful shutdown).
    ///
    /// # Errors
    /// I/O.
    pub fn put_bodies(&self, id: &str, record: &Value) -> std::io::Result<()> {
        fs::create_dir_all(self.root.join("bodies"))?;
        let bytes = serde_json::to_vec_pretty(record).map_err(std::io::Error::other)?;
        write_atomic(&self.bodies_path(id), &bytes)
    }

    /// A scene's persisted bodies, if any.
    ///
    /// # Errors
    /// An unreadable or malformed file, as a message.
    pub fn load_bodies(&self, id: &str) -> Result<Option<Value>, String> {
        match fs::read(self.bodies_path(id)) {
            Ok(bytes) => serde_json::from_slice(&bytes)
                .map(Some)
                .map_err(|e| e.to_string()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.to_string()),
        }
    }

    fn clock_path(&self, id: &str) -> PathBuf {
        self.root.join("clocks").join(format!("{id}.json"))
    }

    /// Persists a scene put by an admin.
    ///
    /// # Errors
    /// I/O.
    pub fn put_scene(&self, id: &str, spec: &Value) -> std::io::Result<()> {
        let f = SceneFile {
            format: FORMAT,
            id: id.to_owned(),
            spec: Some(spec.clone()),
            deleted: false,
        };
        write_atomic(&self.scene_path(id), &to_json(&f)?)
    }

    /// Persists a deletion (and forgets the scene's clock).
    ///
    /// # Errors
    /// I/O.
    pub fn delete_scene(&self, id: &str) -> std::io::Result<()> {
        let f = SceneFile {
            format: FORMAT,
            id: id.to_owned(),
            spec: None,
            deleted: true,
        };
        write_atomic(&self.scene_path(id), &to_json(&f)?)?;
        self.delete_clock(id)
    }

    /// Removes a scene's clock file, if any.
    ///
    /// # Errors
    /// I/O other than "not found".
    pub fn delete_clock(&self, id: &str) -> std::io::Result<()> {
        match fs::remove_file(self.clock_path(id)) {
            Ok(()) => sync_dir(&self.root.join("clocks")),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(e),
        }
    }

    /// Persists a clock.
    ///
    /// # Errors
    /// I/O.
    pub fn put_clock(&self, id: &str, clock: ClockRecord) -> std::io::Result<()> {
        let f = ClockFile {
            format: FORMAT,
            clock,
        };
        write_atomic(&self.clock_path(id), &to_json(&f)?)
    }

    /// Every persisted scene record, sorted by id. Unreadable files are reported in
    /// [`LoadedScenes::bad`] and skipped.
    pub fn load_scenes(&self) -> LoadedScenes {
        let mut out = Vec::new();
        let mut bad = Vec::new();
        for path in json_files(&self.root.join("scenes")) {
            match read_json::<SceneFile>(&path) {
                Ok(f) if f.format == FORMAT && path_id(&path) == Some(f.id.as_str()) => {
                    let rec = match (f.deleted, f.spec) {
                        (true, _) => SceneRecord::Deleted,
                        (false, Some(spec)) => SceneRecord::Put(spec),
                        (false, None) => {
                            bad.push((path, "neither spec nor deleted".into()));
                            continue;
                        }
                    };
                    out.push((f.id, rec));
                }
                Ok(_) => bad.push((path, "unknown format or id mismatch".into())),
                Err(e) => bad.push((path, e)),
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0));
        LoadedScenes { records: out, bad }
    }

    /// The persisted clock of a scene, if any (`Err` if the file is unreadable).
    pub fn load_clock(&self, id: &str) -> Result<Option<ClockRecord>, String> {
        let path = self.clock_path(id);
        if !path.exists() {
            return Ok(None);
        }
        read_json::<ClockFile>(&path).map(|f| Some(f.clock))
    }
}

fn to_json<T: Serialize>(v: &T) -> std::io::Result<Vec<u8>> {
    let mut bytes = serde_json::to_vec_pretty(v).map_err(std::io::Error::other)?;
    bytes.push(b'\n');
    Ok(bytes)
}

fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, String> {
    let bytes = fs::read(path).map_err(|e| e.to_string())?;
    serde_json::from_slice(&bytes).map_err(|e| e.to_string())
}

fn path_id(path: &Path) -> Option<&str> {
    path.file_stem().and_then(|s| s.to_str())
}

fn json_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    v.sort();
    v
}

/// Writes `bytes` to `path` atomically: temp file in the same directory, fsync, rename, fsync
/// the directory (so the rename itself is durable).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .ok_or_else(|| std::io::Error::other("path has no parent directory"))?;
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    fs::rename(&tmp, path)?;
    sync_dir(dir)
}

fn sync_dir(dir: &Path) -> std::io::Result<()> {
    // Directories can be opened and fsynced on Unix; elsewhere this is a no-op best effort.
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_scenes_tombstones_and_clocks() {
        let dir = tempfile::tempdir().unwrap();
        let s = Store::open(dir.path()).unwrap();
        s.put_scene("a", &serde_json::json!({"layers": []}))
            .unwrap();
        s.put_scene("b", &serde_json::json!({"x": 1})).unwrap();
        s.delete_scene("b").unwrap();
        let c = ClockRecord {
            t: 0.1 + 0.2,
            rate: -2.5,
            paused: true,
            unix: 1.7e9,
            generation: 3,
        };
        s.put_clock("a", c).unwrap();
        let loaded = s.load_scenes();
        assert!(loaded.bad.is_empty());
        assert_eq!(
            loaded.records,
            vec![
                (
                    "a".into(),
                    SceneRecord::Put(serde_json::json!({"layers": []}))
                ),
                ("b".into(), SceneRecord::Deleted)
            ]
        );
        assert_eq!(s.load_clock("a").unwrap(), Some(c));
        assert_eq!(s.load_clock("b").unwrap(), None);
        // No temp files are left behind.
        let left: Vec<_> = fs::read_dir(dir.path().join("scenes")).unwrap().collect();
        assert_eq!(left.len(), 2);
    }
}
