stateforge::model! {
    /// A model written with indexing and an array, as in other languages.
    pub mod m {
        scalar f32;
        state
            /// velocity
            v: Vec3;
        output y = v[0];
        dynamics discrete {
            v = [v.x, v.y, v.z];
        }
    }
}

fn main() {}
