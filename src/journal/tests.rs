//! The journal on disk: appends survive a reopen; a torn or corrupt file is reported, never
//! fatal, and loses nothing it did not touch; snapshots compact the log.

use std::fs;

use serde_json::json;

use super::*;
use crate::scene::store::ClockRecord;

fn put(i: u64) -> Op {
    Op::ScenePut {
        scene: format!("s{i}"),
        spec: json!({"n": i, "x": 0.1 + i as f64 * 1e-17}),
        clock: None,
    }
}

fn clock(i: u64) -> Op {
    Op::Clock {
        scene: "calm".into(),
        clock: ClockRecord {
            t: 1.0 / (i as f64 + 3.0),
            rate: -0.5,
            paused: i.is_multiple_of(2),
            unix: 1.7e9 + i as f64,
            generation: i,
        },
    }
}

/// SplitMix64, so the damage is the same on every run.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) % n as u64) as usize
    }
}

#[test]
fn appended_records_come_back_in_order_with_exact_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert!(rec.records.is_empty() && rec.snapshot.is_none() && rec.problems.is_empty());
    let ops: Vec<Op> = (0..20)
        .map(|i: u64| {
            if i.is_multiple_of(3) {
                clock(i)
            } else {
                put(i)
            }
        })
        .collect();
    for (i, op) in ops.iter().enumerate() {
        assert_eq!(j.append(op.clone()).unwrap(), i as u64 + 1);
    }
    j.sync_blocking(20).unwrap();
    drop(j);
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert!(rec.problems.is_empty(), "{:?}", rec.problems);
    let got: Vec<Op> = rec.records.iter().map(|r| r.op.clone()).collect();
    assert_eq!(got, ops);
    // Numbers round-trip to the bit (`PartialEq` on f64 is exact, and 1/(i+3) is not short).
    assert_eq!(j.last_seq(), 20);
    assert_eq!(
        j.append(put(99)).unwrap(),
        21,
        "seqs continue after a reopen"
    );
}

/// A crash mid-write, and bit rot: truncate or corrupt the log at seeded random offsets. The
/// journal always opens; what it reads is exactly the records the damage did not touch, in
/// order; the damage is reported; and the rewritten log reopens clean with the same records.
#[test]
fn truncated_or_corrupt_logs_open_with_every_untouched_record() {
    let dir = tempfile::tempdir().unwrap();
    let (j, _) = Journal::open(dir.path()).unwrap();
    let ops: Vec<Op> = (0..30).map(put).collect();
    for op in &ops {
        j.append(op.clone()).unwrap();
    }
    drop(j);
    let log = dir.path().join("journal").join(LOG_FILE);
    let pristine = fs::read(&log).unwrap();
    // Record boundaries, from the framing itself.
    let offsets: Vec<usize> = frame::decode(&pristine, frame::HEADER_LEN)
        .records
        .iter()
        .map(|(o, _)| *o)
        .collect();
    let end_of = |i: usize| offsets.get(i + 1).copied().unwrap_or(pristine.len());
    let mut rng = Rng(2024);
    for round in 0..60_u32 {
        let mut bytes = pristine.clone();
        let mut touched = vec![false; ops.len()];
        // A cut exactly between two records leaves a shorter, undamaged log.
        let mut undamaged = false;
        if round.is_multiple_of(2) {
            let cut = frame::HEADER_LEN + rng.below(bytes.len() - frame::HEADER_LEN);
            bytes.truncate(cut);
            undamaged = offsets.contains(&cut);
            for (i, t) in touched.iter_mut().enumerate() {
                *t = end_of(i) > cut;
            }
        } else {
            for _ in 0..1 + rng.below(3) {
                let at = frame::HEADER_LEN + rng.below(bytes.len() - frame::HEADER_LEN);
                bytes[at] ^= 0x5A;
                let i = offsets.iter().rposition(|&o| o <= at).unwrap();
                touched[i] = true;
            }
        }
        fs::write(&log, &bytes).unwrap();
        let (j, rec) = Journal::open(dir.path()).unwrap();
        let want: Vec<Op> = ops
            .iter()
            .zip(&touched)
            .filter(|(_, t)| !**t)
            .map(|(o, _)| o.clone())
            .collect();
        let got: Vec<Op> = rec.records.iter().map(|r| r.op.clone()).collect();
        assert_eq!(got, want, "round {round}");
        assert_eq!(
            rec.problems.is_empty(),
            undamaged,
            "round {round}: {:?}",
            rec.problems
        );
        // New records go after the good ones, and the file now reads clean.
        let seq = j.append(put(1000)).unwrap();
        drop(j);
        let (_, again) = Journal::open(dir.path()).unwrap();
        assert!(
            again.problems.is_empty(),
            "round {round}: {:?}",
            again.problems
        );
        assert_eq!(again.records.len(), want.len() + 1);
        assert_eq!(again.records.last().unwrap().seq, seq);
    }
}

#[test]
fn a_foreign_or_newer_file_is_moved_aside_not_read_or_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let jdir = dir.path().join("journal");
    fs::create_dir_all(&jdir).unwrap();
    let mut newer = frame::header(LOG_MAGIC, FORMAT + 1).to_vec();
    newer.extend_from_slice(&frame::encode(b"{}"));
    fs::write(jdir.join(LOG_FILE), &newer).unwrap();
    fs::write(jdir.join(SNAPSHOT_FILE), b"garbage that is not a snapshot").unwrap();
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert_eq!(rec.problems.len(), 2, "{:?}", rec.problems);
    assert!(rec.records.is_empty() && rec.snapshot.is_none());
    let aside: Vec<String> = fs::read_dir(&jdir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.contains(".damaged-"))
        .collect();
    assert_eq!(aside.len(), 2, "{aside:?}");
    let kept = aside.iter().find(|n| n.starts_with(LOG_FILE)).unwrap();
    assert_eq!(fs::read(jdir.join(kept)).unwrap(), newer);
    assert_eq!(j.append(put(1)).unwrap(), 1);
}

