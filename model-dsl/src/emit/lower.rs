//! Lowers graph nodes to straight-line Rust: `let` temporaries for shared subexpressions,
//! inline expressions for the rest, and an operation count of what was emitted.

use super::names::TempNamer;
use super::registers::{RegisterFile, Step, FPU_REGISTERS};
use crate::fast_hash::{FastMap, FastSet};
use crate::model::{Func, Scalar};
use crate::symbolic::{Graph, Node, NodeId, VarId};
use proc_macro2::{Delimiter, Group, Literal, Punct, Spacing, TokenStream, TokenTree};
use quote::quote;
use std::collections::BTreeSet;
use std::str::FromStr;

/// The longest array [`Lowerer::read_lazily`] reads one name at a time (a 10-state
/// covariance, packed, has 55 entries).
pub const LAZY_READ_MAX_LEN: usize = 64;

/// The deepest an expression is written inline before a part of it is named by a `let`:
/// a 100-term sum nested to the right would otherwise be 100 parentheses deep, which
/// rustc's parser (and ours, when the code is formatted) recurses through.
const MAX_INLINE_DEPTH: u32 = 24;

/// Arithmetic a generated function performs, counted from the emitted code, and the
/// memory traffic and branches it implies (for the static cycle estimate,
/// [`crate::timing`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCount {
    /// Additions, subtractions and negations.
    pub add: u32,
    /// Multiplications.
    pub mul: u32,
    /// Divisions.
    pub div: u32,
    /// Library calls: `sin cos tan exp ln sqrt abs`.
    pub call: u32,
    /// Comparisons of piecewise terms.
    pub compare: u32,
    /// The library calls by function, indexed by [`Callee`].
    pub calls: [u32; Callee::COUNT],
    /// Scalars read from memory: the fields and arguments the code reads, and values
    /// reloaded after a spill ([`super::registers`]).
    pub load: u32,
    /// Literal constants loaded from the constant pool.
    pub literal: u32,
    /// Scalars written to memory: the fields the code writes, and spilled values.
    pub store: u32,
    /// Branches taken: a loop's iterations.
    pub branch: u32,
    /// Calls of generated functions the code makes (the output predictor's of `f`), an
    /// entry and return each, beside its own.
    pub entry: u32,
}

/// A library function generated code calls, as [`OpCount::calls`] counts it: the
/// model's functions in [`Func`]'s order, then `atan2`, then `sin_cos` (a sine and a
/// cosine of one argument, one call).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Callee(pub usize);

impl Callee {
    /// `atan2(y, x)`.
    pub const ATAN2: Callee = Callee(Func::ALL.len());
    /// `sin_cos(x)`.
    pub const SIN_COS: Callee = Callee(Func::ALL.len() + 1);
    /// How many there are.
    pub const COUNT: usize = Func::ALL.len() + 2;

    /// A model function's.
    pub fn of(f: Func) -> Callee {
        Callee(f as usize)
    }

    /// The name generated code calls (`sin_cos`).
    pub fn name(self) -> &'static str {
        match self {
            Callee::ATAN2 => Func::ATAN2.name,
            Callee::SIN_COS => "sin_cos",
            Callee(i) => Func::ALL[i].name(),
        }
    }
}

impl OpCount {
    /// Each count of `self` and `other` combined by `f`.
    fn zip(self, other: OpCount, f: impl Fn(u32, u32) -> u32) -> OpCount {
        let mut calls = self.calls;
        for (c, o) in calls.iter_mut().zip(other.calls) {
            *c = f(*c, o);
        }
        OpCount {
            add: f(self.add, other.add),
            mul: f(self.mul, other.mul),
            div: f(self.div, other.div),
            call: f(self.call, other.call),
            compare: f(self.compare, other.compare),
            calls,
            load: f(self.load, other.load),
            literal: f(self.literal, other.literal),
            store: f(self.store, other.store),
            branch: f(self.branch, other.branch),
            entry: f(self.entry, other.entry),
        }
    }

    /// Both counts together.
    pub fn plus(self, other: OpCount) -> OpCount {
        self.zip(other, u32::saturating_add)
    }

