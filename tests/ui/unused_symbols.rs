// Warnings denied, so that trybuild shows them: a parameter, an input and a run-time
// constant nothing reads are each warned about under their name; the symbols declared
// `#[allow(unused)]`, one by one or as a list, are not.
#![deny(deprecated)]

stateforge::model! {
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k, spare, #[allow(unused)] carried;
        input u, ignored;
        #[allow(unused)]
        input reserved_a, reserved_b;
        known gain, offset;
        output y = x1;
        generate ekf;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * k * gain * u;
        }
    }
}

fn main() {}