/// A log whose header is not a journal's (or with damage mid-log) is rewritten from what could
/// be read, but its bytes are kept aside first: "never deleted" (an outside audit found 100 KB
/// of junk replaced by an empty log). A torn tail, what every kill -9 mid-append leaves, is not
/// copied.
#[test]
fn a_log_rewritten_around_damage_is_kept_aside_first() {
    let aside = |jdir: &Path| -> Vec<String> {
        fs::read_dir(jdir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.contains(".damaged-"))
            .collect()
    };
    let dir = tempfile::tempdir().unwrap();
    let jdir = dir.path().join("journal");
    fs::create_dir_all(&jdir).unwrap();
    let junk: Vec<u8> = (0..100_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    fs::write(jdir.join(LOG_FILE), &junk).unwrap();
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert!(
        rec.problems.iter().any(|p| p.contains("damaged header")),
        "{:?}",
        rec.problems
    );
    let kept = aside(&jdir);
    assert_eq!(kept.len(), 1, "{kept:?}");
    assert_eq!(fs::read(jdir.join(&kept[0])).unwrap(), junk);
    j.append(put(1)).unwrap();
    j.sync_blocking(1).unwrap();
    drop(j);
    // A torn tail only: rewritten, nothing more kept aside.
    let log = jdir.join(LOG_FILE);
    let mut bytes = fs::read(&log).unwrap();
    bytes.extend_from_slice(&frame::encode(b"{\"seq\": 2")[..7]);
    fs::write(&log, &bytes).unwrap();
    let (_j, rec) = Journal::open(dir.path()).unwrap();
    assert_eq!(rec.records.len(), 1, "{:?}", rec.problems);
    assert_eq!(aside(&jdir).len(), 1, "a torn tail is not copied aside");
}

/// One journal per data dir: a second open (another process, or a test's second server)
/// fails with a message naming the dir while the first is open, and succeeds once it is gone.
#[test]
fn a_data_dir_in_use_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (j, _) = Journal::open(dir.path()).unwrap();
    let e = Journal::open(dir.path()).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::WouldBlock);
    assert!(
        e.to_string().contains("in use by another swell process"),
        "{e}"
    );
    drop(j);
    Journal::open(dir.path()).unwrap();
}

#[test]
fn a_snapshot_compacts_the_log_and_replay_starts_after_it() {
    let dir = tempfile::tempdir().unwrap();
    let (j, _) = Journal::open(dir.path()).unwrap();
    for i in 0..50 {
        j.append(put(i)).unwrap();
    }
    let (admin_seq, admin) = j.admin();
    assert_eq!(admin.scenes.len(), 50);
    let snap = Snapshot {
        admin_seq,
        admin,
        bodies_seq: admin_seq,
        ..Snapshot::default()
    };
    j.write_snapshot(&snap).unwrap();
    assert_eq!(j.tail_len(), 0);
    j.append(clock(1)).unwrap();
    j.append(Op::SceneDelete { scene: "s3".into() }).unwrap();
    j.sync_blocking(52).unwrap();
    let log_len = fs::metadata(dir.path().join("journal").join(LOG_FILE))
        .unwrap()
        .len();
    drop(j);
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert!(rec.problems.is_empty(), "{:?}", rec.problems);
    assert_eq!(rec.snapshot.as_ref().unwrap().admin.scenes.len(), 50);
    assert_eq!(
        rec.records.iter().map(|r| r.seq).collect::<Vec<_>>(),
        vec![51, 52]
    );
    assert!(
        log_len < 1000,
        "the log holds only the tail: {log_len} bytes"
    );
    let (seq, admin) = j.admin();
    assert_eq!(seq, 52);
    assert_eq!(admin.scenes["s3"], AdminScene::Deleted);
    assert_eq!(admin.clocks.len(), 1);
}

/// A put that moves a scene's epoch records the scene's fresh clock, and the fold takes it in
/// place of the replaced clock's record: the fold used to keep the old record (a put left
/// `clocks` alone), so a restart from a snapshot brought back the clock the put had replaced.
/// A put without a clock (it kept the clock) leaves the record as it is, and is written as
/// puts were before they could carry one.
#[test]
fn a_put_that_moves_the_epoch_replaces_the_folded_clock() {
    let dir = tempfile::tempdir().unwrap();
    let (j, _) = Journal::open(dir.path()).unwrap();
    j.append(clock(2)).unwrap();
    let Op::Clock { clock: old, .. } = clock(2) else {
        unreachable!()
    };
    let kept = Op::ScenePut {
        scene: "calm".into(),
        spec: json!({"epoch": 1.0}),
        clock: None,
    };
    assert!(!serde_json::to_string(&kept).unwrap().contains("clock"));
    j.append(kept).unwrap();
    assert_eq!(j.admin().1.clocks["calm"], old);
    let fresh = ClockRecord {
        t: 0.1,
        rate: 1.0,
        paused: false,
        unix: 1.7e9,
        generation: old.generation + 1,
    };
    j.append(Op::ScenePut {
        scene: "calm".into(),
        spec: json!({"epoch": 1.7e9 - 0.1}),
        clock: Some(fresh),
    })
    .unwrap();
    assert_eq!(j.admin().1.clocks["calm"], fresh);
    j.sync_blocking(3).unwrap();
    drop(j);
    let (j, rec) = Journal::open(dir.path()).unwrap();
    assert_eq!(rec.records.len(), 3);
    assert_eq!(j.admin().1.clocks["calm"], fresh, "folded again on open");
}
