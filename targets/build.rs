//! Puts `memory.x` where the linker finds it, and embeds the measured sequence the host
//! also uses (`generated_demo::sequence`) as a constant, so target and host filter
//! exactly the same data.

use std::fmt::Write as _;
use std::path::PathBuf;

/// Samples in the embedded sequence (15 s at 15 ms).
const SAMPLES: usize = 1000;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");

    let mut code = String::new();
    let _ = writeln!(
        code,
        "/// The measured sequence: `(u[k], y[k])`, from `generated_demo::sequence`.\n\
         pub const SEQUENCE: [(f32, f32); {SAMPLES}] = ["
    );
    for sample in generated_demo::sequence::Measured::new().take(SAMPLES) {
        let _ = writeln!(code, "    ({:?}, {:?}),", sample.u, sample.y);
    }
    code.push_str("];\n");
    std::fs::write(out.join("sequence.rs"), code).expect("OUT_DIR is writable");
    observer_sequences(&out);
    peers();
}

/// With the `peers` feature, links `libpeers.a` from `$PEERS_LIB_DIR` (compiled by
/// `cargo xtask peers` with arm-none-eabi-gcc).
fn peers() {
    println!("cargo:rerun-if-env-changed=PEERS_LIB_DIR");
    if std::env::var_os("CARGO_FEATURE_PEERS").is_none() {
        return;
    }
    let Some(dir) = std::env::var_os("PEERS_LIB_DIR") else {
        panic!("the `peers` feature links libpeers.a from $PEERS_LIB_DIR: run `cargo xtask peers`");
    };
    let dir = PathBuf::from(dir);
    println!("cargo:rustc-link-search=native={}", dir.display());
    println!("cargo:rustc-link-lib=static=peers");
    println!(
        "cargo:rerun-if-changed={}",
        dir.join("libpeers.a").display()
    );
}

/// Samples of the beam (0.5 s at 0.5 ms) and hub (10 s at 10 ms) sequences.
const OBSERVER_SAMPLES: usize = 1000;

/// Embeds the sequences of the compile-time designed observers
/// (`generated_demo::observer_sequences`).
pub fn observer_sequences(out: &std::path::Path) {
    use generated_demo::observer_sequences::{BeamMeasured, HubMeasured};
    let mut code = String::new();
    let _ = writeln!(
        code,
        "/// The beam sequence `(u[k], [y_act[k], y_mid[k]])`.\n\
         pub const BEAM_SEQUENCE: [(f32, [f32; 2]); {OBSERVER_SAMPLES}] = ["
    );
    for s in BeamMeasured::new().take(OBSERVER_SAMPLES) {
        let _ = writeln!(code, "    ({:?}, [{:?}, {:?}]),", s.u, s.y[0], s.y[1]);
    }
    let _ = writeln!(
        code,
        "];\n/// The hub sequence `y[k]`.\npub const HUB_SEQUENCE: [f32; {OBSERVER_SAMPLES}] = ["
    );
    for y in HubMeasured::new().take(OBSERVER_SAMPLES) {
        let _ = writeln!(code, "    {y:?},");
    }
    code.push_str("];\n");
    std::fs::write(out.join("observer_sequences.rs"), code).expect("OUT_DIR is writable");
}
