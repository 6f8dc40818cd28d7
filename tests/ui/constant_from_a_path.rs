const DT: f32 = 0.01;

stateforge::model! {
    /// A model sees only its own names.
    pub mod m {
        scalar f32;
        const TS = crate::DT;
        state x1;
        dynamics discrete {
            x1 = TS * x1;
        }
    }
}

fn main() {
    let _ = DT;
}
