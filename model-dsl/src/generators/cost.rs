//! The arithmetic of one generated call, as a generator reports it: published as its
//! `*_OPS` and `*_CYCLES` constants, and checked against a budget by the call's name.

use crate::emit::lower::OpCount;

/// The arithmetic of one generated call.
pub struct Cost {
    /// The constant's name, `EKF_STEP_OPS`.
    pub constant: String,
    /// What it counts, for the constant's doc (`Ekf::step`).
    pub what: String,
    /// The operation counts.
    pub ops: OpCount,
    /// Whether it is the call a budget of one number (`max_cycles = ..`) bounds without a
    /// schedule: a filter's step, a controller's solve at its worst.
    pub is_budgeted: bool,
    /// Whether it counts part of a call (a sub-step, an iteration), whose estimate has no
    /// entry and return of its own.
    pub is_part: bool,
    /// The method a user calls that it counts (`predict`, `update_gnss`), by which a
    /// budget or a schedule names it; `None` for what is no whole call.
    pub call: Option<String>,
}

impl Cost {
    /// A cost named `constant`, counting `what`; of the call `what` names when it is a
    /// method, `Type::method` (`Ekf::update_gnss`).
    pub fn new(constant: &str, what: &str, ops: OpCount) -> Cost {
        let word = |w: &str| !w.is_empty() && w.chars().all(|c| c.is_alphanumeric() || c == '_');
        let call = what
            .split_once("::")
            .filter(|(ty, method)| word(ty) && word(method))
            .map(|(_, method)| method.to_owned());
        Cost {
            constant: constant.to_owned(),
            what: what.to_owned(),
            ops,
            is_budgeted: false,
            is_part: false,
            call,
        }
    }

    /// The same cost, of the call `method` (one of a method's several paths, say).
    pub fn of_call(self, method: &str) -> Cost {
        Cost {
            call: Some(method.to_owned()),
            ..self
        }
    }

    /// The same cost, as part of a call.
    pub fn part(self) -> Cost {
        Cost {
            is_part: true,
            call: None,
            ..self
        }
    }

    /// The same cost, as the one a budget bounds.
    pub fn budgeted(self) -> Cost {
        Cost {
            is_budgeted: true,
            ..self
        }
    }
}
