//! The blocks of a Kalman filter's covariance that nothing in the model couples, so that the
//! covariance between two of them stays zero once it is zero: a structural zero of every
//! covariance the filter holds, which it never computes again.
//!
//! Two coordinates of the state (of its tangent space, for an error-state filter) are
//! coupled when the prediction or a correction can make their covariance non-zero from a
//! covariance that was zero between their blocks:
//!
//! - the prediction `F P F' + Q (+ G Qu G')`: `(F P F')_ik = sum F_ia P_ab F_kb`, non-zero
//!   only if `i` moves with some `a` (`F_ia != 0`) and `k` with some `b` of `a`'s block; so
//!   a coordinate is coupled with each one it moves with, with each one the process noise
//!   correlates it with (`Q_ik != 0`), and with each one the same noisy input enters
//!   (`G_ia != 0` and `G_ka != 0`);
//! - a correction `P - P H' S^-1 H P`: `(P H')_i` is non-zero only if `i` shares a block with
//!   a coordinate some output reads, and any two measured coordinates are correlated by it:
//!   every coordinate an output reads is coupled with every other one read (a joint step
//!   reads all outputs at once);
//! - an error-state filter's reset `G P G'` mixes a rotation's three coordinates.
//!
//! The blocks are the classes of the coupling's transitive closure. A state nothing reads
//! and nothing moves (a random walk carried for a layout, as a navigation filter's wind
//! that no airspeed sensor measures) is a block of its own: its covariance with the rest
//! stays zero whatever the filter does, and computing it would be multiplying zeros.

use super::linalg::Matrix;
use super::ModelGraph;
use std::ops::Range;

/// Which block each coordinate of a filter's covariance belongs to, numbered by the order
/// of their first coordinates (the first coordinate's block is 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CovarianceBlocks {
    block: Vec<usize>,
}

/// The couplings of an extended Kalman filter's model, by what couples (see the module's
/// documentation): the model's Jacobians come from a [`ModelGraph`].
pub struct Couplings<'a> {
    /// The coordinates a full process noise covariance correlates (all of them, or those
    /// it enters); empty for a diagonal one.
    pub correlated_noise: &'a [usize],
    /// The inputs whose noise enters through the input Jacobian (indices among the inputs).
    pub noisy_inputs: &'a [usize],
    /// Ranges of coordinates that are one block whatever else holds (a rotation's three).
    pub together: &'a [Range<usize>],
}

impl CovarianceBlocks {
    /// One block of `n` coordinates: a covariance without structural zeros.
    pub fn one(n: usize) -> CovarianceBlocks {
        CovarianceBlocks { block: vec![0; n] }
    }

    /// The packed positions (row by row, upper triangle) of the entries between two
    /// blocks: zero in every covariance of a filter whose coordinates these blocks split.
    pub fn uncoupled_entries(&self) -> Vec<(usize, usize, usize)> {
        let n = self.block.len();
        let mut entries = Vec::new();
        let mut k = 0;
        for i in 0..n {
            for j in i..n {
                if !self.coupled(i, j) {
                    entries.push((k, i, j));
                }
                k += 1;
            }
        }
        entries
    }

    /// The blocks of the covariance of an extended Kalman filter of the model `mg` (its
    /// tangent space, for a state with rotations) coupled by `couplings`.
    pub fn of_ekf(mg: &ModelGraph, couplings: &Couplings<'_>) -> CovarianceBlocks {
        let mut mg = mg.clone();
        let f = mg.tangent_jacobian_f_wrt_x();
        let h = mg.tangent_jacobian_h_wrt_x();
        let g: Matrix = if couplings.noisy_inputs.is_empty() {
            Vec::new()
        } else {
            let all = mg.tangent_jacobian_f_wrt_u();
            let columns = |row: &Vec<_>| couplings.noisy_inputs.iter().map(|&j| row[j]).collect();
            all.iter().map(columns).collect()
        };
        let n = f.len();
        let nonzero = |m: &Matrix, i: usize, j: usize| !mg.graph.is_zero(m[i][j]);
        let mut classes = Classes::new(n);
        for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
            if i != j && nonzero(&f, i, j) {
                classes.join(i, j);
            }
        }
        classes.join_all(couplings.correlated_noise.iter().copied());
        for a in 0..couplings.noisy_inputs.len() {
            classes.join_all((0..n).filter(|&i| nonzero(&g, i, a)));
        }
        classes.join_all((0..n).filter(|&j| (0..h.len()).any(|o| nonzero(&h, o, j))));
        for range in couplings.together {
            classes.join_all(range.clone().filter(|&i| i < n));
        }
        classes.numbered()
    }

    /// Whether there is more than one block: whether the covariance has structural zeros.
    pub fn is_split(&self) -> bool {
        self.block.iter().any(|&b| b != 0)
    }

    /// Whether the covariance between coordinates `i` and `j` may be non-zero.
    pub fn coupled(&self, i: usize, j: usize) -> bool {
        self.block[i] == self.block[j]
    }

    /// Each coordinate's block.
    pub fn ids(&self) -> &[usize] {
        &self.block
    }
}

/// Disjoint classes of `0..n`, joined one pair at a time (union by size, path halving).
struct Classes {
    parent: Vec<usize>,
    size: Vec<usize>,
}

impl Classes {
    fn new(n: usize) -> Classes {
        Classes {
            parent: (0..n).collect(),
            size: vec![1; n],
        }
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    fn join(&mut self, i: usize, j: usize) {
        let (mut a, mut b) = (self.root(i), self.root(j));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a;
        self.size[a] += self.size[b];
    }

    fn join_all(&mut self, members: impl Iterator<Item = usize>) {
        let mut first = None;
        for i in members {
            match first {
                None => first = Some(i),
                Some(f) => self.join(f, i),
            }
        }
    }

    /// Each member's class, numbered by the order of their first members.
    fn numbered(mut self) -> CovarianceBlocks {
        let n = self.parent.len();
        let mut number = vec![usize::MAX; n];
        let mut next = 0;
        let block = (0..n)
            .map(|i| {
                let r = self.root(i);
                if number[r] == usize::MAX {
                    number[r] = next;
                    next += 1;
                }
                number[r]
            })
            .collect();
        CovarianceBlocks { block }
    }
}
