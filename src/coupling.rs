//! Remote points and general outputs as a change of variables of the model (docs/design.md
//! §3.11): the joints of a multibody model attach to a reference point coupled to a set of
//! nodes, and an output may be any functional y = c q. Both become single coordinates of a
//! congruent model M' = TᵀMT, K' = TᵀKT, D' = TᵀDT, so every reductor, export and check that
//! works on DoFs works on them unchanged.
//!
//! **Rigid motion of a point.** A node at offset r = x − x_ref from the reference point moves
//! with the point's rigid motion x_ref = (t, θ) as u = t + θ × r = G(r) x_ref, G(r) = [I, −[r]×]
//! (3 × 6).
//!
//! **Rigid coupling (RBE2, kinematic).** Every coupled node follows the point: u_i = G(r_i)
//! x_ref (and, on a model with rotational DoFs, θ_i = θ). The coupled nodes' DoFs are
//! eliminated: q = T z with z the other DoFs in their order followed by the six DoFs of each
//! point, so K' = TᵀKT is the constrained stiffness (the coupling is a constraint and adds
//! stiffness) and a force on the point acts on the surface through Tᵀ, as a Lagrange
//! multiplier would carry it ([`rigid_elimination`]).
//!
//! **Distributing coupling (RBE3).** The point's motion is the weighted least-squares rigid
//! motion of its nodes' translations: x_ref = argmin Σ w_i ‖u_i − G(r_i) x‖², i.e.
//! x_ref = A⁻¹ Σ w_i G(r_i)ᵀ u_i with A = Σ w_i G(r_i)ᵀ G(r_i) (6 × 6), six functionals W q
//! ([`distributing_rows`]); a force on the point spreads over the nodes as Wᵀ, the transpose
//! of the same map (virtual work), and the coupling adds no stiffness. A rotation is defined
//! only when the nodes do not lie on one line (A is then nonsingular).
//!
//! **Functionals as coordinates.** Rows c_1 … c_r (RBE3 points, general outputs) become
//! coordinates by the change of variables FE codes use to eliminate multipoint constraints:
//! one pivot DoF p_k per row, chosen by Gaussian elimination with complete pivoting on the
//! rows' support, and z = S q with S the identity whose rows p_k are replaced by c_k. Then
//! q = T z with T = S⁻¹, which differs from the identity only in the pivot rows:
//! q_P = W_PP⁻¹ (z_P − W_{·R} q_R), R the rest of the support ([`functionals_as_coordinates`]).
//! Since S T = I, e_pᵀ T⁻¹ = c_k, so the transformed model's response at the pivots to
//! unit loads at the pivots is C A⁻¹ Cᵀ: the functionals' transfer function, exactly. Nothing
//! is dense but the r × |support| block of the rows.

use crate::sparse::{from_parts, Csc, Scatter};
use crate::{Error, Result};
use faer::linalg::solvers::Solve;

/// How a remote point is tied to its nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// RBE2 / kinematic: the nodes follow the point's rigid motion (a constraint).
    Rigid,
    /// RBE3 / distributing: the point moves as the weighted least-squares rigid motion of the
    /// nodes; forces on it spread over them; no added stiffness.
    Distributing,
}

/// A reference point with six DoFs (x, y, z, rx, ry, rz) coupled to a set of nodes.
#[derive(Clone, Debug)]
pub struct RemotePoint {
    /// Its name (`POINT:DIR` in a scene).
    pub name: String,
    /// The reference position.
    pub position: [f64; 3],
    /// The coupled nodes (indices into the model's nodes).
    pub nodes: Vec<usize>,
    /// One weight per node (RBE3); empty = equal weights.
    pub weights: Vec<f64>,
    /// Rigid or distributing.
    pub kind: Kind,
}

/// A sparse row vector c: the functional y = c q.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseRow {
    /// Column indices, increasing.
    pub idx: Vec<usize>,
    /// Values.
    pub val: Vec<f64>,
}

/// The change of variables q = T z of a coupled model.
#[derive(Clone, Debug)]
pub struct Change {
    /// T (old size × new size).
    pub t: Csc,
    /// The coordinates of z the couplings introduced: each RBE2 point's six DoFs, or each
    /// functional's pivot, in the order given.
    pub coordinates: Vec<usize>,
}

/// G(r) = [I, −[r]×]: the translation of a node at offset `r` under the rigid motion (t, θ).
fn rigid_rows(r: [f64; 3]) -> [[f64; 6]; 3] {
    [
        [1.0, 0.0, 0.0, 0.0, r[2], -r[1]],
        [0.0, 1.0, 0.0, -r[2], 0.0, r[0]],
        [0.0, 0.0, 1.0, r[1], -r[0], 0.0],
    ]
}