    /// What `self` counts beyond `earlier`, a count taken before it.
    pub fn minus(self, earlier: OpCount) -> OpCount {
        self.zip(earlier, |a, b| a - b)
    }

    /// The count of `n` repetitions.
    pub fn times(self, n: u32) -> OpCount {
        self.zip(OpCount::default(), |a, _| a.saturating_mul(n))
    }

    /// The count of a loop of `trips` iterations of `self`: each iteration also tests
    /// and branches back.
    pub fn looped(self, trips: u32) -> OpCount {
        OpCount {
            branch: self.branch + 1,
            ..self
        }
        .times(trips)
    }

    /// `n` branches taken (a loop's, say).
    pub fn branches(n: u32) -> OpCount {
        OpCount {
            branch: n,
            ..OpCount::default()
        }
    }

    /// `n` scalars read from memory.
    pub fn loads(n: usize) -> OpCount {
        OpCount {
            load: u32::try_from(n).unwrap_or(u32::MAX),
            ..OpCount::default()
        }
    }

    /// `n` calls of generated functions: an entry and return each.
    pub fn entries(n: u32) -> OpCount {
        OpCount {
            entry: n,
            ..OpCount::default()
        }
    }

    /// `n` scalars written to memory.
    pub fn stores(n: usize) -> OpCount {
        OpCount {
            store: u32::try_from(n).unwrap_or(u32::MAX),
            ..OpCount::default()
        }
    }
}

/// Binding strength of a rendered expression, to place parentheses.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Sum,
    Product,
    Prefix,
    Atom,
}

/// Lowers the nodes of one generated function to straight-line code, in segments.
///
/// A function may need statements of its own between computations (a guard before a
/// division, say). Each [`Lowerer::segment`] emits what its roots need and was not emitted
/// before; use counts are taken over all of the function's roots up front, so a node that
/// a later segment also needs is bound to a `let` in the segment that first computes it.
/// Cloning a lowerer forks it: code for alternative branches continues from one point.
#[derive(Clone)]
pub struct Lowerer<'g> {
    graph: &'g Graph,
    scalar: Scalar,
    namer: TempNamer,
    /// Uses of each node by the function's code; a root occurrence counts as one.
    uses: Vec<u32>,
    /// Whether a node's value was already computed by emitted code.
    emitted: Vec<bool>,
    statements: Vec<TokenStream>,
    used_vars: BTreeSet<VarId>,
    ops: OpCount,
    /// Statements that read variables, emitted just before the first use of any variable
    /// they name; `read_of` maps a variable to its statement.
    reads: Vec<Option<TokenStream>>,
    /// How deeply each emitted node nests where it is written inline (0 once named).
    inline_depth: Vec<u32>,
    read_of: FastMap<NodeId, usize>,
    /// Nodes the use counts have reached.
    reached: Vec<bool>,
    /// Variables that stand for a value computed here (see [`Lowerer::define`]).
    definitions: FastMap<NodeId, NodeId>,
    /// Uses of each node by the code emitted so far.
    consumed: Vec<u32>,
    /// The values in registers, for the memory traffic of the code.
    registers: RegisterFile,
    /// Variables whose values the code holds in registers, not in memory.
    held: FastSet<NodeId>,
}

impl<'g> Lowerer<'g> {
    /// A lowerer for a function whose code, all segments together, computes `all_roots`.
    pub fn new(graph: &'g Graph, scalar: Scalar, namer: TempNamer, all_roots: &[NodeId]) -> Self {
        let mut lowerer = Lowerer {
            graph,
            scalar,
            namer,
            uses: vec![0; graph.len()],
            emitted: vec![false; graph.len()],
            statements: Vec::new(),
            used_vars: BTreeSet::new(),
            ops: OpCount::default(),
            reads: Vec::new(),
            inline_depth: vec![0; graph.len()],
            read_of: FastMap::default(),
            reached: vec![false; graph.len()],
            definitions: FastMap::default(),
            consumed: vec![0; graph.len()],
            registers: RegisterFile::new(FPU_REGISTERS),
            held: FastSet::default(),
        };
        lowerer.count_uses(all_roots);
        lowerer
    }

