//! The constraint Jacobian in CSR form from its values in the evaluator's `(row, column)`
//! order. The COO → CSR conversion (bucket by row, sort each row's columns, sum repeats)
//! depends on the pattern alone, so its result is found once: the list converted with each
//! entry's position as its value gives the CSR pattern and, per stored entry, the position
//! whose value it takes; placing values by it gives the converted matrix bit for bit. Kept
//! per thread for the [`REMEMBERED`] most recently used patterns (the rounds of a cmc run
//! solve NLPs of one pattern). A list that repeats an entry has no such layout (the
//! conversion sums the repeats): its Jacobians are converted each time.

use std::cell::RefCell;
use std::sync::Arc;

use nalgebra_sparse::pattern::SparsityPattern;
use nalgebra_sparse::{CooMatrix, CsrMatrix};

use crate::solver::remembered::Remembered;

/// Jacobian patterns each thread keeps.
pub const REMEMBERED: usize = 2;

/// A pattern's CSR layout: the sparsity pattern and, per stored entry (row-major, columns
/// ascending), the position of its value in the evaluator's order; `None` for a list that
/// repeats an entry.
type Layout = Option<(SparsityPattern, Vec<usize>)>;

/// A layout's key: rows, columns, and the entries' rows and columns.
type Shape = (usize, usize, Vec<usize>, Vec<usize>);

thread_local! {
    /// This thread's layouts.
    static LAYOUTS: RefCell<Remembered<Shape, Layout>> =
        const { RefCell::new(Remembered::new(REMEMBERED)) };
}

/// The `m × n` constraint Jacobian whose entries are `(rows[k], cols[k])`, for values given in
/// that order.
pub struct Jacobian {
    m: usize,
    n: usize,
    rows: Vec<usize>,
    cols: Vec<usize>,
    layout: Arc<Layout>,
}

impl Jacobian {
    /// The Jacobian of the entries `(rows[k], cols[k])`, its layout from this thread's
    /// remembered ones when it is one of them (module header).
    pub fn new(m: usize, n: usize, rows: &[usize], cols: &[usize]) -> Self {
        let layout = LAYOUTS.with_borrow_mut(|layouts| {
            layouts.get_or_make(
                |(lm, ln, r, c)| *lm == m && *ln == n && r == rows && c == cols,
                || {
                    let layout = layout(&coo(m, n, rows, cols, |k| k as f64));
                    Ok::<_, std::convert::Infallible>((
                        (m, n, rows.to_vec(), cols.to_vec()),
                        layout,
                    ))
                },
            )
        });
        let Ok(layout) = layout;
        Jacobian {
            m,
            n,
            rows: rows.to_vec(),
            cols: cols.to_vec(),
            layout,
        }
    }

    /// The entries' rows and columns, in the order of the values.
    pub fn entries(&self) -> (&[usize], &[usize]) {
        (&self.rows, &self.cols)
    }

    /// The matrix of `values` (one per entry, in the entries' order), repeats summed.
    pub fn csr(&self, values: &[f64]) -> CsrMatrix<f64> {
        match self.layout.as_ref() {
            Some((pattern, order)) => {
                let placed = order.iter().map(|&k| values[k]).collect();
                CsrMatrix::try_from_pattern_and_values(pattern.clone(), placed)
                    .expect("the layout holds one position per stored entry")
            }
            None => CsrMatrix::from(&coo(self.m, self.n, &self.rows, &self.cols, |k| values[k])),
        }
    }
}

/// The `m × n` COO matrix of the entries `(rows[k], cols[k])` with the values `value(k)`.
fn coo(
    m: usize,
    n: usize,
    rows: &[usize],
    cols: &[usize],
    value: impl Fn(usize) -> f64,
) -> CooMatrix<f64> {
    let mut coo = CooMatrix::new(m, n);
    for (k, (&r, &c)) in rows.iter().zip(cols).enumerate() {
        coo.push(r, c, value(k));
    }
    coo
}

/// The layout of the entries of `positions` (each entry's value its position): `None` when
/// the conversion merged repeats.
fn layout(positions: &CooMatrix<f64>) -> Layout {
    let csr = CsrMatrix::from(positions);
    (csr.nnz() == positions.nnz()).then(|| {
        let order = csr.values().iter().map(|&k| k as usize).collect();
        (csr.pattern().clone(), order)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The placed matrix equals the converted one, with and without repeated entries.
    #[test]
    fn placed_values_equal_the_conversion() {
        let (rows, cols) = (vec![1, 0, 1, 0], vec![2, 1, 0, 0]);
        let values = [0.5, -2.0, 3.25, 7.0];
        let jacobian = Jacobian::new(2, 3, &rows, &cols);
        assert!(jacobian.layout.is_some());
        let converted = CsrMatrix::from(&coo(2, 3, &rows, &cols, |k| values[k]));
        assert_eq!(jacobian.csr(&values), converted);
        let (rows, cols) = (vec![1, 0, 1], vec![2, 1, 2]);
        let repeated = Jacobian::new(2, 3, &rows, &cols);
        assert!(repeated.layout.is_none());
        let csr = repeated.csr(&[1.0, 2.0, 4.0]);
        assert_eq!(csr.nnz(), 2);
        assert_eq!(csr.values(), &[2.0, 5.0]);
    }
}
