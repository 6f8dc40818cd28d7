stateforge::model! {
    /// A vector whose entry name (`v_x`) is declared as well.
    pub mod m {
        scalar f32;
        state
            /// velocity
            v: Vec3,
            /// a number named like the first entry of `v`
            v_x;
        output y = v_x;
        dynamics discrete {
            v = v;
            v_x = v_x;
        }
    }
}

fn main() {}
