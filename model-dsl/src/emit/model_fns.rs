//! Emits the model functions `f`, `h` and their Jacobians, with their zero patterns and
//! operation counts.

use super::lower::{Lowered, Lowerer, OpCount};
use super::names::{ident, nonzero_const, ops_const, TempNamer};
use crate::model::{Discretisation, Expr, Method, Model, Scalar};
use crate::symbolic::{ModelGraph, NodeId};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// What a generated function returns.
enum Shape {
    /// `[S; n]`
    Vector,
    /// `[[S; cols]; rows]`, row-major.
    Matrix { cols: usize },
}

/// One function to generate: its name, documentation, arguments and the nodes it returns.
pub struct ModelFunction {
    /// Function name, e.g. `jacobian_f_wrt_x`.
    pub name: &'static str,
    doc: String,
    takes_u: bool,
    shape: Shape,
    /// Returned nodes, row by row for matrices.
    roots: Vec<NodeId>,
    rows: usize,
}

impl ModelFunction {
    /// Whether each returned entry is structurally non-zero.
    pub fn nonzero(&self, mg: &ModelGraph) -> Vec<bool> {
        self.roots.iter().map(|&r| !mg.graph.is_zero(r)).collect()
    }
}

/// The model functions of `model`, built on `mg`.
pub fn model_functions(model: &Model, mg: &mut ModelGraph) -> Vec<ModelFunction> {
    let has_inputs = !model.inputs.is_empty();
    let h_uses_u = model
        .outputs
        .iter()
        .any(|o| model.reads(&o.expr, &|e| matches!(e, Expr::Input(_))));
    let flat = |m: Vec<Vec<NodeId>>| m.into_iter().flatten().collect::<Vec<_>>();
    let n = model.state_len();

    // With too many sub-steps to unroll, `f` is a loop (`substeps::looped_f`) and has no
    // Jacobians.
    let looped = model.dynamics.discretisation.is_looped();
    let mut functions = vec![ModelFunction {
        name: "f",
        doc: format!(
            "One sample of the dynamics, `x[k+1] = f(x[k], u[k])`{}.",
            discretisation_doc(model)
        ),
        takes_u: has_inputs,
        shape: Shape::Vector,
        roots: mg.f.clone(),
        rows: n,
    }];
    if !model.outputs.is_empty() {
        functions.push(ModelFunction {
            name: "h",
            doc: "The measurement, `y[k] = h(x[k])`.".into(),
            takes_u: h_uses_u,
            shape: Shape::Vector,
            roots: mg.h.clone(),
            rows: model.outputs.len(),
        });
    }
    functions.push(ModelFunction {
        name: "jacobian_f_wrt_x",
        doc: "The Jacobian `df/dx`: entry `[i][j]` is `d f_i / d x_j`.".into(),
        takes_u: has_inputs,
        shape: Shape::Matrix { cols: n },
        roots: flat(mg.jacobian_f_wrt_x()),
        rows: n,
    });
    if has_inputs {
        functions.push(ModelFunction {
            name: "jacobian_f_wrt_u",
            doc: "The Jacobian `df/du`: entry `[i][j]` is `d f_i / d u_j`.".into(),
            takes_u: true,
            shape: Shape::Matrix {
                cols: model.inputs.len(),
            },
            roots: flat(mg.jacobian_f_wrt_u()),
            rows: n,
        });
    }
    if looped {
        functions.retain(|f| f.name == "h");
    }
    if !model.outputs.is_empty() {
        functions.push(ModelFunction {
            name: "jacobian_h_wrt_x",
            doc: "The Jacobian `dh/dx`: entry `[i][j]` is `d h_i / d x_j`.".into(),
            takes_u: h_uses_u,
            shape: Shape::Matrix { cols: n },
            roots: flat(mg.jacobian_h_wrt_x()),
            rows: model.outputs.len(),
        });
    }
    functions
}

fn discretisation_doc(model: &Model) -> String {
    match &model.dynamics.discretisation {
        Discretisation::Discrete => String::new(),
        Discretisation::Continuous {
            method, substeps, ..
        } => {
            let method = integration_rule_name(*method);
            let steps = if *substeps == 1 {
                "one step".to_owned()
            } else {
                format!("{substeps} steps")
            };
            format!(", integrating the continuous dynamics with {method} ({steps} per sample)")
        }
    }
}

/// The integration rule as the model functions' docs name it.
pub fn integration_rule_name(method: Method) -> &'static str {
    match method {
        Method::Euler => "forward Euler",
        Method::Rk4 => "classical fourth-order Runge-Kutta",
    }
}

