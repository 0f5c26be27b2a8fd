//! Small CSC helpers shared by the model, pencil and reduction code: symmetry check, lower
//! triangle extraction and its inverse (mirroring a lower triangle to full storage), compressed
//! columns filled entry by entry ([`Scatter`]). Products with the model's matrices are the
//! pencil's ([`crate::pencil::Pencil::mul`]).
//!
//! Matrices are faer [`SparseColMat<usize, f64>`] in full storage (both triangles) with sorted
//! row indices per column, as produced by `io::matrix_market::read_sparse` and `fe`.

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};

/// Full-storage real sparse matrix, the crate's matrix type.
pub type Csc = SparseColMat<usize, f64>;

/// Largest |a_ij − a_ji| over all entries (a missing entry counts as zero), and max |a_ij|,
/// of a square matrix with sorted columns.
///
/// One pass without a transpose: the upper entries (i, j), i < j, are met column by column,
/// so their mirrors (j, i) are met in increasing j within column i, and one cursor per column
/// walks its lower entries in step; a lower entry the cursor passes, or never reaches, has
/// no mirror.
pub fn asymmetry(a: SparseColMatRef<'_, usize, f64>) -> (f64, f64) {
    let n = a.ncols();
    let col = |j: usize| (a.symbolic().row_idx_of_col_raw(j), a.val_of_col(j));
    let mut cursor: Vec<usize> = (0..n)
        .map(|i| col(i).0.partition_point(|&r| r <= i))
        .collect();
    let max_abs = a.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut max_diff = 0.0f64;
    for j in 0..n {
        let (rows, vals) = col(j);
        for (&i, &v) in rows.iter().zip(vals).take_while(|(&i, _)| i < j) {
            let (mirror_rows, mirror_vals) = col(i);
            let c = &mut cursor[i];
            while *c < mirror_rows.len() && mirror_rows[*c] < j {
                max_diff = max_diff.max(mirror_vals[*c].abs());
                *c += 1;
            }
            if *c < mirror_rows.len() && mirror_rows[*c] == j {
                max_diff = max_diff.max((v - mirror_vals[*c]).abs());
                *c += 1;
            } else {
                max_diff = max_diff.max(v.abs());
            }
        }
    }
    for (i, &c) in cursor.iter().enumerate() {
        max_diff = col(i).1[c..].iter().fold(max_diff, |m, v| m.max(v.abs()));
    }
    (max_diff, max_abs)
}

/// The lower triangle (row ≥ column) of a full-storage matrix, as (col_ptr, row_idx, values).
pub fn lower_triangle(a: SparseColMatRef<'_, usize, f64>) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let n = a.ncols();
    let lower = (a.compute_nnz() + n) / 2;
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(lower);
    let mut val = Vec::with_capacity(lower);
    col_ptr.push(0);
    for j in 0..n {
        for (i, &v) in a
            .symbolic()
            .row_idx_of_col_raw(j)
            .iter()
            .zip(a.val_of_col(j))
        {
            if *i >= j {
                row_idx.push(*i);
                val.push(v);
            }
        }
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx, val)
}

/// Full storage (both triangles) of the symmetric matrix whose lower triangle (row ≥ column)
/// is the n×n CSC pattern `col_ptr`, `row_idx` (rows strictly increasing within each column),
/// as (col_ptr, row_idx, src): full entry `q` holds the value of lower entry `src[q]`.
///
/// Rows stay sorted within each column: column j gets the mirrored entries (j, i) of the
/// earlier columns i < j, in increasing i, then its own lower entries.
pub fn mirror_lower(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let lower = || (0..n).flat_map(|j| (col_ptr[j]..col_ptr[j + 1]).map(move |p| (p, j)));
    let mut scatter = Scatter::count(n, true, lower().map(|(p, j)| (row_idx[p], j)));
    let (mut full_row, mut src) = (vec![0usize; scatter.len()], vec![0usize; scatter.len()]);
    for (p, j) in lower() {
        scatter.put(row_idx[p], j, p, &mut full_row, &mut src);
    }
    (scatter.into_col_ptr(), full_row, src)
}

