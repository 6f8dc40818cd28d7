//! The memory traffic a register file implies for straight-line code: which operands
//! must be loaded (a variable from its array, a literal from the constant pool, a value
//! spilled earlier) and which computed values must be spilled to the stack, when the code
//! runs in the order the lowerer emits it with a given number of registers.
//!
//! A register allocator decides this on the target; the estimate follows the textbook
//! optimum for straight-line code (Belady: evict the value whose next use is furthest
//! away), which a good allocator approaches. It feeds the static cycle estimate
//! ([`crate::timing`]): on a Cortex-M4F a load or a store costs as much as two additions.

use crate::fast_hash::{FastMap, FastSet};
use crate::symbolic::{Graph, Node, NodeId};

/// The FPU's registers of the Cortex-M4F: 32 single-precision (`s0` to `s31`).
pub const FPU_REGISTERS: usize = 32;

/// Values held in registers across the segments of one function.
#[derive(Clone, Debug)]
pub struct RegisterFile {
    capacity: usize,
    resident: Vec<NodeId>,
    /// Computed values with a copy on the stack (evicting them again stores nothing).
    spilled: FastSet<NodeId>,
}

/// The memory traffic of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    /// Variables read from memory, and values reloaded after a spill.
    pub load: u32,
    /// Literals loaded from the constant pool.
    pub literal: u32,
    /// Values spilled.
    pub store: u32,
}

/// One computation of a segment, in order: the value and its operands.
pub struct Step {
    /// The value computed.
    pub value: NodeId,
    /// Its operands.
    pub operands: Vec<NodeId>,
}

impl RegisterFile {
    /// An empty register file of `capacity` values.
    pub fn new(capacity: usize) -> RegisterFile {
        RegisterFile {
            capacity: capacity.max(3),
            resident: Vec::new(),
            spilled: FastSet::default(),
        }
    }

    /// Takes `values` into registers as far as they fit (a loop's carried values at the
    /// start of its body); the others are loaded where they are first used.
    pub fn hold(&mut self, values: &[NodeId]) {
        for &v in values {
            if self.resident.len() < self.capacity && !self.resident.contains(&v) {
                self.resident.push(v);
            }
        }
    }

    /// Takes `n` registers away, for values live across the code that it does not see
    /// (at least three stay: an operation's two operands and its result).
    pub fn reserve(&mut self, n: usize) {
        self.capacity = self.capacity.saturating_sub(n).max(3);
    }

    /// How many registers are free.
    pub fn room(&self) -> usize {
        self.capacity.saturating_sub(self.resident.len())
    }

    /// Runs `steps` and returns the loads, literals and stores they cost. `live_after`
    /// says whether a value is used after the segment (by a later segment, or as the
    /// segment's result); `in_memory` whether a leaf is read from memory (a variable
    /// that a definition computes instead is a computed value).
    pub fn run(
        &mut self,
        graph: &Graph,
        steps: &[Step],
        live_after: &dyn Fn(NodeId) -> bool,
        in_memory: &dyn Fn(NodeId) -> bool,
    ) -> Traffic {
        let plan = NextUses::of(steps);
        // Beside each resident value, its next use: the first position past the one
        // being run where it is an operand (kept up to date as each step is run).
        let mut ahead: Vec<Option<usize>> = self
            .resident
            .iter()
            .map(|v| plan.first.get(v).copied())
            .collect();
        let mut traffic = Traffic::default();
        for (position, step) in steps.iter().enumerate() {
            let after = plan.operands_after(position);
            for (&operand, &next) in step.operands.iter().zip(after) {
                if let Some(i) = self.resident.iter().position(|&v| v == operand) {
                    ahead[i] = next;
                }
            }
            if in_memory(step.value) {
                // A leaf is loaded where it is used.
                continue;
            }
            for (&operand, &next) in step.operands.iter().zip(after) {
                if self.resident.contains(&operand) {
                    continue;
                }
                match graph.node(operand) {
                    Node::Num(_) | Node::Named(_) => traffic.literal += 1,
                    _ => traffic.load += 1,
                }
                self.make_room(&mut ahead, live_after, in_memory, &mut traffic);
                self.resident.push(operand);
                ahead.push(next);
            }
            // Operands used for the last time free their registers for the result.
            self.release_dead(&mut ahead, live_after);
            // A held value (a loop's carried value) may be in a register already.
            if !self.resident.contains(&step.value) {
                self.make_room(&mut ahead, live_after, in_memory, &mut traffic);
                self.resident.push(step.value);
                ahead.push(plan.value_after[position]);
            }
        }
        traffic
    }

    /// Drops the resident values that have no use ahead and are not live after the run.
    fn release_dead(
        &mut self,
        ahead: &mut Vec<Option<usize>>,
        live_after: &dyn Fn(NodeId) -> bool,
    ) {
        let mut kept = 0;
        for i in 0..self.resident.len() {
            let v = self.resident[i];
            if ahead[i].is_some() || live_after(v) {
                self.resident[kept] = v;
                ahead[kept] = ahead[i];
                kept += 1;
            }
        }
        self.resident.truncate(kept);
        ahead.truncate(kept);
    }

