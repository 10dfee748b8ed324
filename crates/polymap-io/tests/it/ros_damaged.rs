//! Damaged MCAP files and bags, as a crashed recorder, a bad disk or a bad copy leave them: bit
//! flips in chunks and cuts anywhere, seeded. A damaged file never yields changed scans: it is an
//! error, or its damaged chunks are skipped (counted) with `--skip-bad-input`, or, cut off, it
//! yields the scans before the cut with a warning saying where it ends.

use std::path::Path;

use polymap::scan::RangeScan;
use polymap_io::log::{LogError, LogOptions, LogSource, LogStats};
use polymap_io::ros::mcap_file::{McapCompression, McapReader};
use polymap_io::ros::ros1::BagCompression;
use polymap_io::ros::{MessageSource, ReadLimits, write_bag, write_mcap};

use crate::ros_written::scans;

/// The scans of a file and the reader's counts.
fn read(path: &Path, skip_bad_input: bool) -> Result<(Vec<RangeScan>, LogStats), LogError> {
    let options = LogOptions {
        topic: Some("/scan".into()),
        skip_bad_input,
        ..LogOptions::default()
    };
    let mut log = LogSource::open(path, &options)?;
    let mut out = Vec::new();
    while let Some(s) = log.next_scan()? {
        out.push(s);
    }
    Ok((out, log.stats()))
}

/// The byte ranges `(offset, length)` of the chunk records of an MCAP file.
fn chunk_records(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut at = 8;
    let mut chunks = Vec::new();
    while at + 9 <= bytes.len() {
        let length = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        match bytes[at] {
            0x06 => chunks.push((at, 9 + length)),
            0x0F => break, // the footer
            _ => {}
        }
        at += 9 + length;
    }
    chunks
}

/// Whether `r` is the scan `w` read back: its stamp and every reading (no-returns as such).
fn same(r: &RangeScan, w: &RangeScan) -> bool {
    r.stamp == w.stamp
        && r.ranges_m.len() == w.ranges_m.len()
        && r.ranges_m.iter().zip(&w.ranges_m).all(|(a, b)| {
            r.is_valid_range(*a) == w.is_valid_range(*b) && (!w.is_valid_range(*b) || a == b)
        })
}

/// Each scan of `read` is a written one, in order: nothing changed, only lost.
fn kept(read: &[RangeScan], written: &[RangeScan]) -> bool {
    let mut rest = written.iter();
    read.iter().all(|r| rest.any(|w| same(r, w)))
}

/// An error about a damaged file names the file and the byte where the damage is.
fn named(e: &str, what: &str) {
    assert!(
        e.contains("flipped.mcap") && e.contains("byte "),
        "{what}: {e}"
    );
}

/// A small seeded generator (SplitMix64): the same probes on every run.
fn positions(seed: u64, n: usize, below: usize) -> Vec<usize> {
    let mut state = seed;
    (0..n)
        .map(|_| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) % below as u64) as usize
        })
        .collect()
}

/// One flipped bit in a chunk of a `polymap simulate --ros` recording changed the trajectory
/// with exit 0 in 30 of 40 tries (the indexed reader did not check the chunk CRCs). Now a flip
/// in a chunk, with or without the file's summary, is an error naming the chunk, or skipped
/// and counted under --skip-bad-input; the scans read are never changed ones.
#[test]
fn a_flipped_bit_in_a_chunk_is_an_error_or_a_counted_skip() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(600);
    for compression in [McapCompression::Zstd, McapCompression::None] {
        let path = dir.path().join("whole.mcap");
        write_mcap(&path, &written, compression).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let chunks = chunk_records(&bytes);
        assert!(chunks.len() >= 3, "{} chunks", chunks.len());
        // The same flips in the whole file (read through its summary) and in the file cut
        // before its summary (read linearly).
        let summary = chunks.last().map(|&(at, len)| at + len).unwrap();
        let span = summary - chunks[0].0;
        for (k, offset) in positions(7, 40, span).into_iter().enumerate() {
            let at = chunks[0].0 + offset;
            for end in [bytes.len(), summary] {
                let mut damaged = bytes[..end].to_vec();
                damaged[at] ^= 1 << (k % 8);
                let flipped = dir.path().join("flipped.mcap");
                std::fs::write(&flipped, &damaged).unwrap();
                let what = format!("{compression:?}, byte {at}, file of {end} bytes");
                // Without skipping: every scan, or fewer with a warning (a file cut before
                // its summary is read as cut off), or an error naming the file and the byte.
                match read(&flipped, false) {
                    Ok((scans, stats)) => {
                        assert!(kept(&scans, &written), "changed scans in silence: {what}");
                        let lost = scans.len() < written.len();
                        assert!(
                            !lost || !stats.warnings.is_empty(),
                            "{} of {} scans read without a word: {what}",
                            scans.len(),
                            written.len()
                        );
                    }
                    Err(e) => named(&e.to_string(), &what),
                }
                // Skipping: the same, with skips counted; an error still names the place.
                match read(&flipped, true) {
                    Ok((scans, stats)) => {
                        assert!(
                            kept(&scans, &written),
                            "changed scans when skipping: {what}"
                        );
                        let lost = scans.len() < written.len();
                        assert!(
                            !lost || stats.bad_records > 0 || !stats.warnings.is_empty(),
                            "scans lost without a word: {what}"
                        );
                    }
                    // The chunk that declares the channels skipped: no scan topic is left.
                    Err(e) if e.to_string().contains("no messages on topic /scan") => {
                        assert!(e.to_string().contains("flipped.mcap"), "{what}: {e}")
                    }
                    Err(e) => named(&e.to_string(), &what),
                }
            }
        }
        // A flip in the compressed data of the middle chunk: named, then skipped.
        let (at, len) = chunks[chunks.len() / 2];
        let mut damaged = bytes.clone();
        damaged[at + len - 20] ^= 0x10;
        let flipped = dir.path().join("flipped.mcap");
        std::fs::write(&flipped, &damaged).unwrap();
        let e = read(&flipped, false).unwrap_err().to_string();
        let number = chunks.len() / 2 + 1;
        assert!(
            e.contains(&format!("chunk {number} (byte {at}, log times")),
            "{e}"
        );
        let (scans, stats) = read(&flipped, true).unwrap();
        assert_eq!(stats.bad_records, 1, "{compression:?}");
        assert!(scans.len() < written.len() && kept(&scans, &written));
        assert!(
            stats.bad_record_errors[0].contains(": skipped"),
            "{stats:?}"
        );
    }
}