/// Compressed columns filled entry by entry: [`Self::count`] counts the entries (row,
/// column) of each column, [`Self::put`] then places each entry after those already put in
/// its column. With `mirror` an off-diagonal entry (r, c) is also placed at (c, r): a lower
/// triangle given column by column, rows increasing, comes out as full storage with sorted
/// columns (column c receives the rows i < c of the columns before it, in increasing i, then
/// its own).
pub struct Scatter {
    col_ptr: Vec<usize>,
    next: Vec<usize>,
    mirror: bool,
}

impl Scatter {
    /// The column pointers of `ncols` columns holding `entries` (row, column), mirrored or not.
    pub fn count(
        ncols: usize,
        mirror: bool,
        entries: impl IntoIterator<Item = (usize, usize)>,
    ) -> Self {
        let mut col_ptr = vec![0usize; ncols + 1];
        for (r, c) in entries {
            col_ptr[c + 1] += 1;
            if mirror && r != c {
                col_ptr[r + 1] += 1;
            }
        }
        for j in 0..ncols {
            col_ptr[j + 1] += col_ptr[j];
        }
        let next = col_ptr[..ncols].to_vec();
        Scatter {
            col_ptr,
            next,
            mirror,
        }
    }

    /// Stored entries in all: the length of the row and item arrays [`Self::put`] fills.
    pub fn len(&self) -> usize {
        self.col_ptr[self.col_ptr.len() - 1]
    }

    /// True when no entry was counted.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Puts entry (r, c) with `item` into `rows`/`items` at its column's next place, and its
    /// mirror (c, r) when mirroring. Every entry counted is put exactly once.
    pub fn put<T: Copy>(
        &mut self,
        r: usize,
        c: usize,
        item: T,
        rows: &mut [usize],
        items: &mut [T],
    ) {
        let mut place = |r: usize, c: usize| {
            let p = self.next[c];
            (rows[p], items[p]) = (r, item);
            self.next[c] += 1;
        };
        place(r, c);
        if self.mirror && r != c {
            place(c, r);
        }
    }

    /// The column pointers.
    pub fn into_col_ptr(self) -> Vec<usize> {
        self.col_ptr
    }
}

/// Builds a CSC matrix from parts that are known to be valid (sorted, in range).
///
/// # Errors
/// None in practice; the parts are checked by faer (a violation is a programming error).
pub fn from_parts(
    n_rows: usize,
    n_cols: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
) -> Csc {
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(n_rows, n_cols, col_ptr, None, row_idx),
        val,
    )
}