/// The point's nodes checked (non-empty, in range, distinct from the reference position) and
/// their offsets from it.
fn offsets(p: &RemotePoint, nodes: &[[f64; 3]]) -> Result<Vec<[f64; 3]>> {
    let bad = |what: String| Error::InvalidSetting(format!("remote point {}: {what}", p.name));
    if p.nodes.is_empty() {
        return Err(bad(
            "its node set is empty; select the nodes of the surface it ties to".into(),
        ));
    }
    if !p.weights.is_empty() && p.weights.len() != p.nodes.len() {
        return Err(bad(format!(
            "{} weights for {} nodes; give one weight per node or none",
            p.weights.len(),
            p.nodes.len()
        )));
    }
    if let Some(w) = p.weights.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
        return Err(bad(format!("weight {w}: weights must be finite and > 0")));
    }
    let mut sorted = p.nodes.clone();
    sorted.sort_unstable();
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(bad(format!("node {} is listed twice", w[0])));
    }
    if !p.position.iter().all(|v| v.is_finite()) {
        return Err(bad(format!("position {:?} is not finite", p.position)));
    }
    let mut r = Vec::with_capacity(p.nodes.len());
    for &i in &p.nodes {
        let x = nodes.get(i).ok_or_else(|| {
            bad(format!(
                "node {i} is out of range (the model has {} nodes)",
                nodes.len()
            ))
        })?;
        r.push([
            x[0] - p.position[0],
            x[1] - p.position[1],
            x[2] - p.position[2],
        ]);
    }
    // the size of the set, to judge a coincidence and a line relative to it
    let size = r
        .iter()
        .map(|d| d.iter().map(|v| v * v).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    for (d, &i) in r.iter().zip(&p.nodes) {
        let dist = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        if dist <= 1e-9 * size.max(f64::MIN_POSITIVE) {
            return Err(bad(format!(
                "its reference position coincides with coupled node {i}; place the point off \
                 the surface (e.g. on the bore's axis) or leave that node out of the set"
            )));
        }
    }
    Ok(r)
}

/// The weighted least-squares rigid fit of a point's nodes (module doc): the offsets r_i, the
/// scaled rows G(r_i) (rotations times 1/ℓ, ℓ the set's mean radius, so A compares lengths
/// with lengths) and A⁻¹ in unscaled rotations (its rows 3..6 divided by ℓ).
struct Fit {
    r: Vec<[f64; 3]>,
    scale: f64,
    inv: faer::Mat<f64>,
}

impl Fit {
    /// # Errors
    /// As [`offsets`], and the nodes on one line (A singular: no rotation about it).
    fn new(p: &RemotePoint, nodes: &[[f64; 3]]) -> Result<Self> {
        let r = offsets(p, nodes)?;
        let scale = r
            .iter()
            .map(|d| d.iter().map(|v| v * v).sum::<f64>().sqrt())
            .sum::<f64>()
            / r.len() as f64;
        let mut a = faer::Mat::<f64>::zeros(6, 6);
        for (k, d) in r.iter().enumerate() {
            let gk = scaled_rows(*d, scale);
            for i in 0..6 {
                for j in 0..6 {
                    a[(i, j)] += weight(p, k) * (0..3).map(|m| gk[m][i] * gk[m][j]).sum::<f64>();
                }
            }
        }
        let (values, vectors) = crate::dense::sym_eigen(a.as_ref()).ok_or_else(|| {
            Error::InvalidSetting(format!(
                "remote point {}: its 6 × 6 normal matrix has no eigendecomposition",
                p.name
            ))
        })?;
        if !(values[0] > 1e-10 * values[5]) {
            return Err(Error::InvalidSetting(format!(
                "remote point {}: its {} nodes lie on one line (or are one point), so a \
                 rotation about that line moves none of them and rx, ry, rz are undefined; add \
                 nodes off the line",
                p.name,
                p.nodes.len()
            )));
        }
        // A⁻¹ = V Λ⁻¹ Vᵀ, then unscale the rotation rows (θ = θ'/ℓ)
        let inv = faer::Mat::<f64>::from_fn(6, 6, |i, j| {
            let s: f64 = (0..6)
                .map(|k| vectors[(i, k)] * vectors[(j, k)] / values[k])
                .sum();
            s / if i >= 3 { scale } else { 1.0 }
        });
        Ok(Fit { r, scale, inv })
    }
}

/// Node k's weight (1 when the point gives none).
fn weight(p: &RemotePoint, k: usize) -> f64 {
    p.weights.get(k).copied().unwrap_or(1.0)
}

/// G(r) with its rotation columns divided by `scale` (θ' = θ·scale).
fn scaled_rows(d: [f64; 3], scale: f64) -> [[f64; 6]; 3] {
    let mut g = rigid_rows(d);
    for row in &mut g {
        for v in &mut row[3..] {
            *v /= scale;
        }
    }
    g
}

