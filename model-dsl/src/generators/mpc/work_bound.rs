//! The MPC's work bound: a solve's cost varies with what it rebuilds (the prediction model,
//! the terminal weight, the condensed Hessian) and with its active-set iterations, so a
//! cycle budget (`max_cycles = ..`) bounds the iterations instead of rejecting the model
//! for a worst case that runs every one of `max_iterations` after a full rebuild. Each
//! kind of solve may take as many iterations as keep its static estimate within the
//! budget; a solve that reaches its bound stops with `optimal = false` and the best
//! feasible plan found, which the primal active-set method guarantees (its iterates stay
//! within the bounds and never raise the cost); the next solve is warm-started from that
//! plan, shifted by one move.

use crate::emit::lower::OpCount;
use crate::timing::Target;
use proc_macro2::Span;

/// The arithmetic of a solve's parts, as the generated code's cost constants count them.
#[derive(Clone, Copy, Debug, Default)]
pub struct SolveOps {
    /// What every solve runs besides the rebuilds and the iterations.
    pub plan: OpCount,
    /// The prediction model at the estimate.
    pub prediction: OpCount,
    /// The Riccati steps towards the terminal weight.
    pub riccati: OpCount,
    /// The condensed Hessian, and storing what the next solve may keep.
    pub condense: OpCount,
    /// One active-set iteration, with the loop's branch back.
    pub iteration: OpCount,
}

/// What a solve rebuilt before its iterations, in the order of the generated
/// `ITERATIONS_WITHIN_BUDGET` (and of `MpcRebuild`'s variants).
const KINDS: [&str; 3] = [
    "kept everything",
    "rebuilt the terminal weight and Hessian",
    "rebuilt the model, the terminal weight and the Hessian",
];

impl SolveOps {
    /// A solve of kind `kind` (an index into [`KINDS`]) that takes `iterations`.
    fn solve(&self, kind: usize, iterations: u32) -> OpCount {
        let problem = self.riccati.plus(self.condense);
        let rebuilt = match kind {
            0 => OpCount::default(),
            1 => problem,
            _ => problem.plus(self.prediction),
        };
        self.plan
            .plus(rebuilt)
            .plus(self.iteration.times(iterations))
    }

    /// The costliest solve on `target` when each kind takes at most `limits[kind]`
    /// iterations.
    pub fn worst(&self, limits: [u32; 3], target: &Target) -> OpCount {
        let solves = (0..KINDS.len()).map(|kind| self.solve(kind, limits[kind]));
        solves
            .max_by_key(|ops| target.estimate(ops).cycles)
            .unwrap_or_default()
    }
}

/// The iterations each kind of solve may take, at most `max_iterations`, with its
/// estimate on `target` within `budget` cycles; an error under the budget if a solve that
/// rebuilds everything could not take one.
pub fn iterations_within(
    ops: &SolveOps,
    max_iterations: u32,
    (budget, span): (u64, Span),
    target: &Target,
) -> syn::Result<[u32; 3]> {
    let fits = |kind: usize, n: u32| target.estimate(&ops.solve(kind, n)).cycles <= budget;
    let limits: [u32; 3] = std::array::from_fn(|kind| {
        // The estimate grows with each iteration: the last that fits, by bisection.
        let (mut low, mut high) = (0, max_iterations);
        while low < high {
            let mid = high - (high - low) / 2;
            if fits(kind, mid) {
                low = mid;
            } else {
                high = mid - 1;
            }
        }
        low
    });
    if limits[2] == 0 {
        let needed = target.estimate(&ops.solve(2, 1)).cycles;
        return Err(syn::Error::new(
            span,
            format!(
                "`Mpc::solve` bounds its active-set iterations within the budget ({budget} \
                 cycles), but a solve that {} is estimated at {needed} cycles with a single \
                 iteration on a {}: raise the budget to at least {needed}, or make the solve \
                 cheaper (a shorter horizon, fewer `riccati_iterations`)",
                KINDS[2], target.description
            ),
        ));
    }
    Ok(limits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::CORTEX_M4F;

    fn ops() -> SolveOps {
        let some = |add: u32| OpCount {
            add,
            mul: add,
            ..OpCount::default()
        };
        SolveOps {
            plan: some(100),
            prediction: some(200),
            riccati: some(300),
            condense: some(100),
            iteration: some(150),
        }
    }

    #[test]
    fn each_kind_takes_the_most_iterations_within_the_budget() {
        let ops = ops();
        let budget = CORTEX_M4F.estimate(&ops.solve(2, 2)).cycles + 10;
        let limits = iterations_within(&ops, 20, (budget, Span::call_site()), &CORTEX_M4F)
            .expect("two iterations fit after a full rebuild");
        assert_eq!(limits[2], 2);
        for (kind, &n) in limits.iter().enumerate() {
            assert!(CORTEX_M4F.estimate(&ops.solve(kind, n)).cycles <= budget);
            let one_more = CORTEX_M4F.estimate(&ops.solve(kind, n + 1)).cycles;
            assert!(n == 20 || one_more > budget, "kind {kind}: {n}");
        }
        assert!(
            limits[0] > limits[1] && limits[1] >= limits[2],
            "{limits:?}"
        );
    }

    #[test]
    fn the_worst_solve_is_the_costliest_kind_at_its_bound() {
        let ops = ops();
        // With the same iterations a full rebuild costs most; a kept solve with five
        // iterations costs more than a full rebuild with none.
        assert_eq!(ops.worst([1, 1, 1], &CORTEX_M4F), ops.solve(2, 1));
        assert_eq!(ops.worst([5, 0, 0], &CORTEX_M4F), ops.solve(0, 5));
    }

    #[test]
    fn max_iterations_still_bounds_a_generous_budget() {
        let limits = iterations_within(&ops(), 3, (1_000_000, Span::call_site()), &CORTEX_M4F);
        assert_eq!(limits.ok(), Some([3, 3, 3]));
    }

    #[test]
    fn a_budget_without_room_for_one_iteration_after_a_rebuild_is_an_error() {
        let ops = ops();
        let budget = CORTEX_M4F.estimate(&ops.solve(2, 1)).cycles - 1;
        let error = iterations_within(&ops, 20, (budget, Span::call_site()), &CORTEX_M4F)
            .expect_err("no iteration fits");
        let message = error.to_string();
        assert!(
            message.contains("raise the budget to at least"),
            "{message}"
        );
    }
}
