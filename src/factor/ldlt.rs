//! Complex-symmetric supernodal LDLᵀ of a damped A(iω) = K − ω²M + iωD (docs/design.md §3.1),
//! and the same kernel in real arithmetic ([`RealLdlt`]: K − σM, its negative pivots counting
//! the eigenvalues below σ): every routine is generic over the scalar ([`FactorScalar`]).
//!
//! P A Pᵀ = L D Lᵀ with the transpose, never the adjoint: A is complex *symmetric*
//! (Aᵀ = A, Aᴴ ≠ A), L unit lower triangular in c64 and D diagonal in c64. The structure is
//! the ordered (AMD, level-set bisection or nested dissection) supernodal symbolic Cholesky of
//! the pencil's N×N pattern ([`super::symbolic_cholesky`]), shared with the real path and the
//! eigensolver, so the factor has the fill of a real Cholesky in complex numbers: half the
//! bytes of the interleaved 2N×2N LBLᵀ form and a quarter of its entries.
//!
//! **Left-looking supernodal factorization.** For each supernode s (columns c₀..c₁, rows below
//! them `pattern(s)`), its panel [L_top; L_bot] is assembled from A, then every descendant d
//! whose pattern meets c₀..c₁ subtracts L_d,rows · D_d · L_d,colsᵀ (a dense product, scattered
//! through a row map; of its square block on c₀..c₁ only the lower triangle is computed: a
//! full square product makes the 32³ cube's factor 1.3× slower, docs/design.md §3.1), then the
//! diagonal block is factored by a recursive blocked dense LDLᵀ and L_bot ← L_bot L_top⁻ᵀ D⁻¹
//! (triangular solve). Every flop outside the smallest diagonal blocks is a faer GEMM or
//! triangular solve on the scalar (c64 for A(iω)).
//!
//! **Threads inside one factorization** (the sweep's factor-parallel schedule): the supernodes
//! are in postorder, so every subtree of the elimination tree is a contiguous range of
//! supernodes and of L's values. [`SubtreeGroups`] finds two groups of independent subtrees of
//! comparable work; each group is factored on its own thread, then the supernodes above them
//! with the threads inside the large dense products (≥ 2²¹ multiply-adds) and in the scatter
//! of large updates (two halves of the target columns, which write disjoint columns). Each
//! supernode is computed the same way in either case, so the factor does not depend on the
//! thread count. The solves run the two groups independently too (see
//! [`Numeric::solve_block`]); on a bar with the level-set bisection ([`super::ordering`]) the
//! groups are its two halves (the speed-ups of two threads on the 10⁵ bar are in
//! docs/design.md §3.1).
//!
//! **Pivoting: static, with a pivoting fallback** (docs/design.md §3.1). The order is fixed by
//! the symbolic analysis. A numerically zero pivot, |d| < ε·max|aᵢⱼ|, is replaced and counted
//! ([`Factorization::perturbed`]); if there was one, the whole factorization is repeated with
//! PARDISO's threshold τ = √ε·max|aᵢⱼ| (every |d| < τ becomes τ·d/|d|), which bounds the growth
//! behind the zero pivot, and the sweep's refinement with the exact A removes the perturbation.
//! Where a solve stays inaccurate after refinement, `factor::Numeric::factor_with_pivoting`
//! hands the frequency to the pivoting LBLᵀ of the 2N form. τ is ε first, not √ε: the last
//! pivots of a free body at low frequency are legitimately ~ω²m, ~1e-9 of max|aᵢⱼ| at 1 Hz on
//! the paper bar, and perturbing those makes refinement diverge. Tested against dense complex
//! solves, zero-diagonal and near-resonance cases included (tests `factor_ldlt`).

use super::backend::{
    require_pivots, try_vec, Analysed, Backend, Factorization, Footprint, SymbolicFactorization,
    Values,
};
use super::lblt;
use super::ordering::supernode_tree;
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::{
    solve_unit_lower_triangular_in_place, solve_unit_upper_triangular_in_place,
};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{c64, Accum, Mat, MatMut, MatRef, Par};
use std::sync::Arc;
use std::sync::OnceLock;

/// Diagonal blocks up to this size are factored column by column.
const UNBLOCKED: usize = 32;

/// Triangular solves with up to this many columns go to faer directly.
const UNBLOCKED_SOLVE: usize = 8;

/// Dense products of fewer multiply-adds than this run on one thread even when the
/// factorization has several: splitting them costs more than it saves (threads inside every
/// product make the 10⁵ bar's factor 1.24× slower, docs/design.md §3.1).
const PAR_MIN_WORK: usize = 1 << 21;

/// `par` for a dense operation of `work` multiply-adds, else sequential.
pub(super) fn par_for(work: usize, par: Par) -> Par {
    if work >= PAR_MIN_WORK {
        par
    } else {
        Par::Seq
    }
}

/// The scalars the factorization runs in: `c64` for A(iω), `f64` for a real shifted pencil
/// (the same kernel, the transpose throughout: no conjugation in either). On top of the
/// residual's [`pattern::Scalar`] (parts, |·|₁), what pivots need.
pub(crate) trait FactorScalar:
    pattern::Scalar + std::ops::Add<Output = Self> + std::ops::MulAssign + Default
{
    /// 0 and 1.
    const ZERO: Self;
    const ONE: Self;
    /// |x|.
    fn magnitude(self) -> f64;
    /// 1/x.
    fn reciprocal(self) -> Self;
    /// x < 0 (a real pivot's sign; never for a complex one).
    fn negative(self) -> bool;
}

impl FactorScalar for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    fn magnitude(self) -> f64 {
        self.abs()
    }
    fn reciprocal(self) -> f64 {
        1.0 / self
    }
    fn negative(self) -> bool {
        self < 0.0
    }
}

impl FactorScalar for c64 {
    const ZERO: c64 = c64::new(0.0, 0.0);
    const ONE: c64 = c64::new(1.0, 0.0);
    fn magnitude(self) -> f64 {
        self.norm()
    }
    fn reciprocal(self) -> c64 {
        self.inv()
    }
    fn negative(self) -> bool {
        false
    }
}

/// The analysis: the supernodal structure, where each entry of A lands in L, and which
/// supernodes update which.
pub(super) struct Symbolic {
    pub(super) sym: Arc<SymbolicCholesky<usize>>,
    /// The fill-reducing order: row i of P A Pᵀ is row `fwd[i]` of A.
    pub(super) fwd: Vec<usize>,
    /// Where A's entries land in L, built once by [`Self::prepare`] for the first numeric
    /// factor (or why it could not be): an analysis that is never factored (the sweep's
    /// beside a response space) does not hold its 16 bytes per entry of A.
    assembly: OnceLock<std::result::Result<Assembly, String>>,
    /// Supernodes d updating supernode s: `desc[desc_ptr[s]..desc_ptr[s + 1]]`, increasing.
    desc_ptr: Vec<usize>,
    desc: Vec<usize>,
    /// Largest descendant update (rows × columns) and largest supernode pattern: workspace.
    max_update: usize,
    pub(super) max_pattern: usize,
    pub(super) max_cols: usize,
    max_rhs: usize,
    /// Independent subtrees of the elimination tree for two threads, if it has any worth it.
    pub(super) split: Option<SubtreeGroups>,
}