/// An MCAP file cut off, as a crashed recorder leaves it, failed with "ended in the middle of
/// a record" where a bag cut the same way mapped. Cut at a record boundary or inside a record,
/// it yields every scan before the cut, with a warning saying where the file ends.
#[test]
fn a_cut_recording_yields_the_scans_before_the_cut_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(600);
    let path = dir.path().join("whole.mcap");
    write_mcap(&path, &written, McapCompression::Zstd).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let chunks = chunk_records(&bytes);
    let boundaries = chunks.iter().skip(1).map(|&(at, _)| at);
    let inside = positions(11, 12, bytes.len() - chunks[1].0)
        .into_iter()
        .map(|p| chunks[1].0 + p);
    for cut in boundaries.chain(inside) {
        let path = dir.path().join("cut.mcap");
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (scans, stats) = read(&path, false).unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
        assert!(!scans.is_empty(), "cut at {cut}");
        let prefix = scans.iter().zip(&written).all(|(r, w)| same(r, w));
        assert!(prefix, "cut at {cut}: not the scans before the cut");
        let said = stats.warnings.join(" ");
        assert!(
            said.contains(&format!("the file ends at byte {cut}")),
            "cut at {cut}: {said}"
        );
    }
}

/// The records `(offset, opcode)` of an MCAP file's summary section, as its footer places it.
fn summary_records(bytes: &[u8]) -> Vec<(usize, u8)> {
    let footer = bytes.len() - 8 - 29;
    let mut at = u64::from_le_bytes(bytes[footer + 9..footer + 17].try_into().unwrap()) as usize;
    let mut records = Vec::new();
    while at < footer {
        let length = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        records.push((at, bytes[at]));
        at += 9 + length;
    }
    records
}

/// One flipped bit in the opcode of a chunk index (0x08 to 0x88) made the summary reader pass
/// over it as an unknown record, and its chunk was never read: scans lost with no word. The
/// summary is now checked by the footer's CRC and, where the footer has none, by the
/// statistics' chunk count; a summary that fails either is read past with a warning, and the
/// linear reader, which checks every chunk, reads every scan.
#[test]
fn a_damaged_summary_is_read_past_with_a_warning_and_loses_no_scan() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(600);
    let path = dir.path().join("whole.mcap");
    write_mcap(&path, &written, McapCompression::Zstd).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let indexes: Vec<usize> = summary_records(&bytes)
        .into_iter()
        .filter(|&(_, opcode)| opcode == 0x08)
        .map(|(at, _)| at)
        .collect();
    assert!(indexes.len() >= 3, "{} chunk indexes", indexes.len());
    let crc_at = bytes.len() - 8 - 4;
    assert_ne!(
        &bytes[crc_at..crc_at + 4],
        &[0; 4],
        "the writer writes a CRC"
    );
    // With the footer's CRC, then without it (a CRC of 0: only the chunk count tells).
    for (crc, said) in [(true, "fails its CRC"), (false, "chunk indexes list")] {
        let mut damaged = bytes.clone();
        damaged[indexes[1]] ^= 0x80;
        if !crc {
            damaged[crc_at..crc_at + 4].fill(0);
        }
        let flipped = dir.path().join("flipped.mcap");
        std::fs::write(&flipped, &damaged).unwrap();
        for skip in [false, true] {
            let (scans, stats) = read(&flipped, skip).unwrap();
            assert_eq!(scans.len(), written.len(), "crc {crc}, skip {skip}");
            assert!(kept(&scans, &written));
            let warned = stats.warnings.join(" ");
            assert!(
                warned.contains(said) && warned.contains("every chunk in file order"),
                "crc {crc}: {warned}"
            );
        }
    }
}

