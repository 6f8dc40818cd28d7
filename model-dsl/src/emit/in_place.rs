//! The commit of a filter step's new estimate and covariance in place: the step computes
//! what its tests need (the new estimate, the new variances, the divergence probe), tests
//! them, and only then computes the covariance's other entries, storing each in its place
//! in `self.p` as soon as it is computed.
//!
//! A step that computed every entry before storing any would hold all of them at once: a
//! 24-state covariance has 300 entries, which the target's 32 floating-point registers
//! hold by spilling each to the stack and loading it back for the store. Stored as they
//! are computed, each is live for a moment. The step still leaves the filter unchanged
//! unless it returns `Status::Ok`: every test comes before the first store, and the tests
//! are the ones the step made before (the probe of the estimate and variances; the
//! off-diagonal entries are not tested, as they were not). An entry of the estimate or of
//! the covariance that the step leaves as it was (a parameter's estimate in a prediction)
//! is neither probed nor written: it was tested when it was written.
//!
//! The covariance is read through references to its entries: before the tests, through
//! `let [p11_in, p12_in, ..] = stateforge_math::opaque(&self.p);`, an entry read where it is
//! first used, `let p12 = *p12_in;`; after them, through
//! `let [p11_slot, p12_slot, ..] = &mut self.p;`, read again where the stores need it,
//! `let p12 = *p12_slot;`, and written in place, `*p12_slot = p12_new;`, after its old
//! value was read if code still to come needs it. An entry whose new value is its old one
//! (a parameter's covariance in a prediction) is not written at all.
//!
//! The tests' reference is opaque to the compiler (`stateforge_math::opaque`, a barrier that
//! costs nothing at the start of the method): it cannot tell that the entries the tests
//! read are those the stores read, and loads them again where the stores need them. Told,
//! it keeps every entry the tests read until its store, spilled to the stack: a 24-state
//! magnetometer update read 195 entries to make its gain, and kept them, which cost it
//! 460 instructions of 4510 (stores to and loads from a stack frame past the 1 KB a load
//! instruction reaches, each with an address computed for it).

use super::code::{divergence_test_ops, divergence_tests};
use super::filter::unclaimed_name;
use super::lower::{Lowered, Lowerer, OpCount};
use super::names::ident;
use crate::model::Scalar;
use crate::symbolic::linalg::{packed_index, packed_len};
use crate::symbolic::NodeId;
use proc_macro2::{Ident, TokenStream};
use quote::{quote, ToTokens};
use std::collections::BTreeSet;

/// The references a method reads and writes the packed covariance through: the tests'
/// (`p12_in`) and the stores' (`p12_slot`).
pub struct CovarianceSlots {
    /// The variables standing for the entries' values when the method starts.
    vars: Vec<NodeId>,
    /// The tests' reference to each entry, `p12_in`.
    inputs: Vec<Ident>,
    /// The stores' reference to each entry, `p12_slot`.
    names: Vec<Ident>,
}

impl CovarianceSlots {
    /// Has `lowerer` read each of the covariance's variables `vars` (packed, in the
    /// order of `self.p`) where it is first used: through the tests' reference if the
    /// stores read the covariance again (`reread`, see [`Commit::reread`]), else through
    /// the stores'. The references' names avoid `avoid`.
    pub fn read(
        lowerer: &mut Lowerer,
        vars: &[NodeId],
        avoid: &[String],
        reread: bool,
    ) -> CovarianceSlots {
        let graph = lowerer.graph();
        let named = |suffix: &str| -> Vec<Ident> {
            vars.iter()
                .map(|&var| reference_name(graph, var, "p", suffix, avoid))
                .collect()
        };
        let slots = CovarianceSlots {
            vars: vars.to_vec(),
            inputs: named("in"),
            names: named("slot"),
        };
        let first = if reread { &slots.inputs } else { &slots.names };
        slots.read_through(lowerer, first, false);
        slots
    }