/// The entries of A by supernode, each supernode's in the order of the pencil's pattern:
/// (position p in the pencil's lower pattern, position in L's values), supernode s's at
/// `entries[ptr[s]..ptr[s + 1]]`.
struct Assembly {
    entries: Vec<(usize, usize)>,
    ptr: Vec<usize>,
}

/// Two groups of independent subtrees of the supernodal elimination tree (each subtree a
/// contiguous range of supernodes, faer's order being a postorder) and the supernodes above
/// them: with two threads, each group is factored on its own thread, then the top with the
/// threads inside the dense products.
pub(super) struct SubtreeGroups {
    /// Supernode ranges [first, last + 1) of each group's subtrees.
    groups: [Vec<(usize, usize)>; 2],
    /// The supernodes in no subtree of a group, increasing.
    top: Vec<usize>,
    /// Row → its position among the top supernodes' rows (`usize::MAX` for a group's row):
    /// where a group's solve leaves its contributions to the top.
    top_pos: Vec<usize>,
    /// The top supernodes' rows, by position.
    top_rows: Vec<usize>,
}

impl SubtreeGroups {
    /// Every subtree of the groups as (first supernode, last + 1, group), in order.
    fn subtrees(&self) -> Vec<(usize, usize, usize)> {
        let mut ranges: Vec<(usize, usize, usize)> = self
            .groups
            .iter()
            .enumerate()
            .flat_map(|(g, rs)| rs.iter().map(move |&(f, e)| (f, e, g)))
            .collect();
        ranges.sort_unstable();
        ranges
    }

    /// The split of the supernodal elimination tree of `s` (`parent` from [`supernode_tree`]), or
    /// `None` when it is not a postorder (subtrees not contiguous) or no two groups of
    /// subtrees hold comparable work. Work of a supernode: ncols · nrows², its dense flops up
    /// to a constant. The frontier starts at the roots; while its heaviest subtree holds more
    /// than half the frontier's work it is replaced by its children (its root joins the top).
    /// At each frontier the subtrees go, heaviest first, to the lighter group, and the frontier
    /// with the least estimated time (the top's work plus the heavier group's) is kept: on a
    /// bisected bar the two halves are chains, and descending them to the end would put all
    /// in the top.
    fn new(
        s: &SymbolicSupernodalCholesky<usize>,
        parent: &[Option<usize>],
    ) -> Option<SubtreeGroups> {
        let ns = s.n_supernodes();
        let (begin, end) = (s.supernode_begin(), s.supernode_end());
        let mut first: Vec<usize> = (0..ns).collect();
        let (mut size, mut work) = (vec![1usize; ns], vec![0f64; ns]);
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); ns];
        for sn in 0..ns {
            let ncols = (end[sn] - begin[sn]) as f64;
            let nrows = ncols + pattern(s, sn).len() as f64;
            work[sn] += ncols * nrows * nrows;
            if let Some(p) = parent[sn] {
                if p <= sn {
                    return None;
                }
                first[p] = first[p].min(first[sn]);
                size[p] += size[sn];
                work[p] += work[sn];
                children[p].push(sn);
            }
        }
        // a postorder: every subtree is the contiguous range first..=root
        if (0..ns).any(|sn| sn + 1 - first[sn] != size[sn]) {
            return None;
        }
        let all: f64 = (0..ns)
            .filter(|&sn| parent[sn].is_none())
            .map(|r| work[r])
            .sum();
        // the frontier's subtrees, heaviest first, each to the lighter group: the groups and
        // the estimated time (the top's work, then the heavier group)
        let partition = |frontier: &[usize]| {
            let mut order = frontier.to_vec();
            order.sort_by(|a, b| work[*b].total_cmp(&work[*a]));
            let mut groups: [Vec<(usize, usize)>; 2] = [Vec::new(), Vec::new()];
            let mut load = [0f64; 2];
            for f in order {
                let g = usize::from(load[1] < load[0]);
                groups[g].push((first[f], f + 1));
                load[g] += work[f];
            }
            (all - load[0] - load[1] + load[0].max(load[1]), groups)
        };
        let mut frontier: Vec<usize> = (0..ns).filter(|&sn| parent[sn].is_none()).collect();
        let mut top = Vec::new();
        let (mut best, mut groups) = partition(&frontier);
        let mut best_top = top.clone();
        loop {
            let total: f64 = frontier.iter().map(|&f| work[f]).sum();
            let (at, &heaviest) = frontier
                .iter()
                .enumerate()
                .max_by(|a, b| work[*a.1].total_cmp(&work[*b.1]))?;
            if work[heaviest] <= 0.5 * total || children[heaviest].is_empty() {
                break;
            }
            frontier.swap_remove(at);
            frontier.extend(&children[heaviest]);
            top.push(heaviest);
            let (t, g) = partition(&frontier);
            if t < best {
                (best, groups, best_top) = (t, g, top.clone());
            }
        }
        // worth a second thread when the estimated time is at most 0.8 of one thread's
        if best > 0.8 * all {
            return None;
        }
        let mut top = best_top;
        top.sort_unstable();
        let top_rows: Vec<usize> = top.iter().flat_map(|&t| begin[t]..end[t]).collect();
        let mut top_pos = vec![usize::MAX; s.nrows()];
        for (p, &r) in top_rows.iter().enumerate() {
            top_pos[r] = p;
        }
        Some(SubtreeGroups {
            groups,
            top,
            top_pos,
            top_rows,
        })
    }
}

/// The LDLᵀ analysis of the damped pencil on `sym_n`, the ordered symbolic Cholesky of its
/// N×N pattern (the registry's entry, `factor::analyse`). A pattern without off-diagonal
/// entries has no supernodes (faer builds them for every other pattern,
/// `supernodal_params`): the LBLᵀ takes it.
pub(super) fn analyse(
    pencil: &Pencil,
    sym_n: Arc<SymbolicCholesky<usize>>,
    max_rhs: usize,
) -> Result<Analysed> {
    if !matches!(sym_n.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
        return lblt::analyse(pencil, sym_n, max_rhs);
    }
    let (symbolic, footprint) = Symbolic::new(pencil, sym_n, max_rhs)?;
    Ok((Box::new(symbolic), footprint))
}

/// The supernodal part of `sym` ([`analyse`] checks it before a [`Symbolic`] is built).
pub(super) fn supernodal(sym: &SymbolicCholesky<usize>) -> &SymbolicSupernodalCholesky<usize> {
    match sym.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => s,
        SymbolicCholeskyRaw::Simplicial(_) => {
            unreachable!("analyse checks the structure before building the LDLᵀ")
        }
    }
}

/// Rows of supernode `s`'s pattern (below its diagonal block).
pub(super) fn pattern(s: &SymbolicSupernodalCholesky<usize>, sn: usize) -> &[usize] {
    s.supernode(sn).pattern()
}