/// The names a model function's signature binds (`t`, `x`, `u`) and unpacks (constants,
/// states and inputs by their own names): its temporaries must not take them.
pub fn argument_names(model: &Model) -> impl Iterator<Item = &str> {
    model
        .constants
        .iter()
        .map(|c| c.name.as_str())
        .chain(model.state_names())
        .chain(model.inputs.iter().map(|s| s.name.as_str()))
        .chain(["t", "x", "u"])
}

/// The function's code over `scalar`, and what it computes.
pub fn emit_function(
    model: &Model,
    mg: &ModelGraph,
    function: &ModelFunction,
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let known = model.known.iter().map(|s| s.name.as_str());
    let interval = model.interval_parameter().unwrap_or_default();
    let reserved = argument_names(model)
        .chain(known)
        .chain(["known", interval.as_str()]);
    let namer = TempNamer::new(reserved);
    let mut lowerer = Lowerer::new(&mg.graph, scalar, namer, &function.roots);
    let roots = lowerer.segment(&function.roots);
    let Lowered {
        statements: lets,
        used_vars,
        ops,
    } = lowerer.finish();
    let ty = ident(scalar.type_name());
    let used = |node: NodeId| used_vars.contains(&mg.var_id(node));
    let (params, unpack) = parameters(model, mg, function, &used, &ty);
    let (ret, value) = returned(function, &roots, &ty);
    let name = ident(function.name);
    let doc = format!(" {}", function.doc);
    let ops_name = ops_const(function.name);
    let ops_doc = if model.scalars.first() == Some(&scalar) {
        format!(" Cost: see [`{ops_name}`].")
    } else {
        format!(" Cost: see [`{ops_name}`](super::{ops_name}).")
    };
    let lets = super::scopes::scoped(lets, &value);
    let tokens = quote! {
        #[doc = #doc]
        #[doc = ""]
        #[doc = #ops_doc]
        #[inline]
        #[must_use]
        pub fn #name(#(#params),*) -> #ret {
            #(#unpack)*
            #(#lets)*
            #value
        }
    };
    (tokens, ops)
}

