stateforge::model! {
    /// Input noise listing a name that is not an input.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input gyro: Vec3;
        output y = x1;
        generate ekf(input_noise = [gyr]);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * gyro.x;
        }
    }
}

fn main() {}