impl Symbolic {
    /// The analysis of the damped pencil on `sym_n`, the ordered symbolic Cholesky of its
    /// N×N pattern.
    pub(super) fn new(
        pencil: &Pencil,
        sym_n: Arc<SymbolicCholesky<usize>>,
        max_rhs: usize,
    ) -> Result<(Self, Footprint)> {
        let n = pencil.n();
        let s = supernodal(&sym_n);
        let ns = s.n_supernodes();
        let (begin, end) = (s.supernode_begin(), s.supernode_end());
        let (owner, parent) = supernode_tree(s);
        let fwd = match sym_n.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        // descendants: d updates every supernode owning a row of its pattern
        let mut lists: Vec<Vec<usize>> = vec![Vec::new(); ns];
        let (mut max_update, mut max_pattern, mut max_cols) = (0, 0, 0);
        for d in 0..ns {
            let pat = pattern(s, d);
            max_pattern = max_pattern.max(pat.len());
            max_cols = max_cols.max(end[d] - begin[d]);
            let mut i = 0;
            while i < pat.len() {
                let t = owner[pat[i]];
                let k = pat[i..].partition_point(|&r| r < end[t]);
                lists[t].push(d);
                max_update = max_update.max((pat.len() - i + end[d] - begin[d]) * k);
                i += k;
            }
        }
        let mut desc_ptr = Vec::with_capacity(ns + 1);
        desc_ptr.push(0);
        let mut desc = Vec::new();
        for l in lists {
            desc.extend(l);
            desc_ptr.push(desc.len());
        }
        let split = SubtreeGroups::new(s, &parent);
        let factor_nnz = s.len_val();
        let scratch = 16 * (max_update + max_cols * max_cols / 2) + 8 * n;
        let bytes = 16 * (factor_nnz + n)
            + scratch * if split.is_some() { 2 } else { 1 }
            + 16 * (n + max_pattern) * (max_rhs + 1)
            + 8 * (2 * pencil.row_idx().len() + desc.len());
        let symbolic = Symbolic {
            sym: sym_n,
            fwd,
            assembly: OnceLock::new(),
            desc_ptr,
            desc,
            max_update,
            max_pattern,
            max_cols,
            max_rhs,
            split,
        };
        Ok((symbolic, Footprint { factor_nnz, bytes }))
    }

    /// Builds where A's entries land in L, once: concurrent callers (the sweep's workers
    /// allocating their factors) wait for the first, later ones return at once. Every numeric
    /// factor on this analysis calls it first, with the pencil whose pattern the analysis was
    /// made on.
    ///
    /// # Errors
    /// [`Error::Factor`] when an entry of A lies outside L's pattern or memory is short.
    pub(super) fn prepare(&self, pencil: &Pencil) -> Result<()> {
        match self.assembly.get_or_init(|| {
            self.assembly_of(pencil).map_err(|e| match e {
                Error::Factor(why) => why,
                other => other.to_string(),
            })
        }) {
            Ok(_) => Ok(()),
            Err(why) => Err(Error::Factor(why.clone())),
        }
    }

    /// Where A's entries land in L: entry (i, j) goes to (max, min) of its permuted indices
    /// in the panel of the supernode owning the column.
    fn assembly_of(&self, pencil: &Pencil) -> Result<Assembly> {
        let s = supernodal(&self.sym);
        let (n, ns) = (pencil.n(), s.n_supernodes());
        let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
        let (owner, _) = supernode_tree(s);
        let inv = match self.sym.perm() {
            Some(p) => p.arrays().1.to_vec(),
            None => (0..n).collect(),
        };
        // grouped by supernode (a counting sort: the order inside a supernode does not
        // matter, each position gets one entry)
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let mut ptr = vec![0usize; ns + 1];
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                ptr[owner[inv[ri[p]].min(inv[j])] + 1] += 1;
            }
        }
        for sn in 0..ns {
            ptr[sn + 1] += ptr[sn];
        }
        let mut next = ptr[..ns].to_vec();
        let mut entries: Vec<(usize, usize)> = try_vec(ri.len())?;
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                let (a, b) = (inv[ri[p]], inv[j]);
                let (row, col) = (a.max(b), a.min(b));
                let sn = owner[col];
                let ncols = end[sn] - begin[sn];
                let pat = pattern(s, sn);
                let local = if row < end[sn] {
                    row - begin[sn]
                } else {
                    ncols
                        + pat.binary_search(&row).map_err(|_| {
                            Error::Factor(
                                "symbolic analysis: an entry of A outside the pattern of L".into(),
                            )
                        })?
                };
                entries[next[sn]] = (p, cpv[sn] + (col - begin[sn]) * (ncols + pat.len()) + local);
                next[sn] += 1;
            }
        }
        Ok(Assembly { entries, ptr })
    }

    /// Bytes of a real factorization in memory with its buffers (one thread's; a second
    /// thread's with a [`SubtreeGroups`]) and solves of `rhs` columns.
    pub(super) fn real_bytes(&self, rhs: usize) -> usize {
        let n = self.sym.nrows();
        let scratch = self.max_update + self.max_cols * self.max_cols.div_ceil(2) + n;
        let threads = if self.split.is_some() { 2 } else { 1 };
        8 * (supernodal(&self.sym).len_val()
            + n
            + threads * scratch
            + (n + 2 * self.max_pattern) * (rhs + 1))
    }

    /// The work buffers of one thread of the factorization.
    fn scratch<T: FactorScalar>(&self) -> Result<Scratch<T>> {
        Ok(Scratch {
            update: try_vec(self.max_update)?,
            dense: try_vec(self.max_cols * self.max_cols.div_ceil(2))?,
            local: vec![usize::MAX; self.sym.nrows()],
        })
    }
}

impl SymbolicFactorization for Symbolic {
    fn backend(&self) -> Backend {
        Backend::Ldlt
    }

    /// The ordered symbolic Cholesky it works on: the pivoting fallback's ordering.
    fn pivoting_structure(&self) -> Option<Arc<SymbolicCholesky<usize>>> {
        Some(self.sym.clone())
    }

    fn numeric(&self, pencil: &Pencil) -> Result<Box<dyn Factorization + '_>> {
        self.prepare(pencil)?;
        Ok(Box::new(Numeric::<_, c64>::new(self)?))
    }
}

impl<S: std::ops::Deref<Target = Symbolic>, T: FactorScalar> Numeric<S, T> {
    /// The factor's storage and buffers on `symbolic`, not yet factored.
    pub(super) fn new(symbolic: S) -> Result<Self> {
        let n = symbolic.sym.nrows();
        let rhs = symbolic.max_rhs + 1;
        let (max_pattern, top) = (
            symbolic.max_pattern,
            symbolic.split.as_ref().map_or(0, |sp| sp.top_rows.len()),
        );
        Ok(Numeric {
            l: try_vec(supernodal(&symbolic.sym).len_val())?,
            d_inv: try_vec(n)?,
            scratch: Some(symbolic.scratch()?),
            second: None,
            x: Mat::zeros(n, rhs),
            solve: std::array::from_fn(|_| SolveScratch {
                gathered: Mat::zeros(max_pattern, rhs),
                top: Mat::zeros(top, rhs),
            }),
            pivot_ratio: f64::NAN,
            perturbed: 0,
            symbolic,
        })
    }
}

