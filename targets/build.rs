//! Puts `memory.x` (the board's, beside the shared measuring harness in
//! `model-codegen/firmware/`) where the linker finds it, and embeds the measured sequence the host
//! also uses (`generated_demo::sequence`) as a constant, so target and host filter
//! exactly the same data; likewise the observers' sequences and the first seconds of the
//! navigation flight (`generated_demo::flight`), both read through `data.rs`, which the
//! C firmware's data is written from too.

use std::fmt::Write as _;
use std::path::PathBuf;

/// The data both firmwares run on.
#[path = "data.rs"]
mod data;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    // The board's memory map, shared with the firmware `stateforge-codegen measure` builds.
    let memory = "../model-codegen/firmware/memory.x";
    std::fs::copy(memory, out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={memory}");
    println!("cargo:rerun-if-changed=data.rs");

    let mut code = String::new();
    let _ = writeln!(
        code,
        "/// The measured sequence: `(u[k], y[k])`, from `generated_demo::sequence`.\n\
         pub const SEQUENCE: [(f32, f32); {}] = [",
        data::SAMPLES
    );
    for (u, y) in data::sequence() {
        let _ = writeln!(code, "    ({u:?}, {y:?}),");
    }
    code.push_str("];\n");
    std::fs::write(out.join("sequence.rs"), code).expect("OUT_DIR is writable");
    observer_sequences(&out);
    navigation(&out);
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
    // SymForce's generated C++ calls `sinf` and `cosf`: the ARM toolchain's own C math
    // library (newlib's `libm.a` for this CPU and ABI, single precision), searched before
    // Rust's `compiler_builtins`, whose `libm` port widens them to software `f64`.
    println!("cargo:rerun-if-env-changed=PEERS_LIBM_DIR");
    if std::env::var_os("CARGO_FEATURE_SYMFORCE").is_some() {
        let Some(libm) = std::env::var_os("PEERS_LIBM_DIR") else {
            panic!("the `symforce` feature links newlib's libm.a from $PEERS_LIBM_DIR: run `cargo xtask peers`");
        };
        println!(
            "cargo:rustc-link-search=native={}",
            PathBuf::from(libm).display()
        );
        println!("cargo:rustc-link-lib=static=m");
    }
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

/// Writes `values` as a Rust array literal of `f32` (`{:?}`: every `f32` read back exactly).
fn f32_array(values: &[f32]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
    format!("[{}]", items.join(", "))
}

/// Embeds the navigation flight as the host's experiment flies it (`data::flight`): the
/// filter's initial estimate and tuning, then the IMU samples' intervals and the samples
/// as the model's inputs, and the magnetometer and GNSS readings with the index of the IMU
/// sample they follow.
fn navigation(out: &std::path::Path) {
    let flight = data::flight();
    let mut code = String::new();
    let _ = writeln!(
        code,
        "/// The initial estimate (`flight::initial_estimate`).\n\
         pub const X0: [f32; 24] = {};\n\
         /// The diagonals of `P0` and of the density `Q` (over the 23 tangent\n\
         /// coordinates) and `R` (`flight::tuning`).\n\
         pub const P0: [f32; 23] = {};\n\
         pub const Q: [f32; 23] = {};\n\
         pub const R: [f32; 9] = {};",
        f32_array(&flight.x0),
        f32_array(&flight.p0),
        f32_array(&flight.q),
        f32_array(&flight.r),
    );
    let imu: String = flight
        .imu
        .iter()
        .map(|sample| format!("    {},\n", f32_array(sample)))
        .collect();
    let indexed = |readings: &[(usize, Vec<f32>)]| -> Vec<String> {
        readings
            .iter()
            .map(|(k, y)| format!("    ({k}, {}),", f32_array(y)))
            .collect()
    };
    let (magnetometer, gnss) = (indexed(&flight.magnetometer), indexed(&flight.gnss));
    let samples = data::NAVIGATION_SAMPLES;
    // Statics, not constants: the IMU samples are 24 KB.
    let _ = writeln!(
        code,
        "/// IMU samples, magnetometer readings and GNSS fixes.\n\
         pub const SAMPLES: usize = {samples};\n\
         pub const MAGNETOMETER_READINGS: usize = {};\n\
         pub const GNSS_FIXES: usize = {};\n\
         /// IMU samples' intervals (s), jittered about the nominal `DT`.\n\
         pub static INTERVAL: [f32; SAMPLES] = {};\n\
         /// IMU samples as the model's inputs, gyro (rad/s) and accelerometer (m/s^2):\n\
         /// the delta angle and delta velocity over the sample divided by its interval.\n\
         pub static IMU: [[f32; 6]; SAMPLES] = [\n{imu}];\n\
         /// Magnetometer readings, after the IMU sample of the index given.\n\
         pub static MAGNETOMETER: [(usize, [f32; 3]); MAGNETOMETER_READINGS] = [\n{}\n];\n\
         /// GNSS fixes (NED velocity, position), after the IMU sample of the index given.\n\
         pub static GNSS: [(usize, [f32; 6]); GNSS_FIXES] = [\n{}\n];",
        magnetometer.len(),
        gnss.len(),
        f32_array(&flight.interval),
        magnetometer.join("\n"),
        gnss.join("\n"),
    );
    std::fs::write(out.join("navigation_flight.rs"), code).expect("OUT_DIR is writable");
}
