//! `stateforge_math::f32` on the target against the host: in the build without fused
//! multiply-adds, the same bits (the f32 filter checks compare the target with the host's
//! f32 run, which needs every function to be the same IEEE arithmetic on both); in the
//! build that contracts `a * b + c`, within the functions' error bounds of `libm`'s `f64`.

use crate::firmware::Build;
use crate::math_ulps::ulp_error;

/// The host's value of the firmware's `function` of `x` (`atan2` of `(x, 1.5 - x)`), its
/// `f64` reference, and the bound, in ulps, the fused build must meet (`None`: outside
/// the function's accurate domain, where only a finite value in `[-1, 1]` is asked).
fn host(function: &str, x: f32) -> Result<(f32, f64, Option<f64>), String> {
    use stateforge_math::f32 as m;
    let trig = (x.abs() <= m::TRIG_ACCURATE || !x.is_finite()).then_some(2.0);
    let w = f64::from(x);
    Ok(match function {
        "sin" => (m::sin(x), libm::sin(w), trig),
        "cos" => (m::cos(x), libm::cos(w), trig),
        "exp" => (m::exp(x), libm::exp(w), Some(2.0)),
        "ln" => (m::ln(x), libm::log(w), Some(2.0)),
        "tanh" => (m::tanh(x), libm::tanh(w), Some(3.0)),
        "sqrt" => (m::sqrt(x), libm::sqrt(w), Some(0.5)),
        "atan2" => (
            m::atan2(x, 1.5 - x),
            libm::atan2(w, f64::from(1.5 - x)),
            Some(3.0),
        ),
        _ => {
            return Err(format!(
                "the firmware printed an unknown function `{function}`"
            ))
        }
    })
}

/// Checks the firmware's `math` lines (see the module documentation).
pub fn check(math: &[(String, u32, u32)], build: Build) -> Result<String, String> {
    if math.is_empty() {
        return Err("the firmware printed no `math` values".into());
    }
    let mut differing = 0;
    for (function, x, y) in math {
        let (x, target) = (f32::from_bits(*x), f32::from_bits(*y));
        let (ours, reference, bound) = host(function, x)?;
        // NaNs agree whatever their payload (the FPU's default NaN is positive, x86's not).
        let same = target.to_bits() == ours.to_bits() || (target.is_nan() && ours.is_nan());
        if same {
            continue;
        }
        differing += 1;
        let within = match bound {
            Some(bound) => ulp_error(target, reference) <= bound,
            None => target.is_finite() && target.abs() <= 1.0,
        };
        if !build.fused || !within {
            return Err(format!(
                "the firmware {}: {function}({x:e}) = {target:e} ({:#010x}), the host's \
                 {ours:e} ({:#010x}), exact {reference:e}",
                build.name,
                target.to_bits(),
                ours.to_bits()
            ));
        }
    }
    Ok(format!(
        "stateforge_math::f32: {} of {} target values equal the host's bit for bit{}",
        math.len() - differing,
        math.len(),
        if differing > 0 {
            " (the others within the error bounds: fused multiply-adds)"
        } else {
            ""
        }
    ))
}