/// The six functionals of an RBE3 point's motion (x, y, z, rx, ry, rz) in the DoFs of a
/// model whose node i owns DoFs `dofs_per_node·i + d` (translations d = 0, 1, 2): the weighted
/// least-squares rigid motion of its nodes (module doc). Rotations are scaled by the set's
/// mean radius while A is solved, so its condition number compares lengths with lengths.
///
/// # Errors
/// [`Error::InvalidSetting`] naming the point: an empty node set, a node out of range, a
/// weight count that does not match, a non-positive weight, the reference position on a
/// coupled node, or nodes on one line (no rotation about it is defined).
pub fn distributing_rows(
    p: &RemotePoint,
    nodes: &[[f64; 3]],
    dofs_per_node: usize,
) -> Result<[SparseRow; 6]> {
    let Fit { r, scale, inv } = Fit::new(p, nodes)?;
    let mut order: Vec<usize> = (0..p.nodes.len()).collect();
    order.sort_by_key(|&k| p.nodes[k]);
    let mut rows: [SparseRow; 6] = Default::default();
    for &k in &order {
        let gk = scaled_rows(r[k], scale);
        for m in 0..3 {
            let col = dofs_per_node * p.nodes[k] + m;
            for (i, row) in rows.iter_mut().enumerate() {
                let v: f64 = (0..6).map(|j| inv[(i, j)] * gk[m][j]).sum::<f64>() * weight(p, k);
                row.idx.push(col);
                row.val.push(v);
            }
        }
    }
    Ok(rows)
}

/// The elimination of RBE2 points' coupled nodes (module doc): q = T z with z the model's
/// other DoFs in their order, then each point's six DoFs. A model with `dofs_per_node` = 6
/// also ties the nodes' rotations to the point's.
///
/// # Errors
/// [`Error::InvalidSetting`]: as [`distributing_rows`] for each point's node set (a line of
/// nodes only on a model with rotational DoFs, whose nodes' rotations then fix the point's),
/// and a node coupled by two rigid points (each would constrain it: the second overconstrains
/// it).
pub fn rigid_elimination(
    points: &[RemotePoint],
    nodes: &[[f64; 3]],
    dofs_per_node: usize,
) -> Result<Change> {
    let n = nodes.len() * dofs_per_node;
    let mut owner = vec![usize::MAX; nodes.len()];
    let mut offs = Vec::with_capacity(points.len());
    for (k, p) in points.iter().enumerate() {
        // without rotational DoFs a line of nodes leaves the point's rotation about it with
        // neither mass nor stiffness (a singular M'), so the fit's check applies
        offs.push(if dofs_per_node == 6 {
            offsets(p, nodes)?
        } else {
            Fit::new(p, nodes)?.r
        });
        for &i in &p.nodes {
            if owner[i] != usize::MAX {
                return Err(Error::InvalidSetting(format!(
                    "remote points {} and {}: both rigidly couple node {i}, which \
                     overconstrains it; couple it to one of them (or make one distributing)",
                    points[owner[i]].name, p.name
                )));
            }
            owner[i] = k;
        }
    }
    // new index of each kept DoF
    let mut new_of = vec![usize::MAX; n];
    let mut kept = 0;
    for (q, slot) in new_of.iter_mut().enumerate() {
        if owner[q / dofs_per_node] == usize::MAX {
            *slot = kept;
            kept += 1;
        }
    }
    let ref_dof = |k: usize, d: usize| kept + 6 * k + d;
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); kept + 6 * points.len()];
    for (q, &z) in new_of.iter().enumerate() {
        if z != usize::MAX {
            cols[z].push((q, 1.0));
        }
    }
    for (k, (p, r)) in points.iter().zip(&offs).enumerate() {
        for (&i, d) in p.nodes.iter().zip(r) {
            let g = rigid_rows(*d);
            for (m, gm) in g.iter().enumerate() {
                for (j, &v) in gm.iter().enumerate() {
                    if v != 0.0 {
                        cols[ref_dof(k, j)].push((dofs_per_node * i + m, v));
                    }
                }
            }
            if dofs_per_node == 6 {
                for m in 3..6 {
                    cols[ref_dof(k, m)].push((6 * i + m, 1.0));
                }
            }
        }
    }
    let coordinates = (0..6 * points.len()).map(|j| kept + j).collect();
    Ok(Change {
        t: from_columns(n, cols),
        coordinates,
    })
}