    /// Counts one use of each of `roots` and, once per node newly reached, one use of
    /// each of its operands.
    fn count_uses(&mut self, roots: &[NodeId]) {
        let mut stack: Vec<NodeId> = roots.to_vec();
        for &r in roots {
            self.uses[r.index()] += 1;
        }
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut self.reached[id.index()], true) {
                continue;
            }
            for child in self.operands(id) {
                self.uses[child.index()] += 1;
                stack.push(child);
            }
        }
    }

    /// A node's operands; a defined variable's is its value.
    fn operands(&self, id: NodeId) -> Vec<NodeId> {
        match self.definitions.get(&id) {
            Some(&value) => vec![value],
            None => self.graph.node(id).children(),
        }
    }

    /// Makes the variable `var` stand for `value`: where the code first uses `var`, it
    /// computes `let var = value;`. A stage built on a matrix whose entries are
    /// variables (`f21` for `eta TS phi_x3`, say) so reuses each entry once computed;
    /// built on the entries themselves, the simplifier would move their literal factors
    /// out of every product (`c (x y)`) and multiply by them again each time.
    /// Call before the first [`Lowerer::segment`].
    pub fn define(&mut self, var: NodeId, value: NodeId) {
        debug_assert!(matches!(self.graph.node(var), Node::Var(_)));
        self.definitions.insert(var, value);
        if self.reached[var.index()] {
            self.count_uses(&[value]);
        }
    }

    /// Reads each of `vars` from the array `source` (`self.p`, say) where it is first used,
    /// as `let [_, _, p13, ..] = self.p;`, rather than all of them up front: a value read
    /// early stays live (in a register, or spilled to the stack) until its use.
    ///
    /// One-name patterns grow with the position they read, so an array longer than
    /// [`LAZY_READ_MAX_LEN`] is read by one pattern naming every variable the function uses,
    /// at the first use of any of them: code stays linear in the array's length (a
    /// 100-state covariance has 5050 entries), and a filter that large spills regardless.
    pub fn read_lazily(&mut self, source: &TokenStream, vars: &[NodeId]) {
        let names: Vec<Option<proc_macro2::Ident>> = vars
            .iter()
            .map(|&var| match self.graph.node(var) {
                Node::Var(v) => Some(super::names::ident(&self.graph.var_info(v).name)),
                _ => None,
            })
            .collect();
        if vars.len() > LAZY_READ_MAX_LEN {
            let pattern = vars.iter().zip(&names).map(|(&var, name)| match name {
                Some(name) if self.uses[var.index()] > 0 => quote! { #name },
                _ => quote! { _ },
            });
            self.reads
                .push(Some(quote! { let [#(#pattern),*] = #source; }));
            let read = self.reads.len() - 1;
            for &var in vars {
                self.read_of.insert(var, read);
            }
            return;
        }
        let len = vars.len();
        for (position, (&var, name)) in vars.iter().zip(&names).enumerate() {
            let Some(name) = name else {
                continue;
            };
            let before = (0..position).map(|_| quote! { _ });
            let pattern = if position + 1 == len {
                quote! { [.., #name] }
            } else {
                quote! { [#(#before,)* #name, ..] }
            };
            self.reads.push(Some(quote! { let #pattern = #source; }));
            self.read_of.insert(var, self.reads.len() - 1);
        }
    }

    /// Reads each of `vars` where it is first used with the statement `read(name)`
    /// (`let p13 = *p13_slot;`, through a reference the caller binds): one short
    /// statement per variable, whatever the length of the array they live in.
    pub fn read_each(
        &mut self,
        vars: &[NodeId],
        read: impl Fn(&proc_macro2::Ident) -> TokenStream,
    ) {
        for &var in vars {
            if let Node::Var(v) = self.graph.node(var) {
                let name = super::names::ident(&self.graph.var_info(v).name);
                self.reads.push(Some(read(&name)));
                self.read_of.insert(var, self.reads.len() - 1);
            }
        }
    }

    /// Emits the `let`s `roots` need and returns an expression for each root.
    ///
    /// Values are scheduled depth-first from each root in turn, so each is computed just
    /// before its first use, as careful hand-written code would: live ranges stay short,
    /// and so does the register pressure on the target (spills cost loads and stores).
    pub fn segment(&mut self, roots: &[NodeId]) -> Vec<TokenStream> {
        let (order, _) = self.schedule(roots);
        self.count_traffic(&order, roots);
        for id in order {
            self.emit_node(id);
        }
        roots.iter().map(|&r| self.render(r).0).collect()
    }

    /// Emits each value of `writes` in turn and stores it in place, as careful code
    /// updating an array in place does: `(root, old, place)` computes `root`, then
    /// `place = root;`, where `old` is the variable standing for the value `place` held.
    /// The old value is read first (see [`Lowerer::read_each`]) if code still to come
    /// needs it and has not read it yet; a value equal to its old one stores nothing.
    /// Storing each value once computed keeps it live for a moment, where one store of
    /// every value at the end keeps them all live (a covariance of 300 entries, spilled).
    pub fn segment_in_place(&mut self, writes: &[(NodeId, NodeId, TokenStream)]) {
        let roots: Vec<NodeId> = writes
            .iter()
            .filter(|(root, old, _)| root != old)
            .map(|&(root, _, _)| root)
            .collect();
        let (order, ends) = self.schedule(&roots);
        self.count_traffic(&order, &roots);
        // Where in `order` each value is last an operand.
        let mut last_operand = FastMap::default();
        for (position, &id) in order.iter().enumerate() {
            for operand in self.operands(id) {
                last_operand.insert(operand, position);
            }
        }
        let mut next = 0;
        let changed = writes.iter().filter(|(root, old, _)| root != old);
        for ((root, old, place), end) in changed.zip(ends) {
            for &id in &order[next..end] {
                self.emit_node(id);
            }
            next = end;
            // Still to come: a value of this run after `end`, or code after the run (a
            // use the run's traffic did not consume).
            let needed = last_operand.get(old).is_some_and(|&last| last >= end)
                || self.consumed[old.index()] < self.uses[old.index()];
            if needed {
                self.read_pending(&[*old]);
            }
            let value = self.render(*root).0;
            self.statements.push(quote! { #place = #value; });
        }
    }

    /// Reads now each of `vars` that code still to come uses and that was not read yet:
    /// before the place it is read from is overwritten.
    pub fn read_pending(&mut self, vars: &[NodeId]) {
        for &var in vars {
            if self.uses[var.index()] > 0 && !self.emitted[var.index()] {
                self.emit_node(var);
            }
        }
    }

    /// The order `roots` are computed in (depth-first from each in turn, skipping what
    /// was emitted before), and where in it each root's own computation ends.
    fn schedule(&self, roots: &[NodeId]) -> (Vec<NodeId>, Vec<usize>) {
        let mut order = Vec::new();
        let mut ends = Vec::with_capacity(roots.len());
        let mut visited = vec![false; self.graph.len()];
        for &root in roots {
            let mut stack = vec![(root, false)];
            while let Some((id, children_done)) = stack.pop() {
                if children_done {
                    order.push(id);
                    continue;
                }
                if self.emitted[id.index()] || std::mem::replace(&mut visited[id.index()], true) {
                    continue;
                }
                stack.push((id, true));
                let children = self.operands(id);
                for &child in children.iter().rev() {
                    if !self.emitted[child.index()] && !visited[child.index()] {
                        stack.push((child, false));
                    }
                }
            }
            ends.push(order.len());
        }
        (order, ends)
    }

    /// Emits one scheduled node: its read, definition or `let`, as its uses ask.
    fn emit_node(&mut self, id: NodeId) {
        if self.emitted[id.index()] {
            // The cosine of a sine (or the reverse) computed with it.
            return;
        }
        self.emitted[id.index()] = true;
        let node = self.graph.node(id);
        self.count(node);
        if self.sin_cos(id, node) {
            return;
        }
        if let Some(&value) = self.definitions.get(&id) {
            let value = self.render(value).0;
            // A value that has a name of its own already (the model computes it too) is
            // read under that name: `let a22 = c1_plus_ts_x4;` would only copy it.
            if let Ok(name) = syn::parse2::<syn::Ident>(value.clone()) {
                self.namer.alias(id, &name.to_string());
            } else {
                let name = self.render(id).0;
                self.statements.push(quote! { let #name = #value; });
            }
        } else if let Node::Var(v) = node {
            self.used_vars.insert(v);
            let read = self.read_of.get(&id).and_then(|&i| self.reads[i].take());
            self.statements.extend(read);
        }
        let shared = self.uses[id.index()] > 1 || self.graph.name_hint(id).is_some();
        let depth = self.inline_depth_of(node);
        let needs_let = !self.graph.is_leaf(id)
            && (shared || matches!(node, Node::Select { .. }) || depth > MAX_INLINE_DEPTH);
        self.inline_depth[id.index()] = if needs_let { 0 } else { depth };
        if needs_let {
            let (value, _) = self.render_node(node);
            let name = self.namer.assign(self.graph, id);
            self.statements.push(quote! { let #name = #value; });
        }
    }

    /// Declares that `vars` are values in registers, not read from memory: a loop's
    /// carried values at the start of its body, or values the caller's own statements
    /// compute (a guarded reciprocal). Where they do not all fit, the rest are loaded.
    pub fn hold_in_registers(&mut self, vars: &[NodeId]) {
        self.held.extend(vars.iter().copied());
        self.registers.hold(vars);
    }

    /// Leaves `n` registers to values the caller's own code keeps live across this code
    /// (a window being shifted): they are not the estimate's to use.
    pub fn reserve_registers(&mut self, n: usize) {
        self.registers.reserve(n);
    }

    /// Loads, before a loop, the variables and literals its body (computing `roots`)
    /// reads and does not change, into the registers left free: a compiler hoists them
    /// out of the loop when they fit. Those that do not fit are loaded where used.
    pub fn hoist_leaves(&mut self, roots: &[NodeId]) {
        let mut stack: Vec<NodeId> = roots.to_vec();
        let mut seen = FastSet::default();
        let mut leaves = Vec::new();
        while let Some(id) = stack.pop() {
            if !seen.insert(id) || self.held.contains(&id) {
                continue;
            }
            if self.graph.is_leaf(id) && !self.definitions.contains_key(&id) {
                leaves.push(id);
            } else if !self.emitted[id.index()] {
                stack.extend(self.operands(id));
            }
        }
        leaves.sort();
        let room = self.registers.room();
        for &leaf in leaves.iter().take(room) {
            match self.graph.node(leaf) {
                Node::Num(_) | Node::Named(_) => self.ops.literal += 1,
                _ => self.ops.load += 1,
            }
        }
        self.hold_in_registers(&leaves[..room.min(leaves.len())]);
    }

    /// Counts the loads, literals and stores of computing `order` and then `roots`
    /// ([`RegisterFile`]).
    fn count_traffic(&mut self, order: &[NodeId], roots: &[NodeId]) {
        let steps: Vec<Step> = order
            .iter()
            .map(|&value| Step {
                value,
                operands: if self.graph.is_leaf(value) && !self.definitions.contains_key(&value) {
                    Vec::new()
                } else {
                    self.operands(value)
                },
            })
            .collect();
        for operand in steps.iter().flat_map(|s| &s.operands).chain(roots) {
            self.consumed[operand.index()] = self.consumed[operand.index()].saturating_add(1);
        }
        let (consumed, uses) = (&self.consumed, &self.uses);
        // A set: a Jacobian's segment has thousands of roots, asked about at every step.
        let root_set: FastSet<NodeId> = roots.iter().copied().collect();
        let live_after = |v: NodeId| consumed[v.index()] < uses[v.index()] || root_set.contains(&v);
        let (definitions, held) = (&self.definitions, &self.held);
        let graph = self.graph;
        let in_memory =
            |v: NodeId| graph.is_leaf(v) && !definitions.contains_key(&v) && !held.contains(&v);
        let traffic = self.registers.run(graph, &steps, &live_after, &in_memory);
        self.ops.load += traffic.load;
        self.ops.literal += traffic.literal;
        self.ops.store += traffic.store;
    }

    /// Computes a sine and the cosine of the same argument, both used by this function,
    /// with one call, `let (sin_x, cos_x) = stateforge_math::f32::sin_cos(x);` (one range
    /// reduction): true if `node` (`id`) was so emitted with its partner.
    fn sin_cos(&mut self, id: NodeId, node: Node) -> bool {
        let (partner, x) = match node {
            Node::Call(Func::Sin, x) => (Node::Call(Func::Cos, x), x),
            Node::Call(Func::Cos, x) => (Node::Call(Func::Sin, x), x),
            _ => return false,
        };
        let Some(partner) = self.graph.find(partner) else {
            return false;
        };
        if self.uses[partner.index()] == 0 || self.emitted[partner.index()] {
            return false;
        }
        self.emitted[partner.index()] = true;
        if let Node::Call(f, _) = node {
            self.ops.calls[Callee::of(f).0] -= 1;
        }
        self.ops.calls[Callee::SIN_COS.0] += 1;
        let (sin, cos) = match node {
            Node::Call(Func::Sin, _) => (id, partner),
            _ => (partner, id),
        };
        let (x, _) = self.render(x);
        let function = super::names::math_fn(self.scalar, "sin_cos");
        let sin = self.namer.assign(self.graph, sin);
        let cos = self.namer.assign(self.graph, cos);
        self.statements
            .push(quote! { let (#sin, #cos) = #function(#x); });
        true
    }

    /// How deeply `node` would nest if written inline: one more than its deepest operand
    /// that is written inline too (leaves and named values count nothing).
    fn inline_depth_of(&self, node: Node) -> u32 {
        let children = node.children();
        let deepest = children.iter().map(|c| self.inline_depth[c.index()]).max();
        deepest.map_or(0, |d| d + 1)
    }

    /// Makes `root` available under a name (a `let` named `name` unless it already has
    /// one, or is a leaf) and returns that name as an expression.
    pub fn bind(&mut self, root: NodeId, name: &str) -> TokenStream {
        self.prefer_name(root, name);
        self.force_let(root)
    }

    /// Makes `root` available under a name of the usual rules (a `let` unless it is a
    /// leaf) and returns that name as an expression.
    pub fn force_let(&mut self, root: NodeId) -> TokenStream {
        if self.namer.get(root).is_none() && !self.emitted[root.index()] {
            // Counting the root once more makes `segment` bind it to a `let`.
            self.uses[root.index()] += 1;
        }
        self.segment(&[root]).remove(0)
    }

    /// A name for a value the emitter binds itself, shadowing nothing.
    pub fn fresh_name(&mut self, base: &str) -> proc_macro2::Ident {
        self.namer.fresh(base)
    }

    /// What the code emitted so far computes.
    pub fn ops(&self) -> OpCount {
        self.ops
    }

    /// Hands over the statements emitted so far, to place them (before a loop, say).
    pub fn take_statements(&mut self) -> Vec<TokenStream> {
        std::mem::take(&mut self.statements)
    }

    /// Asks for `name` when `node` is bound to a `let` (it is, if it is used twice).
    pub fn prefer_name(&mut self, node: NodeId, name: &str) {
        if !self.emitted[node.index()] && !self.graph.is_leaf(node) {
            self.namer.prefer(node, name);
        }
    }

    /// The graph being lowered.
    pub fn graph(&self) -> &'g Graph {
        self.graph
    }

    /// The scalar type the code is lowered in.
    pub fn scalar(&self) -> Scalar {
        self.scalar
    }

    /// Appends a statement of the caller's (a guard, a reciprocal); returns its index
    /// among the statements [`Lowerer::finish`] hands over.
    pub fn statement(&mut self, tokens: TokenStream) -> usize {
        self.statements.push(tokens);
        self.statements.len() - 1
    }

    /// Whether the code emitted so far computes `node` (for a variable: reads it).
    pub fn is_emitted(&self, node: NodeId) -> bool {
        self.emitted[node.index()]
    }

    /// Reads each of `vars` again where code still to come first uses it, with the
    /// statement `read(name)`: the value read before is not used past this point.
    pub fn reread(&mut self, vars: &[NodeId], read: impl Fn(&proc_macro2::Ident) -> TokenStream) {
        for &var in vars {
            self.emitted[var.index()] = false;
        }
        self.read_each(vars, read);
    }

    /// Counts operations the caller's own statements perform.
    pub fn count_extra(&mut self, ops: OpCount) {
        self.ops = self.ops.plus(ops);
    }

    /// The statements emitted so far, the variables they read, and what they compute.
    pub fn finish(self) -> Lowered {
        Lowered {
            statements: self.statements,
            used_vars: self.used_vars,
            ops: self.ops,
        }
    }
}

/// A lowered function body.
pub struct Lowered {
    /// Statements in order.
    pub statements: Vec<TokenStream>,
    /// Free variables the code reads.
    pub used_vars: BTreeSet<VarId>,
    /// What the code computes.
    pub ops: OpCount,
}

impl Lowerer<'_> {
    fn count(&mut self, node: Node) {
        let ops = &mut self.ops;
        match node {
            Node::Num(_) | Node::Named(_) | Node::Var(_) => {}
            Node::Neg(_) | Node::Add(..) | Node::Sub(..) => ops.add += 1,
            Node::Mul(..) => ops.mul += 1,
            Node::Div(..) => ops.div += 1,
            Node::Call(f, _) => {
                ops.call += 1;
                ops.calls[Callee::of(f).0] += 1;
            }
            Node::Atan2(..) => {
                ops.call += 1;
                ops.calls[Callee::ATAN2.0] += 1;
            }
            Node::Select { .. } => ops.compare += 1,
        }
    }

    /// A node as an expression: its temporary's name if it has one, else inline.
    fn render(&self, id: NodeId) -> (TokenStream, Prec) {
        if let Some(name) = self.namer.get(id) {
            let name = super::names::ident(name);
            return (quote! { #name }, Prec::Atom);
        }
        self.render_node(self.graph.node(id))
    }

    fn render_node(&self, node: Node) -> (TokenStream, Prec) {
        // Operands rendered with at least `min` binding strength, else parenthesised.
        let operand = |id, min: Prec| {
            let (tokens, prec) = self.render(id);
            if prec < min {
                TokenStream::from(TokenTree::Group(Group::new(Delimiter::Parenthesis, tokens)))
            } else {
                tokens
            }
        };
        match node {
            Node::Num(bits) => self.literal(f64::from_bits(bits)),
            Node::Named(c) => {
                let name = super::names::ident(&self.graph.const_info(c).name);
                (quote! { #name }, Prec::Atom)
            }
            Node::Var(v) => {
                let name = super::names::ident(&self.graph.var_info(v).name);
                (quote! { #name }, Prec::Atom)
            }
            Node::Neg(a) => {
                let a = operand(a, Prec::Prefix);
                (infix(TokenStream::new(), '-', a), Prec::Prefix)
            }
            // Right operands bind tighter than the operator: floating-point `a + (b + c)`
            // is not `a + b + c`, so the parentheses keep the computed value exact.
            Node::Add(a, b) => {
                let (a, b) = (operand(a, Prec::Sum), operand(b, Prec::Product));
                (infix(a, '+', b), Prec::Sum)
            }
            Node::Sub(a, b) => {
                let (a, b) = (operand(a, Prec::Sum), operand(b, Prec::Product));
                (infix(a, '-', b), Prec::Sum)
            }
            Node::Mul(a, b) => {
                let (a, b) = (operand(a, Prec::Product), operand(b, Prec::Prefix));
                (infix(a, '*', b), Prec::Product)
            }
            Node::Div(a, b) => {
                let (a, b) = (operand(a, Prec::Product), operand(b, Prec::Prefix));
                (infix(a, '/', b), Prec::Product)
            }
            Node::Call(f, a) => {
                let a = operand(a, Prec::Sum);
                let function = super::names::math_fn(self.scalar, f.name());
                (quote! { #function(#a) }, Prec::Atom)
            }
            Node::Atan2(y, x) => {
                let (y, x) = (operand(y, Prec::Sum), operand(x, Prec::Sum));
                let function = super::names::math_fn(self.scalar, Func::ATAN2.name);
                (quote! { #function(#y, #x) }, Prec::Atom)
            }
            Node::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                let (lhs, rhs) = (operand(lhs, Prec::Sum), operand(rhs, Prec::Sum));
                let (then, otherwise) = (operand(then, Prec::Sum), operand(otherwise, Prec::Sum));
                let cmp = TokenStream::from_str(cmp.symbol()).unwrap_or_default();
                (
                    quote! { if #lhs #cmp #rhs { #then } else { #otherwise } },
                    Prec::Atom,
                )
            }
        }
    }

    fn literal(&self, v: f64) -> (TokenStream, Prec) {
        let tokens = literal(v, self.scalar);
        let prec = if v < 0.0 || !v.is_finite() {
            Prec::Prefix
        } else {
            Prec::Atom
        };
        (tokens, prec)
    }
}

/// `a op b` (`op b` when `a` is empty): `b`'s tokens moved after `a`'s, in place, where
/// `quote!` would copy both, at every level of an operand nested inline.
fn infix(mut a: TokenStream, op: char, b: TokenStream) -> TokenStream {
    a.extend([TokenTree::Punct(Punct::new(op, Spacing::Alone))]);
    a.extend(b);
    a
}

/// A typed literal, `0.015_f32`; negative values as `-lit`.
pub fn literal(v: f64, scalar: Scalar) -> TokenStream {
    let ty = super::names::ident(scalar.type_name());
    if v.is_nan() {
        return quote! { #ty::NAN };
    }
    if v.is_infinite() {
        return if v > 0.0 {
            quote! { #ty::INFINITY }
        } else {
            quote! { #ty::NEG_INFINITY }
        };
    }
    let magnitude = v.abs();
    let mut text = match scalar {
        Scalar::F32 => format!("{:?}", magnitude as f32),
        Scalar::F64 => format!("{magnitude:?}"),
    };
    if !text.contains(['.', 'e']) {
        text.push_str(".0");
    }
    let lit = Literal::from_str(&format!("{text}_{}", scalar.type_name()))
        .unwrap_or_else(|_| Literal::f64_unsuffixed(magnitude));
    if v < 0.0 {
        quote! { -#lit }
    } else {
        quote! { #lit }
    }
}

/// A matrix known at generation time as a nested array literal, row by row:
/// `[[1.0_f32, 0.0_f32], [..]]`.
pub fn matrix_literal(mat: &crate::numerics::Mat, scalar: Scalar) -> TokenStream {
    let rows = mat.to_rows();
    let rows = rows.iter().map(|row| {
        let row = row.iter().map(|&v| literal(v, scalar));
        quote! { [#(#row),*] }
    });
    quote! { [#(#rows),*] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The statements and root expressions of `roots` lowered in `f32`, as one string.
    fn lowered(graph: &Graph, roots: &[NodeId]) -> (String, OpCount) {
        let mut lowerer = Lowerer::new(graph, Scalar::F32, TempNamer::new(["x"]), roots);
        let exprs = lowerer.segment(roots);
        let ops = lowerer.ops();
        let statements = lowerer.finish().statements;
        (quote! { #(#statements)* #(#exprs;)* }.to_string(), ops)
    }

    #[test]
    fn a_sine_and_cosine_of_one_argument_are_one_sin_cos_call() {
        let mut g = Graph::new();
        let x = g.var("x");
        let (sin, cos) = (g.call(Func::Sin, x), g.call(Func::Cos, x));
        let (code, ops) = lowered(&g, &[sin, cos]);
        assert_eq!(
            code.matches("stateforge_math :: f32 :: sin_cos (x)")
                .count(),
            1
        );
        assert!(
            !code.contains(":: sin (") && !code.contains(":: cos ("),
            "{code}"
        );
        assert_eq!(ops.call, 1);
        // Alone, a sine is a sine.
        let (code, ops) = lowered(&g, &[sin]);
        assert!(code.contains("stateforge_math :: f32 :: sin (x)"), "{code}");
        assert_eq!(ops.call, 1);
    }
}
