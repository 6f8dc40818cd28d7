//! The main job (`cargo run --release -p generated-demo`): reports what was generated for
//! each demo model, and checks on the spot that the cantilever's `f32` and `f64` code
//! agree over a short simulated run.

use generated_demo::{cantilever, helicopter, mass_spring_damper, piecewise_beam, polynomial};

/// One row of the report: a generated function and what it computes per call.
struct Row {
    function: &'static str,
    add: u32,
    mul: u32,
    div: u32,
    call: u32,
    compare: u32,
}

macro_rules! rows {
    ($model:ident: $($function:literal => $ops:ident),* $(,)?) => {
        vec![$(Row {
            function: $function,
            add: $model::$ops.add,
            mul: $model::$ops.mul,
            div: $model::$ops.div,
            call: $model::$ops.call,
            compare: $model::$ops.compare,
        }),*]
    };
}

fn main() {
    let models: [(&str, [usize; 3], Vec<Row>); 5] = [
        (
            "cantilever",
            [cantilever::X_LEN, cantilever::U_LEN, cantilever::Y_LEN],
            rows!(cantilever: "f" => F_OPS, "h" => H_OPS, "jacobian_f_wrt_x" => JACOBIAN_F_WRT_X_OPS,
                "jacobian_f_wrt_u" => JACOBIAN_F_WRT_U_OPS, "jacobian_h_wrt_x" => JACOBIAN_H_WRT_X_OPS),
        ),
        (
            "mass_spring_damper",
            [
                mass_spring_damper::X_LEN,
                mass_spring_damper::U_LEN,
                mass_spring_damper::Y_LEN,
            ],
            rows!(mass_spring_damper: "f" => F_OPS, "h" => H_OPS, "jacobian_f_wrt_x" => JACOBIAN_F_WRT_X_OPS,
                "jacobian_f_wrt_u" => JACOBIAN_F_WRT_U_OPS, "jacobian_h_wrt_x" => JACOBIAN_H_WRT_X_OPS),
        ),
        (
            "polynomial",
            [polynomial::X_LEN, polynomial::U_LEN, polynomial::Y_LEN],
            rows!(polynomial: "f" => F_OPS, "h" => H_OPS, "jacobian_f_wrt_x" => JACOBIAN_F_WRT_X_OPS,
                "jacobian_h_wrt_x" => JACOBIAN_H_WRT_X_OPS),
        ),
        (
            "piecewise_beam",
            [
                piecewise_beam::X_LEN,
                piecewise_beam::U_LEN,
                piecewise_beam::Y_LEN,
            ],
            rows!(piecewise_beam: "f" => F_OPS, "h" => H_OPS, "jacobian_f_wrt_x" => JACOBIAN_F_WRT_X_OPS,
                "jacobian_f_wrt_u" => JACOBIAN_F_WRT_U_OPS, "jacobian_h_wrt_x" => JACOBIAN_H_WRT_X_OPS),
        ),
        (
            "helicopter",
            [helicopter::X_LEN, helicopter::U_LEN, helicopter::Y_LEN],
            rows!(helicopter: "f" => F_OPS, "h" => H_OPS, "jacobian_f_wrt_x" => JACOBIAN_F_WRT_X_OPS,
                "jacobian_f_wrt_u" => JACOBIAN_F_WRT_U_OPS, "jacobian_h_wrt_x" => JACOBIAN_H_WRT_X_OPS),
        ),
    ];
    println!("Generated model functions: arithmetic per call (counted from the generated code)\n");
    println!(
        "{:<20} {:>3} {:>3} {:>3}  {:<18} {:>5} {:>5} {:>5} {:>5} {:>5}",
        "model", "nx", "nu", "ny", "function", "add", "mul", "div", "call", "cmp"
    );
    for (name, [nx, nu, ny], rows) in &models {
        for (i, row) in rows.iter().enumerate() {
            let (name, nx, nu, ny) = if i == 0 {
                (*name, nx.to_string(), nu.to_string(), ny.to_string())
            } else {
                ("", String::new(), String::new(), String::new())
            };
            println!(
                "{:<20} {:>3} {:>3} {:>3}  {:<18} {:>5} {:>5} {:>5} {:>5} {:>5}",
                name, nx, nu, ny, row.function, row.add, row.mul, row.div, row.call, row.compare
            );
        }
    }
    cantilever_precision_check();
}

/// Runs the cantilever's generated `f` in `f32` and `f64` side by side for 10 s of a
/// square-wave input and reports how far the single-precision trajectory drifts.
fn cantilever_precision_check() {
    // Euler-equivalent parameters of a 20 rad/s, zeta = 0.026 beam at Ts = 15 ms
    // (shared/reference/simulating-the-paper.md).
    let mut x64 = [0.0, 0.0, -393.93, -6.941, 0.4924];
    let mut x32 = x64.map(|v| v as f32);
    let mut worst = 0.0f64;
    let steps = (10.0 / cantilever::in_f64::TS) as usize;
    for k in 0..steps {
        let u = if (k / 40) % 2 == 0 { 1.0 } else { -1.0 };
        x64 = cantilever::in_f64::f(&x64, &[u]);
        x32 = cantilever::f(&x32, &[u as f32]);
        worst = worst.max((f64::from(x32[0]) - x64[0]).abs());
    }
    let amplitude = x64[0].abs().max(1e-12);
    println!(
        "\ncantilever: {steps} steps of f in f32 vs f64, largest tip-displacement difference \
         {worst:.2e} mm (final displacement {amplitude:.3e} mm)"
    );
}
