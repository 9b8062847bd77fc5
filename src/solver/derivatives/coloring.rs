//! Column grouping of a sparse Jacobian (Curtis, Powell & Reid 1974).
//!
//! Two columns may share one perturbation when no row has a structural nonzero in both: the
//! difference of that row then belongs to exactly one column of the group. Finding few groups
//! is colouring the column-intersection graph; the greedy method gives each column, in order,
//! the smallest group none of whose columns meets it in a row (Coleman & Moré 1983 call this
//! the sequential algorithm). Columns are visited largest-degree first (ties by index), which
//! usually needs fewer groups than natural order, and the result is deterministic.
//!
//! The number of groups is at least the largest number of nonzeros in any row; a dense row
//! (such as an objective that depends on every variable) forces one group per column.

/// Columns partitioned into structurally orthogonal groups, each group sorted ascending.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColumnGroups {
    groups: Vec<Vec<usize>>,
}

impl ColumnGroups {
    /// One column per group (no sharing).
    pub fn singletons(n: usize) -> Self {
        ColumnGroups {
            groups: (0..n).map(|j| vec![j]).collect(),
        }
    }

    /// Greedy grouping of `n` columns from a pattern given as rows, each a list of columns
    /// (duplicates allowed).
    pub fn greedy(n: usize, rows: &[Vec<usize>]) -> Self {
        // Column → rows incidence.
        let mut col_rows: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (r, cols) in rows.iter().enumerate() {
            for &j in cols {
                if col_rows[j].last() != Some(&r) {
                    col_rows[j].push(r);
                }
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&j| (std::cmp::Reverse(col_rows[j].len()), j));

        const NONE: usize = usize::MAX;
        let mut group_of = vec![NONE; n];
        // forbidden[g] == j marks group g as taken by a neighbour of column j.
        let mut forbidden: Vec<usize> = Vec::new();
        let mut count = 0;
        for &j in &order {
            for &r in &col_rows[j] {
                for &k in &rows[r] {
                    let g = group_of[k];
                    if g != NONE {
                        forbidden[g] = j;
                    }
                }
            }
            let g = (0..count).find(|&g| forbidden[g] != j).unwrap_or(count);
            if g == count {
                count += 1;
                forbidden.push(NONE);
            }
            group_of[j] = g;
        }
        let mut groups = vec![Vec::new(); count];
        for (j, &g) in group_of.iter().enumerate() {
            groups[g].push(j);
        }
        ColumnGroups { groups }
    }

    /// The groups, each a sorted list of column indices.
    pub fn groups(&self) -> &[Vec<usize>] {
        &self.groups
    }

    /// Number of groups (perturbations per forward difference).
    pub fn len(&self) -> usize {
        self.groups.len()
    }

    /// Whether there are no columns at all.
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_orthogonal(groups: &ColumnGroups, n: usize, rows: &[Vec<usize>]) {
        let mut seen = vec![false; n];
        for g in groups.groups() {
            for &j in g {
                assert!(!seen[j], "column {j} in two groups");
                seen[j] = true;
            }
            for row in rows {
                let hits = g.iter().filter(|j| row.contains(j)).count();
                assert!(hits <= 1, "group {g:?} meets row {row:?} twice");
            }
        }
        assert!(seen.iter().all(|&s| s), "a column was left out");
    }

    #[test]
    fn tridiagonal_needs_three_groups() {
        let n = 10;
        let rows: Vec<Vec<usize>> = (0..n)
            .map(|i: usize| (i.saturating_sub(1)..(i + 2).min(n)).collect())
            .collect();
        let g = ColumnGroups::greedy(n, &rows);
        check_orthogonal(&g, n, &rows);
        assert_eq!(g.len(), 3);
    }

    #[test]
    fn dense_row_forces_singletons() {
        let rows = vec![vec![0, 1, 2, 3], vec![1]];
        let g = ColumnGroups::greedy(4, &rows);
        check_orthogonal(&g, 4, &rows);
        assert_eq!(g.len(), 4);
    }

    #[test]
    fn arrow_pattern_groups_are_orthogonal() {
        // Rows coupling x0 with each other variable, plus independent diagonal rows.
        let n = 8;
        let mut rows: Vec<Vec<usize>> = (1..n).map(|j| vec![0, j]).collect();
        rows.extend((0..n).map(|j| vec![j, j]));
        let g = ColumnGroups::greedy(n, &rows);
        check_orthogonal(&g, n, &rows);
        assert_eq!(g.len(), 2);
    }
}