    /// Frees one register if all are taken, evicting the value used furthest ahead; a
    /// computed value still needed is stored (once).
    fn make_room(
        &mut self,
        ahead: &mut Vec<Option<usize>>,
        live_after: &dyn Fn(NodeId) -> bool,
        in_memory: &dyn Fn(NodeId) -> bool,
        traffic: &mut Traffic,
    ) {
        if self.resident.len() < self.capacity {
            return;
        }
        let distance = |v: NodeId, next: Option<usize>| match next {
            Some(p) => p,
            None if live_after(v) => usize::MAX - 1,
            None => usize::MAX,
        };
        let Some((index, &victim)) = self
            .resident
            .iter()
            .enumerate()
            .max_by_key(|&(i, &v)| distance(v, ahead[i]))
        else {
            return;
        };
        let needed = distance(victim, ahead[index]) != usize::MAX;
        self.resident.swap_remove(index);
        ahead.swap_remove(index);
        if needed && !in_memory(victim) && self.spilled.insert(victim) {
            traffic.store += 1;
        }
    }
}

/// Where each value of a run is next used: for each operand of each step, and for each
/// step's value, the first later position where it is an operand; and each operand's
/// first use. Found in one backward pass, so that running the steps asks no map.
struct NextUses {
    /// The next use of each step's operands in turn, all steps' one after the other.
    operands: Vec<Option<usize>>,
    /// Where each step's operands start in `operands`.
    starts: Vec<usize>,
    /// The first use of each step's value after its step.
    value_after: Vec<Option<usize>>,
    /// The first use of each operand in the run.
    first: FastMap<NodeId, usize>,
}

impl NextUses {
    fn of(steps: &[Step]) -> NextUses {
        let mut starts = Vec::with_capacity(steps.len() + 1);
        starts.push(0);
        for step in steps {
            starts.push(starts[starts.len() - 1] + step.operands.len());
        }
        let mut operands = vec![None; starts[steps.len()]];
        let mut value_after = vec![None; steps.len()];
        // The first use at or after the position being looked at, walking back.
        let mut first: FastMap<NodeId, usize> = FastMap::default();
        for (position, step) in steps.iter().enumerate().rev() {
            value_after[position] = first.get(&step.value).copied();
            for (k, operand) in step.operands.iter().enumerate() {
                operands[starts[position] + k] = first.get(operand).copied();
            }
            for &operand in &step.operands {
                first.insert(operand, position);
            }
        }
        NextUses {
            operands,
            starts,
            value_after,
            first,
        }
    }

    /// The next uses of the operands of the step at `position`.
    fn operands_after(&self, position: usize) -> &[Option<usize>] {
        &self.operands[self.starts[position]..self.starts[position + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `terms` summed left to right, each addition appended to `steps`; the sum.
    fn sum_in_order(g: &mut Graph, terms: &[NodeId], steps: &mut Vec<Step>) -> NodeId {
        let mut sum = terms[0];
        for &term in &terms[1..] {
            let next = g.add(sum, term);
            steps.push(Step {
                value: next,
                operands: vec![sum, term],
            });
            sum = next;
        }
        sum
    }

    /// A sum of `n` variables, each read once: every variable is loaded once, and
    /// nothing is spilled however few the registers.
    #[test]
    fn a_chain_loads_each_variable_once_and_spills_nothing() {
        let mut g = Graph::new();
        let vars: Vec<NodeId> = (0..40).map(|i| g.var(&format!("v{i}"))).collect();
        let mut steps: Vec<Step> = vars
            .iter()
            .map(|&v| Step {
                value: v,
                operands: vec![],
            })
            .collect();
        let sum = sum_in_order(&mut g, &vars, &mut steps);
        let leaf = |id: NodeId| g.is_leaf(id);
        let traffic = RegisterFile::new(4).run(&g, &steps, &|v| v == sum, &leaf);
        assert_eq!((traffic.load, traffic.store), (40, 0));
    }

    /// Forty products of `x`, all needed by the sum at the end, with 32 registers: about
    /// eight are spilled and reloaded (and `x` itself may be reloaded once).
    #[test]
    fn values_beyond_the_registers_are_spilled_once_and_reloaded() {
        let mut g = Graph::new();
        let x = g.var("x");
        let mut steps = vec![Step {
            value: x,
            operands: vec![],
        }];
        let products: Vec<NodeId> = (2..=41)
            .map(|i| {
                let c = g.num(f64::from(i));
                let p = g.mul(c, x);
                steps.push(Step {
                    value: p,
                    operands: vec![c, x],
                });
                p
            })
            .collect();
        let sum = sum_in_order(&mut g, &products, &mut steps);
        let leaf = |id: NodeId| g.is_leaf(id);
        let traffic = RegisterFile::new(FPU_REGISTERS).run(&g, &steps, &|v| v == sum, &leaf);
        assert_eq!(traffic.literal, 40);
        assert!(
            (8..=12).contains(&traffic.store)
                && (1 + traffic.store..=2 + traffic.store).contains(&traffic.load),
            "{traffic:?}"
        );
    }
}
