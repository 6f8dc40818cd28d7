//! The names a model declares and what each refers to, as the checks resolve them and as
//! the generators' options look them up (a module of its own, so that neither `check` nor
//! `generators` imports the other both ways).

use crate::ast::{ModelDecl, Statement, SymbolKind};
use crate::model::Scalar;
use indexmap::IndexMap;
use proc_macro2::Span;

/// What a name in an expression refers to.
#[derive(Clone, Copy, Debug)]
pub enum Binding {
    Const(usize),
    State(usize),
    Param(usize),
    Input(usize),
    Known(usize),
    Local(usize),
    /// A vector or rotation: [`Scope::typed`]`[i]`, its entries as expressions.
    Typed(usize),
}

/// The names declared so far, and what expressions need to know of them.
pub struct Scope {
    pub(crate) names: IndexMap<String, (Binding, Span)>,
    /// The values of the constants declared so far, by index.
    pub(crate) const_values: Vec<f64>,
    /// The model's scalar types: every constant must be finite in each.
    pub(crate) scalars: Vec<Scalar>,
    /// What each name of the model is, declared yet or not, for a name used before (or
    /// where) it can be.
    pub(crate) declared: std::collections::HashMap<String, &'static str>,
    /// Names whose definition (a constant's or an intermediate's expression) had an error,
    /// recorded already: an expression that reads one is left unresolved without an error
    /// of its own, so one mistake is reported once, where it is.
    pub(crate) failed: std::collections::HashSet<String>,
    /// The values of the typed names (vectors and rotations), each entry a scalar
    /// expression (a state, an input, an intermediate, ..).
    pub(crate) typed: Vec<crate::model::Value>,
    /// How many entries the physical states take (a vector state three): where the
    /// parameters start in the state vector.
    pub(crate) state_len: usize,
}

impl Scope {
    /// An empty scope for `decl`, knowing what each of its names will be.
    pub(crate) fn new(decl: &ModelDecl) -> Scope {
        let mut declared = std::collections::HashMap::new();
        for sym in &decl.symbols {
            let what = match sym.kind {
                SymbolKind::State => "a state",
                SymbolKind::Param => "a parameter",
                SymbolKind::Input => "an input",
                SymbolKind::Known => "a constant known at run time",
            };
            declared.insert(sym.name.text.clone(), what);
        }
        for out in &decl.outputs {
            declared.insert(out.name.text.clone(), "an output");
        }
        for statement in decl.dynamics.iter().flat_map(|d| &d.statements) {
            if let Statement::Let { name, .. } = statement {
                declared.insert(name.text.clone(), "an intermediate of `dynamics`");
            }
        }
        Scope {
            names: IndexMap::new(),
            const_values: Vec::new(),
            scalars: Vec::new(),
            declared,
            failed: std::collections::HashSet::new(),
            typed: Vec::new(),
            state_len: 0,
        }
    }

    /// What `name` refers to, and where it was declared.
    pub fn get(&self, name: &str) -> Option<&(Binding, Span)> {
        self.names.get(name)
    }

    /// Whether `name` is declared.
    pub(crate) fn contains_key(&self, name: &str) -> bool {
        self.names.contains_key(name)
    }

    /// The value of the typed name bound as [`Binding::Typed`]`(i)`.
    pub fn typed(&self, i: usize) -> Option<&crate::model::Value> {
        self.typed.get(i)
    }

    /// The value of the `i`-th constant.
    pub fn const_value(&self, i: usize) -> Option<f64> {
        self.const_values.get(i).copied()
    }
}
