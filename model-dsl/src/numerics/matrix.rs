//! A small dense `f64` matrix, row-major, for the designs done at generation time.

use std::ops::{Add, Index, IndexMut, Mul, Sub};

/// A dense `rows x cols` matrix of `f64`, stored row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct Mat {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Mat {
    /// The `rows x cols` zero matrix.
    pub fn zeros(rows: usize, cols: usize) -> Mat {
        Mat {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// The `n x n` identity.
    pub fn identity(n: usize) -> Mat {
        let mut m = Mat::zeros(n, n);
        for i in 0..n {
            m[(i, i)] = 1.0;
        }
        m
    }

    /// A matrix from its rows (all of one length).
    pub fn from_rows(rows: &[Vec<f64>]) -> Mat {
        let cols = rows.first().map_or(0, Vec::len);
        assert!(rows.iter().all(|r| r.len() == cols), "ragged rows");
        Mat {
            rows: rows.len(),
            cols,
            data: rows.concat(),
        }
    }

    /// A diagonal matrix.
    pub fn diagonal(values: &[f64]) -> Mat {
        let mut m = Mat::zeros(values.len(), values.len());
        for (i, &v) in values.iter().enumerate() {
            m[(i, i)] = v;
        }
        m
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The rows as vectors (`rows` empty ones when there are no columns).
    pub fn to_rows(&self) -> Vec<Vec<f64>> {
        if self.cols == 0 {
            return vec![Vec::new(); self.rows];
        }
        self.data.chunks(self.cols).map(<[f64]>::to_vec).collect()
    }

    /// The transpose.
    pub fn t(&self) -> Mat {
        let mut m = Mat::zeros(self.cols, self.rows);
        for i in 0..self.rows {
            for j in 0..self.cols {
                m[(j, i)] = self[(i, j)];
            }
        }
        m
    }

    /// Every entry times `s`.
    pub fn scale(&self, s: f64) -> Mat {
        Mat {
            data: self.data.iter().map(|v| v * s).collect(),
            ..self.clone()
        }
    }

    /// The largest absolute entry (0 for an empty matrix).
    pub fn max_abs(&self) -> f64 {
        self.data.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// The Frobenius norm.
    pub fn norm(&self) -> f64 {
        self.data.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// Whether every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.data.iter().all(|v| v.is_finite())
    }

    /// `(A + A') / 2`.
    pub fn symmetrised(&self) -> Mat {
        (self + &self.t()).scale(0.5)
    }

    /// Rows `r0..r1` and columns `c0..c1`.
    pub fn block(&self, r0: usize, r1: usize, c0: usize, c1: usize) -> Mat {
        let mut m = Mat::zeros(r1 - r0, c1 - c0);
        for i in r0..r1 {
            for j in c0..c1 {
                m[(i - r0, j - c0)] = self[(i, j)];
            }
        }
        m
    }

    /// `self` with `other` stacked below it (same number of columns).
    pub fn stack(&self, other: &Mat) -> Mat {
        assert_eq!(self.cols, other.cols, "stacking needs equal widths");
        let mut data = self.data.clone();
        data.extend_from_slice(&other.data);
        Mat {
            rows: self.rows + other.rows,
            cols: self.cols,
            data,
        }
    }

    /// The inverse by Gaussian elimination with partial pivoting, or `None` when a pivot
    /// is below `1e-14` of the matrix's largest entry (numerically singular).
    pub fn inverse(&self) -> Option<Mat> {
        assert_eq!(self.rows, self.cols, "only square matrices have inverses");
        let n = self.rows;
        let mut a = self.clone();
        let mut inv = Mat::identity(n);
        let tiny = 1e-14 * self.max_abs();
        for col in 0..n {
            let pivot =
                (col..n).max_by(|&i, &j| a[(i, col)].abs().total_cmp(&a[(j, col)].abs()))?;
            let magnitude = a[(pivot, col)].abs();
            if magnitude.is_nan() || magnitude <= tiny {
                return None;
            }
            a.swap_rows(col, pivot);
            inv.swap_rows(col, pivot);
            let d = a[(col, col)];
            for j in 0..n {
                a[(col, j)] /= d;
                inv[(col, j)] /= d;
            }
            for i in (0..n).filter(|&i| i != col) {
                let factor = a[(i, col)];
                if factor != 0.0 {
                    for j in 0..n {
                        a[(i, j)] -= factor * a[(col, j)];
                        inv[(i, j)] -= factor * inv[(col, j)];
                    }
                }
            }
        }
        Some(inv)
    }

    fn swap_rows(&mut self, i: usize, j: usize) {
        if i != j {
            for c in 0..self.cols {
                self.data.swap(i * self.cols + c, j * self.cols + c);
            }
        }
    }
}

impl Index<(usize, usize)> for Mat {
    type Output = f64;
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        assert!(i < self.rows && j < self.cols, "index out of the matrix");
        &self.data[i * self.cols + j]
    }
}

impl IndexMut<(usize, usize)> for Mat {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut f64 {
        assert!(i < self.rows && j < self.cols, "index out of the matrix");
        &mut self.data[i * self.cols + j]
    }
}

impl Mul for &Mat {
    type Output = Mat;
    fn mul(self, rhs: &Mat) -> Mat {
        assert_eq!(self.cols, rhs.rows, "product of mismatched shapes");
        let mut m = Mat::zeros(self.rows, rhs.cols);
        for i in 0..self.rows {
            for k in 0..self.cols {
                let a = self[(i, k)];
                if a != 0.0 {
                    for j in 0..rhs.cols {
                        m[(i, j)] += a * rhs[(k, j)];
                    }
                }
            }
        }
        m
    }
}

impl Add for &Mat {
    type Output = Mat;
    fn add(self, rhs: &Mat) -> Mat {
        assert_eq!(
            (self.rows, self.cols),
            (rhs.rows, rhs.cols),
            "sum of mismatched shapes"
        );
        Mat {
            data: self
                .data
                .iter()
                .zip(&rhs.data)
                .map(|(a, b)| a + b)
                .collect(),
            ..self.clone()
        }
    }
}

impl Sub for &Mat {
    type Output = Mat;
    fn sub(self, rhs: &Mat) -> Mat {
        assert_eq!(
            (self.rows, self.cols),
            (rhs.rows, rhs.cols),
            "difference of mismatched shapes"
        );
        Mat {
            data: self
                .data
                .iter()
                .zip(&rhs.data)
                .map(|(a, b)| a - b)
                .collect(),
            ..self.clone()
        }
    }
}
