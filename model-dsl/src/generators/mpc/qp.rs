//! The MPC's box-constrained QP, `min 1/2 v' H v + c' v` with `low <= v <= high`,
//! by a primal active-set method unrolled over its `HORIZON x inputs` moves: each
//! iteration either checks the multipliers of the bounds held (after a full step: the
//! iterate then minimises the cost with those bounds fixed) and releases the most
//! negative, or takes the Newton step on the free moves and stops at the first bound in
//! the way, which is then held. The iterate stays feasible and the cost never rises, so
//! when `MAX_ITERATIONS` runs out the last iterate is the best feasible plan found.
//!
//! Chosen over projected gradient and ADMM because the condensed problem of a lightly
//! damped structure is small and dense, its Hessian is formed anyway, and the warm start
//! from the shifted plan usually holds the right bounds: one or two `L D L'` solves
//! finish it, with an exact answer rather than a tolerance-bound one.

use super::names::Names;
use super::newton::{newton_step, NewtonNames};
use super::spec::MpcSpec;
use crate::emit::code::{all_is_finite, packed_names};
use crate::emit::lower::{literal, Lowerer, OpCount};
use crate::emit::names::ident;
use crate::emit::scopes::scoped;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{matmul, packed_index, symmetric_from_packed, Matrix};
use crate::symbolic::Graph;
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// The names of the moves and of the values per move and per input.
pub struct MoveNames {
    /// Per input: its name.
    inputs: Vec<String>,
    /// Per move, step by step (`u_1`, then `u_2`, ..; each step all inputs): its name.
    moves: Vec<String>,
    /// Per move: the index of its input.
    input_of: Vec<usize>,
    /// `H`'s packed entries: `h11 ..` or `h_1_1 ..`.
    pub hessian: Vec<String>,
    /// `c`'s entries: `c_u_1 ..`.
    pub linear: Vec<String>,
}

impl MoveNames {
    /// The moves of `spec`'s inputs over its horizon.
    pub fn new(model: &Model, spec: &MpcSpec, names: &Names) -> MoveNames {
        let inputs: Vec<String> = spec
            .inputs
            .iter()
            .map(|&i| model.inputs[i].name.clone())
            .collect();
        let mut moves = Vec::new();
        let mut input_of = Vec::new();
        for step in 1..=spec.horizon {
            for (i, input) in inputs.iter().enumerate() {
                moves.push(names.fresh(&format!("{input}_{step}")));
                input_of.push(i);
            }
        }
        let hessian = packed_names("h", moves.len(), &|name| names.takes(name));
        let linear = moves
            .iter()
            .map(|m| names.fresh(&format!("c_{m}")))
            .collect();
        MoveNames {
            inputs,
            moves,
            input_of,
            hessian,
            linear,
        }
    }

    /// The inputs' count.
    pub fn input_count(&self) -> usize {
        self.inputs.len()
    }

    /// The moves' count, horizon times inputs.
    pub fn count(&self) -> usize {
        self.moves.len()
    }

    /// `<prefix>_<move>` for every move.
    pub fn per_move(&self, prefix: &str) -> Vec<Ident> {
        self.moves
            .iter()
            .map(|m| ident(&format!("{prefix}_{m}")))
            .collect()
    }

    /// `<input>_<suffix>` for the input of every move.
    pub fn per_move_input(&self, suffix: &str) -> Vec<Ident> {
        self.input_of
            .iter()
            .map(|&i| ident(&format!("{}_{suffix}", self.inputs[i])))
            .collect()
    }

    /// `<input>_<suffix>` for every input.
    pub fn per_input(&self, suffix: &str) -> Vec<Ident> {
        self.inputs
            .iter()
            .map(|i| ident(&format!("{i}_{suffix}")))
            .collect()
    }

    /// The moves' names.
    pub fn move_idents(&self) -> Vec<Ident> {
        self.moves.iter().map(|m| ident(m)).collect()
    }