/// One numeric LDLᵀ factorization, refilled per frequency.
pub(super) struct Numeric<S, T> {
    symbolic: S,
    /// L (strictly lower part) and D (its diagonal) in faer's supernodal layout.
    pub(super) l: Vec<T>,
    /// D⁻¹, in the order of L's columns.
    d_inv: Vec<T>,
    /// The factorization's work buffers (allocated with the factor, again after
    /// [`Self::release_scratch`]).
    scratch: Option<Scratch<T>>,
    /// The second thread's buffers when subtrees run in parallel (allocated on first use).
    second: Option<Scratch<T>>,
    /// The permuted right-hand sides of a solve.
    pub(super) x: Mat<T>,
    /// The solve's buffers for each of the two groups of a [`SubtreeGroups`] (the first alone
    /// without one).
    solve: [SolveScratch<T>; 2],
    pivot_ratio: f64,
    perturbed: usize,
}

/// The buffers of one thread of a solve.
pub(super) struct SolveScratch<T> {
    /// One supernode's pattern rows, gathered.
    pub(super) gathered: Mat<T>,
    /// A group's contributions to the top's rows (forward), or the top's solution (backward).
    pub(super) top: Mat<T>,
}

/// The work buffers of one thread of the factorization.
struct Scratch<T> {
    /// A descendant's update block before it is scattered.
    update: Vec<T>,
    /// L21·D1 inside the recursive dense LDLᵀ.
    dense: Vec<T>,
    /// Row → position in the current supernode's pattern (usize::MAX elsewhere).
    local: Vec<usize>,
}

impl<S: std::ops::Deref<Target = Symbolic>, T: FactorScalar> Numeric<S, T> {
    /// One left-looking factorization of the matrix with lower-pattern entries `a(p)` with
    /// the static pivot threshold `tau`: with more than one thread and a [`SubtreeGroups`],
    /// its two groups of subtrees in parallel first.
    pub(super) fn factor_with(
        &mut self,
        a: &(impl Fn(usize) -> T + Sync),
        tau: f64,
        par: Par,
    ) -> Result<Pivots> {
        let sy: &Symbolic = &self.symbolic;
        let s = supernodal(&sy.sym);
        let cpv = s.col_ptr_for_val();
        let mut pivots = Pivots::new(tau);
        if self.scratch.is_none() {
            self.scratch = Some(sy.scratch()?);
        }
        let first = self.scratch.as_mut().expect("allocated above");
        let split = sy.split.as_ref().filter(|_| par.degree() > 1);
        let Some(split) = split else {
            for sn in 0..s.n_supernodes() {
                sy.factor_supernode(sn, &mut self.l, 0, a, first, &mut pivots, par);
            }
            return Ok(pivots);
        };
        if self.second.is_none() {
            self.second = Some(sy.scratch()?);
        }
        let second = self.second.as_mut().expect("allocated above");
        // each subtree's values, cut from L in order of position
        let ranges = split.subtrees();
        let mut parts: [Vec<(usize, usize, &mut [T])>; 2] = [Vec::new(), Vec::new()];
        let mut rest: &mut [T] = &mut self.l;
        let mut offset = 0;
        for (first, end, g) in ranges {
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(cpv[first] - offset);
            let (mine, tail) = tail.split_at_mut(cpv[end] - cpv[first]);
            parts[g].push((first, end, mine));
            rest = tail;
            offset = cpv[end];
        }
        let [p0, p1] = parts;
        let run = |part: Vec<(usize, usize, &mut [T])>, sc: &mut Scratch<T>| {
            let mut pv = Pivots::new(tau);
            for (first, end, l) in part {
                for sn in first..end {
                    sy.factor_supernode(sn, l, cpv[first], a, sc, &mut pv, Par::Seq);
                }
            }
            pv
        };
        let (a0, a1) = rayon::join(|| run(p0, &mut *first), || run(p1, second));
        pivots.merge(a0);
        pivots.merge(a1);
        for &sn in &split.top {
            sy.factor_supernode(sn, &mut self.l, 0, a, first, &mut pivots, par);
        }
        Ok(pivots)
    }

    /// Frees the factorization's work buffers (the largest descendant update and dense
    /// block, per thread): a factor that is solved with, not refactored, does not hold them
    /// through its solves. The next factorization allocates them again.
    pub(super) fn release_scratch(&mut self) {
        self.scratch = None;
        self.second = None;
    }

    /// The factorization of a matrix factored once and solved with many times (the factors
    /// of [`super::real_ldlt`]): pivots below `tau` perturbed, the work buffers freed, D
    /// inverted for the solves.
    pub(super) fn factor_once(
        &mut self,
        a: &(impl Fn(usize) -> T + Sync),
        tau: f64,
        par: Par,
    ) -> Result<Pivots> {
        let pivots = self.factor_with(a, tau, par)?;
        self.release_scratch();
        self.invert_diagonal(par);
        Ok(pivots)
    }

    /// X ← A⁻¹X in place, in blocks of the factor's right-hand-side width.
    pub(super) fn solve_all(&mut self, x: MatMut<'_, T>, par: Par) {
        let width = self.x.ncols();
        in_blocks(x, width, |b| self.solve_block(b, par));
    }
}

