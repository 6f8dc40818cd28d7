stateforge::model! {
    /// `#[allow(unused)]` on a declaration it does not apply to.
    pub mod m {
        scalar f32;
        state x1;
        #[allow(unused)]
        output y = x1;
        dynamics discrete {
            x1 = x1;
        }
    }
}

fn main() {}