    /// The inputs' bounds as deviations from `u_ref`: binds `<input>_low` and
    /// `<input>_high`.
    pub fn deviation_bounds(&self) -> TokenStream {
        let (reference, min, max) = (
            self.per_input("ref"),
            self.per_input("minimum"),
            self.per_input("maximum"),
        );
        let (low, high) = (self.per_input("low"), self.per_input("high"));
        quote! {
            // The moves' bounds as deviations from u_ref.
            let [#(#reference),*] = self.u_ref;
            let [#(#min),*] = self.u_min;
            let [#(#max),*] = self.u_max;
            #(let #low = #min - #reference;)*
            #(let #high = #max - #reference;)*
        }
    }

    /// The bounds' entries as `new` binds them: `<input>_minimum` and `<input>_maximum`.
    pub fn bounds(&self) -> (Vec<Ident>, Vec<Ident>) {
        (self.per_input("minimum"), self.per_input("maximum"))
    }

    /// The rejection of bounds that leave no room (not `u_min < u_max`), after the check
    /// that they are finite: `rejected` is what the function returns then (`new`'s
    /// `Err(Status::RejectedInput)`, a setter's `Status::RejectedInput`).
    pub fn bounds_order_check(&self, rejected: &TokenStream) -> TokenStream {
        let (min, max) = self.bounds();
        quote! {
            if #(#min >= #max)||* {
                return #rejected;
            }
        }
    }

    /// The first plan's move, zero clipped to the bounds (`new`, after
    /// [`MoveNames::bounds_order_check`]).
    pub fn start_move(&self, zero: &TokenStream) -> TokenStream {
        let (min, max) = (self.per_input("minimum"), self.per_input("maximum"));
        let clipped = min.iter().zip(&max).map(|(lo, hi)| {
            quote! {
                if #zero < #lo {
                    #lo
                } else if #zero > #hi {
                    #hi
                } else {
                    #zero
                }
            }
        });
        quote! { [#(#clipped),*] }
    }

    /// `set_reference`'s check that the reference is finite.
    pub fn reference_check(&self, state_refs: &[Ident]) -> TokenStream {
        let inputs = self.per_input("ref");
        let all: Vec<Ident> = state_refs.iter().chain(&inputs).cloned().collect();
        let finite = all_is_finite(&all);
        quote! {
            let finite = {
                let [#(#state_refs),*] = *x_ref;
                let [#(#inputs),*] = *u_ref;
                #finite
            };
            if !finite {
                return Status::RejectedInput;
            }
        }
    }

    /// The plan in absolute inputs, each clipped to its bounds, named `plan_<move>`.
    pub fn absolute_plan(&self) -> TokenStream {
        let plan = self.per_move("plan");
        let (reference, min, max) = (
            self.per_move_input("ref"),
            self.per_move_input("minimum"),
            self.per_move_input("maximum"),
        );
        let moves = self.move_idents();
        let absolute = self.per_move("absolute");
        let clipped = absolute
            .iter()
            .zip(min.iter().zip(&max))
            .map(|(v, (lo, hi))| clip(v, lo, hi));
        quote! {
            // Back to absolute inputs, clipped so that rounding never leaves the bounds.
            #(let #absolute = #moves + #reference;)*
            #(let #plan = #clipped;)*
        }
    }

    /// The names [`MoveNames::absolute_plan`] binds.
    pub fn absolute_names(&self) -> Vec<Ident> {
        self.per_move("plan")
    }

    /// The plan's rows, `[plan_u_1], [plan_u_2], ..`.
    pub fn plan_rows(&self) -> Vec<TokenStream> {
        let plan = self.per_move("plan");
        plan.chunks(self.inputs.len().max(1))
            .map(|row| quote! { [#(#row),*] })
            .collect()
    }
}

/// `if v < lo { lo } else if v > hi { hi } else { v }`
fn clip(v: &Ident, lo: &Ident, hi: &Ident) -> TokenStream {
    quote! {
        if #v < #lo {
            #lo
        } else if #v > #hi {
            #hi
        } else {
            #v
        }
    }
}

/// The active-set solve's code (bounds, warm start, the loop) and one iteration's cost.
pub struct QpCode {
    /// Statements from the bounds to the end of the loop; they leave the moves, `optimal`
    /// and `iterations` bound.
    pub code: TokenStream,
    /// Arithmetic of one iteration.
    pub iteration_ops: OpCount,
    /// What runs once per solve before the loop: the bounds, the warm start (without
    /// its tail) and the gradient at it.
    pub setup_ops: OpCount,
}

/// The loop, on the names of `moves`: `H` and `c` must be bound before it. `last_pass`,
/// a condition on the loop's `pass`, ends it before the step of that pass: at the latest
/// `pass == Self::PASSES`, after `MAX_ITERATIONS` steps.
pub fn active_set_loop(
    g: &mut Graph,
    moves: &MoveNames,
    (names, tail, last_pass): (&Names, &TokenStream, &TokenStream),
    scalar: Scalar,
) -> QpCode {
    let m = moves.count();
    let (grad_statements, grad_values, grad_ops) = gradient(g, moves, names, scalar);
    let setup = bounds_and_warm_start(moves, tail);
    let release = release_check(moves, scalar);
    let newton = NewtonNames {
        free: moves.per_move("free"),
        grad: moves.per_move("grad"),
        step: moves.per_move("step"),
        lower: moves.per_move("lower"),
        upper: moves.per_move("upper"),
        hessian: moves.hessian.iter().map(|h| ident(h)).collect(),
    };
    let (step, step_ops) = newton_step(&newton, names, scalar);
    let ratio = ratio_test(moves, scalar);
    let grad = &newton.grad;
    let code = quote! {
        #setup
        // The cost's gradient H v + c at the warm start; each step updates it.
        #(#grad_statements)*
        #(let mut #grad = #grad_values;)*
        let mut full_step = false;
        let mut optimal = false;
        // Newton steps taken; the pass after the last step only checks the multipliers.
        let mut steps = usize::MIN;
        for pass in 1..=Self::PASSES {
            if full_step {
                #release
            }
            if #last_pass {
                break;
            }
            steps = pass;
            #step
            #ratio
        }
    };
    // Per iteration: the ratio test's divisions and comparisons, the update.
    let extra = OpCount {
        add: 2 * m as u32,
        mul: m as u32,
        div: m as u32,
        compare: 4 * m as u32,
        ..Default::default()
    };
    // The gradient's update along the step, with every move free; and the projection's
    // when the step is cut short: its moves, their gradient and the costs' changes.
    let (m32, square) = (m as u32, (m * m) as u32);
    let update = OpCount {
        add: square + 4 * m32 + 2,
        mul: square + 3 * m32 + 4,
        compare: 2 * m32 + 1,
        ..Default::default()
    };
    QpCode {
        code,
        iteration_ops: step_ops.plus(extra).plus(update),
        setup_ops: warm_start_ops(moves).plus(grad_ops),
    }
}

/// What [`bounds_and_warm_start`]'s own statements do: the fields read, the bounds as
/// deviations, the shifted moves, their clipping and the bounds they touch, the release
/// thresholds.
fn warm_start_ops(moves: &MoveNames) -> OpCount {
    let (m, nu) = (moves.count() as u32, moves.inputs.len() as u32);
    let shifted = m.saturating_sub(nu);
    OpCount {
        // low, high; each shifted move's deviation; each threshold's `high - low`
        add: 2 * nu + shifted + m,
        mul: 2 * m,
        // two for the clip and two for the bounds held, per move
        compare: 4 * m,
        // u_ref, u_min, u_max, the kept plan but its first step, the Hessian's diagonal
        load: 3 * nu + shifted + m,
        // RELEASE_TOLERANCE
        literal: 1,
        ..OpCount::default()
    }
}

/// The gradient `H v + c` at the moves, lowered: its statements, its values and their
/// cost.
fn gradient(
    g: &mut Graph,
    moves: &MoveNames,
    names: &Names,
    scalar: Scalar,
) -> (Vec<TokenStream>, Vec<TokenStream>, OpCount) {
    let m = moves.count();
    let hessian_vars: Vec<_> = moves.hessian.iter().map(|n| g.var(n)).collect();
    let linear_vars: Vec<_> = moves.linear.iter().map(|n| g.var(n)).collect();
    let move_vars: Vec<_> = moves.moves.iter().map(|n| g.var(n)).collect();
    let hessian = symmetric_from_packed(&hessian_vars, m);
    let column: Matrix = move_vars.iter().map(|&v| vec![v]).collect();
    let product = matmul(g, &hessian, &column);
    let gradient: Vec<_> = product
        .iter()
        .zip(&linear_vars)
        .map(|(row, &c)| g.add(row[0], c))
        .collect();
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &gradient);
    let values = lowerer.segment(&gradient);
    let statements = scoped(lowerer.take_statements(), &quote! { #(#values)* });
    (statements, values, lowerer.ops())
}

/// Bounds of the deviations from `u_ref`, and the warm start: the last plan shifted by
/// one move, its new last move the terminal feedback `-K x` at the state the shifted
/// moves lead to (`tail`, which binds `<input>_tail` from the others: the dual mode's
/// control after the horizon), clipped to the bounds, with the bounds it touches held.
fn bounds_and_warm_start(moves: &MoveNames, tail: &TokenStream) -> TokenStream {
    let bounds = moves.deviation_bounds();
    let previous = moves.per_move("previous");
    // The last plan's first move was applied; the warm start begins with its second.
    let previous_rows =
        previous
            .chunks(moves.inputs.len().max(1))
            .enumerate()
            .map(|(step, row)| match step {
                0 => {
                    let unread = row.iter().map(|_| quote! { _ });
                    quote! { [#(#unread),*] }
                }
                _ => quote! { [#(#row),*] },
            });
    // Move k is input k % nu at step k / nu; it starts from the same input one step later.
    let nu = moves.inputs.len().max(1);
    let last_step = moves.count() / nu - 1;
    let shifted: Vec<&Ident> = (0..moves.count())
        .map(|k| &previous[(k / nu + 1).min(last_step) * nu + k % nu])
        .collect();
    let move_ids = moves.move_idents();
    let (move_low, move_high) = (moves.per_move_input("low"), moves.per_move_input("high"));
    let move_ref = moves.per_move_input("ref");
    let (lower, upper) = (moves.per_move("lower"), moves.per_move("upper"));
    let threshold = moves.per_move("threshold");
    let diagonal: Vec<Ident> = (0..moves.count())
        .map(|k| ident(&moves.hessian[crate::symbolic::linalg::packed_index(moves.count(), k, k)]))
        .collect();
    let warm = moves.per_move("warm");
    let (early, last) = warm.split_at(last_step * nu);
    let early_shifted = &shifted[..last_step * nu];
    let (early_ref, tail_values) = (&move_ref[..last_step * nu], moves.per_input("tail"));
    let clipped: Vec<TokenStream> = warm
        .iter()
        .zip(move_low.iter().zip(&move_high))
        .map(|(w, (lo, hi))| clip(w, lo, hi))
        .collect();
    quote! {
        #bounds
        // Warm start: the last plan shifted by one move, clipped, holding the bounds it
        // touches.
        let [#(#previous_rows),*] = self.plan;
        #(let #early = #early_shifted - #early_ref;)*
        #tail
        #(let #last = #tail_values;)*
        #(let mut #move_ids = #clipped;)*
        #(let mut #lower = #move_ids <= #move_low;)*
        #(let mut #upper = !#lower && #move_ids >= #move_high;)*
        #(let #threshold = Self::RELEASE_TOLERANCE * (#move_high - #move_low) * #diagonal;)*
    }
}

/// After a full step: the multipliers of the bounds held (`grad` at a lower bound,
/// `-grad` at an upper one, each plus its threshold); all non-negative means optimal,
/// else the bound with the most negative one is released.
fn release_check(moves: &MoveNames, scalar: Scalar) -> TokenStream {
    let zero = literal(0.0, scalar);
    let (lower, upper) = (moves.per_move("lower"), moves.per_move("upper"));
    let (grad, threshold) = (moves.per_move("grad"), moves.per_move("threshold"));
    let multiplier = moves.per_move("multiplier");
    let releases = multiplier
        .iter()
        .zip(lower.iter().zip(&upper))
        .map(|(mu, (lo, hi))| {
            quote! {
                if #mu <= worst {
                    #lo = false;
                    #hi = false;
                }
            }
        });
    let releases: Vec<TokenStream> = releases.collect();
    let chain = releases
        .iter()
        .cloned()
        .reduce(|first, next| quote! { #first else #next })
        .unwrap_or_default();
    quote! {
        // The iterate minimises the cost with the held bounds fixed: check their
        // multipliers.
        #(
            let #multiplier = if #lower {
                #grad + #threshold
            } else if #upper {
                #threshold - #grad
            } else {
                #zero
            };
        )*
        let mut worst = #zero;
        #(
            if #multiplier < worst {
                worst = #multiplier;
            }
        )*
        if worst >= #zero {
            optimal = true;
            break;
        }
        // Release the first bound with the most negative multiplier.
        #chain
    }
}

/// The longest step along `step` (at most 1) that keeps every move within its bounds;
/// a move that stops it holds that bound. When the step is cut short, the projection of
/// the whole step onto the bounds competes with it (a projected Newton step, Bertsekas,
/// "Projected Newton methods for optimization problems with simple constraints"): it
/// holds every bound the step crosses at once, instead of one an iteration, and is taken
/// when it costs less, so the cost still never rises.
fn ratio_test(moves: &MoveNames, scalar: Scalar) -> TokenStream {
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    let (step, ratio) = (moves.per_move("step"), moves.per_move("ratio"));
    let (lower, upper) = (moves.per_move("lower"), moves.per_move("upper"));
    let (low, high) = (moves.per_move_input("low"), moves.per_move_input("high"));
    let v = moves.move_idents();
    let holds: Vec<TokenStream> = (0..moves.count())
        .map(|k| {
            let (r, s, x, lo, hi) = (&ratio[k], &step[k], &v[k], &low[k], &high[k]);
            let (l, u) = (&lower[k], &upper[k]);
            quote! {
                if #r <= alpha {
                    if #s < #zero {
                        #x = #lo;
                        #l = true;
                    } else {
                        #x = #hi;
                        #u = true;
                    }
                }
            }
        })
        .collect();
    let chain = holds
        .into_iter()
        .reduce(|first, next| quote! { #first else #next })
        .unwrap_or_default();
    let projection = projection(moves, scalar);
    let projected = moves.per_move("projected");
    let (grad, grad_projected) = (moves.per_move("grad"), moves.per_move("grad_projected"));
    let update = gradient_update(moves);
    quote! {
        // Ratio test: the longest step that keeps every move within its bounds.
        #(
            let #ratio = if #step < #zero {
                (#low - #v) / #step
            } else if #step > #zero {
                (#high - #v) / #step
            } else {
                #one
            };
        )*
        let mut alpha = #one;
        #(
            if #ratio < alpha {
                alpha = #ratio;
            }
        )*
        if alpha < #zero {
            alpha = #zero;
        }
        full_step = alpha >= #one;
        if full_step {
            #(#v += alpha * #step;)*
            #update
        } else {
            #projection
            if gain_projected < gain_cut {
                #(#v = #projected;)*
                #(#grad = #grad_projected;)*
                #(#lower = #v <= #low;)*
                #(#upper = !#lower && #v >= #high;)*
            } else {
                #(#v += alpha * #step;)*
                #update
                // Hold the first bound in the way, exactly.
                #chain
            }
        }
    }
}

/// The gradient's update along `alpha` times the step: `H` times it, which is zero on the
/// held moves, so only the free moves' columns are added.
fn gradient_update(moves: &MoveNames) -> TokenStream {
    let m = moves.count();
    let (free, step, grad) = (
        moves.per_move("free"),
        moves.per_move("step"),
        moves.per_move("grad"),
    );
    let columns = (0..m).map(|k| {
        let (f, s) = (&free[k], &step[k]);
        let adds = (0..m).map(|i| {
            let h = ident(&moves.hessian[packed_index(m, i.min(k), i.max(k))]);
            let g = &grad[i];
            quote! { #g += #h * moved; }
        });
        quote! {
            if #f {
                let moved = alpha * #s;
                #(#adds)*
            }
        }
    });
    quote! {
        // The gradient follows the step: H times it, on the free moves' columns.
        #(#columns)*
    }
}

/// The costs' changes from the iterate's: `gain_cut` of the step cut short and
/// `gain_projected` of the projected step, with the projected moves `projected_<move>` and
/// the gradient there. Along the Newton step `p` on the free moves, `p' H p = -p' grad`,
/// so the cut step changes the cost by `alpha (1 - alpha / 2) p' grad`; the projection
/// moves the free moves only, by `d`, and changes it by `d' grad + 1/2 d' H d`, that is
/// `1/2 d' (grad + grad_projected)` with `grad_projected = grad + H d`.
fn projection(moves: &MoveNames, scalar: Scalar) -> TokenStream {
    let m = moves.count();
    let (half, one) = (literal(0.5, scalar), literal(1.0, scalar));
    let (step, grad, free) = (
        moves.per_move("step"),
        moves.per_move("grad"),
        moves.per_move("free"),
    );
    let (low, high) = (moves.per_move_input("low"), moves.per_move_input("high"));
    let v = moves.move_idents();
    let (projected, whole, shift) = (
        moves.per_move("projected"),
        moves.per_move("whole"),
        moves.per_move("shift"),
    );
    let grad_projected = moves.per_move("grad_projected");
    let clipped = whole
        .iter()
        .zip(low.iter().zip(&high))
        .map(|(w, (lo, hi))| clip(w, lo, hi));
    let columns = (0..m).map(|k| {
        let (f, d) = (&free[k], &shift[k]);
        let adds = (0..m).map(|i| {
            let h = ident(&moves.hessian[packed_index(m, i.min(k), i.max(k))]);
            let g = &grad_projected[i];
            quote! { #g += #h * #d; }
        });
        quote! {
            if #f {
                #(#adds)*
            }
        }
    });
    quote! {
        let descent = #(#step * #grad)+*;
        let gain_cut = alpha * (#one - #half * alpha) * descent;
        #(let #whole = #v + #step;)*
        #(let #projected = #clipped;)*
        // Zero on the held moves, whose step is zero.
        #(let #shift = #projected - #v;)*
        #(let mut #grad_projected = #grad;)*
        #(#columns)*
        let gain_projected = #half * (#(#shift * (#grad + #grad_projected))+*);
    }
}
