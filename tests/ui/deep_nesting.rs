stateforge::model! {
    /// Nesting past 64 levels is refused before anything recurses through it.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = ((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((x1))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))));
        }
    }
}

fn main() {}