/// Coordinate entries (0-based row, column, value) collected by the importers before the
/// CSC matrix is assembled ([`Triplets::into_csc`]).
#[derive(Clone, Debug, Default)]
pub struct Triplets {
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl Triplets {
    /// Appends one entry; the caller has checked the indices against the final size.
    pub fn push(&mut self, row: usize, col: usize, val: f64) {
        self.rows.push(row);
        self.cols.push(col);
        self.vals.push(val);
    }

    /// Number of entries pushed.
    pub fn len(&self) -> usize {
        self.vals.len()
    }

    /// True when no entry was pushed.
    pub fn is_empty(&self) -> bool {
        self.vals.is_empty()
    }

    /// Largest row and column index + 1 (0 when empty): the smallest size that holds them.
    pub fn extent(&self) -> usize {
        let m = |v: &[usize]| v.iter().max().map_or(0, |&x| x + 1);
        m(&self.rows).max(m(&self.cols))
    }

    /// Counts of strictly lower (row > column) and strictly upper (row < column) entries.
    pub fn triangles(&self) -> (usize, usize) {
        let lower = self
            .rows
            .iter()
            .zip(&self.cols)
            .filter(|(r, c)| r > c)
            .count();
        let upper = self
            .rows
            .iter()
            .zip(&self.cols)
            .filter(|(r, c)| r < c)
            .count();
        (lower, upper)
    }

    /// Renumbers rows and columns through `f` (a permutation or an injection into 0..n).
    pub fn map_indices(&mut self, f: impl Fn(usize) -> usize) {
        self.rows
            .iter_mut()
            .chain(&mut self.cols)
            .for_each(|i| *i = f(*i));
    }

    /// True when every entry is on the diagonal (a lumped matrix).
    pub fn is_diagonal(&self) -> bool {
        self.rows.iter().zip(&self.cols).all(|(r, c)| r == c)
    }

    /// Canonical `n × n` CSC (rows sorted, duplicates summed in push order). With `mirror`,
    /// every off-diagonal entry is stored a second time transposed: one stored triangle
    /// becomes full storage. Indices must be < n (checked by the caller while parsing).
    pub fn into_csc(self, n: usize, mirror: bool) -> Csc {
        let Triplets { rows, cols, vals } = self;
        let mut scatter = Scatter::count(n, mirror, rows.iter().copied().zip(cols.iter().copied()));
        let (mut row_idx, mut val) = (vec![0usize; scatter.len()], vec![0f64; scatter.len()]);
        for ((&r, &c), &v) in rows.iter().zip(&cols).zip(&vals) {
            scatter.put(r, c, v, &mut row_idx, &mut val);
        }
        let count = scatter.into_col_ptr();
        drop((rows, cols, vals));
        // Sort each column by row (stable: duplicates keep push order) and sum duplicates.
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut out = 0;
        let mut pairs: Vec<(usize, f64)> = Vec::new();
        for j in 0..n {
            let (a, b) = (count[j], count[j + 1]);
            pairs.clear();
            pairs.extend(row_idx[a..b].iter().copied().zip(val[a..b].iter().copied()));
            if !pairs.windows(2).all(|w| w[0].0 < w[1].0) {
                pairs.sort_by_key(|p| p.0);
            }
            for &(r, v) in &pairs {
                if out > col_ptr[j] && row_idx[out - 1] == r {
                    val[out - 1] += v;
                } else {
                    row_idx[out] = r;
                    val[out] = v;
                    out += 1;
                }
            }
            col_ptr.push(out);
        }
        row_idx.truncate(out);
        val.truncate(out);
        from_parts(n, n, col_ptr, row_idx, val)
    }
}

/// a M + b K + E of full-storage matrices, entry by entry in that order (full storage): each
/// column the merge of the three sorted columns, an entry's terms summed as a M, then b K,
/// then E, without a sort (the 0.76 M-DoF crank's coupled matrices have 0.3 G entries).
pub fn linear_combination(a: f64, m: &Csc, b: f64, k: &Csc, e: Option<&Csc>) -> Csc {
    let n = m.ncols();
    let terms: Vec<(&Csc, f64)> = [(Some(m), a), (Some(k), b), (e, 1.0)]
        .into_iter()
        .filter_map(|(x, s)| x.map(|x| (x, s)))
        .collect();
    let bound: usize = terms.iter().map(|(x, _)| x.compute_nnz()).sum();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(bound);
    let mut val = Vec::with_capacity(bound);
    col_ptr.push(0);
    let mut at = vec![0usize; terms.len()];
    let mut cols: Vec<(&[usize], &[f64])> = Vec::with_capacity(terms.len());
    for j in 0..n {
        cols.clear();
        cols.extend(
            terms
                .iter()
                .map(|(x, _)| (x.symbolic().row_idx_of_col_raw(j), x.val_of_col(j))),
        );
        at.iter_mut().for_each(|p| *p = 0);
        // the next row: the least one not yet taken from any of the columns
        while let Some(i) = cols
            .iter()
            .zip(&at)
            .filter_map(|((r, _), &p)| r.get(p))
            .min()
        {
            let i = *i;
            let mut sum: Option<f64> = None;
            for (((rows, vals), p), (_, scale)) in cols.iter().zip(at.iter_mut()).zip(&terms) {
                if rows.get(*p) == Some(&i) {
                    let v = scale * vals[*p];
                    sum = Some(sum.map_or(v, |s| s + v));
                    *p += 1;
                }
            }
            row_idx.push(i);
            val.push(sum.unwrap_or(0.0));
        }
        col_ptr.push(row_idx.len());
    }
    from_parts(n, n, col_ptr, row_idx, val)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    #[test]
    fn mirror_lower_inverts_lower_triangle() {
        // Symmetric 4x4 with an empty column 2 and a zero-free diagonal elsewhere.
        let entries = [
            (0, 0, 4.0),
            (1, 0, -1.0),
            (3, 0, 0.5),
            (1, 1, 3.0),
            (3, 1, 2.0),
            (3, 3, 1.0),
        ];
        let mut dense = Mat::<f64>::zeros(4, 4);
        for &(i, j, v) in &entries {
            dense[(i, j)] = v;
            dense[(j, i)] = v;
        }
        let mut col_ptr = vec![0usize; 5];
        for &(_, j, _) in &entries {
            col_ptr[j + 1] += 1;
        }
        for j in 0..4 {
            col_ptr[j + 1] += col_ptr[j];
        }
        let row_idx: Vec<usize> = entries.iter().map(|e| e.0).collect();
        let val: Vec<f64> = entries.iter().map(|e| e.2).collect();
        let (cp, ri, src) = mirror_lower(4, &col_ptr, &row_idx);
        let full = from_parts(4, 4, cp, ri, src.iter().map(|&p| val[p]).collect());
        assert_eq!(full.compute_nnz(), 9);
        assert_eq!(full.to_dense(), dense);
        let (lcp, lri, lval) = lower_triangle(full.as_ref());
        assert_eq!((lcp, lri, lval), (col_ptr, row_idx, val));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The asymmetry is max |A − Aᵀ| and max |A| of the dense matrix, for patterns with
        /// and without mirrors and values with and without differences.
        #[test]
        fn asymmetry_is_that_of_the_dense_matrix(
            n in 1usize..25,
            density in 0.0f64..0.6,
            seed in 1u64..1000,
        ) {
            let mut rng = crate::random::Xorshift::new(seed);
            let mut t = Triplets::default();
            for j in 0..n {
                for i in 0..n {
                    let u = rng.next_centred() + 0.5;
                    if u < density {
                        // a third of the entries mirrored to the bit, the rest perturbed or alone
                        let v = rng.next_centred();
                        t.push(i, j, v);
                        if i > j && u < density / 3.0 {
                            t.push(j, i, v);
                        } else if i > j && u < 2.0 * density / 3.0 {
                            t.push(j, i, v + 1e-3 * rng.next_centred());
                        }
                    }
                }
            }
            let a = t.into_csc(n, false);
            let d = a.to_dense();
            let dt = d.transpose().to_owned();
            let (diff, max) = asymmetry(a.as_ref());
            proptest::prop_assert_eq!(diff, (&d - &dt).norm_max());
            proptest::prop_assert_eq!(max, d.norm_max());
        }
    }

    /// a M + b K + E has the union pattern and, entry by entry, the dense sums in that order.
    #[test]
    fn linear_combination_is_the_dense_one_on_the_union_pattern() {
        let mut rng = crate::random::Xorshift::new(5);
        let n = 9;
        let mut random = |density: f64| {
            let mut t = Triplets::default();
            for j in 0..n {
                for i in j..n {
                    if i == j || rng.next_centred() + 0.5 < density {
                        t.push(i, j, rng.next_centred());
                    }
                }
            }
            t.into_csc(n, true)
        };
        let (m, k, e) = (random(0.3), random(0.5), random(0.2));
        let (a, b) = (-0.7, 1.3);
        let sum = linear_combination(a, &m, b, &k, Some(&e));
        let (dm, dk, de) = (m.to_dense(), k.to_dense(), e.to_dense());
        let ds = sum.to_dense();
        for j in 0..n {
            let rows = sum.symbolic().row_idx_of_col_raw(j);
            assert!(rows.windows(2).all(|w| w[0] < w[1]), "column {j} sorted");
            for i in 0..n {
                let stored = rows.contains(&i);
                let any = [&dm, &dk, &de].iter().any(|x| x[(i, j)] != 0.0);
                assert_eq!(stored, any, "({i}, {j}) in the union pattern");
                assert_eq!(ds[(i, j)], (a * dm[(i, j)] + b * dk[(i, j)]) + de[(i, j)]);
            }
        }
        let without = linear_combination(a, &m, b, &k, None).to_dense();
        assert_eq!(
            without,
            Mat::from_fn(n, n, |i, j| a * dm[(i, j)] + b * dk[(i, j)])
        );
    }
}
