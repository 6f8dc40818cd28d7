// The piecewise beam (generated-demo/models/piecewise_beam.rs) with its equations of motion
// integrated by RK4 in 64 unrolled sub-steps per sample: the largest unrolled step, what
// the build benchmark (tests/examples/build_scale.rs) runs through stateforge-codegen.
stateforge::model! {
    pub mod piecewise_beam_substeps {
        scalar f32, f64;
        const TS = 0.0005;
        const K_NL = 1.98e5;
        const C_H = 9.4e-4;
        const M11 = 4.0;
        const M12 = 1.5;
        const M13 = -0.06;
        const M22 = 7.0;
        const M23 = 0.12;
        const M33 = 0.05;
        const K11 = 3.2e5;
        const K12 = -1.65e5;
        const K13 = 0.0;
        const K22 = 1.85e5;
        const K23 = 0.0;
        const K33 = 7.126e4;
        const RAY_A = 1.0;
        const RAY_B = 1.0e-4;
        const B11 = RAY_A * M11 + RAY_B * K11;
        const B12 = RAY_A * M12 + RAY_B * K12;
        const B13 = RAY_A * M13 + RAY_B * K13;
        const B22 = RAY_A * M22 + RAY_B * K22;
        const B23 = RAY_A * M23 + RAY_B * K23;
        const B33 = RAY_A * M33 + RAY_B * K33;
        const M_DET = M11 * (M22 * M33 - M23 * M23) - M12 * (M12 * M33 - M23 * M13) + M13 * (M12 * M23 - M22 * M13);
        const MI11 = (M22 * M33 - M23 * M23) / M_DET;
        const MI12 = (M13 * M23 - M12 * M33) / M_DET;
        const MI13 = (M12 * M23 - M13 * M22) / M_DET;
        const MI22 = (M11 * M33 - M13 * M13) / M_DET;
        const MI23 = (M12 * M13 - M11 * M23) / M_DET;
        const MI33 = (M11 * M22 - M12 * M12) / M_DET;
        state
            q_act,
            q_mid,
            xi,
            v_act,
            v_mid,
            v_xi;
        input
            u;
        output
            y_act = q_act,
            y_mid = q_mid;
        const Q_POS = 1e-14;
        const Q_VEL = 1e-8;
        const R_LVDT = 2.5e-11;
        generate ekf;
        dynamics continuous(rk4, dt = TS, substeps = 64) {
            let f_nl = if q_mid > 0.0 { K_NL * q_mid } else { 0.0 };
            let f_act = -(B11 * v_act + B12 * v_mid + B13 * v_xi) - (K11 * q_act + K12 * q_mid + K13 * xi);
            let f_mid = u - f_nl - (B12 * v_act + B22 * v_mid + B23 * v_xi) - (K12 * q_act + K22 * q_mid + K23 * xi);
            let f_xi = -(B13 * v_act + B23 * v_mid + B33 * v_xi) - (K13 * q_act + K23 * q_mid + K33 * xi);
            der(q_act) = v_act;
            der(q_mid) = v_mid;
            der(xi) = v_xi;
            der(v_act) = MI11 * f_act + MI12 * f_mid + MI13 * f_xi;
            der(v_mid) = MI12 * f_act + MI22 * f_mid + MI23 * f_xi;
            der(v_xi) = MI13 * f_act + MI23 * f_mid + MI33 * f_xi;
        }
    }
}

