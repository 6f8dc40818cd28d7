stateforge::model! {
    /// A sensor named as a vector output, listing more than it: only the output's own
    /// sensor (it alone) may take its name.
    pub mod m {
        scalar f32;
        state v: Vec3, b;
        output mag = v, offset = b;
        sensor mag(gate = 16.27) = [mag, offset];
        generate ekf;
        dynamics discrete {
            v = v;
            b = b;
        }
    }
}

fn main() {}
