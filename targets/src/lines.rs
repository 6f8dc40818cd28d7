//! The estimate lines the firmware prints for the host (`cargo xtask` reads them).

use cortex_m_semihosting::{hprint, hprintln};

/// `<tag> <k> <v1> <v2> ..`, each value in full precision (`{:?}`).
pub fn estimate_line<'a>(tag: &str, k: usize, values: impl IntoIterator<Item = &'a f32>) {
    hprint!("{} {}", tag, k);
    for value in values {
        hprint!(" {:?}", value);
    }
    hprintln!();
}
