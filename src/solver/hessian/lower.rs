//! The lower triangle of a sparse symmetric matrix in compressed columns from triplets, with
//! the triplet pattern's assembly plan shared by every assembly of the same pattern.
//!
//! An exact-Hessian SQP assembles `H` from the problem's triplets at every iterate, and a
//! problem solved in rounds (cmc normal coordinates) rebuilds its NLP with the same pattern.
//! The conversion (bucket by column, sort each column by row, sum the duplicates) depends on the
//! pattern alone, so it is done once per pattern: the plan lists, per entry of the compressed
//! matrix, the triplets that sum to it in the order the conversion of `nalgebra_sparse` sums
//! them (its counting sort by column keeps the triplet order, then each column is put in row
//! order by the same unstable sort of the same keys, and duplicates are added left to right).
//! An assembly from a plan is then one pass over the triplets and the result is the same bit for
//! bit. Each thread keeps the [`REMEMBERED`] most recently used patterns (least recently used
//! forgotten first), so nothing crosses threads and results do not depend on `--threads`.

use std::cell::RefCell;

use nalgebra_sparse::CscMatrix;
use nalgebra_sparse::pattern::SparsityPattern;

use crate::solver::remembered::Remembered;

/// Triplet patterns remembered per thread: an SQP with variables held at bounds assembles two
/// (with and without the held diagonal).
pub const REMEMBERED: usize = 2;

/// How the triplets of one pattern make the compressed lower triangle.
struct Plan {
    pattern: SparsityPattern,
    /// Triplet indices in summation order, entry after entry.
    order: Vec<usize>,
    /// Entry e sums `order[starts[e]..starts[e + 1]]`.
    starts: Vec<usize>,
}

impl Plan {
    fn new(n: usize, rows: &[usize], cols: &[usize]) -> Plan {
        // (major, minor) = (column, row) of the lower triangle.
        let lower: Vec<(usize, usize)> = rows
            .iter()
            .zip(cols)
            .map(|(&r, &c)| if r >= c { (c, r) } else { (r, c) })
            .collect();
        let mut offsets = vec![0usize; n + 1];
        for &(major, _) in &lower {
            offsets[major + 1] += 1;
        }
        for j in 0..n {
            offsets[j + 1] += offsets[j];
        }
        let mut lane = vec![0usize; lower.len()];
        let mut filled = offsets.clone();
        for (k, &(major, _)) in lower.iter().enumerate() {
            lane[filled[major]] = k;
            filled[major] += 1;
        }
        let (mut order, mut starts) = (Vec::with_capacity(lower.len()), Vec::new());
        let (mut col_offsets, mut row_indices) = (vec![0usize], Vec::new());
        let mut perm = Vec::new();
        for j in 0..n {
            let entries = &lane[offsets[j]..offsets[j + 1]];
            perm.clear();
            perm.extend(0..entries.len());
            perm.sort_unstable_by_key(|&i| lower[entries[i]].1);
            for &i in &perm {
                let minor = lower[entries[i]].1;
                if row_indices.len() == col_offsets[j] || row_indices.last() != Some(&minor) {
                    row_indices.push(minor);
                    starts.push(order.len());
                }
                order.push(entries[i]);
            }
            col_offsets.push(row_indices.len());
        }
        starts.push(order.len());
        let pattern = SparsityPattern::try_from_offsets_and_indices(n, n, col_offsets, row_indices)
            .expect("columns are sorted and in bounds by construction");
        Plan {
            pattern,
            order,
            starts,
        }
    }

    fn assemble(&self, values: &[f64]) -> CscMatrix<f64> {
        let sums = self
            .starts
            .windows(2)
            .map(|w| {
                let terms = &self.order[w[0]..w[1]];
                terms[1..]
                    .iter()
                    .fold(values[terms[0]], |sum, &k| sum + values[k])
            })
            .collect();
        CscMatrix::try_from_pattern_and_values(self.pattern.clone(), sums)
            .expect("one value per entry of the pattern")
    }
}

/// A plan's key: the matrix order and the triplets' rows and columns.
type Triplets = (usize, Vec<usize>, Vec<usize>);

thread_local! {
    /// This thread's plans.
    static PLANS: RefCell<Remembered<Triplets, Plan>> =
        const { RefCell::new(Remembered::new(REMEMBERED)) };
}

