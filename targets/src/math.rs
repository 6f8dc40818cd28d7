//! `stateforge_math::f32` on the target: instructions per call of each function, beside
//! `libm`'s (in the baseline column), over arguments a model feeds them, and their values'
//! bits for the host to check (`math <function> <argument bits> <result bits>`: the
//! functions must give the host's bits, which the f32 filter checks rely on).

use crate::measure::{per_call, report, stack_depth, Clock};
use core::hint::black_box;
use cortex_m_semihosting::hprintln;

/// Calls measured per function.
const CALLS: usize = 256;

/// `CALLS` arguments spread over `[low, high]` (a deterministic scramble of the order, so
/// branches are not trained on a ramp).
fn arguments(low: f32, high: f32) -> [f32; CALLS] {
    let mut out = [0.0; CALLS];
    for (i, slot) in out.iter_mut().enumerate() {
        let j = (i * 97) % CALLS;
        *slot = low + (high - low) * (j as f32 / (CALLS - 1) as f32);
    }
    out
}

/// Never-inlined wrappers, `generated_<kernel>` (ours) and `baseline_<kernel>` (`libm`),
/// so each is one symbol the trace follows.
macro_rules! wrappers {
    ($($ours:ident = $our_fn:path, $theirs:ident = $their_fn:path, ($($arg:ident),*) -> $ret:ty;)*) => {
        $(
            // One argument is a parenthesised pattern too.
            #[allow(unused_parens)]
            #[inline(never)]
            fn $ours(($($arg),*): args!($($arg),*)) -> $ret {
                $our_fn($($arg),*)
            }
            #[allow(unused_parens)]
            #[inline(never)]
            fn $theirs(($($arg),*): args!($($arg),*)) -> $ret {
                $their_fn($($arg),*)
            }
        )*
    };
}

/// The argument type of a wrapper: `f32`, or `(f32, f32)` for two.
macro_rules! args {
    ($x:ident) => {
        f32
    };
    ($y:ident, $x:ident) => {
        (f32, f32)
    };
}

wrappers! {
    generated_sin_cos_f32 = stateforge_math::f32::sin_cos, baseline_sin_cos_f32 = libm::sincosf, (x) -> (f32, f32);
    generated_tan_f32 = stateforge_math::f32::tan, baseline_tan_f32 = libm::tanf, (x) -> f32;
    generated_exp_f32 = stateforge_math::f32::exp, baseline_exp_f32 = libm::expf, (x) -> f32;
    generated_ln_f32 = stateforge_math::f32::ln, baseline_ln_f32 = libm::logf, (x) -> f32;
    generated_tanh_f32 = stateforge_math::f32::tanh, baseline_tanh_f32 = libm::tanhf, (x) -> f32;
    generated_sqrt_f32 = stateforge_math::f32::sqrt, baseline_sqrt_f32 = libm::sqrtf, (x) -> f32;
    generated_atan2_f32 = stateforge_math::f32::atan2, baseline_atan2_f32 = libm::atan2f, (y, x) -> f32;
}

/// Instructions per call and stack of `ours` and `theirs` over `args`, reported as `kernel`.
fn measure<A: Copy, R>(
    clock: &Clock,
    kernel: &str,
    args: &[A],
    ours: fn(A) -> R,
    theirs: fn(A) -> R,
) {
    let generated = per_call(clock, args.iter().copied(), |a| {
        black_box(ours(a));
    });
    let baseline = per_call(clock, args.iter().copied(), |a| {
        black_box(theirs(a));
    });
    let stack = (
        stack_depth(|| {
            black_box(ours(args[0]));
        }),
        stack_depth(|| {
            black_box(theirs(args[0]));
        }),
    );
    report(kernel, (generated, baseline), stack);
}

/// Measures every function (the argument ranges a filter feeds them: angles of a few
/// turns, exponents of a decay, logarithms and roots of positive magnitudes).
pub fn costs(clock: &Clock) {
    let angles = arguments(-20.0, 20.0);
    measure(
        clock,
        "sin_cos_f32",
        &angles,
        generated_sin_cos_f32,
        baseline_sin_cos_f32,
    );
    measure(
        clock,
        "tan_f32",
        &angles,
        generated_tan_f32,
        baseline_tan_f32,
    );
    measure(
        clock,
        "exp_f32",
        &arguments(-20.0, 20.0),
        generated_exp_f32,
        baseline_exp_f32,
    );
    measure(
        clock,
        "ln_f32",
        &arguments(1e-3, 1e3),
        generated_ln_f32,
        baseline_ln_f32,
    );
    measure(
        clock,
        "tanh_f32",
        &arguments(-3.0, 3.0),
        generated_tanh_f32,
        baseline_tanh_f32,
    );
    measure(
        clock,
        "sqrt_f32",
        &arguments(0.0, 1e3),
        generated_sqrt_f32,
        baseline_sqrt_f32,
    );
    let mut pairs = [(0.0, 0.0); CALLS];
    for (i, pair) in pairs.iter_mut().enumerate() {
        *pair = (angles[i], angles[(i * 31 + 7) % CALLS]);
    }
    measure(
        clock,
        "atan2_f32",
        &pairs,
        generated_atan2_f32,
        baseline_atan2_f32,
    );
}

/// Prints each function's result bits on arguments over their domains (edges included),
/// for the host to compare with its own.
pub fn values() {
    let print = |name: &str, x: f32, y: f32| {
        hprintln!("math {} {:08x} {:08x}", name, x.to_bits(), y.to_bits());
    };
    let special = [
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e-45,
        1e-40,
        7000.0,
        1e30,
    ];
    let spread = arguments(-100.0, 100.0);
    for &x in special.iter().chain(spread.iter().step_by(4)) {
        let (s, c) = stateforge_math::f32::sin_cos(x);
        print("sin", x, s);
        print("cos", x, c);
        print("exp", x, stateforge_math::f32::exp(x));
        print("ln", x, stateforge_math::f32::ln(x));
        print("tanh", x, stateforge_math::f32::tanh(x));
        print("sqrt", x, stateforge_math::f32::sqrt(x));
        print("atan2", x, stateforge_math::f32::atan2(x, 1.5 - x));
    }
}
