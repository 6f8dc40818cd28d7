//! The `Mpc`'s limits besides the inputs' bounds, as its user sets them: the fields that
//! hold them (no limit until set), and the setters that check and replace them.

use super::spec::MpcSpec;
use crate::emit::names::ident;
use crate::model::{Model, Scalar};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// The penalty of each soft limit's violation until `set_limit_penalties`: large enough
/// to hold a limit against most costs, small enough that an `f32` solve's multipliers stay
/// within the rounding the dual active set tolerates (on TinyMPC's quadrotor `1e5` makes
/// two solves of a gust run out of iterations, `1e6` the loop diverge).
pub const DEFAULT_PENALTY: f64 = 1e4;

/// A group of limited quantities, as its fields and setter name it.
struct Group {
    /// `rate`, `state`, `output`: the fields `<kind>_min`, `<kind>_max`.
    kind: &'static str,
    /// The quantities' names, in the order the model lists them.
    names: Vec<String>,
    /// What the setter's doc calls a quantity's value.
    what: &'static str,
}

fn groups(model: &Model, spec: &MpcSpec) -> Vec<Group> {
    let limits = &spec.limits;
    let groups = [
        Group {
            kind: "rate",
            names: limits
                .rates
                .iter()
                .map(|&q| model.inputs[spec.inputs[q]].name.clone())
                .collect(),
            what: "change of each input between moves, `u_k - u_(k-1)` (the first move's \
                   from the input `solve` is given),",
        },
        Group {
            kind: "state",
            names: limits
                .states
                .iter()
                .map(|&j| model.states[spec.states[j]].name.clone())
                .collect(),
            what: "state over the horizon, `x_1 .. x_n`,",
        },
        Group {
            kind: "output",
            names: limits
                .outputs
                .iter()
                .map(|&(o, _)| model.outputs[o].name.clone())
                .collect(),
            what: "output over the horizon, `y_1 .. y_n`,",
        },
    ];
    groups.into_iter().filter(|g| !g.names.is_empty()).collect()
}

/// The fields (`value`: their values in `new`, every limit infinite and every penalty
/// [`DEFAULT_PENALTY`]).
pub fn fields(model: &Model, spec: &MpcSpec, scalar: Scalar, value: bool) -> TokenStream {
    let ty = ident(scalar.type_name());
    let mut fields = TokenStream::new();
    for group in groups(model, spec) {
        let len = Literal::usize_unsuffixed(group.names.len());
        let (min, max) = field_names(group.kind);
        fields.extend(match value {
            false => quote! { #min: [#ty; #len], #max: [#ty; #len], },
            true => quote! {
                #min: [#ty::NEG_INFINITY; #len],
                #max: [#ty::INFINITY; #len],
            },
        });
    }
    let soft = spec.limits.soft_count();
    if soft > 0 {
        let len = Literal::usize_unsuffixed(soft);
        let penalty = crate::emit::lower::literal(DEFAULT_PENALTY, scalar);
        fields.extend(match value {
            false => quote! { limit_penalties: [#ty; #len], },
            true => quote! { limit_penalties: [#penalty; #len], },
        });
    }
    fields
}

fn field_names(kind: &str) -> (Ident, Ident) {
    (ident(&format!("{kind}_min")), ident(&format!("{kind}_max")))
}

/// `set_rate_limits`, `set_state_limits`, `set_output_limits` (for the groups the model
/// limits) and `set_limit_penalties` (with soft limits).
pub fn setters(model: &Model, spec: &MpcSpec, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let mut setters = TokenStream::new();
    for group in groups(model, spec) {
        let (min_field, max_field) = field_names(group.kind);
        let setter = ident(&format!("set_{}_limits", group.kind));
        let len = Literal::usize_unsuffixed(group.names.len());
        let min: Vec<Ident> = group
            .names
            .iter()
            .map(|n| ident(&format!("{n}_min")))
            .collect();
        let max: Vec<Ident> = group
            .names
            .iter()
            .map(|n| ident(&format!("{n}_max")))
            .collect();
        let listed = group.names.join("`, `");
        let doc = format!(
            " Replaces the limits `minimum <= .. <= maximum` on the {} each in the order \
             `{listed}`, from the next solve on: infinite for no limit on that side. \
             [`Status::RejectedInput`] if an entry is NaN, a minimum is above its maximum, a \
             minimum is `+inf` or a maximum `-inf`, the limits then as they were.",
            group.what
        );
        setters.extend(quote! {
            #[doc = #doc]
            pub fn #setter(&mut self, minimum: &[#ty; #len], maximum: &[#ty; #len]) -> Status {
                let [#(#min),*] = *minimum;
                let [#(#max),*] = *maximum;
                if #(#min.is_nan() || #max.is_nan() || #min > #max
                    || #min == #ty::INFINITY || #max == #ty::NEG_INFINITY)||* {
                    return Status::RejectedInput;
                }
                self.#min_field = *minimum;
                self.#max_field = *maximum;
                Status::Ok
            }
        });
    }
    setters.extend(penalty_setter(model, spec, scalar));
    setters
}

/// `set_limit_penalties`, when some limits are soft.
fn penalty_setter(model: &Model, spec: &MpcSpec, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let names: Vec<String> = groups(model, spec)
        .into_iter()
        .flat_map(|g| g.names)
        .zip(&spec.limits.soft)
        .filter_map(|(name, &soft)| soft.then_some(name))
        .collect();
    if names.is_empty() {
        return TokenStream::new();
    }
    let len = Literal::usize_unsuffixed(names.len());
    let penalty: Vec<Ident> = names
        .iter()
        .map(|n| ident(&format!("{n}_penalty")))
        .collect();
    let doc = format!(
        " Replaces the penalties of the soft limits' violations, each in the order `{}`: the \
         cost of a unit of violation (the slack) at each step. A soft limit is met whenever \
         a plan within it exists and its penalty exceeds what meeting it costs (its \
         multiplier), and is violated as little as the penalty makes worth it otherwise \
         (an exact penalty). [`Status::RejectedInput`] unless each is positive and finite, \
         the penalties then as they were.",
        names.join("`, `")
    );
    let zero = crate::emit::lower::literal(0.0, scalar);
    quote! {
        #[doc = #doc]
        pub fn set_limit_penalties(&mut self, penalties: &[#ty; #len]) -> Status {
            let [#(#penalty),*] = *penalties;
            if #(!#penalty.is_finite() || #penalty <= #zero)||* {
                return Status::RejectedInput;
            }
            self.limit_penalties = *penalties;
            Status::Ok
        }
    }
}
