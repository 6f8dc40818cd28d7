//! The stinger of Takács et al. (sect. 2): a linear motor that, "upon receiving a digital
//! signal, ... delivers a shock-like impact to the end of the beam then returns to its
//! starting position, leaving the beam to vibrate freely afterwards".
//!
//! Modelled as what it is, a displacement source: the motor moves the stinger's tip out
//! and back along a raised-cosine stroke, and the stinger pushes the blade's tip through
//! a stiff one-sided contact, `F = k_c max(0, s(t) - q_tip)`. So the force depends on
//! where the blade is when it arrives (a blade still swinging from the last hit, or
//! pushed by its controller, takes a different hit), the contact stiffens the blade while
//! it lasts, and the stinger can only push.
//!
//! The paper gives the hit's size only as the estimates it tunes its filter with,
//! `F_e = 4 N` and `T_e = 0.1 s` (sect. 4.1), which the single-mode blade applies as a
//! half-sine force. The stroke lasts `T_e`, and its reach is calibrated so that the hit
//! leaves the nominal blade at rest vibrating as that force does
//! (`like_the_force_estimate`): the same hit, as a contact. (Calibrated instead to a
//! contact force that peaks at `F_e` and lasts `T_e`, the stroke is slow, the blade rides
//! the stinger back, and the open loop's largest swing is 3 mm against 20: the hit's size
//! is the paper's least known quantity, and `blade_control` shows what a smaller one
//! does.) The gap at rest and the contact stiffness are our assumptions (`GAP`,
//! `CONTACT_STIFFNESS`).

use super::blade_plant::{hit_force, rk4, B, FIRST_HIT, HIT_DURATION, K, M};

/// Where the stinger rests, behind the blade's rest position \[m\]: clear of the open
/// loop's largest swing (37 mm with the stinger's hits) so that it "leaves the beam to
/// vibrate freely" (our assumption; the ablation counts touches of the resting stinger).
pub const GAP: f64 = 0.040;
/// Contact stiffness \[N/m\] in the paper's equivalent scale: stiff against the blade's
/// `k = 533 N/m` (our assumption).
pub const CONTACT_STIFFNESS: f64 = 1e4;

/// A stinger's stroke and contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stinger {
    /// Distance from the stinger's rest position to the blade's rest position \[m\].
    pub gap: f64,
    /// Contact stiffness \[N/m\].
    pub stiffness: f64,
    /// How far past the blade's rest position the stroke reaches \[m\].
    pub reach: f64,
    /// The stroke's duration, out and back \[s\].
    pub stroke: f64,
}

impl Stinger {
    /// The stinger tip's position (along the blade's deflection) `since` seconds after
    /// the stroke began; at rest before and after.
    pub fn position(&self, since: f64) -> f64 {
        if (0.0..self.stroke).contains(&since) {
            let travel = 0.5 * (1.0 - (2.0 * std::f64::consts::PI * since / self.stroke).cos());
            -self.gap + (self.gap + self.reach) * travel
        } else {
            -self.gap
        }
    }

    /// The contact force on the blade's tip at `tip` \[m\], `since` seconds into a stroke.
    pub fn force(&self, since: f64, tip: f64) -> f64 {
        self.stiffness * (self.position(since) - tip).max(0.0)
    }

    /// The nominal single-mode blade, at rest at `t = 0`, under `force(t, q)` \[N\] at its
    /// tip: its free vibration's amplitude `sqrt(q^2 + (q' / w)^2)` \[m\] at `until` \[s\]
    /// (RK4 at 0.1 ms).
    pub fn amplitude_after(force: impl Fn(f64, f64) -> f64, until: f64) -> f64 {
        let h = 1e-4;
        let rate = |t: f64, x: [f64; 2]| [x[1], (force(t, x[0]) - K * x[0] - B * x[1]) / M];
        let x = rk4(rate, 0.0, [0.0; 2], until, (until / h).ceil() as u32);
        (x[0].powi(2) + (x[1] / (K / M).sqrt()).powi(2)).sqrt()
    }

    /// The stroke lasting the paper's `T_e` whose hit leaves the nominal blade at rest
    /// vibrating as the paper's force estimate, a half-sine of `hit_peak` \[N\] over
    /// `T_e`, does.
    pub fn like_the_force_estimate(hit_peak: f64) -> Self {
        let until = 2.0 * HIT_DURATION;
        let target = Self::amplitude_after(|t, _| hit_force(FIRST_HIT + t, hit_peak), until);
        Self::calibrated(target, HIT_DURATION)
    }

    /// The stroke of duration `stroke` \[s\] that leaves the nominal blade at rest
    /// vibrating as `target_amplitude` \[m\] does, for the assumed gap and contact
    /// stiffness: bisection on the reach (a longer reach, a faster stinger, a harder hit).
    pub fn calibrated(target_amplitude: f64, stroke: f64) -> Self {
        let with = |reach: f64| Stinger {
            gap: GAP,
            stiffness: CONTACT_STIFFNESS,
            reach,
            stroke,
        };
        // Measured once the stroke is over and the blade has left the stinger.
        let until = 2.0 * stroke;
        let reach = bisect(-GAP, 0.2, |reach| {
            let stinger = with(reach);
            Self::amplitude_after(|t, q| stinger.force(t, q), until) < target_amplitude
        });
        with(reach)
    }
}

/// The point in `(lo, hi)` where `below` turns false, by 40 halvings.
fn bisect(mut lo: f64, mut hi: f64, below: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::blade_plant::HIT_FORCE;

    #[test]
    fn the_calibrated_stroke_hits_as_hard_as_the_papers_force_estimate() {
        let until = 2.0 * HIT_DURATION;
        let target = Stinger::amplitude_after(|t, _| hit_force(t + FIRST_HIT, HIT_FORCE), until);
        let stinger = Stinger::like_the_force_estimate(HIT_FORCE);
        assert_eq!(stinger.stroke, HIT_DURATION);
        let amplitude = Stinger::amplitude_after(|t, q| stinger.force(t, q), until);
        assert!(
            (amplitude / target - 1.0).abs() < 1e-6,
            "{amplitude} vs {target}"
        );
        // The stinger only pushes, and rests clear of the blade.
        assert_eq!(stinger.force(-1.0, 0.0), 0.0);
        assert_eq!(stinger.force(0.5 * stinger.stroke, 1.0), 0.0);
        assert_eq!(stinger.position(stinger.stroke), -GAP);
    }
}
