stateforge::model! {
    /// A model with one mistake per intermediate, each reported under the operand that
    /// does not fit, all at once.
    pub mod m {
        scalar f32;
        const DT = 0.01;
        state
            /// attitude
            q: Rot3,
            /// velocity
            v: Vec3;
        input
            /// rate
            w: Vec3,
            /// another attitude
            r: Rot3,
            /// a number
            s;
        output y = v.x;
        dynamics discrete {
            let a = v + 1.0;
            let b = v * w;
            let c = v * q;
            let d = v.w;
            let e = q.x;
            let f = q + r;
            let g = sin(v);
            let h = log(s);
            let i = v.cross(q);
            let j = s.x;
            let k = if v > 0.0 { 1.0 } else { 0.0 };
            let l = if s > 0.0 { v } else { q };
            let m = -q;
            let n = v / w;
            let o = exp(q);
            let p = vec3(v, s, s);
            q = q * exp(w * DT);
            v = v + w * DT;
        }
    }
}

fn main() {}
