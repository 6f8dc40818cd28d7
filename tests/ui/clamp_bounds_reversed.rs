stateforge::model! {
    /// A saturation whose bounds are written the wrong way round.
    pub mod m {
        scalar f32;
        const LOW = -1.0;
        state x1;
        dynamics discrete {
            x1 = clamp(x1, 1.0, LOW);
        }
    }
}

fn main() {}