/// The change of variables that makes each row a coordinate (module doc): pivots by complete
/// pivoting on the rows' support, T = S⁻¹. `coordinates[k]` is row k's pivot.
///
/// # Errors
/// [`Error::InvalidSetting`] when a row is empty or out of range (`n` columns), or the rows
/// are linearly dependent to rounding (`what` names them, e.g. "outputs").
pub fn functionals_as_coordinates(rows: &[SparseRow], n: usize, what: &str) -> Result<Change> {
    let mut support: Vec<usize> = rows.iter().flat_map(|r| r.idx.iter().copied()).collect();
    support.sort_unstable();
    support.dedup();
    if let Some(&c) = support.last().filter(|&&c| c >= n) {
        return Err(Error::InvalidSetting(format!(
            "{what}: column {c} is out of range (the model has {n} DoFs)"
        )));
    }
    let pos = |c: usize| support.binary_search(&c).unwrap_or(usize::MAX);
    let (r, s) = (rows.len(), support.len());
    let mut w = faer::Mat::<f64>::zeros(r, s);
    for (i, row) in rows.iter().enumerate() {
        if row.idx.is_empty() || row.val.iter().all(|v| *v == 0.0) {
            return Err(Error::InvalidSetting(format!(
                "{what}: row {i} is zero; every functional needs a nonzero entry"
            )));
        }
        for (&c, &v) in row.idx.iter().zip(&row.val) {
            if !v.is_finite() {
                return Err(Error::InvalidSetting(format!(
                    "{what}: row {i} has the non-finite value {v} at column {c}"
                )));
            }
            w[(i, pos(c))] += v;
        }
    }
    // complete pivoting on a copy: pivot column (in the support) of each row
    let mut e = w.clone();
    let scale = (0..s)
        .flat_map(|j| (0..r).map(move |i| (i, j)))
        .map(|(i, j)| e[(i, j)].abs())
        .fold(0.0, f64::max);
    let mut row_done = vec![false; r];
    let mut col_done = vec![false; s];
    let mut pivot_of_row = vec![0usize; r];
    for _ in 0..r {
        let mut best = (0.0, 0, 0);
        for i in (0..r).filter(|&i| !row_done[i]) {
            for j in (0..s).filter(|&j| !col_done[j]) {
                if e[(i, j)].abs() > best.0 {
                    best = (e[(i, j)].abs(), i, j);
                }
            }
        }
        let (piv, i, j) = best;
        if !(piv > 1e-12 * scale) {
            return Err(Error::InvalidSetting(format!(
                "{what}: the {r} functionals are linearly dependent (to rounding); give \
                 independent rows"
            )));
        }
        row_done[i] = true;
        col_done[j] = true;
        pivot_of_row[i] = j;
        for k in (0..r).filter(|&k| !row_done[k]) {
            let f = e[(k, j)] / e[(i, j)];
            if f != 0.0 {
                for c in 0..s {
                    let v = e[(i, c)];
                    e[(k, c)] -= f * v;
                }
            }
        }
    }
    // T's pivot rows: [W_PP⁻¹, −W_PP⁻¹ W_R] over the support
    let w_pp = faer::Mat::<f64>::from_fn(r, r, |i, k| w[(i, pivot_of_row[k])]);
    let lu = w_pp.partial_piv_lu();
    let rhs = faer::Mat::<f64>::from_fn(r, s, |i, c| {
        if col_done[c] {
            // z_P's coefficients: the identity, placed at the pivots' own columns
            f64::from(pivot_of_row[i] == c)
        } else {
            -w[(i, c)]
        }
    });
    // rows k of W_PP⁻¹ ·: q_{pivot k} in terms of z over the support
    let sol = lu.solve(&rhs);
    let is_pivot: Vec<bool> = {
        let mut v = vec![false; n];
        for &j in &pivot_of_row {
            v[support[j]] = true;
        }
        v
    };
    let mut cols: Vec<Vec<(usize, f64)>> = (0..n)
        .map(|j| {
            if is_pivot[j] {
                Vec::new()
            } else {
                vec![(j, 1.0)]
            }
        })
        .collect();
    for (c, &col) in support.iter().enumerate() {
        for k in 0..r {
            let v = sol[(k, c)];
            if v != 0.0 {
                cols[col].push((support[pivot_of_row[k]], v));
            }
        }
    }
    for col in &mut cols {
        col.sort_unstable_by_key(|e| e.0);
    }
    Ok(Change {
        t: from_columns(n, cols),
        coordinates: pivot_of_row.iter().map(|&j| support[j]).collect(),
    })
}

/// A CSC matrix of `rows` rows from its columns' (row, value) entries (rows increasing).
fn from_columns(rows: usize, cols: Vec<Vec<(usize, f64)>>) -> Csc {
    let mut ptr = vec![0usize];
    let (mut idx, mut val) = (Vec::new(), Vec::new());
    for mut c in cols {
        c.sort_unstable_by_key(|e| e.0);
        for (i, v) in c {
            idx.push(i);
            val.push(v);
        }
        ptr.push(idx.len());
    }
    from_parts(rows, ptr.len() - 1, ptr, idx, val)
}

/// TᵀAT of a symmetric A (N × N, both triangles stored) and T (N × n), exactly symmetric:
/// its lower triangle is computed and mirrored (docs/design.md §3.11).
///
/// Column j of the lower triangle is (Tᵀ y)_{i ≥ j} with y = A t_j: y is gathered from the
/// columns of A that t_j touches, then every entry y_r is spread along row r of T from
/// column j on. Both steps accumulate in dense scratch vectors with a list of the entries
/// touched, so the work is the number of products that reach the lower triangle and no
/// intermediate matrix (A T, or the full product) is formed. Columns are computed in
/// chunks on the current thread pool; each column's sums run in one fixed order, so the
/// result does not depend on the number of threads.
///
/// # Errors
/// [`Error::InvalidSetting`] when the sizes disagree; [`Error::Factor`] when T's row
/// storage cannot be formed.
pub fn congruence(a: &Csc, t: &Csc) -> Result<Csc> {
    congruence_in_chunks(a, t, 1024)
}

