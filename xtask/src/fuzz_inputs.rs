//! The fuzz tests' last inputs: `tests/tests/fuzz_front_ends.rs` writes each case before
//! it expands it, one file per test, so that when a test process is killed (a memory
//! limit, a signal) and proptest shows nothing, the cases that were running are known.

use crate::scratch;
use std::fmt::Write as _;
use std::time::SystemTime;

/// The last inputs written since `started`, each with its file's path, to append to the
/// tests' failure; empty when there are none.
pub fn written_since(started: SystemTime) -> String {
    let dir = scratch::workspace_root().join("target/tmp/fuzz-last-input");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return String::new();
    };
    let mut report = String::new();
    for entry in entries.flatten() {
        let fresh = entry
            .metadata()
            .and_then(|m| m.modified())
            .is_ok_and(|modified| modified >= started);
        if let (true, Ok(text)) = (fresh, std::fs::read_to_string(entry.path())) {
            let _ = write!(
                report,
                "\nxtask: the last case of {} (a fuzz test's input, written before it was \
                 expanded):\n{text}",
                entry.path().display()
            );
        }
    }
    report
}