/// The offsets of the chunk records of a bag (format 2.0), in file order.
fn bag_chunks(bytes: &[u8]) -> Vec<usize> {
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let mut at = 13;
    let mut chunks = Vec::new();
    while at + 8 <= bytes.len() {
        let header_len = u32_at(at);
        let header = &bytes[at + 4..at + 4 + header_len];
        if header.windows(4).any(|w| w == b"op=\x05") {
            chunks.push(at);
        }
        at += 8 + header_len + u32_at(at + 4 + header_len);
    }
    chunks
}

/// One flipped bit in a chunk's length field of a whole, indexed bag made the chunk run past
/// the end of the file, and the bag was read as a recording cut off: a warning, a third of the
/// scans lost, exit 0. A bag whose header places its index within the file is whole, so the
/// record is damaged: an error, or under --skip-bad-input a counted skip.
#[test]
fn a_damaged_length_in_a_whole_bag_is_an_error_not_a_cut() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(1200);
    let path = dir.path().join("whole.bag");
    write_bag(&path, &written, BagCompression::Lz4).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let chunks = bag_chunks(&bytes);
    assert!(chunks.len() >= 3, "{} chunks", chunks.len());
    let at = chunks[1];
    let header_len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let mut damaged = bytes.clone();
    damaged[at + 4 + header_len + 3] ^= 0x10;
    let flipped = dir.path().join("flipped.bag");
    std::fs::write(&flipped, &damaged).unwrap();
    let e = read(&flipped, false).unwrap_err().to_string();
    assert!(
        e.contains("flipped.bag") && e.contains("runs past the end of the file"),
        "{e}"
    );
    let (scans, stats) = read(&flipped, true).unwrap();
    assert!(scans.len() < written.len() && kept(&scans, &written));
    assert_eq!(stats.bad_records, 1, "{stats:?}");
    assert!(
        stats.bad_record_errors[0].contains("a damaged length"),
        "{stats:?}"
    );
    // The same bag cut inside its index: every scan read, the cut said, nothing said lost.
    let cut = dir.path().join("cut.bag");
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    let (scans, stats) = read(&cut, false).unwrap();
    assert_eq!(scans.len(), written.len());
    let said = stats.warnings.join(" ");
    assert!(
        said.contains("inside its index") && !said.contains("lost"),
        "{said}"
    );
}

/// Every message of an MCAP file, read linearly.
fn read_linear(path: &Path, skip_bad: bool) -> (usize, Vec<String>, u64) {
    let mut r = McapReader::open(path, ReadLimits::default(), skip_bad).unwrap();
    let mut n = 0;
    loop {
        match r.advance() {
            Ok(true) => n += 1,
            Ok(false) => break,
            Err(e) => return (n, vec![format!("error: {e}")], r.skipped().0),
        }
    }
    (n, r.warnings().to_vec(), r.skipped().0)
}

/// The same flip in an MCAP chunk's length field was read as a recording cut off. A file that
/// ends with MCAP's magic bytes is whole, so a record that runs past its end is damage: an
/// error, or under --skip-bad-input a counted skip. A file cut right after its footer, or
/// inside its summary, loses no message and is said to.
#[test]
fn a_damaged_length_in_a_whole_mcap_is_an_error_not_a_cut() {
    let dir = tempfile::tempdir().unwrap();
    let written = scans(600);
    let path = dir.path().join("whole.mcap");
    write_mcap(&path, &written, McapCompression::Zstd).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let whole = read_linear(&path, false);
    assert!(whole.0 >= written.len() && whole.1.is_empty(), "{whole:?}");
    let chunks = chunk_records(&bytes);
    let mut damaged = bytes.clone();
    damaged[chunks[1].0 + 3] ^= 0x10;
    let flipped = dir.path().join("flipped.mcap");
    std::fs::write(&flipped, &damaged).unwrap();
    let (_, said, _) = read_linear(&flipped, false);
    let said = said.join(" ");
    assert!(
        said.starts_with("error: ") && said.contains("a damaged length"),
        "{said}"
    );
    let (n, said, skipped) = read_linear(&flipped, true);
    assert!(
        n < whole.0 && skipped == 1,
        "{n} read, {skipped} skipped: {said:?}"
    );
    let footer_end = bytes.len() - 8;
    let summary_start = summary_records(&bytes)[0].0 + 5;
    for (cut, says) in [
        (footer_end, "right after its footer"),
        (summary_start, "inside its summary section"),
    ] {
        let path = dir.path().join("cut.mcap");
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (n, said, _) = read_linear(&path, false);
        let said = said.join(" ");
        assert_eq!(n, whole.0, "{said}");
        assert!(
            said.contains(says) && said.contains("every message read") && !said.contains("lost"),
            "cut at {cut}: {said}"
        );
    }
}