    /// Registers with `lowerer` the reads of the entries through `references`, each where
    /// code to come first uses it: again (`again`, the stores' reads after the tests), or
    /// for the first time.
    fn read_through(&self, lowerer: &mut Lowerer, references: &[Ident], again: bool) {
        let graph = lowerer.graph();
        let reference_of: std::collections::HashMap<String, Ident> = self
            .vars
            .iter()
            .zip(references)
            .filter_map(|(&var, reference)| match graph.node(var) {
                crate::symbolic::Node::Var(v) => {
                    Some((graph.var_info(v).name.clone(), reference.clone()))
                }
                _ => None,
            })
            .collect();
        let read = |name: &Ident| {
            let reference = &reference_of[&name.to_string()];
            quote! { let #name = *#reference; }
        };
        if again {
            lowerer.reread(&self.vars, read);
        } else {
            lowerer.read_each(&self.vars, read);
        }
    }

    /// `let [p11_in, ..] = stateforge_math::opaque(&self.p);`, naming `_` the entries the
    /// tests do not read (`read[k]` false).
    pub fn inputs_binding(&self, read: &[bool]) -> TokenStream {
        let names = self.inputs.iter().zip(read).map(|(name, &read)| {
            if read {
                quote! { #name }
            } else {
                quote! { _ }
            }
        });
        quote! { let [#(#names),*] = stateforge_math::opaque(&self.p); }
    }

    /// `let [p11_slot, ..] = &mut self.p;`, naming `_` the entries the stores neither read
    /// (`read[k]` false) nor write (`written`, positions in `self.p`).
    pub fn binding(&self, read: &[bool], written: &BTreeSet<usize>) -> TokenStream {
        let names = self.names.iter().enumerate().map(|(k, name)| {
            if read[k] || written.contains(&k) {
                quote! { #name }
            } else {
                quote! { _ }
            }
        });
        quote! { let [#(#names),*] = &mut self.p; }
    }

    /// Which of the entries `lowerer` has read so far.
    pub fn read_so_far(&self, lowerer: &Lowerer) -> Vec<bool> {
        self.vars
            .iter()
            .map(|&var| lowerer.is_emitted(var))
            .collect()
    }
}

/// The name of a reference to the value `var` stands for, `<var>_<suffix>` (`p12_slot`),
/// `<fallback>_<suffix>` if `var` is not a variable, avoiding `avoid`.
fn reference_name(
    graph: &crate::symbolic::Graph,
    var: NodeId,
    fallback: &str,
    suffix: &str,
    avoid: &[String],
) -> Ident {
    let name = match graph.node(var) {
        crate::symbolic::Node::Var(v) => graph.var_info(v).name.as_str(),
        _ => fallback,
    };
    ident(&unclaimed_name(format!("{name}_{suffix}"), avoid))
}

/// What a step commits in place: its new estimate and covariance, and what it tests first.
pub struct Commit<'a> {
    /// The divergence probe of the new estimate and variances, bound to a name.
    pub probe: &'a TokenStream,
    /// The new estimate.
    pub x: &'a [NodeId],
    /// The estimate's variables, read from `self.x`.
    pub x_vars: &'a [NodeId],
    /// The new covariance, packed.
    pub p: &'a [NodeId],
    /// The references the covariance is read and written through.
    pub slots: &'a CovarianceSlots,
    /// The order its entries are computed and stored in (positions in `self.p`; see
    /// [`prediction_order`] and [`update_order`]).
    pub order: &'a [usize],
    /// Names the code's own variables must not take (the model's).
    pub avoid: &'a [String],
    /// The variables that hold variances (the old covariance's, the process noise's).
    pub known_variances: &'a [NodeId],
    /// Whether the stores read again the entries the tests read, through the stores' own
    /// references (see the module's documentation), rather than keep them: a measurement
    /// update's tests read the covariance's rows that make its gain, and its stores need
    /// each of them once more; a prediction's tests read the entries its new variances
    /// need, and its stores most of them again (the navigation model's `predict`: 3347
    /// instructions keeping them, 3321 reading them again).
    pub reread: bool,
}

/// What [`commit`] leaves to bind once the method is lowered: which entries the tests read,
/// where the stores' references are bound (a statement of the lowerer's, to replace), and
/// which entries are written.
pub struct Committed {
    /// For each entry, whether the tests read it.
    pub read_by_tests: Vec<bool>,
    /// The index of the statement that binds the stores' references, where the stores read
    /// the covariance again (else they are bound first, before the tests' reads).
    pub binding_statement: Option<usize>,
    /// The positions of `self.p` written.
    pub written: BTreeSet<usize>,
}

/// Tests the probe and the new variances, then stores the estimate, the variances and the
/// covariance's other entries in place, in their order.
/// A new variance that is a sum of known variances (never negative) is not tested: a sum
/// of non-negative numbers is not negative.
pub fn commit(lowerer: &mut Lowerer, commit: &Commit<'_>, scalar: Scalar) -> Committed {
    let (p, slots) = (commit.p, commit.slots);
    // The covariance's dimension, from its packed length `n (n + 1) / 2`: a state with a
    // rotation has more entries than that.
    let n = (0..=p.len())
        .find(|&n| n * (n + 1) / 2 >= p.len())
        .unwrap_or(0);
    let diagonal: Vec<usize> = (0..n).map(|i| packed_index(n, i, i)).collect();
    let variances: Vec<NodeId> = diagonal.iter().map(|&k| p[k]).collect();
    test_divergence(
        lowerer,
        commit.probe,
        (&variances, commit.known_variances),
        scalar,
    );
    let read_by_tests = slots.read_so_far(lowerer);
    let binding_statement = commit.reread.then(|| {
        slots.read_through(lowerer, &slots.names, true);
        lowerer.statement(TokenStream::new())
    });
    let x_written = commit_estimate(lowerer, commit);
    let off_diagonal = commit
        .order
        .iter()
        .copied()
        .filter(|k| !diagonal.contains(k));
    let order: Vec<usize> = diagonal.iter().copied().chain(off_diagonal).collect();
    let writes: Vec<(NodeId, NodeId, TokenStream)> = order
        .iter()
        .map(|&k| {
            let slot = &slots.names[k];
            (p[k], slots.vars[k], quote! { *#slot })
        })
        .collect();
    lowerer.segment_in_place(&writes);
    let written: BTreeSet<usize> = order
        .into_iter()
        .filter(|&k| p[k] != slots.vars[k])
        .collect();
    lowerer.count_extra(OpCount::stores(x_written + written.len()));
    lowerer.count_extra(divergence_test_ops(n));
    Committed {
        read_by_tests,
        binding_statement,
        written,
    }
}

/// A step's test of its prediction, before its correction: the tests `predict` makes
/// before it stores (the divergence probe of the prediction, `probe`, and each predicted
/// variance in `variances` that is not a sum of `known_variances`), so that a step returns
/// what `predict` then `update` would: a prediction beyond the divergence bound is
/// `Diverged` (or `NonFinite`) in both, whatever the correction would have made of it.
pub fn test_prediction(
    lowerer: &mut Lowerer,
    probe: NodeId,
    variances: &[NodeId],
    known_variances: &[NodeId],
    scalar: Scalar,
) {
    let probe = lowerer.bind(probe, "prediction_probe");
    test_divergence(lowerer, &probe, (variances, known_variances), scalar);
    lowerer.count_extra(divergence_test_ops(variances.len()));
}

/// The divergence tests of a step's result: the `probe` against the bound, and each of
/// `variances` not negative, but for a sum of `known` variances (a sum of non-negative
/// numbers is not negative).
fn test_divergence(
    lowerer: &mut Lowerer,
    probe: &TokenStream,
    (variances, known): (&[NodeId], &[NodeId]),
    scalar: Scalar,
) {
    let rendered = lowerer.segment(variances);
    let graph = lowerer.graph();
    let tested: Vec<TokenStream> = variances
        .iter()
        .zip(rendered)
        .filter(|&(&v, _)| !sum_of(graph, v, known))
        .map(|(_, tokens)| tokens)
        .collect();
    for test in divergence_tests(probe, &tested, scalar) {
        lowerer.statement(test);
    }
}

/// Stores the new estimate, `self.x = [..];`, or, where the step leaves entries as they
/// were (a parameter's estimate in a prediction), each changed entry through a reference,
/// as the covariance's unchanged entries are not written either. Returns how many entries
/// it stores.
fn commit_estimate(lowerer: &mut Lowerer, commit: &Commit<'_>) -> usize {
    let (x, n) = (commit.x, commit.x.len());
    let x_changed: Vec<usize> = (0..n).filter(|&i| x[i] != commit.x_vars[i]).collect();
    let changed_values: Vec<NodeId> = x_changed.iter().map(|&i| x[i]).collect();
    let x_values = lowerer.segment(&changed_values);
    let overwritten: Vec<NodeId> = x_changed.iter().map(|&i| commit.x_vars[i]).collect();
    lowerer.read_pending(&overwritten);
    if x_changed.len() == n {
        lowerer.statement(quote! { self.x = [#(#x_values),*]; });
    } else if let Some(&last) = x_changed.last() {
        let graph = lowerer.graph();
        let references: Vec<Ident> = x_changed
            .iter()
            .map(|&i| reference_name(graph, commit.x_vars[i], "x", "slot", commit.avoid))
            .collect();
        let pattern = (0..=last).map(|i| match x_changed.binary_search(&i) {
            Ok(k) => references[k].to_token_stream(),
            Err(_) => quote! { _ },
        });
        let rest = (last + 1 < n).then(|| quote! { , .. });
        lowerer.statement(quote! {
            let [#(#pattern),* #rest] = &mut self.x;
            #(*#references = #x_values;)*
        });
    }
    x_changed.len()
}

/// `lowerer`'s statements, with the references to the covariance bound where [`commit`]
/// left them to bind: the entries neither read nor written through a reference named `_`.
pub fn finish(lowerer: Lowerer, slots: &CovarianceSlots, committed: &Committed) -> Lowered {
    let read_by_stores = slots.read_so_far(&lowerer);
    let mut lowered = lowerer.finish();
    let stores_binding = slots.binding(&read_by_stores, &committed.written);
    match committed.binding_statement {
        Some(at) => {
            lowered.statements[at] = stores_binding;
            let inputs = slots.inputs_binding(&committed.read_by_tests);
            lowered.statements.insert(0, inputs);
        }
        None => lowered.statements.insert(0, stores_binding),
    }
    lowered
}

/// Whether `value` is one of `terms` or a sum of them: a sum of non-negative numbers, which
/// floating-point addition keeps non-negative.
fn sum_of(graph: &crate::symbolic::Graph, value: NodeId, terms: &[NodeId]) -> bool {
    match graph.node(value) {
        crate::symbolic::Node::Add(a, b) => sum_of(graph, a, terms) && sum_of(graph, b, terms),
        _ => terms.contains(&value),
    }
}

/// The order a measurement update with `m` measurements computes the packed upper
/// triangle of an `n x n` covariance in: a few rows at a time, each of their columns in
/// turn, so that the rows' operands (`Y_i` of `P - Y Y'`, `m` values per row) stay in
/// registers while each column's (`Y_j`) is loaded once for all of them. Tiles of 4 rows
/// for up to 3 measurements, of 3 from 4 (`3 m` values and a column's `m` fill most of the
/// FPU's 32 registers); the tiles first first, the columns last first. The coordinates of
/// each range of `whole` (a rotation's three in an error-state filter, which the reset
/// `G P G'` mixes) form one tile of their own. Measured on the navigation model's updates,
/// its magnetometer's 3 and its GNSS receiver's 6: 4259 and 5840 instructions so; 4446
/// and 6164 in square blocks of 4 and of 2 with the rotation's coordinates split among
/// them, 4427 and 5880 in square blocks with them whole.
pub fn update_order(n: usize, m: usize, whole: &[std::ops::Range<usize>]) -> Vec<usize> {
    let tile = if m <= 3 { 4 } else { 3 };
    let mut order = Vec::with_capacity(packed_len(n));
    for rows in tiles(n, tile, whole) {
        for j in (rows.start..n).rev() {
            for i in rows.clone().filter(|&i| i <= j) {
                order.push(packed_index(n, i, j));
            }
        }
    }
    order
}

/// `0..n` cut into ranges of `tile`, but for the ranges `whole`, each kept as one.
fn tiles(n: usize, tile: usize, whole: &[std::ops::Range<usize>]) -> Vec<std::ops::Range<usize>> {
    let mut tiles = Vec::new();
    let mut start = 0;
    while start < n {
        let end = match whole.iter().find(|range| range.start == start) {
            Some(range) => range.end.min(n),
            None => {
                let next_whole = whole
                    .iter()
                    .map(|range| range.start)
                    .filter(|&s| s > start)
                    .min()
                    .unwrap_or(n);
                (start + tile).min(next_whole).min(n)
            }
        };
        tiles.push(start..end.max(start + 1));
        start = end.max(start + 1);
    }
    tiles
}

/// The order a prediction `A P A' + Q` computes the packed upper triangle of its
/// covariance in: the rows of `A` that mix several states (the others are a state's own,
/// `x_i = x_i + ..`, and leave its covariance with the like as it was) in groups of
/// rows with mostly the same structural non-zeros (an attitude quaternion's four rows, a
/// velocity's three), each group column by column, so that the entries of a column share
/// the covariance entries they read and the group's coefficients stay in registers;
/// then the entries between two mixing rows, column after column, each column from its
/// diagonal up. Rows join a group when they share half their structural non-zeros or
/// have the same coefficients (a position's three rows, `p_i = p_i + T v_i`). The
/// groups go last first and each its columns last first. Orders chosen by measurement,
/// not derived: the navigation model's `predict` took 3219 instructions so (before its
/// unchanged entries were left unwritten and unprobed); 3243 with
/// the positions' rows apart, 3321 with the last entries in blocks of 2 x 2, 3397 with
/// the groups and columns first first as well.
pub fn prediction_order(
    graph: &crate::symbolic::Graph,
    a: &crate::symbolic::linalg::Matrix,
) -> Vec<usize> {
    let n = a.len();
    let support: Vec<BTreeSet<usize>> = a
        .iter()
        .map(|row| (0..n).filter(|&k| !graph.is_zero(row[k])).collect())
        .collect();
    let mixing: Vec<bool> = (0..n)
        .map(|i| support[i].iter().any(|&k| k != i) || !graph.is_one(a[i][i]))
        .collect();
    let coefficients =
        |i: usize| -> BTreeSet<NodeId> { support[i].iter().map(|&k| a[i][k]).collect() };
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in (0..n).filter(|&i| mixing[i]) {
        let joins = groups.last().is_some_and(|group| {
            let last = *group.last().unwrap_or(&i);
            let shared = support[i].intersection(&support[last]).count();
            let alike = 2 * shared >= support[i].len() || coefficients(i) == coefficients(last);
            group.len() < MAX_GROUP && alike
        });
        if joins {
            if let Some(group) = groups.last_mut() {
                group.push(i);
            }
        } else {
            groups.push(vec![i]);
        }
    }
    let mut order = Vec::new();
    let mut placed = vec![false; packed_len(n)];
    let mut place = |order: &mut Vec<usize>, i: usize, j: usize| {
        let k = packed_index(n, i, j);
        if !std::mem::replace(&mut placed[k], true) {
            order.push(k);
        }
    };
    for group in groups.iter().rev() {
        for j in (0..n).rev().filter(|&j| !mixing[j]) {
            for &i in group {
                place(&mut order, i, j);
            }
        }
    }
    for j in (0..n).filter(|&j| mixing[j]) {
        for i in (0..=j).rev().filter(|&i| mixing[i]) {
            place(&mut order, i, j);
        }
    }
    order
}

/// The most rows of `A` [`prediction_order`] groups: their coefficients and the entries
/// of a column they read share the registers.
const MAX_GROUP: usize = 4;
