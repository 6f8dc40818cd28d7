stateforge::model! {
    /// A sub-step count too large for any integer type still gets the limit.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1;
        dynamics continuous(euler, dt = TS, substeps = 18446744073709551616) {
            der(x1) = -x1;
        }
    }
}

fn main() {}
