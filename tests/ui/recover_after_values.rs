stateforge::model! {
    /// `recover_after` is a whole number of refusals from 1, or `off`: each mistake is
    /// reported under its value, several at once.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param c;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (c * x1 + u);
        }
        generate ekf(recover_after = 0),
            ekf(name = HalfEkf, recover_after = 2.5),
            ekf(name = NeverEkf, recover_after = never),
            dkf(recover_after = [x1]);
    }
}

fn main() {}