/// `solve` on the columns of `x`, `width` at a time (a factor's solve buffers hold that many).
pub(super) fn in_blocks<T>(
    mut x: MatMut<'_, T>,
    width: usize,
    mut solve: impl FnMut(MatMut<'_, T>),
) {
    let k = x.ncols();
    for c in (0..k).step_by(width) {
        solve(x.rb_mut().subcols_mut(c, width.min(k - c)));
    }
}

impl<S: std::ops::Deref<Target = Symbolic>, T: FactorScalar> Numeric<S, T> {
    /// D⁻¹ from the factor's diagonal, for the solves: with threads, the supernodes in two
    /// halves.
    pub(super) fn invert_diagonal(&mut self, par: Par) {
        let s = supernodal(&self.symbolic.sym);
        let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
        let l = &self.l;
        let invert = |sns: std::ops::Range<usize>, d: &mut [T], r0: usize| {
            for sn in sns {
                let ncols = end[sn] - begin[sn];
                let stride = ncols + pattern(s, sn).len();
                for j in 0..ncols {
                    d[begin[sn] + j - r0] = l[cpv[sn] + j * stride + j].reciprocal();
                }
            }
        };
        let ns = s.n_supernodes();
        if par.degree() > 1 && ns > 1 {
            let mid = ns / 2;
            let (a, b) = self.d_inv.split_at_mut(begin[mid]);
            rayon::join(|| invert(0..mid, a, 0), || invert(mid..ns, b, begin[mid]));
        } else {
            invert(0..ns, &mut self.d_inv, 0);
        }
    }
}

impl Symbolic {
    /// Adds A's entries of supernode `sn` to `panel`, its values laid out as L's (a front's
    /// first columns have the same layout).
    pub(super) fn assemble<T: FactorScalar>(
        &self,
        sn: usize,
        panel: &mut [T],
        a: &(impl Fn(usize) -> T + Sync),
    ) {
        let first = supernodal(&self.sym).col_ptr_for_val()[sn];
        let Some(Ok(asm)) = self.assembly.get() else {
            unreachable!("a numeric factor is made only on a prepared analysis (Symbolic::prepare)")
        };
        for &(p, q) in &asm.entries[asm.ptr[sn]..asm.ptr[sn + 1]] {
            panel[q - first] += a(p);
        }
    }

    /// Factors supernode `sn` (left-looking): assembles its panel from `a`, subtracts the
    /// updates of its descendants, factors the diagonal block and solves the rows below.
    /// `l` holds L's values from position `base` on, `sn` and all its descendants included.
    #[allow(clippy::too_many_arguments)]
    fn factor_supernode<T: FactorScalar>(
        &self,
        sn: usize,
        l: &mut [T],
        base: usize,
        a: &(impl Fn(usize) -> T + Sync),
        sc: &mut Scratch<T>,
        pivots: &mut Pivots,
        par: Par,
    ) {
        let s = supernodal(&self.sym);
        let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
        let (c0, c1) = (begin[sn], end[sn]);
        let ncols = c1 - c0;
        let pat = pattern(s, sn);
        let nrows = ncols + pat.len();
        for (i, &r) in pat.iter().enumerate() {
            sc.local[r] = ncols + i;
        }
        let (head, tail) = l.split_at_mut(cpv[sn] - base);
        let panel = &mut tail[..nrows * ncols];
        panel.fill(T::ZERO);
        self.assemble(sn, panel, a);
        let mut ls = MatMut::from_column_major_slice_mut(panel, nrows, ncols);
        for &d in &self.desc[self.desc_ptr[sn]..self.desc_ptr[sn + 1]] {
            let dpat = pattern(s, d);
            let dcols = end[d] - begin[d];
            let ld = MatRef::from_column_major_slice(
                &head[cpv[d] - base..cpv[d + 1] - base],
                dcols + dpat.len(),
                dcols,
            );
            let first = dpat.partition_point(|&r| r < c0);
            let k = dpat[first..].partition_point(|&r| r < c1);
            let rows = &dpat[first..];
            let below = ld.subrows(dcols + first, rows.len());
            let mid = below.subrows(0, k);
            // W = L_d,rows · (L_d,cols · D_d)ᵀ, then scattered into the lower part of s. The
            // right factor is stored transposed, column-major: faer's GEMM runs 1.5× slower on
            // a transposed (row-major) right operand at the cube's sizes.
            let (dmid, rest) = sc.update.split_at_mut(k * dcols);
            let mut dmid_t = MatMut::from_column_major_slice_mut(dmid, dcols, k);
            for i in 0..k {
                for (j, v) in dmid_t.rb_mut().col_mut(i).iter_mut().enumerate() {
                    *v = mid[(i, j)] * ld[(j, j)];
                }
            }
            let mut w =
                MatMut::from_column_major_slice_mut(&mut rest[..rows.len() * k], rows.len(), k);
            // only the lower triangle of the k×k block is scattered: it alone is computed
            let (w_mid, w_low) = w.rb_mut().split_at_row_mut(k);
            triangular::matmul(
                w_mid,
                BlockStructure::TriangularLower,
                Accum::Replace,
                mid,
                BlockStructure::Rectangular,
                dmid_t.rb(),
                BlockStructure::Rectangular,
                T::ONE,
                par_for(k * k * dcols / 2, par),
            );
            matmul(
                w_low,
                Accum::Replace,
                below.subrows(k, rows.len() - k),
                dmid_t.rb(),
                T::ONE,
                par_for((rows.len() - k) * k * dcols, par),
            );
            let target = Target {
                rows,
                k,
                c0,
                local: &sc.local,
            };
            subtract_update(ls.rb_mut(), 0, w.rb(), &target, 0..k, par);
        }
        factor_panel(ls, &mut sc.dense, pivots, par);
        for &r in pat {
            sc.local[r] = usize::MAX;
        }
    }
}

impl Factorization for Numeric<&Symbolic, c64> {
    fn factor(&mut self, a: &Values<'_>, freq_hz: f64, par: Par) -> Result<()> {
        // max |aᵢⱼ|, exact in any grouping: on two threads, halves
        let max_sq = |entries: std::ops::Range<usize>| {
            entries.fold(0.0f64, |m, p| {
                let v = a.entry(p);
                m.max(v.re * v.re + v.im * v.im)
            })
        };
        let nnz = a.pattern.row_idx().len();
        let amax = if par.degree() > 1 {
            let (m0, m1) = rayon::join(|| max_sq(0..nnz / 2), || max_sq(nnz / 2..nnz));
            m0.max(m1)
        } else {
            max_sq(0..nnz)
        }
        .sqrt();
        // numerically zero pivots only; if there were any, PARDISO's larger threshold, which
        // bounds the growth behind a zero pivot (refinement then removes the perturbation)
        let entry = |p: usize| a.entry(p);
        let mut pivots = self.factor_with(&entry, f64::EPSILON * amax, par)?;
        if pivots.perturbed > 0 {
            pivots = self.factor_with(&entry, f64::EPSILON.sqrt() * amax, par)?;
        }
        self.invert_diagonal(par);
        self.perturbed = pivots.perturbed;
        self.pivot_ratio = if pivots.hi > 0.0 {
            pivots.lo / pivots.hi
        } else {
            f64::NAN
        };
        require_pivots(
            self.pivot_ratio,
            freq_hz,
            "the complex LDLᵀ factorization met a non-finite or all-zero pivot (NaN in the model, or A(iω) = 0)",
        )
    }

    fn solve(&mut self, rhs: MatMut<'_, c64>, par: Par) {
        self.solve_all(rhs, par);
    }

    fn pivot_ratio(&self) -> f64 {
        self.pivot_ratio
    }

    fn perturbed(&self) -> usize {
        self.perturbed
    }

    fn reads_arrays(&self) -> bool {
        false
    }
}

impl<S: std::ops::Deref<Target = Symbolic>, T: FactorScalar> Numeric<S, T> {
    /// Solves A X = B in place for at most `x.ncols()` columns: P, L, D, Lᵀ, Pᵀ. With a
    /// [`SubtreeGroups`] the two groups of subtrees are solved independently (on two threads when
    /// `par` has them): forward, each group keeps its contributions to the top's rows in its
    /// own buffer, added to the top before the top is solved; backward, the top first, then
    /// the groups read its solution from a copy. The groups run the same way on one thread,
    /// so the solution does not depend on the thread count.
    pub(super) fn solve_block(&mut self, rhs: MatMut<'_, T>, par: Par) {
        let sy: &Symbolic = &self.symbolic;
        let s = supernodal(&sy.sym);
        let (n, k) = (rhs.nrows(), rhs.ncols());
        let mut x = self.x.as_mut().submatrix_mut(0, 0, n, k);
        permute(&sy.fwd, rhs.rb(), x.rb_mut(), par);
        let [s0, s1] = &mut self.solve;
        let solver = Sweep { sy, l: &self.l };
        let all = 0..s.n_supernodes();
        match sy.split.as_ref() {
            None => solver.substitute(Direction::Forward, all.clone(), x.rb_mut(), 0, s0, &[], par),
            Some(split) => {
                s0.top.fill(T::ZERO);
                s1.top.fill(T::ZERO);
                solver.groups(split, x.rb_mut(), [s0, s1], par, |sw, sns, xg, r0, sc| {
                    sw.substitute(
                        Direction::Forward,
                        sns,
                        xg,
                        r0,
                        sc,
                        &split.top_pos,
                        Par::Seq,
                    )
                });
                for c in 0..k {
                    for (p, &r) in split.top_rows.iter().enumerate() {
                        x[(r, c)] -= s0.top[(p, c)] + s1.top[(p, c)];
                    }
                }
                solver.substitute(
                    Direction::Forward,
                    split.top.iter().copied(),
                    x.rb_mut(),
                    0,
                    s0,
                    &[],
                    par,
                );
            }
        }
        scale_rows(x.rb_mut(), &self.d_inv, par);
        match sy.split.as_ref() {
            None => solver.substitute(Direction::Backward, all.rev(), x.rb_mut(), 0, s0, &[], par),
            Some(split) => {
                solver.substitute(
                    Direction::Backward,
                    split.top.iter().rev().copied(),
                    x.rb_mut(),
                    0,
                    s0,
                    &[],
                    par,
                );
                for sc in [&mut *s0, &mut *s1] {
                    for c in 0..k {
                        for (p, &r) in split.top_rows.iter().enumerate() {
                            sc.top[(p, c)] = x[(r, c)];
                        }
                    }
                }
                solver.groups(split, x.rb_mut(), [s0, s1], par, |sw, sns, xg, r0, sc| {
                    sw.substitute(
                        Direction::Backward,
                        sns.rev(),
                        xg,
                        r0,
                        sc,
                        &split.top_pos,
                        Par::Seq,
                    )
                });
            }
        }
        unpermute(&sy.fwd, x.rb(), rhs, par);
    }
}

/// X ← P B: row i of `x` is row `fwd[i]` of `b`.
pub(super) fn permute<T: FactorScalar>(
    fwd: &[usize],
    b: MatRef<'_, T>,
    x: MatMut<'_, T>,
    par: Par,
) {
    by_columns(x, par, |c, mut xc| {
        for (i, &f) in fwd.iter().enumerate() {
            xc[i] = b[(f, c)];
        }
    });
}

/// B ← Pᵀ X, the inverse of [`permute`].
pub(super) fn unpermute<T: FactorScalar>(
    fwd: &[usize],
    x: MatRef<'_, T>,
    b: MatMut<'_, T>,
    par: Par,
) {
    by_columns(b, par, |c, mut bc| {
        for (i, &f) in fwd.iter().enumerate() {
            bc[f] = x[(i, c)];
        }
    });
}

/// X ← D⁻¹ X, `d_inv` the diagonal of D⁻¹.
pub(super) fn scale_rows<T: FactorScalar>(x: MatMut<'_, T>, d_inv: &[T], par: Par) {
    by_columns(x, par, |_, xc| {
        for (v, d) in xc.iter_mut().zip(d_inv) {
            *v *= *d;
        }
    });
}

/// `f(c, column c of x)` for every column, on two threads (each half of the columns) when
/// `par` has them.
fn by_columns<T: FactorScalar>(
    x: MatMut<'_, T>,
    par: Par,
    f: impl Fn(usize, faer::ColMut<'_, T>) + Sync,
) {
    let k = x.ncols();
    if par.degree() > 1 && k > 1 {
        let (a, b) = x.split_at_col_mut(k / 2);
        rayon::join(
            || a.col_iter_mut().enumerate().for_each(|(c, col)| f(c, col)),
            || {
                b.col_iter_mut()
                    .enumerate()
                    .for_each(|(c, col)| f(k / 2 + c, col))
            },
        );
    } else {
        x.col_iter_mut().enumerate().for_each(|(c, col)| f(c, col));
    }
}

/// Forward (L y = b) or backward (Lᵀ x = z) substitution.
#[derive(Clone, Copy)]
pub(super) enum Direction {
    Forward,
    Backward,
}

/// The triangular solves of one numeric factorization, supernode by supernode.
struct Sweep<'a, T> {
    sy: &'a Symbolic,
    l: &'a [T],
}

impl<T: FactorScalar> Sweep<'_, T> {
    /// Supernode `sn`'s diagonal block and the rows below it.
    fn panel(&self, sn: usize) -> (MatRef<'_, T>, MatRef<'_, T>) {
        let s = supernodal(&self.sy.sym);
        let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
        let (ncols, np) = (end[sn] - begin[sn], pattern(s, sn).len());
        MatRef::from_column_major_slice(&self.l[cpv[sn]..cpv[sn + 1]], ncols + np, ncols)
            .split_at_row(ncols)
    }

    /// Runs `run` on each group of `split`'s subtrees (each subtree with its rows of `x`, the
    /// first row's index and the group's buffers), the groups on two threads when `par` has
    /// them.
    fn groups(
        &self,
        split: &SubtreeGroups,
        x: MatMut<'_, T>,
        scratch: [&mut SolveScratch<T>; 2],
        par: Par,
        run: impl Fn(&Self, std::ops::Range<usize>, MatMut<'_, T>, usize, &mut SolveScratch<T>) + Sync,
    ) {
        let s = supernodal(&self.sy.sym);
        let (begin, end) = (s.supernode_begin(), s.supernode_end());
        // each subtree's rows, cut from x in order of position
        let ranges = split.subtrees();
        let mut parts: [Vec<(usize, usize, MatMut<'_, T>)>; 2] = [Vec::new(), Vec::new()];
        let mut rest = x;
        let mut offset = 0;
        for (first, last, g) in ranges {
            let (r0, r1) = (begin[first], end[last - 1]);
            let (_, tail) = rest.split_at_row_mut(r0 - offset);
            let (mine, tail) = tail.split_at_row_mut(r1 - r0);
            parts[g].push((first, last, mine));
            rest = tail;
            offset = r1;
        }
        let [p0, p1] = parts;
        let [sc0, sc1] = scratch;
        let group = |part: Vec<(usize, usize, MatMut<'_, T>)>, sc: &mut SolveScratch<T>| {
            for (first, last, xg) in part {
                run(self, first..last, xg, begin[first], sc);
            }
        };
        if par.degree() > 1 {
            rayon::join(|| group(p0, sc0), || group(p1, sc1));
        } else {
            group(p0, sc0);
            group(p1, sc1);
        }
    }

    /// One substitution over the supernodes `sns`: forward L y = b, or backward Lᵀ x = z
    /// (`sns` then in reverse order). `x` holds the rows from `r0` on of every supernode in
    /// `sns` and of every row below them, except rows r with `top_pos[r]` set (the top's, seen
    /// from a group): forward, a group's contributions to them go to `sc.top`; backward, their
    /// solution is read from `sc.top`.
    #[allow(clippy::too_many_arguments)]
    fn substitute(
        &self,
        direction: Direction,
        sns: impl Iterator<Item = usize>,
        mut x: MatMut<'_, T>,
        r0: usize,
        sc: &mut SolveScratch<T>,
        top_pos: &[usize],
        par: Par,
    ) {
        let s = supernodal(&self.sy.sym);
        let begin = s.supernode_begin();
        for sn in sns {
            let (top, bot) = self.panel(sn);
            let at = Rows {
                first: begin[sn] - r0,
                pattern: pattern(s, sn),
                r0,
                top_pos,
            };
            substitute_panel(direction, top, bot, &at, x.rb_mut(), sc, par);
        }
    }
}

/// Where one supernode's panel acts in a substitution: its first row in `x` and its pattern
/// (global rows, `x` holding rows from `r0` on but for the top's, `top_pos`; see
/// [`Sweep::substitute`]).
pub(super) struct Rows<'a> {
    pub(super) first: usize,
    pub(super) pattern: &'a [usize],
    pub(super) r0: usize,
    pub(super) top_pos: &'a [usize],
}

/// One supernode's step of a substitution with its panel [`top`; `bot`]: forward, x_s ←
/// top⁻¹ x_s and the pattern's rows less bot·x_s; backward, x_s ← top⁻ᵀ (x_s − botᵀ x_pattern).
pub(super) fn substitute_panel<T: FactorScalar>(
    direction: Direction,
    top: MatRef<'_, T>,
    bot: MatRef<'_, T>,
    at: &Rows<'_>,
    mut x: MatMut<'_, T>,
    sc: &mut SolveScratch<T>,
    par: Par,
) {
    let k = x.ncols();
    let one = T::ONE;
    let Rows {
        first,
        pattern: pat,
        r0,
        top_pos,
    } = *at;
    let in_top = |r: usize| top_pos.get(r).copied().filter(|&t| t != usize::MAX);
    let p = par_for((top.nrows() + pat.len()) * top.nrows() * k, par);
    let mut g = sc.gathered.as_mut().submatrix_mut(0, 0, pat.len(), k);
    match direction {
        Direction::Forward => {
            let mut xs = x.rb_mut().subrows_mut(first, top.nrows());
            solve_unit_lower_triangular_in_place(top, xs.rb_mut(), p);
            matmul(g.rb_mut(), Accum::Replace, bot, xs.rb(), one, p);
            for c in 0..k {
                for (i, &r) in pat.iter().enumerate() {
                    match in_top(r) {
                        Some(t) => sc.top[(t, c)] += g[(i, c)],
                        None => x[(r - r0, c)] -= g[(i, c)],
                    }
                }
            }
        }
        Direction::Backward => {
            for c in 0..k {
                for (i, &r) in pat.iter().enumerate() {
                    g[(i, c)] = match in_top(r) {
                        Some(t) => sc.top[(t, c)],
                        None => x[(r - r0, c)],
                    };
                }
            }
            let mut xs = x.rb_mut().subrows_mut(first, top.nrows());
            matmul(xs.rb_mut(), Accum::Add, bot.transpose(), g.rb(), -one, p);
            solve_unit_upper_triangular_in_place(top.transpose(), xs, p);
        }
    }
}

/// Scatters of fewer entries than this run on one thread (memory-bound; a split costs a
/// rayon join).
const PAR_MIN_SCATTER: usize = 1 << 16;

/// Where a descendant's update lands in the panel of supernode s (columns c0..): its rows
/// `rows` (global, the first `k` inside s's columns, the rest in s's pattern at panel row
/// `local[row]`).
struct Target<'a> {
    rows: &'a [usize],
    k: usize,
    c0: usize,
    local: &'a [usize],
}

/// Subtracts the descendant update `w` (rows × k, its first k rows only in their lower
/// triangle) from the panel columns `rows[jj] − c0` for jj in `cols`; `ls` holds the panel's
/// columns from `first` on. With threads and enough entries the columns go in two halves of
/// equal work, each on its own thread: they write disjoint columns, and every entry gets the
/// same single subtraction either way.
fn subtract_update<T: FactorScalar>(
    mut ls: MatMut<'_, T>,
    first: usize,
    w: MatRef<'_, T>,
    t: &Target<'_>,
    cols: std::ops::Range<usize>,
    par: Par,
) {
    let Target { rows, k, c0, local } = *t;
    // column jj scatters rows jj.. of w
    let work = |jj: usize| rows.len() - jj;
    let total: usize = cols.clone().map(work).sum();
    if par.degree() > 1 && cols.len() > 1 && total >= PAR_MIN_SCATTER {
        let mut half = 0;
        let mid = cols
            .clone()
            .find(|&jj| {
                half += work(jj);
                2 * half >= total
            })
            .map_or(cols.end - 1, |jj| jj + 1)
            .clamp(cols.start + 1, cols.end - 1);
        let at = rows[mid] - c0 - first;
        let (left, right) = ls.split_at_col_mut(at);
        rayon::join(
            || subtract_update(left, first, w, t, cols.start..mid, Par::Seq),
            || subtract_update(right, first + at, w, t, mid..cols.end, Par::Seq),
        );
        return;
    }
    for jj in cols {
        let dst = ls
            .rb_mut()
            .col_mut(rows[jj] - c0 - first)
            .try_as_col_major_mut()
            .expect("a panel column is contiguous")
            .as_slice_mut();
        let src = w.col(jj).try_as_col_major().expect("contiguous").as_slice();
        for (&r, &v) in rows[jj..k].iter().zip(&src[jj..k]) {
            dst[r - c0] -= v;
        }
        for (&r, &v) in rows[k..].iter().zip(&src[k..]) {
            dst[local[r]] -= v;
        }
    }
}

/// The pivots of one factorization: the static threshold and what was seen.
pub(super) struct Pivots {
    tau: f64,
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) perturbed: usize,
    /// Real pivots below 0 (taken after any perturbation).
    pub(super) negative: usize,
}

