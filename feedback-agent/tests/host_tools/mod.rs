//! The programs some tests drive for real (espeak-ng, sox, speech-dispatcher), and what
//! such a test does when one is missing. `scripts/test` installs them all, so under CI
//! (the `CI` environment variable set and non-empty) a missing program is a broken
//! install and the test fails with its reason; on a developer's machine the test says
//! so loudly and skips.

use std::process::Command;

/// Whether `program arg` runs and exits 0 (e.g. `espeak-ng --version`).
pub fn runs(program: &str, arg: &str) -> bool {
    Command::new(program).arg(arg).output().map(|o| o.status.success()).unwrap_or(false)
}

/// For a test that cannot run here: panics with `reason` under CI; otherwise prints it
/// with the test's name and returns, and the test returns early.
pub fn skip_or_fail(reason: &str) {
    // libtest and nextest run each test on a thread named after it
    let test = std::thread::current().name().unwrap_or("this test").to_owned();
    if std::env::var_os("CI").is_some_and(|v| !v.is_empty()) {
        panic!("{test} cannot run: {reason}; CI is set, so this fails instead of skipping");
    }
    eprintln!("SKIPPED {test}: {reason} (with CI set this is a failure)");
}