/// Sparse lower triangle (row ≥ col) of the symmetric n×n matrix with the triplets
/// `(rows[k], cols[k], values[k])`, duplicates summed; entries given above the diagonal are
/// mirrored below it. Same result, bit for bit, as bucketing a `CooMatrix` of the mirrored
/// triplets into a `CscMatrix`; the pattern's plan comes from this thread's remembered ones
/// when it is one of them (module header).
pub fn assemble_sparse_lower(
    n: usize,
    rows: &[usize],
    cols: &[usize],
    values: &[f64],
) -> CscMatrix<f64> {
    assert!(
        rows.len() == cols.len() && cols.len() == values.len(),
        "one row and column per value"
    );
    assert!(
        rows.iter().chain(cols).all(|&i| i < n),
        "triplet index out of bounds"
    );
    let plan = PLANS.with_borrow_mut(|plans| {
        plans.get_or_make(
            |(m, r, c)| *m == n && r == rows && c == cols,
            || {
                Ok::<_, std::convert::Infallible>((
                    (n, rows.to_vec(), cols.to_vec()),
                    Plan::new(n, rows, cols),
                ))
            },
        )
    });
    let Ok(plan) = plan;
    plan.assemble(values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra_sparse::CooMatrix;

    /// The reference conversion the plan reproduces.
    fn by_coo(n: usize, rows: &[usize], cols: &[usize], values: &[f64]) -> CscMatrix<f64> {
        let mut coo = CooMatrix::new(n, n);
        for ((&r, &c), &v) in rows.iter().zip(cols).zip(values) {
            let (r, c) = if r >= c { (r, c) } else { (c, r) };
            coo.push(r, c, v);
        }
        CscMatrix::from(&coo)
    }

    #[test]
    fn a_plan_sums_duplicates_like_the_coo_conversion_bit_for_bit() {
        // Many duplicates per entry in scrambled order, both triangles, values of mixed
        // magnitude so that a different summation order would show in the last bits.
        let n = 7;
        let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
        let mut state = 12345u64;
        for _ in 0..400 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            rows.push((state >> 33) as usize % n);
            cols.push((state >> 45) as usize % n);
            let mantissa = ((state >> 11) % 1_000_003) as f64 / 1_000_003.0 - 0.5;
            values.push(mantissa * 10f64.powi(((state >> 3) % 9) as i32 - 4));
        }
        for _ in 0..2 {
            // The second pass takes the remembered plan.
            let planned = assemble_sparse_lower(n, &rows, &cols, &values);
            let reference = by_coo(n, &rows, &cols, &values);
            assert_eq!(planned.col_offsets(), reference.col_offsets());
            assert_eq!(planned.row_indices(), reference.row_indices());
            let bits =
                |m: &CscMatrix<f64>| m.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&planned), bits(&reference));
        }
    }

    #[test]
    fn sparse_lower_mirrors_upper_entries() {
        let h = assemble_sparse_lower(3, &[0, 0, 2], &[0, 2, 2], &[1.0, 5.0, 2.0]);
        let t: Vec<_> = h.triplet_iter().map(|(r, c, &v)| (r, c, v)).collect();
        assert!(t.contains(&(2, 0, 5.0)));
        assert!(t.iter().all(|&(r, c, _)| r >= c));
    }

    #[test]
    fn new_values_on_a_remembered_pattern_and_another_pattern_both_assemble() {
        let first = assemble_sparse_lower(3, &[0, 0, 2, 2], &[0, 2, 2, 0], &[1.0, 5.0, 2.0, 1.0]);
        assert_eq!(first.get_entry(2, 0).unwrap().into_value(), 6.0);
        let again = assemble_sparse_lower(3, &[0, 0, 2, 2], &[0, 2, 2, 0], &[2.0, 1.0, 3.0, 1.0]);
        assert_eq!(again.get_entry(2, 0).unwrap().into_value(), 2.0);
        assert_eq!(again.get_entry(2, 2).unwrap().into_value(), 3.0);
        let other = assemble_sparse_lower(2, &[1], &[0], &[4.0]);
        assert_eq!(other.nnz(), 1);
        assert_eq!(other.get_entry(1, 0).unwrap().into_value(), 4.0);
        // An empty column and an empty matrix.
        let empty = assemble_sparse_lower(2, &[], &[], &[]);
        assert_eq!(empty.nnz(), 0);
    }
}