impl Pivots {
    /// No pivot seen yet, threshold `tau`.
    pub(super) fn new(tau: f64) -> Self {
        Pivots {
            tau,
            lo: f64::INFINITY,
            hi: 0.0,
            perturbed: 0,
            negative: 0,
        }
    }

    /// Adds what another thread's pivots saw.
    fn merge(&mut self, other: Pivots) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
        self.perturbed += other.perturbed;
        self.negative += other.negative;
    }

    /// The pivot to use for `d`: d itself, or τ·d/|d| (τ for d = 0) when |d| < τ.
    fn take<T: FactorScalar>(&mut self, d: T) -> T {
        let m = d.magnitude();
        let d = if m < self.tau {
            self.perturbed += 1;
            if m > 0.0 {
                d * T::from_parts(self.tau / m, 0.0)
            } else {
                T::from_parts(self.tau, 0.0)
            }
        } else {
            d
        };
        let m = d.magnitude();
        self.negative += usize::from(d.negative());
        self.lo = self.lo.min(m);
        self.hi = self.hi.max(m);
        d
    }
}

/// Dense LDLᵀ (transpose) of the lower triangle of `a` in place: the strictly lower part
/// becomes L, the diagonal D. Recursive halving: A₁₁ = L₁₁D₁L₁₁ᵀ, L₂₁D₁ = A₂₁L₁₁⁻ᵀ,
/// A₂₂ ← A₂₂ − (L₂₁D₁)L₂₁ᵀ, then A₂₂ itself. `work` holds L₂₁D₁.
fn dense_ldlt<T: FactorScalar>(
    mut a: MatMut<'_, T>,
    work: &mut [T],
    pivots: &mut Pivots,
    par: Par,
) {
    let n = a.nrows();
    if n <= UNBLOCKED {
        for j in 0..n {
            let (left, mut right) = a.rb_mut().split_at_col_mut(j + 1);
            let mut lj = left.col_mut(j).subrows_mut(j, n - j);
            let lj = lj
                .rb_mut()
                .try_as_col_major_mut()
                .expect("a column of a column-major block is contiguous")
                .as_slice_mut();
            let d = pivots.take(lj[0]);
            lj[0] = d;
            let inv = d.reciprocal();
            // a[c.., c] −= (L d)[c.., j] · (L d)[c, j] / d for the columns right of j
            for (c, col) in right.rb_mut().col_iter_mut().enumerate() {
                let f = lj[c + 1] * inv;
                let col = col
                    .try_as_col_major_mut()
                    .expect("a column of a column-major block is contiguous")
                    .as_slice_mut();
                for (x, &l) in col[j + 1 + c..].iter_mut().zip(&lj[c + 1..]) {
                    *x -= l * f;
                }
            }
            for x in &mut lj[1..] {
                *x *= inv;
            }
        }
        return;
    }
    let h = n / 2;
    let par = par_for(n * n * n / 4, par);
    let (mut a11, _, mut a21, mut a22) = a.rb_mut().split_at_mut(h, h);
    dense_ldlt(a11.rb_mut(), work, pivots, par);
    solve_right_transposed(a11.rb(), a21.rb_mut(), work, par);
    // (L21 D1)ᵀ, stored column-major (as in the descendant updates), then L21 in place
    let (wd, rest) = work.split_at_mut((n - h) * h);
    let mut wd_t = MatMut::from_column_major_slice_mut(wd, h, n - h);
    wd_t.copy_from(a21.rb().transpose());
    divide_by_diagonal(a11.rb(), a21.rb_mut());
    triangular::matmul(
        a22.rb_mut(),
        BlockStructure::TriangularLower,
        Accum::Add,
        a21.rb(),
        BlockStructure::Rectangular,
        wd_t.rb(),
        BlockStructure::Rectangular,
        T::from_parts(-1.0, 0.0),
        par,
    );
    dense_ldlt(a22, rest, pivots, par);
}

