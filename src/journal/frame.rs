//! The byte framing of journal files: a file header, then records, each checksummed.
//!
//! ```text
//! file   = magic(8) version(u32 LE) reserved(u32 LE, 0) record*
//! record = 0xA5 'S' 'W' 'R'  len(u32 LE)  crc(u32 LE)  payload(len bytes)
//! crc    = CRC-32/ISO-HDLC (the zlib/PNG CRC) of the 4 `len` bytes followed by the payload
//! ```
//!
//! A record is accepted only if its marker, length and checksum all hold. Reading never fails:
//! a torn tail (a crash mid-write) or a damaged stretch is reported as a [`Damage`] and skipped;
//! after damage the reader looks for the next byte offset where a valid record starts (the
//! marker makes that scan cheap, the checksum makes a false start a 1-in-2³² event), so one bad
//! record does not hide the good ones after it.

/// Bytes of the file header.
pub const HEADER_LEN: usize = 16;
/// Marker at the start of every record.
pub const RECORD_MAGIC: [u8; 4] = [0xA5, b'S', b'W', b'R'];
/// Bytes before a record's payload: marker, length, checksum.
pub const RECORD_OVERHEAD: usize = 12;
/// Largest payload accepted, bytes. A scene spec is limited by the request body limit (8 MiB by
/// default); a snapshot of 1,000 bodies per scene in many scenes is far larger, so snapshots
/// (one record) may be up to this size. A length above it marks the record as damaged.
pub const MAX_PAYLOAD: usize = 1 << 30;

/// The header of a file of kind `magic` at `version`.
pub fn header(magic: &[u8; 8], version: u32) -> [u8; HEADER_LEN] {
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(magic);
    h[8..12].copy_from_slice(&version.to_le_bytes());
    h
}

/// What a file's header says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Header {
    /// The expected magic at this version.
    Version(u32),
    /// Too short or another kind of file.
    Unrecognised,
}

/// Reads a header.
pub fn read_header(bytes: &[u8], magic: &[u8; 8]) -> Header {
    if bytes.len() < HEADER_LEN || &bytes[..8] != magic {
        return Header::Unrecognised;
    }
    let mut v = [0u8; 4];
    v.copy_from_slice(&bytes[8..12]);
    Header::Version(u32::from_le_bytes(v))
}

/// One framed record.
pub fn encode(payload: &[u8]) -> Vec<u8> {
    let len = (payload.len() as u32).to_le_bytes();
    let mut h = crc32fast::Hasher::new();
    h.update(&len);
    h.update(payload);
    let crc = h.finalize().to_le_bytes();
    let mut out = Vec::with_capacity(RECORD_OVERHEAD + payload.len());
    out.extend_from_slice(&RECORD_MAGIC);
    out.extend_from_slice(&len);
    out.extend_from_slice(&crc);
    out.extend_from_slice(payload);
    out
}

/// A stretch of a file that held no valid record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset in the file where it starts.
    pub offset: usize,
    /// Its length, bytes.
    pub len: usize,
    /// Whether it runs to the end of the file (a torn tail, typically).
    pub at_end: bool,
}

/// What [`decode`] found.
#[derive(Debug, Default)]
pub struct Decoded<'a> {
    /// `(file offset, payload)` of each valid record, in file order.
    pub records: Vec<(usize, &'a [u8])>,
    /// Damaged stretches, in file order.
    pub damage: Vec<Damage>,
}

/// The valid record starting at `pos`, if one does: its payload.
fn record_at(bytes: &[u8], pos: usize) -> Option<&[u8]> {
    let head = bytes.get(pos..pos + RECORD_OVERHEAD)?;
    if head[..4] != RECORD_MAGIC {
        return None;
    }
    let len = u32::from_le_bytes([head[4], head[5], head[6], head[7]]) as usize;
    let crc = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if len > MAX_PAYLOAD {
        return None;
    }
    let payload = bytes.get(pos + RECORD_OVERHEAD..pos + RECORD_OVERHEAD + len)?;
    let mut h = crc32fast::Hasher::new();
    h.update(&head[4..8]);
    h.update(payload);
    (h.finalize() == crc).then_some(payload)
}

