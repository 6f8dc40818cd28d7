//! The filter layout every Kalman filter shares: the names generated variables avoid,
//! packed symmetric matrices and their variables, process noise arguments (full or
//! diagonal), the finiteness probe that guards a whole result, and time arguments; the
//! stored estimate, covariance and noise with their constructor, accessors and setters
//! ([`FilterLayout`]) and the variables a filter's method reads ([`FilterVars`]).

use crate::emit::arguments::{Arguments, REJECTS_NON_FINITE};
use crate::emit::code::{estimate_accessors, packed_names};
use crate::emit::known::KnownItems;
use crate::emit::lower::Lowerer;
use crate::emit::names::ident;
use crate::emit::noise_blocks::{block_fields, noise_blocks, noise_methods, stored_noise};
/// The process noise argument, shared by the constructors and the setters.
pub use crate::emit::tuning::noise_argument;
pub use crate::emit::tuning::ProcessNoise;
use crate::emit::tuning::{input_noise_doc, input_noise_setter, noise_setters, StoredNoise};
use crate::model::Model;
use crate::symbolic::linalg::{packed_len, Matrix};
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// What the EKF, the hybrid EKF and the continuous-time EKF store and assemble alike: the
/// estimate `x` (`n` entries), its covariance `p` (packed upper triangle), the process
/// noise `q` (packed, or its variances when diagonal) and the measurement noise `R`
/// (`m x m`: packed in `r`, or in a model with sensors each sensor's block apart, see
/// [`crate::emit::noise_blocks::NoiseBlock`]); their dimension literals, the constructor, the
/// estimate's accessors and the noise setters.
pub struct FilterLayout {
    /// The scalar type, `f32` or `f64`.
    pub ty: Ident,
    /// `n`, the state's length.
    n: usize,
    /// The covariance's dimension: `n`, less one per rotation (see
    /// [`Model::tangent_len`]).
    n_p: usize,
    /// The names of the state's rotations' first entries (`q_x`): `x0` must hold unit
    /// quaternions there.
    rotations: Vec<String>,
    /// `m`, the measurement's length.
    m: usize,
    /// The process noise's shape.
    noise: ProcessNoise,
    /// What the constructor's and setter's documentation say of the states it enters.
    noise_doc: String,
    /// The input entries whose noise enters the state through the input Jacobian (their
    /// names), empty for none; else the field `qu` holds their variances, which the
    /// constructor takes after `q` and `set_input_noise` replaces.
    input_noise: Vec<String>,
    /// What the constructor's documentation says of `qu` ([`input_noise_doc`]).
    input_noise_doc: String,
    /// Whether the covariance's coordinates fall into blocks that nothing couples (see
    /// [`crate::symbolic::covariance_blocks`]), numbered in the const
    /// `COVARIANCE_BLOCKS`: `p0` must be zero between two of them.
    blocks: bool,
    /// `n`, as a literal.
    pub n_len: Literal,
    /// `m`, as a literal.
    pub m_len: Literal,
    /// `n (n + 1) / 2`, the packed covariance's length.
    pub np: Literal,
    /// How the whole measurement noise argument `r` is stored: its fields and their test.
    stored_r: StoredNoise,
    /// The fields holding the measurement noise, each followed by a comma.
    r_fields: TokenStream,
    /// The type of the field `q`.
    pub q_field: TokenStream,
    /// `state()` and `covariance()`.
    pub accessors: TokenStream,
    /// `set_process_noise`, `set_measurement_noise` and each sensor's `<sensor>_noise` and
    /// `set_<sensor>_noise`.
    pub setters: TokenStream,
}