/// The supernode's panel [A₁₁; A₂₁] (`ncols` columns, lower part of A₁₁ used) becomes
/// [L₁₁ with D on its diagonal; L₂₁]: A₁₁ = L₁₁ D L₁₁ᵀ, then L₂₁ = A₂₁ L₁₁⁻ᵀ D⁻¹.
pub(super) fn factor_panel<T: FactorScalar>(
    panel: MatMut<'_, T>,
    work: &mut [T],
    pivots: &mut Pivots,
    par: Par,
) {
    let ncols = panel.ncols();
    let (mut top, mut bot) = panel.split_at_row_mut(ncols);
    dense_ldlt(top.rb_mut(), work, pivots, par);
    let p = par_for(bot.nrows() * ncols * ncols, par);
    solve_right_transposed(top.rb(), bot.rb_mut(), work, p);
    divide_by_diagonal(top.rb(), bot);
}

/// X ← X D⁻¹, D the diagonal of the factored block `ld`.
fn divide_by_diagonal<T: FactorScalar>(ld: MatRef<'_, T>, mut x: MatMut<'_, T>) {
    for j in 0..ld.ncols() {
        let inv = ld[(j, j)].reciprocal();
        for v in x.rb_mut().col_mut(j).iter_mut() {
            *v *= inv;
        }
    }
}

