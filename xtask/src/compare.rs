//! The firmware's `f32` estimates against the host's `f64` run of the same generated code
//! on the same measured sequence.

use crate::firmware::Estimate;
use generated_demo::cantilever::in_f64::{Dkf, Ekf, Lqr, Status};
use generated_demo::sequence::Measured;

/// Host estimates at every sample, in the firmware's order.
pub fn host_run(samples: usize) -> Vec<Estimate> {
    let q = [0.0, 0.0, 100.0, 300.0, 1e-3];
    let r = [[0.001]];
    let close = [0.01, 0.0, -400.0, -1.0, 0.01];
    let wrong = [0.01, 0.0, -50000.0, -10.0, 0.01];
    let p_close = diag([0.1, 1.0, 2e4, 1000.0, 0.1]);
    let p_wrong = diag([0.1, 1.0, 2e6, 1000.0, 0.1]);
    let mut ekf = Ekf::new(&close, &p_close, &q, &r).expect("the tuning is finite");
    let mut dkf = Dkf::new(&close, &p_close, &q, &p_close, &q, &r).expect("the tuning is finite");
    let mut dkf_wrong =
        Dkf::new(&wrong, &p_wrong, &q, &p_wrong, &q, &r).expect("the tuning is finite");
    let mut lqr = Lqr::new(&[[1.0, 0.0], [0.0, 1.0]], &[[0.001]], Some(&[100.0]))
        .expect("the tuning is finite");
    // The firmware sees the f32 samples; so does the host, widened exactly.
    let data: Vec<(f64, f64)> = Measured::new()
        .take(samples)
        .map(|s| (f64::from(s.u), f64::from(s.y)))
        .collect();
    let mut out = Vec::new();
    for k in 1..samples {
        let (u_prev, y) = (data[k - 1].0, data[k].1);
        let _: Status = ekf.step(&[u_prev], &[y]);
        let _ = dkf.step(&[u_prev], &[y]);
        let _ = dkf_wrong.step(&[u_prev], &[y]);
        let _: Status = lqr.solve(&dkf.state(), &[u_prev]);
        out.push(Estimate {
            k,
            ekf: ekf.state(),
            dkf: dkf.state(),
            dkf_wrong: dkf_wrong.state(),
            gain: lqr.gain()[0],
            control: lqr.control(&dkf.state())[0],
        });
    }
    out
}

fn diag(d: [f64; 5]) -> [[f64; 5]; 5] {
    let mut m = [[0.0; 5]; 5];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = d[i];
    }
    m
}

/// Relative agreement required between target (`f32`) and host (`f64`).
pub const RTOL: f64 = 1e-4;
/// Per state entry, the magnitude below which the tolerance stops shrinking: mm, mm/s,
/// 1/s^2, 1/s, mm/(s^2 V).
pub const FLOORS: [f64; 5] = [0.1, 1.0, 1.0, 0.1, 0.01];

/// Checks every printed estimate against the host run, and that the DKF from the wrong
/// guess converges on the target as on the host (wn within 2% of the truth by 10 s).
/// Returns a summary (the largest relative difference, overall and per filter), or the
/// first disagreement.
pub fn check(target: &[Estimate], host: &[Estimate]) -> Result<String, String> {
    // Largest relative difference: EKF, DKF, DKF from the wrong guess, LQR gain and control.
    let mut worst = [0.0f64; 4];
    for t in target {
        let h = host
            .get(t.k.wrapping_sub(1))
            .filter(|h| h.k == t.k)
            .ok_or_else(|| format!("the host has no sample {}", t.k))?;
        for (group, (name, tv, hv)) in [
            ("EKF", t.ekf, h.ekf),
            ("DKF", t.dkf, h.dkf),
            ("DKF (wrong guess)", t.dkf_wrong, h.dkf_wrong),
        ]
        .into_iter()
        .enumerate()
        {
            for i in 0..5 {
                let scale = hv[i].abs().max(FLOORS[i]);
                let error = (tv[i] - hv[i]).abs() / scale;
                worst[group] = worst[group].max(error);
                if error.is_nan() || error > RTOL {
                    return Err(format!(
                        "{name} x{} at sample {}: target {} vs host {} (relative {error:.1e}, allowed {RTOL:e})",
                        i + 1,
                        t.k,
                        tv[i],
                        hv[i]
                    ));
                }
            }
        }
        for (name, tv, hv, floor) in [
            ("LQR gain K1", t.gain[0], h.gain[0], 1.0),
            ("LQR gain K2", t.gain[1], h.gain[1], 1.0),
            ("control", t.control, h.control, 1.0),
        ] {
            let error = (tv - hv).abs() / hv.abs().max(floor);
            worst[3] = worst[3].max(error);
            if error.is_nan() || error > RTOL {
                return Err(format!(
                    "{name} at sample {}: target {tv} vs host {hv} (relative {error:.1e})",
                    t.k
                ));
            }
        }
    }
    let ten_seconds = target
        .iter()
        .find(|t| t.k as f64 * 0.015 >= 10.0)
        .ok_or("the firmware printed nothing after 10 s")?;
    let wn = natural_frequency(ten_seconds.dkf_wrong[2], ten_seconds.dkf_wrong[3]);
    if wn.is_nan() || (wn / 20.0 - 1.0).abs() >= 0.02 {
        return Err(format!(
            "the f32 DKF from the wrong guess has wn = {wn} at 10 s on the target (truth 20)"
        ));
    }
    let [ekf, dkf, dkf_wrong, lqr] = worst;
    let overall = worst.into_iter().fold(0.0, f64::max);
    Ok(format!(
        "{} estimates of EKF, DKF, DKF from the wrong guess and LQR agree with the host's f64 \
         run within {overall:.1e} relative (allowed {RTOL:e}; EKF {ekf:.1e}, DKF {dkf:.1e}, \
         DKF from the wrong guess {dkf_wrong:.1e}, LQR {lqr:.1e}); the wrong-guess DKF's wn at \
         10 s on the target: {wn:.2} rad/s",
        target.len()
    ))
}

/// wn of the continuous mode whose sampled poles are those of the Euler model
/// `[[1, Ts], [Ts x3, 1 + Ts x4]]` (s = ln z / Ts); NaN without an oscillatory mode.
pub fn natural_frequency(x3: f64, x4: f64) -> f64 {
    let ts = 0.015;
    let trace = 2.0 + ts * x4;
    let det = 1.0 + ts * x4 - ts * ts * x3;
    let discriminant = trace * trace / 4.0 - det;
    if discriminant >= 0.0 || det <= 0.0 {
        return f64::NAN;
    }
    let (re, im) = (trace / 2.0, (-discriminant).sqrt());
    let s_re = det.sqrt().ln() / ts;
    let s_im = im.atan2(re) / ts;
    s_re.hypot(s_im)
}
