//! Property tests of the CARMEN log reader (`carmen::parse_log`, and `carmen::read_log`
//! on plain and gzip files): mutated valid logs and random bytes must give a log or a
//! [`CarmenError`] naming the file (and the line where it has one): never a panic,
//! never an allocation beyond the reader's limits, never a hang.
//!
//! Seeds: the first 2 and 10 KB of the Intel lab log (`tests/data`, decompressed here;
//! the 10 KB hold its first `FLASER` scans of 180 beams) and a small log made here
//! (CRLF lines, every message the reader skips). Gzip cases compress a mutated log, or
//! mutate the compressed bytes. CI runs a bounded number of cases (`CASES`, see
//! `docs/fuzzing.md`); `wearnav fuzz` runs millions on demand. `PROPTEST_CASES=N` sets
//! the cases per property.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::LazyLock;

use decoder_props::{config, measured, mutated, mutation_with, within, LargestAllocation, MAX_CASE_TIME};
use localization::carmen::{
    parse_log, read_log, CarmenError, CarmenLog, Record, MAX_BEAMS, MAX_LINE_BYTES, MAX_LOG_BYTES, MAX_RECORDS,
};
use proptest::prelude::*;
use proptest::sample::Index;

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Text that a line reader meets with edge cases.
static TOKENS: [&str; 20] = [
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "-1",
    "0",
    "nan",
    ".nan",
    "inf",
    "-1e400",
    "1e308",
    "\n",
    " ",
    "\"",
    "[",
    "]]",
    "=",
    "\nFLASER ",
    "\t- ",
    "# ",
    "\nODOM ",
];

/// Cases per property in CI (measured numbers in `docs/fuzzing.md`).
const CASES: u32 = 50_000;

// ---------------------------------------------------------------------------------
// Seeds.

const INTEL_GZ: &[u8] = include_bytes!("data/intel-corrected.log.gz");

/// The first `limit` bytes of the Intel log, cut after the last whole line.
fn intel_head(limit: u64) -> Vec<u8> {
    let mut text = Vec::new();
    flate2::read::MultiGzDecoder::new(INTEL_GZ).take(limit).read_to_end(&mut text).expect("the Intel log inflates");
    let end = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    text.truncate(end);
    text
}

fn text_seeds() -> Vec<Vec<u8>> {
    vec![
        intel_head(2 * 1024),
        intel_head(10 * 1024),
        b"# comment\r\nPARAM robot_frontlaser_offset 0.0 nohost 0\r\nODOM 1 2 0.5 0.1 0.2 0 10.5 pippo 10.5\r\n\
          FLASER 3 1.0 2.0 3.0 0.5 -0.5 0.1 0.5 -0.5 0.1 11.0 pippo 11.0\r\nNEFF 15\r\n\r\n\
          FLASER 0 0 0 0 0 0 0 12 h 12\nRLASER 1 2 3\nODOM -1e3 2E-2 3.14 0 0 0 13 h 13"
            .to_vec(),
    ]
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(bytes).expect("compresses");
    gz.finish().expect("compresses")
}

static TEXT_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(text_seeds);
static GZIP_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(|| TEXT_SEEDS.iter().map(|t| gzip(t)).collect());

// ---------------------------------------------------------------------------------
// Checks.

/// Largest single allocation a parse of `len` bytes (decompressed) may make: a record
/// per line of at least 18 bytes (`ODOM` and 7 one-digit numbers; the list doubles as
/// it grows), a line buffer of up to `MAX_LINE_BYTES` (doubling: twice that), a scan's
/// ranges (at most `MAX_BEAMS`), the reader's and inflater's buffers.
fn log_bound(len: usize) -> usize {
    let records = (len / 18 + 4).min(MAX_RECORDS);
    2 * std::mem::size_of::<Record>() * records + 2 * MAX_LINE_BYTES + 8 * MAX_BEAMS + 128 * 1024
}

/// A log keeps the reader's contract, an error names the file and a line in the text.
fn check_outcome(result: Result<CarmenLog, CarmenError>, file: &Path, text: &[u8]) -> Result<(), String> {
    match result {
        Ok(log) => {
            let lasers_ok = log
                .lasers()
                .all(|l| l.ranges_m.len() <= MAX_BEAMS && l.ranges_m.iter().all(|r| r.is_finite() && *r >= 0.0));
            if log.records.len() > MAX_RECORDS || !lasers_ok {
                Err(format!("accepted {} records with a bad scan", log.records.len()))
            } else {
                Ok(())
            }
        }
        Err(e) => {
            let message = e.to_string();
            let lines = text.iter().filter(|&&b| b == b'\n').count() + 1;
            if !message.starts_with(&format!("{}", file.display())) {
                return Err(format!("error does not name {}: {message}", file.display()));
            }
            match e {
                CarmenError::Parse { line, .. } if line == 0 || line > lines => {
                    Err(format!("line {line} of a {lines}-line log: {message}"))
                }
                _ => Ok(()),
            }
        }
    }
}