impl FilterLayout {
    /// The layout of a filter of `model` in the scalar type `ty`, its process noise
    /// shaped as `noise`.
    pub fn new(model: &Model, noise: &ProcessNoise, ty: &Ident) -> FilterLayout {
        let (n, n_p, m) = (model.state_len(), model.tangent_len(), model.outputs.len());
        let [n_len, m_len, np] = [n, m, packed_len(n_p)].map(Literal::usize_unsuffixed);
        let k = noise.len(n_p);
        let (_, q_field, _) = noise_argument("q", k, noise.diagonal, ty);
        let noise_doc = noise.states_doc(model);
        let stored_r = stored_noise(model, ty);
        let mut setters = noise_setters((k, &noise_doc), (m, &stored_r), noise.diagonal, ty);
        setters.extend(noise_methods(model, ty));
        FilterLayout {
            ty: ty.clone(),
            n,
            n_p,
            rotations: {
                let names: Vec<&str> = model.state_names().collect();
                let firsts = model
                    .rotations()
                    .into_iter()
                    .map(|r| names[r.storage].to_owned());
                firsts.collect()
            },
            m,
            noise: noise.clone(),
            noise_doc,
            input_noise: Vec::new(),
            input_noise_doc: String::new(),
            blocks: false,
            n_len,
            m_len,
            np,
            stored_r,
            r_fields: block_fields(model, ty),
            q_field,
            accessors: estimate_accessors((n, n_p), ty),
            setters,
        }
    }

    /// The same layout with noise on the input entries `inputs` (their names, kept in the
    /// layout's `input_noise`): the field `qu`, the constructor's argument and the setter
    /// `set_input_noise`; densities if the predictions take the sample interval `interval`.
    #[must_use]
    pub fn with_input_noise(mut self, inputs: &[&str], interval: Option<&str>) -> FilterLayout {
        if !inputs.is_empty() {
            let doc = input_noise_doc(inputs, interval);
            let setter = input_noise_setter(inputs.len(), &doc, &self.ty);
            self.setters.extend(setter);
            self.input_noise = inputs.iter().map(|&name| name.to_owned()).collect();
            self.input_noise_doc = doc;
        }
        self
    }

