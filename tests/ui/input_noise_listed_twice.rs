stateforge::model! {
    /// Input noise listing an input twice: one variance per entry.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u, gyro: Vec3;
        output y = x1;
        generate ekf(input_noise = [gyro, u, gyro]);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (u + gyro.x);
        }
    }
}

fn main() {}