/// [`congruence`] with the columns computed `chunk` at a time.
fn congruence_in_chunks(a: &Csc, t: &Csc, chunk: usize) -> Result<Csc> {
    use rayon::prelude::*;
    let (n, m) = (t.nrows(), t.ncols());
    if a.nrows() != n || a.ncols() != n {
        return Err(Error::InvalidSetting(format!(
            "coupled model: a {} x {} matrix and a change of variables of {n} rows",
            a.nrows(),
            a.ncols()
        )));
    }
    // T by rows: column r of Tᵀ holds row r of T, its columns increasing
    let rows_of_t = t
        .as_ref()
        .transpose()
        .to_col_major()
        .map_err(|e| Error::Factor(format!("coupled model: {e:?}")))?;
    let (a, t, tr) = (a.as_ref(), t.as_ref(), rows_of_t.as_ref());
    let chunks: Vec<Lower> = (0..m.div_ceil(chunk))
        .into_par_iter()
        .map_init(
            || Scratch::new(n, m),
            |s, c| {
                let mut out = Lower::new(c * chunk);
                for j in c * chunk..((c + 1) * chunk).min(m) {
                    s.column(a, t, tr, j, &mut out);
                }
                out.rows.shrink_to_fit();
                out.vals.shrink_to_fit();
                out
            },
        )
        .collect();
    Ok(mirrored(m, chunks))
}

/// The full storage of the symmetric m × m matrix whose lower triangle's columns are those
/// of `chunks` in order: each entry (i, j), i > j, is also put at (j, i). Column c receives
/// the rows j < c from the columns before it, in increasing j, and then its own rows ≥ c,
/// so every column comes out sorted. Each chunk is freed once it is spread.
fn mirrored(m: usize, chunks: Vec<Lower>) -> Csc {
    let lower = chunks
        .iter()
        .flat_map(Lower::columns)
        .flat_map(|(j, rows, _)| rows.iter().map(move |&i| (i, j)));
    let mut scatter = Scatter::count(m, true, lower);
    let (mut row_idx, mut val) = (vec![0usize; scatter.len()], vec![0.0; scatter.len()]);
    for chunk in chunks {
        for (j, rows, vals) in chunk.columns() {
            for (&i, &v) in rows.iter().zip(vals) {
                scatter.put(i, j, v, &mut row_idx, &mut val);
            }
        }
    }
    from_parts(m, m, scatter.into_col_ptr(), row_idx, val)
}

/// Consecutive columns of a lower triangle, from column `first`: each column's end in
/// `rows`/`vals`.
struct Lower {
    first: usize,
    ends: Vec<usize>,
    rows: Vec<usize>,
    vals: Vec<f64>,
}

impl Lower {
    fn new(first: usize) -> Self {
        Lower {
            first,
            ends: Vec::new(),
            rows: Vec::new(),
            vals: Vec::new(),
        }
    }

    /// (column, rows, values) of each column.
    fn columns(&self) -> impl Iterator<Item = (usize, &[usize], &[f64])> {
        (0..self.ends.len()).map(move |k| {
            let range = if k == 0 { 0 } else { self.ends[k - 1] }..self.ends[k];
            (self.first + k, &self.rows[range.clone()], &self.vals[range])
        })
    }
}

/// A sparse vector accumulated in dense storage: the values, the entries touched (in the
/// order first touched) and, per entry, the column that touched it last (`usize::MAX`:
/// none yet), so that starting the next column costs nothing.
struct Accumulator {
    val: Vec<f64>,
    mark: Vec<usize>,
    touched: Vec<usize>,
}

impl Accumulator {
    fn new(n: usize) -> Self {
        Accumulator {
            val: vec![0.0; n],
            mark: vec![usize::MAX; n],
            touched: Vec::new(),
        }
    }

    /// Entry i += v, for column j.
    fn add(&mut self, i: usize, v: f64, j: usize) {
        if self.mark[i] != j {
            self.mark[i] = j;
            self.val[i] = 0.0;
            self.touched.push(i);
        }
        self.val[i] += v;
    }
}

/// One thread's accumulators for [`congruence`]: y = A t_j over A's rows and z = Tᵀy over
/// T's columns.
struct Scratch {
    y: Accumulator,
    z: Accumulator,
}

impl Scratch {
    fn new(n: usize, m: usize) -> Self {
        Scratch {
            y: Accumulator::new(n),
            z: Accumulator::new(m),
        }
    }