    /// The same layout with the covariance's coordinates in the blocks `blocks` (each
    /// coordinate's, `None` for one block): the associated const `COVARIANCE_BLOCKS`, and
    /// the test that an initial covariance is zero between two blocks.
    #[must_use]
    pub fn with_covariance_blocks(mut self, blocks: Option<&[usize]>) -> FilterLayout {
        if let Some(blocks) = blocks {
            let n_p = Literal::usize_unsuffixed(self.n_p);
            let ids = blocks.iter().map(|&b| Literal::usize_unsuffixed(b));
            self.accessors.extend(quote! {
                /// The block of the covariance each of its coordinates belongs to (in the
                /// order of `TANGENT_NAMES`, or of the state for a state without
                /// rotations): nothing in the model couples two blocks (neither the
                /// dynamics, nor the process noise, nor a measurement), so the covariance
                /// between them stays zero. The filter neither computes nor stores it, and
                /// its constructor and `reset` refuse an initial covariance that is not
                /// zero there ([`Status::InvalidCovariance`]).
                pub const COVARIANCE_BLOCKS: [usize; #n_p] = [#(#ids),*];
            });
            self.blocks = true;
        }
        self
    }

    /// The fields `x`, `p`, `q`, `qu` (with noise on inputs) and `r` (or each sensor's
    /// block of it) of the filter's struct, each followed by a comma.
    pub fn fields(&self) -> TokenStream {
        let FilterLayout {
            ty,
            n_len,
            np,
            q_field,
            r_fields,
            ..
        } = self;
        let qu = (!self.input_noise.is_empty()).then(|| {
            let ku = Literal::usize_unsuffixed(self.input_noise.len());
            quote! { qu: [#ty; #ku], }
        });
        quote! {
            x: [#ty; #n_len],
            p: [#ty; #np],
            q: #q_field,
            #qu
            #r_fields
        }
    }

    /// The arguments `x0: &[S; n]` and `p0: &[[S; n_p]; n_p]` of an initial estimate (the
    /// constructor's, `reset`'s), both checked (`p0` also a covariance); returns the packed
    /// upper triangle of `p0`, as an expression, and `x0` as it is stored: as given, or
    /// with its rotations normalised (see [`FilterLayout::unit_rotations`]).
    pub fn initial_estimate(&self, arguments: &mut Arguments) -> (TokenStream, TokenStream) {
        arguments.vector("x0", self.n, &self.ty);
        let p0 = arguments.covariance("p0", self.n_p, &self.ty);
        if self.blocks {
            let ty = &self.ty;
            arguments.covariance_structure(quote! {
                stateforge_math::#ty::zero_between_blocks(p0, &Self::COVARIANCE_BLOCKS)
            });
        }
        let x0 = if self.rotations.is_empty() {
            quote! { *x0 }
        } else {
            quote! { x0_unit }
        };
        (x0, p0)
    }

    /// For a state with rotations, the statement that gives `x0_unit`, `x0` with each
    /// rotation's quaternion normalised, or leaves with `failed` (an expression of the
    /// method's return type) when one is not within 1 % of a unit norm (a rotation given
    /// as a quaternion not yet normalised, or rounded, is accepted; anything else is not a
    /// rotation). Nothing for a state without one.
    pub fn unit_rotations(&self, failed: &TokenStream) -> TokenStream {
        if self.rotations.is_empty() {
            return TokenStream::new();
        }
        let ty = &self.ty;
        let firsts = self
            .rotations
            .iter()
            .map(|name| crate::emit::names::index_const(name));
        quote! {
            let Some(x0_unit) = stateforge_math::#ty::with_unit_rotations(x0, &[#(index::#firsts),*]) else {
                return #failed;
            };
        }
    }

    /// `fn new(x0, p0, q, qu?, r, known?) -> Result<Self, Status>`: the constructor,
    /// documented by the attributes `doc`, rejecting a non-finite entry of what it reads and storing
    /// `x0` and the packed upper triangles of `p0`, `q` and `r`, the input noise `qu`
    /// (variances per sample, or densities with a sample interval) if the filter has them, and the `known` constants if the filter holds them. `extra_init` continues the struct literal
    /// (each field followed by a comma) with the fields a filter adds.
    pub fn constructor(
        &self,
        type_name: &Ident,
        doc: &TokenStream,
        known: &KnownItems,
        extra_init: &TokenStream,
    ) -> TokenStream {
        let mut arguments = Arguments::default();
        let noise_doc = (!self.noise_doc.is_empty()).then(|| {
            let text = &self.noise_doc;
            quote! { #[doc = #text] }
        });
        let input_noise_doc = (!self.input_noise.is_empty()).then(|| {
            let text = &self.input_noise_doc;
            quote! { #[doc = #text] }
        });
        let sensors_doc = self.stored_r.condition.as_ref().map(|_| {
            quote! {
                ///
                /// The noise of two sensors is independent: `r`'s entries between two sensors
                /// must be zero, and each sensor keeps its own block (`set_<sensor>_noise`).
            }
        });
        let doc = quote! { #doc #noise_doc #input_noise_doc #sensors_doc };
        let (x0, p0) = self.initial_estimate(&mut arguments);
        let unit = self.unit_rotations(&quote! { Err(Status::RejectedInput) });
        let k = self.noise.len(self.n_p);
        let q = arguments.process_noise("q", k, self.noise.diagonal, &self.ty);
        let qu = (!self.input_noise.is_empty()).then(|| {
            let qu = arguments.process_noise("qu", self.input_noise.len(), true, &self.ty);
            quote! { qu: #qu, }
        });
        // Stored whole, or each sensor's block (zero between them, tested with `r`).
        let _ = arguments.covariance("r", self.m, &self.ty);
        if let Some(condition) = &self.stored_r.condition {
            arguments.covariance_structure(condition.clone());
        }
        let r = self
            .stored_r
            .fields
            .iter()
            .map(|(field, value)| quote! { #field: #value, });
        let known_init = known.argument(&mut arguments);
        arguments.constructor(
            &doc,
            REJECTS_NON_FINITE,
            quote! {
                #unit
                Ok(#type_name {
                    x: #x0,
                    p: #p0,
                    q: #q,
                    #qu
                    #(#r)*
                    #extra_init
                    #known_init
                })
            },
        )
    }
}

/// `pub const SUBSTEPS: usize`, documented by the attributes `doc`: the integration
/// sub-steps per sample of the continuous filters (1 for discrete dynamics).
pub fn substeps_constant(model: &Model, mg: &ModelGraph, doc: &TokenStream) -> TokenStream {
    let substeps = mg.clone().substep(model).map_or(1, |(_, _, n)| n);
    let substeps_lit = Literal::usize_unsuffixed(substeps as usize);
    // The loop of sub-steps runs two per iteration (`emit::substeps::lower_loop`).
    let pairs = (substeps > 1).then(|| {
        let pairs_lit = Literal::usize_unsuffixed(substeps as usize / 2);
        quote! {
            /// Iterations of the loop of sub-steps, two sub-steps each.
            const SUBSTEP_PAIRS: usize = #pairs_lit;
        }
    });
    quote! {
        #doc
        pub const SUBSTEPS: usize = #substeps_lit;
        #pairs
    }
}

/// The variables a filter's method reads: the packed covariance `p`, the process noise
/// `q` (and the matrix it makes), the measurement noise `R` (all outputs, by its blocks),
/// and the measurement of the outputs the method corrects with, `<output>_measured`.
/// Declared in this order, so every filter's graph numbers them alike.
pub struct FilterVars {
    /// The packed covariance's variables.
    pub p: Vec<NodeId>,
    /// The process noise's variables (packed, or the variances).
    pub q: Vec<NodeId>,
    /// The process noise covariance they make.
    pub q_matrix: Matrix,
    /// The measurement noise covariance `R` (`m x m`): its blocks' variables, structural
    /// zeros between two sensors.
    pub r_matrix: Matrix,
    /// Each block's field and its variables, packed in the field's order.
    pub r_blocks: Vec<(Ident, Vec<NodeId>)>,
    /// The measurement's variables, one per output corrected with.
    pub y: Vec<NodeId>,
}

impl FilterVars {
    /// Declares the variables of a filter of `model` correcting with `outputs`, avoiding
    /// the names `avoid`.
    pub fn declare(
        graph: &mut Graph,
        model: &Model,
        outputs: &[usize],
        noise: &ProcessNoise,
        avoid: &[String],
    ) -> FilterVars {
        let n = model.tangent_len();
        let p = packed_vars(graph, "p", n, avoid);
        let (q, q_matrix) = noise_vars(graph, "q", n, noise, avoid);
        let (r_matrix, r_blocks) = measurement_noise_vars(graph, model, avoid);
        let y = outputs
            .iter()
            .map(|&j| {
                graph.var(&unclaimed_name(
                    format!("{}_measured", model.outputs[j].name),
                    avoid,
                ))
            })
            .collect();
        FilterVars {
            p,
            q,
            q_matrix,
            r_matrix,
            r_blocks,
            y,
        }
    }

    /// Reads the measurement noise the code uses from its fields, each entry once.
    pub fn read_measurement_noise(&self, lowerer: &mut Lowerer) {
        for (field, vars) in &self.r_blocks {
            lowerer.read_lazily(&quote! { self.#field }, vars);
        }
    }
}

/// The measurement noise `R` of `model`'s outputs over the variables `r11`, `r12`, .. (named
/// by their places in the whole `R`, declared for all of it), each block's entries from
/// its own field and structural zeros between two blocks; and each block's field with its
/// variables, packed in the block's order.
fn measurement_noise_vars(
    graph: &mut Graph,
    model: &Model,
    avoid: &[String],
) -> (Matrix, Vec<(Ident, Vec<NodeId>)>) {
    let m = model.outputs.len();
    let all = crate::symbolic::linalg::symmetric_from_packed(&packed_vars(graph, "r", m, avoid), m);
    let zero = graph.zero();
    let mut matrix = vec![vec![zero; m]; m];
    let blocks = noise_blocks(model)
        .into_iter()
        .map(|block| {
            let rows = &block.outputs;
            for &i in rows {
                for &j in rows {
                    matrix[i][j] = all[i][j];
                }
            }
            let packed = rows
                .iter()
                .enumerate()
                .flat_map(|(a, &i)| rows[a..].iter().map(move |&j| (i, j)))
                .map(|(i, j)| all[i][j])
                .collect();
            (ident(&block.field), packed)
        })
        .collect();
    (matrix, blocks)
}

impl FilterVars {
    /// The variables that hold variances, never negative: the covariance's diagonal
    /// (`n x n`) and the process noise's (on the states it enters).
    pub fn variances(&self, n: usize) -> Vec<NodeId> {
        let p = (0..n).map(|i| self.p[crate::symbolic::linalg::packed_index(n, i, i)]);
        let q = (0..n)
            .map(|i| self.q_matrix[i][i])
            .filter(|v| self.q.contains(v));
        p.chain(q).collect()
    }
}

/// Names the new state entries after what they are and the method that computes them
/// (`suffix`): `x1_pred`, `x1_new`.
pub fn name_estimate(lowerer: &mut Lowerer, model: &Model, x: &[NodeId], suffix: &str) {
    for (&node, name) in x.iter().zip(model.state_names()) {
        lowerer.prefer_name(node, &format!("{name}_{suffix}"));
    }
}

/// `name`, with `_` appended while a name in `avoid` claims it: a generated local must not
/// shadow a model symbol.
pub fn unclaimed_name(mut name: String, avoid: &[String]) -> String {
    while avoid.contains(&name) {
        name.push('_');
    }
    name
}

/// Names already used by the model, which generated variables must avoid.
pub fn model_names(model: &Model) -> Vec<String> {
    model
        .constants
        .iter()
        .map(|c| c.name.clone())
        .chain(model.state_names().map(str::to_owned))
        .chain(model.inputs.iter().map(|s| s.name.clone()))
        .chain(model.known.iter().map(|s| s.name.clone()))
        .chain(model.outputs.iter().map(|o| o.name.clone()))
        .chain(["t", "x", "u", "y", "self", "status", "known"].map(String::from))
        .chain(model.interval_parameter())
        .collect()
}

/// Declares the packed variables of an `n x n` symmetric matrix and returns them.
pub fn packed_vars(graph: &mut Graph, prefix: &str, n: usize, avoid: &[String]) -> Vec<NodeId> {
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    packed_names(prefix, n, &taken)
        .iter()
        .map(|name| graph.var(name))
        .collect()
}

/// A process noise covariance of `n` states shaped as `noise`: its variables (the packed
/// upper triangle, or only the diagonal, over the states it enters) and the `n x n` matrix
/// they make, structural zeros where it does not enter (and off the diagonal if diagonal).
pub fn noise_vars(
    graph: &mut Graph,
    prefix: &str,
    n: usize,
    noise: &ProcessNoise,
    avoid: &[String],
) -> (Vec<NodeId>, Matrix) {
    let k = noise.len(n);
    let packed = packed_vars(graph, prefix, k, avoid);
    let entry = |a: usize, b: usize| packed[crate::symbolic::linalg::packed_index(k, a, b)];
    let zero = graph.zero();
    let mut matrix = vec![vec![zero; n]; n];
    for a in 0..k {
        for b in 0..k {
            if a == b || !noise.diagonal {
                matrix[noise.state(a)][noise.state(b)] = entry(a, b);
            }
        }
    }
    let vars = if noise.diagonal {
        (0..k).map(|a| entry(a, a)).collect()
    } else {
        packed
    };
    (vars, matrix)
}

/// The sum of a vector and of a matrix's diagonal: finite exactly when all of them are
/// (a NaN or infinity anywhere makes it non-finite), so one check guards a whole result.
/// Summed pairwise, so its expression nests as deep as the logarithm of its terms: a chain
/// of 2n nested sums is what made rustfmt take minutes on a 10-state model's code.
pub fn finiteness_probe(graph: &mut Graph, vector: &[NodeId], matrix: &Matrix) -> NodeId {
    finiteness_probe_of_changes(graph, vector, matrix, &[])
}

/// [`finiteness_probe`] without the entries whose new value is one of `stored`, the
/// variables the filter keeps: an entry a step leaves as it was (a parameter's estimate in
/// a prediction, its variance where its process noise is structurally zero) was tested
/// by the step that wrote it, and its constructor and setters accept finite values only.
pub fn finiteness_probe_of_changes(
    graph: &mut Graph,
    vector: &[NodeId],
    matrix: &Matrix,
    stored: &[NodeId],
) -> NodeId {
    let stored: std::collections::HashSet<NodeId> = stored.iter().copied().collect();
    let diagonal = (0..matrix.len()).map(|i| matrix[i][i]);
    let terms: Vec<NodeId> = vector
        .iter()
        .copied()
        .chain(diagonal)
        .filter(|term| !stored.contains(term))
        .collect();
    pairwise_sum(graph, &terms)
}

/// [`finiteness_probe`] with each entry of the vector beside its variance (`x1`, `p11`,
/// `x2`, ..), the order the code computes them in: a measurement update's estimate and
/// variance of a state share their operands (its row of the gain), which then need not be
/// kept for long.
pub fn interleaved_finiteness_probe(
    graph: &mut Graph,
    vector: &[NodeId],
    matrix: &Matrix,
) -> NodeId {
    // A state with a rotation has more entries than variances: the rest follow.
    let variances = (0..matrix.len()).map(|i| Some(matrix[i][i]));
    let entries = vector.iter().map(|&v| Some(v));
    let longest = vector.len().max(matrix.len());
    let terms: Vec<NodeId> = entries
        .chain(std::iter::repeat(None))
        .zip(variances.chain(std::iter::repeat(None)))
        .take(longest)
        .flat_map(|(v, d)| [v, d])
        .flatten()
        .collect();
    pairwise_sum(graph, &terms)
}

/// `terms` summed as a balanced tree: each half, then their sum (zero for none).
fn pairwise_sum(graph: &mut Graph, terms: &[NodeId]) -> NodeId {
    match terms {
        [] => graph.zero(),
        [only] => *only,
        _ => {
            let (left, right) = terms.split_at(terms.len() / 2);
            let (left, right) = (pairwise_sum(graph, left), pairwise_sum(graph, right));
            graph.add(left, right)
        }
    }
}

/// Whether the code reads the variable `var` (the time `t`, an input).
pub fn reads_variable(
    graph: &Graph,
    var: NodeId,
    used: &std::collections::BTreeSet<VarId>,
) -> bool {
    matches!(graph.node(var), crate::symbolic::Node::Var(v) if used.contains(&v))
}

/// What the documentation of a correction that takes the input `u` adds: an output that
/// reads an input (a feedthrough, `y = c x + d u`) needs the input at the measurement.
pub const MEASUREMENT_INPUT_DOC: &str = " `h` reads the input: `u` is the input in effect at \
     the measurement (rejected unless finite, as the measurement is); a step evaluates `h` \
     with `u_prev`, the input held until its measurement.";

/// Whether a correction that does not predict must take the input `u`: its code reads one
/// of the input variables `u` (an output reads an input). A step reads them from `u_prev`.
pub fn correction_reads_input(
    graph: &Graph,
    u: &[NodeId],
    predicts: bool,
    used: &std::collections::BTreeSet<VarId>,
) -> bool {
    !predicts && u.iter().any(|&v| reads_variable(graph, v, used))
}

/// `t: f32` (named `name`), or `_t: f32` when the code does not read it.
pub fn time_param(
    graph: &Graph,
    t: NodeId,
    used: &std::collections::BTreeSet<VarId>,
    ty: &proc_macro2::Ident,
    name: &str,
) -> TokenStream {
    let name = if reads_variable(graph, t, used) {
        ident(name)
    } else {
        ident(&format!("_{name}"))
    };
    quote! { #name: #ty }
}
