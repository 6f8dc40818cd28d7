stateforge::model! {
    /// Sensors with every mistake a sensor can have, all reported at once.
    pub mod m {
        scalar f32;
        state x1, x2;
        output y1 = x1, y2 = x2, y3 = x1 + x2, y4 = x1 - x2;
        sensor pair = [y1, y2];
        sensor y3 = [y3];
        sensor other = [y2, y9];
        sensor doubled = [y4, y4];
        sensor none = [];
        dynamics discrete {
            x1 = x1;
            x2 = x2;
        }
        generate ekf;
    }
}

fn main() {}
