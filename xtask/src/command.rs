//! Running the commands the checks are made of.

use std::process::Command;

/// `cargo`, the one running this task where there is one.
pub fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// Runs a command, naming it in progress (on standard error, after `xtask: `) and error
/// messages: the measuring harness's runner (`stateforge_cli::measure::setup`).
pub fn run(what: &str, command: &mut Command) -> Result<(), String> {
    stateforge_cli::measure::setup::run_announced("xtask: ", what, command)
}
