//! The values a C function passes or receives: the scope's scalar, arrays of one or two
//! dimensions of it, a count, and a record (received only), read from their types' text.

/// The floating-point type of a scope's code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// `f32`, C's `float`.
    F32,
    /// `f64`, C's `double`.
    F64,
}

impl Scalar {
    /// Its Rust name.
    pub fn rust(self) -> &'static str {
        match self {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }

    /// Its C name.
    pub fn c(self) -> &'static str {
        match self {
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

/// The shape of a value C passes or receives: a scalar, an array of one or two
/// dimensions, a count, or one of the scope's records.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Value {
    /// The scope's scalar.
    Scalar,
    /// `[s; n]`.
    Vector(usize),
    /// `[[s; cols]; rows]`.
    Matrix(usize, usize),
    /// `u32`.
    Count,
    /// One of the scope's records (`PredictionModel`), by its Rust name.
    Record(String),
}

impl Value {
    /// Its Rust type in a scope of `scalar`; a record's is `record(name)`.
    pub fn rust(&self, scalar: Scalar, record: &dyn Fn(&str) -> String) -> String {
        let scalar = scalar.rust();
        match self {
            Value::Scalar => scalar.to_owned(),
            Value::Count => "u32".to_owned(),
            Value::Vector(n) => format!("[{scalar}; {n}]"),
            Value::Matrix(rows, cols) => format!("[[{scalar}; {cols}]; {rows}]"),
            Value::Record(name) => record(name),
        }
    }
}

/// `[s; n]` or `[[s; cols]; rows]`.
pub fn array(ty: &str, scalar: Scalar) -> Option<Value> {
    let length = |s: &str| s.trim().parse::<usize>().ok().filter(|&n| n > 0);
    let s = scalar.rust();
    if let Some(rest) = ty
        .strip_prefix(&format!("[{s};"))
        .and_then(|r| r.strip_suffix(']'))
    {
        return Some(Value::Vector(length(rest)?));
    }
    let rest = ty.strip_prefix(&format!("[[{s};"))?.strip_suffix(']')?;
    let (cols, rows) = rest.split_once("];")?;
    Some(Value::Matrix(length(rows)?, length(cols)?))
}
