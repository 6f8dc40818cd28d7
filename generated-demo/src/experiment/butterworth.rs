//! An analog Butterworth low-pass as a cascade of sections, for the laser signal of
//! Takács et al. ("a low-pass filter with a pass band edge at 30 Hz and a stop band edge
//! at 50 Hz", sect. 4.1). The paper gives the edges only; the losses at them are ours to
//! choose, and the order follows (`minimum_order`, the classical formula MATLAB's
//! `buttord` uses for analog filters). The corner is placed so the loss at the pass-band
//! edge is exactly the allowed one: the least phase lag that meets the edges.
//!
//! Run as a continuous filter on the tip position before sampling: its stop band at
//! 50 Hz is the Nyquist frequency of the paper's 100 Hz sampling, an anti-aliasing filter.

/// One section: second order `y'' = w^2 (x - y) - 2 zeta w y'`, or first order
/// `y' = w (x - y)` when `zeta` is `None`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section {
    /// Natural frequency \[rad/s\].
    pub omega: f64,
    /// Damping ratio; `None` for the first-order section of an odd order.
    pub zeta: Option<f64>,
}

/// The filter's design: order and corner (-3 dB) frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Butterworth {
    /// Order.
    pub order: usize,
    /// Corner frequency \[Hz\].
    pub corner_hz: f64,
}

impl Butterworth {
    /// The lowest order whose loss is at most `pass_db` up to `pass_hz` and at least
    /// `stop_db` from `stop_hz` on, with the corner where the loss at `pass_hz` is exactly
    /// `pass_db` (`|H(f)|^2 = 1 / (1 + (f / f_c)^(2n))`).
    pub fn minimum_order(pass_hz: f64, stop_hz: f64, pass_db: f64, stop_db: f64) -> Self {
        let excess = |db: f64| 10f64.powf(db / 10.0) - 1.0;
        let order = ((excess(stop_db) / excess(pass_db)).log10()
            / (2.0 * (stop_hz / pass_hz).log10()))
        .ceil() as usize;
        let corner_hz = pass_hz / excess(pass_db).powf(0.5 / order as f64);
        Self { order, corner_hz }
    }

    /// The sections, second-order ones first. The poles lie on the circle of the corner
    /// frequency at `pi (2k + n - 1) / (2n)`, `k = 1..n`; a pair at angle `a` from the
    /// negative real axis is a section of damping `cos a`, `a = (2j - 1) pi / (2n)` for
    /// even `n`, `j pi / n` for odd `n` (with a real pole), `j = 1..n/2`.
    pub fn sections(&self) -> Vec<Section> {
        let omega = 2.0 * std::f64::consts::PI * self.corner_hz;
        let n = self.order;
        let mut sections: Vec<Section> = (1..=n / 2)
            .map(|j| Section {
                omega,
                zeta: Some(
                    ((2 * j - 1 + n % 2) as f64 * std::f64::consts::PI / (2 * n) as f64).cos(),
                ),
            })
            .collect();
        if self.order % 2 == 1 {
            sections.push(Section { omega, zeta: None });
        }
        sections
    }

    /// The loss \[dB\] at `f_hz`.
    pub fn loss_db(&self, f_hz: f64) -> f64 {
        10.0 * (1.0 + (f_hz / self.corner_hz).powi(2 * self.order as i32)).log10()
    }

    /// The phase lag \[rad\] at `f_hz`, summed over the sections.
    pub fn phase_lag(&self, f_hz: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f_hz;
        self.sections()
            .iter()
            .map(|s| {
                let r = w / s.omega;
                match s.zeta {
                    Some(zeta) => (2.0 * zeta * r).atan2(1.0 - r * r),
                    None => r.atan(),
                }
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the cascade on `sin(2 pi f t)` by RK4 and returns the output's amplitude over
    /// the last tenth of a long run (independent of the closed forms above).
    fn simulated_gain(design: &Butterworth, f_hz: f64) -> f64 {
        let sections = design.sections();
        let w = 2.0 * std::f64::consts::PI * f_hz;
        let rate = |t: f64, z: &[f64]| -> Vec<f64> {
            let mut input = (w * t).sin();
            let mut dz = vec![0.0; z.len()];
            for (j, s) in sections.iter().enumerate() {
                let (y, v) = (z[2 * j], z[2 * j + 1]);
                match s.zeta {
                    Some(zeta) => {
                        dz[2 * j] = v;
                        dz[2 * j + 1] = s.omega * s.omega * (input - y) - 2.0 * zeta * s.omega * v;
                    }
                    None => dz[2 * j] = s.omega * (input - y),
                }
                input = y;
            }
            dz
        };
        let h = 1e-5;
        let (mut t, mut z) = (0.0, vec![0.0; 2 * sections.len()]);
        let last = 2 * (sections.len() - 1);
        let mut peak: f64 = 0.0;
        let end = 1.0;
        while t < end {
            let k1 = rate(t, &z);
            let at =
                |k: &[f64], a: f64| z.iter().zip(k).map(|(z, k)| z + a * k).collect::<Vec<_>>();
            let k2 = rate(t + h / 2.0, &at(&k1, h / 2.0));
            let k3 = rate(t + h / 2.0, &at(&k2, h / 2.0));
            let k4 = rate(t + h, &at(&k3, h));
            for i in 0..z.len() {
                z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += h;
            if t > 0.9 * end {
                peak = peak.max(z[last].abs());
            }
        }
        peak
    }

    #[test]
    fn minimum_order_meets_both_edges() {
        for (pass_db, stop_db, order) in [(3.0, 20.0, 5), (1.0, 60.0, 15)] {
            let design = Butterworth::minimum_order(30.0, 50.0, pass_db, stop_db);
            assert_eq!(design.order, order);
            assert!((design.loss_db(30.0) - pass_db).abs() < 1e-9);
            assert!(design.loss_db(50.0) >= stop_db);
            // One order less, with its corner meeting the pass band, misses the stop band.
            let excess = 10f64.powf(pass_db / 10.0) - 1.0;
            let lower = Butterworth {
                order: order - 1,
                corner_hz: 30.0 / excess.powf(0.5 / (order - 1) as f64),
            };
            assert!((lower.loss_db(30.0) - pass_db).abs() < 1e-9);
            assert!(lower.loss_db(50.0) < stop_db);
        }
    }

    #[test]
    fn sections_give_the_butterworth_magnitude() {
        for order in [2, 3, 4, 5] {
            let design = Butterworth {
                order,
                corner_hz: 30.0,
            };
            for f_hz in [8.0, 30.0, 50.0] {
                let expected = 10f64.powf(-design.loss_db(f_hz) / 20.0);
                let gain = simulated_gain(&design, f_hz);
                assert!(
                    (gain / expected - 1.0).abs() < 2e-3,
                    "order {order}, {f_hz} Hz: {gain} vs {expected}"
                );
            }
        }
    }
}