/// X ← X L⁻ᵀ for a unit lower triangular L (c × c) and a column-major X (p × c), recursively
/// on halves of L. faer solves a transposed (row-major) X directly, but its products then run
/// on row-major operands; here the coupling X₂ −= X₁ L₂₁ᵀ is a GEMM on a column-major copy of
/// L₂₁ᵀ (`work`, c²/4 entries).
fn solve_right_transposed<T: FactorScalar>(
    l: MatRef<'_, T>,
    x: MatMut<'_, T>,
    work: &mut [T],
    par: Par,
) {
    let c = l.nrows();
    if c <= UNBLOCKED_SOLVE {
        solve_unit_lower_triangular_in_place(l, x.transpose_mut(), par);
        return;
    }
    let h = c / 2;
    let (mut x1, mut x2) = x.split_at_col_mut(h);
    solve_right_transposed(l.submatrix(0, 0, h, h), x1.rb_mut(), work, par);
    let mut l21_t = MatMut::from_column_major_slice_mut(&mut work[..h * (c - h)], h, c - h);
    l21_t.copy_from(l.submatrix(h, 0, c - h, h).transpose());
    let p = par_for(x1.nrows() * h * (c - h), par);
    matmul(
        x2.rb_mut(),
        Accum::Add,
        x1.rb(),
        l21_t.rb(),
        T::from_parts(-1.0, 0.0),
        p,
    );
    solve_right_transposed(l.submatrix(h, h, c - h, c - h), x2, work, par);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(40))]

        /// The dense panel kernels (recursive LDLᵀ, blocked right solve) on random
        /// complex-symmetric panels: L₁₁ D L₁₁ᵀ and L₂₁ D L₁₁ᵀ reproduce the panel's blocks,
        /// for sizes on both sides of the unblocked limits and odd halves.
        #[test]
        fn panel_factor_reproduces_the_panel(
            ncols in 1usize..140,
            below in 0usize..60,
            seed in 0u64..1000,
        ) {
            let m = ncols + below;
            let entry = |i: usize, j: usize| {
                let (i, j) = (i.max(j) as u64, i.min(j) as u64);
                let h = (i * 7919 + j * 104_729 + seed * 31).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                c64::new((h % 1000) as f64 / 500.0 - 1.0, ((h >> 20) % 1000) as f64 / 500.0 - 1.0)
            };
            let a = Mat::<c64>::from_fn(m, ncols, |i, j| {
                if i == j { entry(i, j) + c64::new(2.0 * ncols as f64, 0.5) } else { entry(i, j) }
            });
            let mut f = a.clone();
            let mut work = vec![c64::new(0.0, 0.0); ncols * ncols.div_ceil(2)];
            let mut pivots = Pivots::new(0.0);
            factor_panel(f.as_mut(), &mut work, &mut pivots, Par::Seq);
            let l = Mat::<c64>::from_fn(m, ncols, |i, j| match i.cmp(&j) {
                std::cmp::Ordering::Greater => f[(i, j)],
                std::cmp::Ordering::Equal => c64::new(1.0, 0.0),
                std::cmp::Ordering::Less => c64::new(0.0, 0.0),
            });
            let ld = Mat::<c64>::from_fn(m, ncols, |i, j| l[(i, j)] * f[(j, j)]);
            let product = &ld * l.subrows(0, ncols).transpose();
            let mut err = 0.0f64;
            for j in 0..ncols {
                for i in j..m {
                    err = err.max((product[(i, j)] - a[(i, j)]).norm());
                }
            }
            prop_assert!(err <= 1e-12 * ncols as f64, "error {err:.1e}");
        }
    }
}