/// Every valid record of `bytes` from offset `start` (the end of the header), and the damage
/// between them.
pub fn decode(bytes: &[u8], start: usize) -> Decoded<'_> {
    let mut out = Decoded::default();
    let mut pos = start.min(bytes.len());
    while pos < bytes.len() {
        if let Some(p) = record_at(bytes, pos) {
            out.records.push((pos, p));
            pos += RECORD_OVERHEAD + p.len();
            continue;
        }
        // Damage: find the next offset where a valid record starts.
        let next = (pos + 1..bytes.len())
            .find(|&q| bytes[q] == RECORD_MAGIC[0] && record_at(bytes, q).is_some());
        let end = next.unwrap_or(bytes.len());
        out.damage.push(Damage {
            offset: pos,
            len: end - pos,
            at_end: next.is_none(),
        });
        pos = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SplitMix64: a tiny seeded generator, so the damage in these tests is the same every run.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    fn file(payloads: &[Vec<u8>]) -> (Vec<u8>, Vec<usize>) {
        let mut f = header(b"SWELLTST", 1).to_vec();
        let mut offsets = Vec::new();
        for p in payloads {
            offsets.push(f.len());
            f.extend_from_slice(&encode(p));
        }
        (f, offsets)
    }

    fn payloads(rng: &mut Rng, n: usize) -> Vec<Vec<u8>> {
        (0..n)
            .map(|i| {
                let len = 1 + rng.below(200);
                (0..len).map(|j| (i * 31 + j * 7) as u8).collect()
            })
            .collect()
    }

    #[test]
    fn round_trips_records_and_header() {
        let mut rng = Rng(1);
        let ps = payloads(&mut rng, 50);
        let (f, offsets) = file(&ps);
        assert_eq!(read_header(&f, b"SWELLTST"), Header::Version(1));
        assert_eq!(read_header(&f, b"SWELLJNL"), Header::Unrecognised);
        assert_eq!(read_header(&f[..10], b"SWELLTST"), Header::Unrecognised);
        let d = decode(&f, HEADER_LEN);
        assert!(d.damage.is_empty());
        let got: Vec<(usize, Vec<u8>)> = d.records.iter().map(|(o, p)| (*o, p.to_vec())).collect();
        let want: Vec<(usize, Vec<u8>)> = offsets.into_iter().zip(ps).collect();
        assert_eq!(got, want);
    }

    /// A crash mid-write leaves a prefix of the file: every record wholly before the cut is
    /// read, none after, and the torn rest is reported as damage at the end.
    #[test]
    fn a_truncated_file_keeps_every_whole_record() {
        let mut rng = Rng(7);
        let ps = payloads(&mut rng, 40);
        let (f, offsets) = file(&ps);
        for _ in 0..300 {
            let cut = HEADER_LEN + rng.below(f.len() - HEADER_LEN + 1);
            let d = decode(&f[..cut], HEADER_LEN);
            let whole = offsets
                .iter()
                .zip(&ps)
                .filter(|(o, p)| *o + RECORD_OVERHEAD + p.len() <= cut)
                .count();
            assert_eq!(d.records.len(), whole, "cut at {cut}");
            for (i, (_, p)) in d.records.iter().enumerate() {
                assert_eq!(*p, &ps[i][..]);
            }
            let torn = cut - offsets.get(whole).copied().unwrap_or(cut).min(cut);
            match d.damage.as_slice() {
                [] => assert_eq!(torn, 0, "cut at {cut}"),
                [dmg] => {
                    assert!(dmg.at_end && dmg.len == torn && dmg.offset == offsets[whole]);
                }
                more => panic!("cut at {cut}: {more:?}"),
            }
        }
    }

    /// Damage in the middle (bytes flipped at random offsets) loses only the records it touches:
    /// every record it does not touch is still read, and nothing damaged is ever accepted.
    #[test]
    fn corruption_loses_only_the_records_it_touches() {
        let mut rng = Rng(42);
        let ps = payloads(&mut rng, 40);
        let (f, offsets) = file(&ps);
        for round in 0..300 {
            let mut g = f.clone();
            let flips = 1 + rng.below(4);
            let mut hit = vec![false; ps.len()];
            for _ in 0..flips {
                let at = HEADER_LEN + rng.below(g.len() - HEADER_LEN);
                g[at] ^= 1 + rng.below(255) as u8;
                let i = offsets.iter().rposition(|&o| o <= at).unwrap();
                hit[i] = true;
            }
            let d = decode(&g, HEADER_LEN);
            let got: Vec<&[u8]> = d.records.iter().map(|(_, p)| *p).collect();
            let want: Vec<&[u8]> = ps
                .iter()
                .zip(&hit)
                .filter(|(_, h)| !**h)
                .map(|(p, _)| &p[..])
                .collect();
            assert_eq!(got, want, "round {round}");
            assert!(!d.damage.is_empty(), "round {round}: damage not reported");
        }
    }
}
