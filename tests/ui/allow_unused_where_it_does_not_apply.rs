stateforge::model! {
    /// `#[allow(unused)]` where it does not apply: on an output, and on a state (a state is
    /// never warned about).
    pub mod m {
        scalar f32;
        state x1, #[allow(unused)] x2;
        #[allow(unused)]
        output y = x1;
        dynamics discrete {
            x1 = x1;
            x2 = x2;
        }
    }
}

fn main() {}
