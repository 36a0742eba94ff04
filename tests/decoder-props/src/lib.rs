//! What every decoder property test shares (a dev-dependency only): a global allocator
//! that records the largest single allocation a case makes, the time bound of a case,
//! and the mutations of valid inputs (bit flips, overwrites, cuts, tails, runs, forged
//! 0xff lengths, insertions, removals, splices of another seed, tokens parsers trip
//! on). Each test binary installs the allocator:
//!
//! ```ignore
//! #[global_allocator]
//! static ALLOCATOR: decoder_props::LargestAllocation = decoder_props::LargestAllocation;
//! ```

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::sample::Index;

/// Wraps the system allocator to record the largest single request made on this
/// thread while tracking is on (proptest runs each test's cases on its own thread).
pub struct LargestAllocation;

thread_local! {
    static TRACKING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    // `try_with`: the allocator also serves threads being torn down.
    let _ = TRACKING.try_with(|on| {
        if on.get() {
            LARGEST.with(|l| l.set(l.get().max(size)));
        }
    });
}

unsafe impl GlobalAlloc for LargestAllocation {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Longest any one case may take: generous, a hang is seconds to forever.
pub const MAX_CASE_TIME: Duration = Duration::from_secs(2);

/// Runs `f`, returning its result, the largest single allocation it made and its time.
pub fn measured<T>(f: impl FnOnce() -> T) -> (T, usize, Duration) {
    LARGEST.with(|l| l.set(0));
    TRACKING.with(|t| t.set(true));
    let start = Instant::now();
    let out = f();
    let took = start.elapsed();
    TRACKING.with(|t| t.set(false));
    (out, LARGEST.with(Cell::get), took)
}

/// Fails with what was decoded if it allocated more than `bound` at once or took
/// longer than [`MAX_CASE_TIME`].
pub fn within(what: &str, largest: usize, bound: usize, took: Duration) -> Result<(), String> {
    if largest > bound {
        return Err(format!("{what}: allocated {largest} bytes at once (bound {bound})"));
    }
    if took > MAX_CASE_TIME {
        return Err(format!("{what}: took {took:?}"));
    }
    Ok(())
}

/// One change to a byte string, at positions scaled to its length.
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Flip one bit.
    FlipBit(Index, u8),
    /// Overwrite one byte.
    SetByte(Index, u8),
    /// Cut the input there.
    Truncate(Index),
    /// Append random bytes.
    Tail(Vec<u8>),
    /// Overwrite a run of bytes with one value.
    Run(Index, u8, u8),
    /// Overwrite 1..=8 bytes with 0xff: a forged length or count.
    FfLength(Index, u8),
    /// Insert random bytes.
    Insert(Index, Vec<u8>),
    /// Remove a run of bytes.
    Remove(Index, u8),
    /// Overwrite from there with a piece of another seed.
    Splice(Index, Index, Index),
    /// Insert text a reader may trip on: a huge or odd number, a keyword.
    Token(Index, &'static str),
}

/// Text that header and TOML parsers meet with edge cases.
pub const TOKENS: [&str; 16] = [
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "-1",
    "0",
    "nan",
    "inf",
    "-1e400",
    "1e308",
    "\n",
    " ",
    "\"",
    "[",
    "]]",
    "=",
    "\nDATA binary\n",
];

/// A mutation, inserting [`TOKENS`] among others.
pub fn mutation() -> impl Strategy<Value = Mutation> {
    mutation_with(&TOKENS)
}

/// A mutation, inserting the caller's `tokens` (a format's own keywords and edge cases).
pub fn mutation_with(tokens: &'static [&'static str]) -> impl Strategy<Value = Mutation> {
    prop_oneof![
        3 => (any::<Index>(), 0..8u8).prop_map(|(i, b)| Mutation::FlipBit(i, b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, v)| Mutation::SetByte(i, v)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
        1 => prop::collection::vec(any::<u8>(), 1..32).prop_map(Mutation::Tail),
        1 => (any::<Index>(), 1..64u8, any::<u8>()).prop_map(|(i, n, v)| Mutation::Run(i, n, v)),
        2 => (any::<Index>(), 1..=8u8).prop_map(|(i, n)| Mutation::FfLength(i, n)),
        1 => (any::<Index>(), prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(i, v)| Mutation::Insert(i, v)),
        1 => (any::<Index>(), 1..32u8).prop_map(|(i, n)| Mutation::Remove(i, n)),
        1 => (any::<Index>(), any::<Index>(), any::<Index>()).prop_map(|(s, f, t)| Mutation::Splice(s, f, t)),
        2 => (any::<Index>(), prop::sample::select(tokens.to_vec())).prop_map(|(i, t)| Mutation::Token(i, t)),
    ]
}

pub fn mutate(bytes: &mut Vec<u8>, m: &Mutation, seeds: &[Vec<u8>]) {
    let at = |i: &Index, len: usize| if len == 0 { 0 } else { i.index(len) };
    match m {
        Mutation::FlipBit(i, b) if !bytes.is_empty() => {
            let i = at(i, bytes.len());
            bytes[i] ^= 1 << b;
        }
        Mutation::SetByte(i, v) if !bytes.is_empty() => {
            let i = at(i, bytes.len());
            bytes[i] = *v;
        }
        Mutation::Truncate(i) => bytes.truncate(at(i, bytes.len() + 1)),
        Mutation::Tail(tail) => bytes.extend_from_slice(tail),
        Mutation::Run(i, n, v) => {
            let start = at(i, bytes.len() + 1);
            let end = (start + *n as usize).min(bytes.len());
            bytes[start..end].fill(*v);
        }
        Mutation::FfLength(i, n) => {
            let start = at(i, bytes.len() + 1);
            let end = (start + *n as usize).min(bytes.len());
            bytes[start..end].fill(0xff);
        }
        Mutation::Insert(i, v) => {
            let start = at(i, bytes.len() + 1);
            bytes.splice(start..start, v.iter().copied());
        }
        Mutation::Remove(i, n) => {
            let start = at(i, bytes.len() + 1);
            let end = (start + *n as usize).min(bytes.len());
            bytes.drain(start..end);
        }
        Mutation::Splice(s, f, t) => {
            let other = &seeds[s.index(seeds.len())];
            let from = at(f, other.len() + 1);
            let to = at(t, bytes.len() + 1);
            bytes.truncate(to);
            bytes.extend_from_slice(&other[from..]);
        }
        Mutation::Token(i, token) => {
            let start = at(i, bytes.len() + 1);
            bytes.splice(start..start, token.bytes());
        }
        Mutation::FlipBit(..) | Mutation::SetByte(..) => {}
    }
}

pub fn mutated(seeds: &[Vec<u8>], seed: &Index, mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = seeds[seed.index(seeds.len())].clone();
    for m in mutations {
        mutate(&mut bytes, m, seeds);
    }
    bytes
}

/// `cases` per property, or `PROPTEST_CASES` when set (to run more, or fewer).
pub fn config(cases: u32) -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(cases);
    ProptestConfig { cases, failure_persistence: None, ..ProptestConfig::default() }
}
