//! Every rule for names in generated code, in one place.

use crate::fast_hash::{FastMap, FastSet};
use crate::model::Scalar;
use crate::symbolic::{Graph, Node, NodeId};
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;

/// Longest derived temporary name before falling back to a numbered one.
const MAX_DERIVED_LEN: usize = 20;

/// An identifier in generated code.
pub fn ident(name: &str) -> Ident {
    Ident::new(name, Span::call_site())
}

/// The runtime crate's function `name` for `scalar`: `stateforge_math::f32::sin`. Generated
/// code calls elementary functions there only (its `f32` functions never compute in
/// `f64`; its `f64` ones are `libm`'s), so the calling crate has one runtime dependency.
pub fn math_fn(scalar: Scalar, name: &str) -> TokenStream {
    let (module, name) = (ident(scalar.type_name()), ident(name));
    quote! { stateforge_math::#module::#name }
}

/// `F_OPS` for `f`, `JACOBIAN_F_WRT_X_OPS` for `jacobian_f_wrt_x`.
pub fn ops_const(function: &str) -> Ident {
    ident(&format!("{}_OPS", function.to_uppercase()))
}

/// `JACOBIAN_F_WRT_X_NONZERO` for `jacobian_f_wrt_x`.
pub fn nonzero_const(function: &str) -> Ident {
    ident(&format!("{}_NONZERO", function.to_uppercase()))
}

/// `GATED_EKF` for the type name `GatedEkf`: a word break before each capital.
pub fn screaming_snake(type_name: &str) -> String {
    let mut out = String::new();
    for (i, c) in type_name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

/// The index constant of a symbol: `X1` for `x1`.
pub fn index_const(symbol: &str) -> Ident {
    ident(&symbol.to_uppercase())
}

/// The name of entry `(i, j)` (from 1) of the `rows x cols` matrix `prefix`: `a12`, or
/// `a_1_12` when an index has two digits (where `a112` could be `(1, 12)` or `(11, 2)`).
pub fn matrix_entry(prefix: &str, (rows, cols): (usize, usize), (i, j): (usize, usize)) -> String {
    if rows >= 10 || cols >= 10 {
        format!("{prefix}_{i}_{j}")
    } else {
        format!("{prefix}{i}{j}")
    }
}

/// `base`, with `_` appended while `taken` says a name is in use (the model's own names).
pub fn clear_of(base: &str, taken: impl Fn(&str) -> bool) -> String {
    let mut name = base.to_owned();
    while taken(&name) {
        name.push('_');
    }
    name
}

/// Chooses names for the `let` temporaries of one generated function: the model's own
/// name for a `let` intermediate, else a name built from the operands (`ts_x2` for
/// `TS * x2`), else `tmp1`, `tmp2`, ... Names never repeat or shadow a model symbol.
#[derive(Clone)]
pub struct TempNamer {
    taken: FastSet<String>,
    assigned: FastMap<NodeId, String>,
    /// Names the emitter chose for particular nodes, used before any other rule.
    preferred: FastMap<NodeId, String>,
    numbered: usize,
    /// For a base name taken already, the suffix its next variant is sought from: every
    /// smaller one was taken (names are never given back), so a name the model uses in
    /// each of 256 sub-steps does not try `f_act_2` .. `f_act_256` again each time.
    suffixes: FastMap<String, usize>,
}

impl TempNamer {
    /// A namer that avoids every name in `reserved` (symbols, constants, parameters).
    pub fn new<'a>(reserved: impl IntoIterator<Item = &'a str>) -> TempNamer {
        TempNamer {
            taken: reserved.into_iter().map(str::to_owned).collect(),
            assigned: FastMap::default(),
            preferred: FastMap::default(),
            numbered: 0,
            suffixes: FastMap::default(),
        }
    }

    /// The name already given to `id`, if it is bound to a temporary.
    pub fn get(&self, id: NodeId) -> Option<&str> {
        self.assigned.get(&id).map(String::as_str)
    }

    /// Asks for `name` (made unique) when `id` is bound.
    pub fn prefer(&mut self, id: NodeId, name: &str) {
        self.preferred.insert(id, name.to_owned());
    }

    /// Names the temporary holding `id`.
    pub fn assign(&mut self, graph: &Graph, id: NodeId) -> Ident {
        let base = self
            .preferred
            .get(&id)
            .cloned()
            .or_else(|| graph.name_hint(id).map(str::to_owned))
            .or_else(|| self.label(graph, id).filter(|l| l.len() <= MAX_DERIVED_LEN));
        let name = match base {
            Some(base) => self.unique(&base),
            None => loop {
                self.numbered += 1;
                let candidate = format!("tmp{}", self.numbered);
                if !self.taken.contains(&candidate) {
                    break candidate;
                }
            },
        };
        self.taken.insert(name.clone());
        self.assigned.insert(id, name.clone());
        ident(&name)
    }

    /// Gives `id` the name `name` another value already has: the two are one value.
    pub fn alias(&mut self, id: NodeId, name: &str) {
        self.assigned.insert(id, name.to_owned());
    }

    /// Names a value the emitter binds itself (not a graph node): `base`, made unique.
    pub fn fresh(&mut self, base: &str) -> Ident {
        let name = self.unique(base);
        self.taken.insert(name.clone());
        ident(&name)
    }

    fn unique(&mut self, base: &str) -> String {
        let taken = &self.taken;
        let valid = |s: &str| !taken.contains(s) && syn::parse_str::<syn::Ident>(s).is_ok();
        if valid(base) {
            return base.to_owned();
        }
        let start = self.suffixes.get(base).copied().unwrap_or(2);
        let Some((n, name)) = (start..)
            .map(|n| (n, format!("{base}_{n}")))
            .find(|(_, s)| valid(s))
        else {
            return base.to_owned();
        };
        self.suffixes.insert(base.to_owned(), n);
        name
    }

    /// A readable description of a node from its operands, if one is short enough.
    fn label(&self, graph: &Graph, id: NodeId) -> Option<String> {
        if let Some(name) = self.get(id) {
            return Some(name.to_owned());
        }
        let l = |x| self.label(graph, x);
        let text = match graph.node(id) {
            Node::Num(bits) => number_label(f64::from_bits(bits)),
            Node::Named(c) => graph.const_info(c).name.to_lowercase(),
            Node::Var(v) => graph.var_info(v).name.clone(),
            Node::Neg(a) => format!("neg_{}", l(a)?),
            Node::Add(a, b) => format!("{}_plus_{}", l(a)?, l(b)?),
            Node::Sub(a, b) => format!("{}_minus_{}", l(a)?, l(b)?),
            Node::Mul(a, b) => format!("{}_{}", l(a)?, l(b)?),
            Node::Div(a, b) => format!("{}_over_{}", l(a)?, l(b)?),
            Node::Call(f, a) => format!("{}_{}", f.name(), l(a)?),
            Node::Atan2(y, x) => format!("atan2_{}_{}", l(y)?, l(x)?),
            Node::Select { then, .. } => format!("piecewise_{}", l(then)?),
        };
        (text.len() <= MAX_DERIVED_LEN).then_some(text)
    }
}

/// `2` -> `c2`, `0.5` -> `c0_5`: a literal as part of an identifier.
fn number_label(v: f64) -> String {
    let digits = format!("{v}").replace('.', "_").replace('-', "m");
    format!("c{digits}")
}
