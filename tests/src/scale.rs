//! A family of sparse models of any size, for the scale test and the build benchmark.

/// An integrator chain of `n` states driven by one input and measured at its first state,
/// `x_i[k+1] = x_i[k] + TS x_(i+1)[k]`: two structural non-zeros per row of the Jacobian,
/// the sparse shape of a discretised mechanical model. With `ekf`, the filter too.
pub fn integrator_chain(n: usize, ekf: bool) -> String {
    let states: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
    let mut equations = String::new();
    for i in 1..n {
        equations += &format!("            x{i} = x{i} + TS * x{};\n", i + 1);
    }
    equations += &format!("            x{n} = x{n} + TS * u;\n");
    let generate = if ekf { "        generate ekf;\n" } else { "" };
    format!(
        "model! {{\n    pub mod chain {{\n        scalar f32;\n        const TS = 0.01;\n        \
         state {};\n        input u;\n        output y = x1;\n        dynamics discrete {{\n\
         {equations}        }}\n{generate}    }}\n}}\n",
        states.join(", ")
    )
}