fn check_text(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.log");
    let (result, largest, took) = measured(|| parse_log(bytes, file));
    within("CARMEN", largest, log_bound(bytes.len()), took)?;
    check_outcome(result, file, bytes)
}

/// A fresh file per case under the system's temp folder, removed on drop.
struct CaseFile(PathBuf);

impl CaseFile {
    fn new(bytes: &[u8]) -> CaseFile {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("carmen-decoders-{}-{n}.log.gz", std::process::id()));
        std::fs::write(&path, bytes).expect("temp file");
        CaseFile(path)
    }
}

impl Drop for CaseFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Reads a file through `read_log` (gzip when it starts with the magic bytes); the
/// bound is that of the text it inflates to.
fn check_file(bytes: &[u8]) -> Result<(), String> {
    let file = CaseFile::new(bytes);
    let mut text = Vec::new();
    if bytes.starts_with(&[0x1f, 0x8b]) {
        // as far as it inflates: a damaged stream is refused where it breaks
        let _ = flate2::read::MultiGzDecoder::new(bytes).take(MAX_LOG_BYTES + 1).read_to_end(&mut text);
    } else {
        text = bytes.to_vec();
    }
    let (result, largest, took) = measured(|| read_log(&file.0));
    within("CARMEN file", largest, log_bound(text.len()), took)?;
    check_outcome(result, &file.0, &text)
}

#[test]
fn every_seed_is_valid() {
    for (i, seed) in text_seeds().iter().enumerate() {
        let log = parse_log(seed.as_slice(), Path::new("seed.log")).unwrap_or_else(|e| panic!("seed {i}: {e}"));
        assert!(!log.records.is_empty() && log.skipped_lines > 0, "seed {i}");
        assert_eq!(check_file(&gzip(seed)), Ok(()), "seed {i} gzipped");
    }
    let intel = parse_log(intel_head(10 * 1024).as_slice(), Path::new("intel.log")).expect("parses");
    assert!(intel.lasers().any(|l| l.ranges_m.len() == 180), "the 10 KB seed holds a scan");
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn mutated_logs_parse_or_are_refused_with_the_line(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_text(&mutated(&TEXT_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }
}

proptest! {
    // A file per case, and random bytes rarely get past a line's first word: fewer cases.
    #![proptest_config(config(CASES / 10))]

    #[test]
    fn gzip_logs_mutated_before_or_after_compression_read_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
        compressed_damage in any::<bool>(),
    ) {
        let bytes = if compressed_damage {
            mutated(&GZIP_SEEDS, &seed, &mutations)
        } else {
            gzip(&mutated(&TEXT_SEEDS, &seed, &mutations))
        };
        let outcome = check_file(&bytes);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn random_bytes_are_refused_or_skipped(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        prop_assert_eq!(check_text(&bytes), Ok(()));
        let mut gz = vec![0x1f, 0x8b];
        gz.extend_from_slice(&bytes);
        prop_assert_eq!(check_file(&gz), Ok(()));
    }
}

// ---------------------------------------------------------------------------------
// Forged counts and endless lines: refused within the limits.

#[test]
fn forged_beam_counts_are_refused_before_allocating() {
    for count in ["4097", "18446744073709551615", "18446744073709551616", "-1", "nan"] {
        let text = format!("FLASER {count} 1 2 3\n");
        let (result, largest, _) = measured(|| parse_log(text.as_bytes(), Path::new("forged.log")));
        assert!(matches!(result, Err(CarmenError::Parse { line: 1, .. })), "{count}: {result:?}");
        assert!(largest < 64 * 1024, "{count}: allocated {largest} bytes at once");
    }
}

#[test]
fn a_gzip_of_one_endless_line_is_refused_within_the_line_limit() {
    // 4 MB of one line compress to 4 KB: refused at MAX_LINE_BYTES, not buffered whole
    let endless = gzip(&vec![b'1'; 4 << 20]);
    let file = CaseFile::new(&endless);
    let (result, largest, took) = measured(|| read_log(&file.0));
    assert!(matches!(result, Err(CarmenError::TooLarge { .. })), "{result:?}");
    assert!(largest <= 4 * MAX_LINE_BYTES, "allocated {largest} bytes at once");
    assert!(took < MAX_CASE_TIME, "took {took:?}");
}