    /// Appends column j of the lower triangle of TᵀAT to `out` (`tr` = T by rows).
    fn column(
        &mut self,
        a: faer::sparse::SparseColMatRef<'_, usize, f64>,
        t: faer::sparse::SparseColMatRef<'_, usize, f64>,
        tr: faer::sparse::SparseColMatRef<'_, usize, f64>,
        j: usize,
        out: &mut Lower,
    ) {
        let (y, z) = (&mut self.y, &mut self.z);
        y.touched.clear();
        for (k, &tkj) in t.row_idx_of_col(j).zip(t.val_of_col(j)) {
            for (r, &ark) in a.row_idx_of_col(k).zip(a.val_of_col(k)) {
                y.add(r, ark * tkj, j);
            }
        }
        z.touched.clear();
        let (idx, val) = (tr.row_idx(), tr.val());
        for &r in &y.touched {
            let range = tr.col_range(r);
            let from = range.start + idx[range.clone()].partition_point(|&i| i < j);
            for (&i, &tri) in idx[from..range.end].iter().zip(&val[from..range.end]) {
                z.add(i, tri * y.val[r], j);
            }
        }
        z.touched.sort_unstable();
        out.rows.extend_from_slice(&z.touched);
        out.vals.extend(z.touched.iter().map(|&i| z.val[i]));
        out.ends.push(out.rows.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use faer::{c64, Mat};

    fn small_bar() -> crate::model::Model {
        bar_model(&BoxSpec::small()).unwrap()
    }

    fn dense(a: &Csc) -> Mat<f64> {
        a.as_ref().to_dense()
    }

    /// A(s) = K + sD + s²M dense, complex, at s = iω.
    fn pencil(k: &Mat<f64>, m: &Mat<f64>, omega: f64, beta: f64) -> Mat<c64> {
        Mat::from_fn(k.nrows(), k.ncols(), |i, j| {
            c64::new(
                k[(i, j)] - omega * omega * m[(i, j)],
                omega * beta * k[(i, j)],
            )
        })
    }

    fn solve(a: &Mat<c64>, b: &Mat<c64>) -> Mat<c64> {
        a.partial_piv_lu().solve(b)
    }

    /// The node at `x`'s offset from the point.
    fn offset(x: [f64; 3], p: &RemotePoint) -> [f64; 3] {
        [
            x[0] - p.position[0],
            x[1] - p.position[1],
            x[2] - p.position[2],
        ]
    }

    /// The response of `a` at the coordinates `at` to unit loads there.
    fn at_coordinates(a: &Mat<c64>, at: &[usize]) -> Mat<c64> {
        let e = Mat::<c64>::from_fn(a.nrows(), at.len(), |i, j| {
            c64::new(f64::from(at[j] == i), 0.0)
        });
        let x = solve(a, &e);
        Mat::from_fn(at.len(), at.len(), |i, j| x[(at[i], j)])
    }

    fn bore(model: &crate::model::Model, z: f64, kind: Kind, name: &str) -> RemotePoint {
        let nodes = model.nodes.as_ref().unwrap();
        let set: Vec<usize> = (0..nodes.len())
            .filter(|&i| (nodes[i][2] - z).abs() < 1e-12)
            .collect();
        RemotePoint {
            name: name.into(),
            position: [0.01, 0.015, z + 0.05],
            nodes: set,
            weights: Vec::new(),
            kind,
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
        /// TᵀAT equals the dense product to rounding and is exactly symmetric, for a random
        /// symmetric A and a random T with the shapes couplings give: unit columns, dense
        /// rows (a pivot's) and long columns (a rigid point's), computed in chunks of any size.
        #[test]
        fn congruence_is_the_dense_product(
            n in 1usize..40,
            m in 1usize..30,
            density in 0.02f64..0.5,
            dense_row in proptest::prelude::any::<bool>(),
            chunk in 1usize..8,
            seed in 1u64..1000,
        ) {
            let mut rng = crate::random::Xorshift::new(seed);
            let mut a = crate::sparse::Triplets::default();
            for j in 0..n {
                a.push(j, j, 4.0 + rng.next_centred());
                for i in j + 1..n {
                    if rng.next_centred() + 0.5 < density {
                        a.push(i, j, rng.next_centred());
                    }
                }
            }
            let a = a.into_csc(n, true);
            let cols = (0..m)
                .map(|j| {
                    let mut c = Vec::new();
                    for i in 0..n {
                        if i == j % n || rng.next_centred() + 0.5 < density {
                            c.push((i, rng.next_centred()));
                        }
                    }
                    if dense_row && j % 2 == 0 && !c.iter().any(|e| e.0 == n - 1) {
                        c.push((n - 1, 1.0 + rng.next_centred()));
                    }
                    c
                })
                .collect();
            let t = from_columns(n, cols);
            let got = congruence_in_chunks(&a, &t, chunk).unwrap();
            let (ad, td) = (dense(&a), dense(&t));
            let want = td.transpose() * &ad * &td;
            let g = dense(&got);
            let scale = want.norm_max().max(f64::MIN_POSITIVE);
            proptest::prop_assert!((&g - &want).norm_max() <= 1e-14 * scale * n as f64);
            proptest::prop_assert_eq!(&g, &g.transpose().to_owned());
        }
    }

    /// An RBE3 point reproduces a rigid motion of its nodes exactly, and for any motion its
    /// rows satisfy the weighted normal equations Σ w_i G_iᵀ (u_i − G_i x) = 0.
    #[test]
    fn distributing_rows_are_the_weighted_least_squares_rigid_motion() {
        let model = small_bar();
        let nodes = model.nodes.as_ref().unwrap();
        let mut p = bore(&model, 0.0, Kind::Distributing, "A");
        p.weights = (0..p.nodes.len()).map(|k| 1.0 + k as f64).collect();
        let rows = distributing_rows(&p, nodes, 3).unwrap();
        let apply = |u: &dyn Fn(usize) -> f64| -> [f64; 6] {
            let mut x = [0.0; 6];
            for (i, r) in rows.iter().enumerate() {
                x[i] = r.idx.iter().zip(&r.val).map(|(&c, &v)| v * u(c)).sum();
            }
            x
        };
        let x0 = [1e-3, -2e-3, 3e-3, 0.2, -0.1, 0.3];
        let rigid = |c: usize| {
            let (i, m) = (c / 3, c % 3);
            let r = offset(nodes[i], &p);
            (0..6).map(|j| rigid_rows(r)[m][j] * x0[j]).sum()
        };
        let x = apply(&rigid);
        for j in 0..6 {
            assert!((x[j] - x0[j]).abs() < 1e-12 * 0.3, "{x:?}");
        }
        // any motion: the normal equations' residual vanishes
        let u = |c: usize| ((c * 7919) % 13) as f64 * 1e-3 - 6e-3;
        let x = apply(&u);
        let mut normal = [0.0; 6];
        for (k, &i) in p.nodes.iter().enumerate() {
            let r = offset(nodes[i], &p);
            let g = rigid_rows(r);
            for m in 0..3 {
                let res = u(3 * i + m) - (0..6).map(|j| g[m][j] * x[j]).sum::<f64>();
                for j in 0..6 {
                    normal[j] += p.weights[k] * g[m][j] * res;
                }
            }
        }
        for v in normal {
            assert!(v.abs() < 1e-15, "{normal:?}");
        }
    }

    /// The transformed model's response at the pivots equals C A⁻¹ Cᵀ of the original model,
    /// for RBE3 rows and for arbitrary sparse rows together.
    #[test]
    fn functionals_become_coordinates_with_the_same_transfer_function() {
        let model = small_bar();
        let nodes = model.nodes.as_ref().unwrap();
        let n = model.n();
        let mut rows: Vec<SparseRow> =
            distributing_rows(&bore(&model, 0.2, Kind::Distributing, "tip"), nodes, 3)
                .unwrap()
                .into();
        rows.push(SparseRow {
            idx: vec![4, 10, 31, 40],
            val: vec![0.5, -1.0, 2.0, 0.25],
        });
        let change = functionals_as_coordinates(&rows, n, "outputs").unwrap();
        assert_eq!(change.t.nrows(), n);
        assert_eq!(change.t.ncols(), n);
        let k2 = dense(&congruence(&model.stiffness, &change.t).unwrap());
        let m2 = dense(&congruence(&model.mass, &change.t).unwrap());
        let (k, m) = (dense(&model.stiffness), dense(&model.mass));
        let c = Mat::<f64>::from_fn(rows.len(), n, |i, j| {
            rows[i]
                .idx
                .iter()
                .zip(&rows[i].val)
                .filter(|(&cj, _)| cj == j)
                .map(|(_, &v)| v)
                .sum()
        });
        // the free bar's A(iω) is as ill-conditioned as (λ_max/ω²) below its first elastic
        // mode: dense LU alone then loses digits (3e-10 at 300 rad/s), so the frequencies
        // start at the lowest where two dense solves of one system still agree to 1e-11
        for &omega in &[2500.0, 9000.0, 3e4, 1e5] {
            let ct = Mat::<c64>::from_fn(n, rows.len(), |i, j| c64::new(c[(j, i)], 0.0));
            let h = Mat::<c64>::from_fn(rows.len(), n, |i, j| c64::new(c[(i, j)], 0.0))
                * solve(&pencil(&k, &m, omega, 1e-5), &ct);
            let h2 = at_coordinates(&pencil(&k2, &m2, omega, 1e-5), &change.coordinates);
            let err = (&h2 - &h).norm_l2() / h.norm_l2();
            assert!(err <= 1e-10, "ω = {omega}: {err:e}");
        }
    }

    /// RBE2: the eliminated model's response at the point equals the one of the dense
    /// Lagrange-multiplier system [A 0 Cqᵀ; 0 0 Cxᵀ; Cq Cx 0] with the point's six DoFs as
    /// unknowns of their own and the constraints u_i − G(r_i) x = 0.
    #[test]
    fn rigid_elimination_equals_the_lagrange_multiplier_solution() {
        let model = small_bar();
        let nodes = model.nodes.as_ref().unwrap();
        let n = model.n();
        let points = [
            bore(&model, 0.0, Kind::Rigid, "root"),
            bore(&model, 0.2, Kind::Rigid, "tip"),
        ];
        let change = rigid_elimination(&points, nodes, 3).unwrap();
        let nz = change.t.ncols();
        assert_eq!(nz, n - 3 * 12 + 12);
        let k2 = dense(&congruence(&model.stiffness, &change.t).unwrap());
        let m2 = dense(&congruence(&model.mass, &change.t).unwrap());
        let (k, m) = (dense(&model.stiffness), dense(&model.mass));
        // the constraints
        let mut cons: Vec<(Vec<(usize, f64)>, usize)> = Vec::new();
        let mut nc = 0;
        for (pk, p) in points.iter().enumerate() {
            for &i in &p.nodes {
                let r = offset(nodes[i], p);
                for (mm, g) in rigid_rows(r).iter().enumerate() {
                    let mut row = vec![(3 * i + mm, 1.0)];
                    for (j, &v) in g.iter().enumerate() {
                        row.push((n + 6 * pk + j, -v));
                    }
                    cons.push((row, nc));
                    nc += 1;
                }
            }
        }
        let big = n + 12 + nc;
        let omega = 2000.0;
        let a = pencil(&k, &m, omega, 1e-5);
        let mut l = Mat::<c64>::zeros(big, big);
        for i in 0..n {
            for j in 0..n {
                l[(i, j)] = a[(i, j)];
            }
        }
        for (row, c) in &cons {
            for &(j, v) in row {
                l[(n + 12 + c, j)] = c64::new(v, 0.0);
                l[(j, n + 12 + c)] = c64::new(v, 0.0);
            }
        }
        // unit loads on the twelve point DoFs
        let rhs = Mat::<c64>::from_fn(big, 12, |i, j| c64::new(f64::from(i == n + j), 0.0));
        let x = solve(&l, &rhs);
        let h = Mat::<c64>::from_fn(12, 12, |i, j| x[(n + i, j)]);
        let h2 = at_coordinates(&pencil(&k2, &m2, omega, 1e-5), &change.coordinates);
        let err = (&h2 - &h).norm_l2() / h.norm_l2();
        assert!(err <= 1e-10, "{err:e}");
    }

    #[test]
    fn bad_point_definitions_name_the_point_and_the_fix() {
        let model = small_bar();
        let nodes = model.nodes.as_ref().unwrap();
        let mut p = bore(&model, 0.0, Kind::Distributing, "bore");
        let message = |p: &RemotePoint| distributing_rows(p, nodes, 3).unwrap_err().to_string();
        let empty = RemotePoint {
            nodes: Vec::new(),
            ..p.clone()
        };
        assert!(message(&empty).contains("bore: its node set is empty"));
        // the nodes on the line x = 0, y = 0 of the bottom face... and a few of the z axis
        let line: Vec<usize> = (0..nodes.len())
            .filter(|&i| nodes[i][0] == 0.0 && nodes[i][1] == 0.0)
            .collect();
        let collinear = RemotePoint {
            nodes: line,
            position: [0.01, 0.01, 0.0],
            ..p.clone()
        };
        assert!(
            message(&collinear).contains("lie on one line"),
            "{}",
            message(&collinear)
        );
        // a rigid point on that line of a translations-only model: the same refusal (its
        // rotation about the line would have neither mass nor stiffness)
        let rigid_line = RemotePoint {
            kind: Kind::Rigid,
            ..collinear.clone()
        };
        let err = rigid_elimination(&[rigid_line], nodes, 3)
            .unwrap_err()
            .to_string();
        assert!(err.contains("lie on one line"), "{err}");
        p.position = nodes[p.nodes[2]];
        assert!(message(&p).contains("coincides with coupled node"));
        let a = bore(&model, 0.0, Kind::Rigid, "A");
        let mut b = bore(&model, 0.0, Kind::Rigid, "B");
        b.nodes.truncate(3);
        let err = rigid_elimination(&[a, b], nodes, 3)
            .unwrap_err()
            .to_string();
        assert!(err.contains("A and B: both rigidly couple node"), "{err}");
        let rows = vec![
            SparseRow {
                idx: vec![0, 1],
                val: vec![1.0, 2.0],
            },
            SparseRow {
                idx: vec![0, 1],
                val: vec![-2.0, -4.0],
            },
        ];
        let err = functionals_as_coordinates(&rows, 10, "outputs")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("outputs: the 2 functionals are linearly dependent"),
            "{err}"
        );
    }
}
