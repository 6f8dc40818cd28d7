stateforge::model! {
    /// Several EKFs need distinct UpperCamelCase type names that the module does not use.
    pub mod m {
        scalar f32;
        state x1;
        input u;
        output y = x1;
        generate ekf, ekf(name = Ekf), ekf(gate = 9.0, name = gated), ekf(name = Lqr),
            ekf(name = Tuned), ekf(gate = 5.0, name = Tuned);
        dynamics discrete {
            x1 = x1 + u;
        }
    }
}

fn main() {}
