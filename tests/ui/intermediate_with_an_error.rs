stateforge::model! {
    /// Intermediates whose definitions are wrong: each mistake is reported once, under its
    /// token, and the lines that read those intermediates add no error of their own.
    pub mod m {
        scalar f32;
        state wx, wy;
        output y = wx;
        dynamics discrete {
            let h2 = wx.powf(2.0);
            let c = h2 + 1.0;
            let v = wy * gain;
            let d = c * v;
            wx = wx + 0.01 * d;
            wy = wy - 0.01 * (h2 + v);
        }
    }
}

fn main() {}