/// The function's parameters (`t`, `x`, `u` if it takes it, `known` if the model has
/// some), each prefixed `_` when the code reads none of it, and the `let [..] = *x;`
/// naming the entries it reads (`used`).
fn parameters(
    model: &Model,
    mg: &ModelGraph,
    function: &ModelFunction,
    used: &dyn Fn(NodeId) -> bool,
    ty: &proc_macro2::Ident,
) -> (Vec<TokenStream>, Vec<TokenStream>) {
    let mut params = Vec::new();
    let mut unpack = Vec::new();
    if model.uses_time() {
        let t = if used(mg.t) { ident("t") } else { ident("_t") };
        params.push(quote! { #t: #ty });
    }
    // The sample interval, for the functions that read it (its Jacobians), and for `f`
    // whenever the dynamics do (a delayed horizon's output predictor passes it).
    if let (Some(dt), Some(name)) = (mg.interval, model.interval_parameter()) {
        if used(dt) {
            let dt = ident(&name);
            params.push(quote! { #dt: #ty });
        } else if function.name == "f" && model.dynamics_read_interval() {
            let dt = ident(&format!("_{name}"));
            params.push(quote! { #dt: #ty });
        }
    }
    for (arg, vars, names) in [
        ("x", &mg.x, model.state_names().collect::<Vec<_>>()),
        (
            "u",
            &mg.u,
            model.inputs.iter().map(|s| s.name.as_str()).collect(),
        ),
        (
            "known",
            &mg.known,
            model.known.iter().map(|s| s.name.as_str()).collect(),
        ),
    ] {
        let len = Literal::usize_unsuffixed(vars.len());
        if (arg == "u" && !function.takes_u) || (arg == "known" && vars.is_empty()) {
            continue;
        }
        let any_used = vars.iter().any(|&v| used(v));
        let arg_name = if any_used {
            ident(arg)
        } else {
            ident(&format!("_{arg}"))
        };
        params.push(quote! { #arg_name: &[#ty; #len] });
        if any_used {
            let pattern = vars.iter().zip(&names).map(|(&v, name)| {
                if used(v) {
                    let name = ident(name);
                    quote! { #name }
                } else {
                    quote! { _ }
                }
            });
            unpack.push(quote! { let [#(#pattern),*] = *#arg_name; });
        }
    }
    (params, unpack)
}

/// The return type and the returned value: a vector `[S; n]`, or a matrix
/// `[[S; cols]; rows]` whose rows are `roots` in chunks of `cols`.
fn returned(
    function: &ModelFunction,
    roots: &[TokenStream],
    ty: &proc_macro2::Ident,
) -> (TokenStream, TokenStream) {
    let rows = Literal::usize_unsuffixed(function.rows);
    match function.shape {
        Shape::Vector => (quote! { [#ty; #rows] }, quote! { [#(#roots),*] }),
        Shape::Matrix { cols } => {
            let row_values = roots.chunks(cols.max(1)).map(|row| quote! { [#(#row),*] });
            let cols = Literal::usize_unsuffixed(cols);
            (
                quote! { [[#ty; #cols]; #rows] },
                quote! { [#(#row_values),*] },
            )
        }
    }
}

/// `pub const F_OPS: OpCount = ..;` for a function.
pub fn ops_item(function: &ModelFunction, ops: OpCount) -> TokenStream {
    named_ops_item(&ops_const(function.name).to_string(), function.name, ops)
}

/// `what` for a doc or a message: a single name (`f`) in a code span, or the paths in a
/// phrase (`the two filters of Dkf::step`) each in one.
pub fn code_spans(what: &str) -> String {
    if !what.contains(char::is_whitespace) {
        return format!("`{what}`");
    }
    let words: Vec<String> = what
        .split(' ')
        .map(|word| {
            let path = word.trim_end_matches(|c: char| !c.is_alphanumeric() && c != '_');
            if path.contains("::") {
                format!("`{path}`{}", &word[path.len()..])
            } else {
                word.to_owned()
            }
        })
        .collect();
    words.join(" ")
}

/// `pub const NAME: OpCount = ..;` documenting what `what` computes.
pub fn named_ops_item(name: &str, what: &str, ops: OpCount) -> TokenStream {
    let name = ident(name);
    let doc = format!(" What {} computes per call.", code_spans(what));
    let [add, mul, div, call, compare] = [ops.add, ops.mul, ops.div, ops.call, ops.compare]
        .map(|count| proc_macro2::Literal::usize_unsuffixed(count as usize));
    quote! {
        #[doc = #doc]
        pub const #name: OpCount = OpCount { add: #add, mul: #mul, div: #div, call: #call, compare: #compare };
    }
}

/// `pub const EKF_STEP_CYCLES: u32 = ..;`, the static estimate of `what` on `target`, a
/// call or (`is_part`) part of one, beside its `*_OPS` constant `ops_name`.
pub fn cycles_item(
    (ops_name, what, is_part): (&str, &str, bool),
    estimate: &crate::timing::Estimate,
    target: &crate::timing::Target,
) -> TokenStream {
    let base = ops_name.strip_suffix("_OPS").unwrap_or(ops_name);
    let name = ident(&format!("{base}_CYCLES"));
    let subject = match is_part {
        true => format!("{} (part of a call: no entry and return)", code_spans(what)),
        false => format!("one call of {}", code_spans(what)),
    };
    let doc = format!(
        " Estimated cycles of {subject} on a {} (zero wait states), from what its code does \
         ([`{ops_name}`], its loads and stores): {}.",
        target.description,
        estimate.largest(usize::MAX)
    );
    let cycles = Literal::u32_unsuffixed(u32::try_from(estimate.cycles).unwrap_or(u32::MAX));
    quote! {
        #[doc = #doc]
        pub const #name: u32 = #cycles;
    }
}

/// `pub const JACOBIAN_F_WRT_X_NONZERO: [[bool; n]; m] = ..;` for a Jacobian.
pub fn nonzero_item(function: &ModelFunction, mg: &ModelGraph) -> Option<TokenStream> {
    let Shape::Matrix { cols } = function.shape else {
        return None;
    };
    let name = nonzero_const(function.name);
    let doc = format!(
        " Structural non-zeros of `{}`: `false` entries are zero for every argument.",
        function.name
    );
    let flags = function.nonzero(mg);
    let row_values = flags.chunks(cols.max(1)).map(|row| quote! { [#(#row),*] });
    let (rows, cols) = (
        Literal::usize_unsuffixed(function.rows),
        Literal::usize_unsuffixed(cols),
    );
    Some(quote! {
        #[doc = #doc]
        pub const #name: [[bool; #cols]; #rows] = [#(#row_values),*];
    })
}

#[cfg(test)]
mod tests {
    use super::code_spans;

    #[test]
    fn code_spans_mark_names_and_paths_only() {
        assert_eq!(code_spans("f"), "`f`");
        assert_eq!(code_spans("Ekf::step"), "`Ekf::step`");
        assert_eq!(
            code_spans("the two filters of Dkf::step"),
            "the two filters of `Dkf::step`"
        );
        assert_eq!(
            code_spans("Mpc::solve at its worst (every iteration run)"),
            "`Mpc::solve` at its worst (every iteration run)"
        );
        assert_eq!(
            code_spans("PolynomialKf::step (recursive)"),
            "`PolynomialKf::step` (recursive)"
        );
        assert_eq!(
            code_spans("one sub-step of HybridEkf::step,"),
            "one sub-step of `HybridEkf::step`,"
        );
    }
}
