//! The fill-reducing ordering of the pencil's pattern (docs/design.md §3.1): AMD always, a
//! level-set bisection from [`MIN_BISECTED`] unknowns, and with cargo feature `metis` (on by
//! default) also METIS's nested dissection, keeping the one whose symbolic Cholesky has the fewest entries
//! (the bisection also when it has at most 5 % more: its two halves give one factorization
//! two threads).
//!
//! Every sparse symmetric factorization of the crate (the complex LDLᵀ, the LBLᵀ forms, the
//! eigensolver's Cholesky and inertia counts) works on the one symbolic analysis chosen here.
//! Slender bars keep the bisection; a chunky 3-D body (the 32³ cube) takes nested dissection,
//! with half of AMD's factor entries, and the flops follow (docs/performance.md, "Ordering
//! matters").

use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::Side;

/// The orderings the analysis compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Approximate minimum degree on the whole pattern.
    Amd,
    /// One level of dissection by a breadth-first level set, each part in a profile order
    /// toward it (docs/design.md §3.1): two independent subtrees for two threads.
    Bisected,
    /// METIS's nested dissection (cargo feature `metis`).
    NestedDissection,
}

/// Which ordering the analysis kept, and the factor sizes it compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderingChoice {
    /// The ordering kept.
    pub kept: Order,
    /// Entries of the symbolic Cholesky factor with AMD.
    pub amd_nnz: usize,
    /// Entries with the bisected order (`None` when the graph has no useful level set:
    /// disconnected, too small, or too shallow).
    pub bisected_nnz: Option<usize>,
    /// Entries with nested dissection (`None` without the `metis` feature or when METIS
    /// failed, e.g. a pattern too large for its 32-bit indices).
    pub nd_nnz: Option<usize>,
}

impl OrderingChoice {
    /// Entries of the factor with the kept ordering.
    pub fn nnz(&self) -> usize {
        match self.kept {
            Order::Amd => Some(self.amd_nnz),
            Order::Bisected => self.bisected_nnz,
            Order::NestedDissection => self.nd_nnz,
        }
        .unwrap_or(self.amd_nnz)
    }
}

impl std::fmt::Display for OrderingChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self.kept {
            Order::Amd => "AMD",
            Order::Bisected => "level-set bisection",
            Order::NestedDissection => "METIS nested dissection",
        };
        write!(f, "{name} (nnz(L) {}; AMD {}", self.nnz(), self.amd_nnz)?;
        if let Some(b) = self.bisected_nnz {
            write!(f, ", bisection {b}")?;
        }
        if let Some(nd) = self.nd_nnz {
            write!(f, ", METIS {nd}")?;
        }
        write!(f, ")")
    }
}

/// The bisected order is kept over a fewer-entry one when it has at most this factor more
/// entries: its two independent halves let one factorization use two threads.
const BISECTED_ALLOWANCE: f64 = 1.05;

/// The symbolic Cholesky of the pencil's N×N lower pattern on the best of the orderings,
/// and what was compared: the fewest entries, where the bisected order may have
/// 5 % more (`BISECTED_ALLOWANCE`).
///
/// # Errors
/// [`Error::Factor`] when the analysis fails (allocation, index overflow).
pub fn symbolic_cholesky_ordered(
    pencil: &Pencil,
) -> Result<(SymbolicCholesky<usize>, OrderingChoice)> {
    // the orderings are independent: side by side when there are threads; the bisection
    // and METIS share one graph, and a custom order is postordered only if it is kept
    let (amd, (bis, nd)) = rayon::join(
        || analyse(pencil, SymmetricOrdering::Amd),
        || {
            let graph = Graph::new(pencil);
            rayon::join(
                || {
                    bisected(&graph)
                        .map(|o| analyse_custom(pencil, o))
                        .transpose()
                },
                || nested_dissection_analysis(pencil, &graph),
            )
        },
    );
    let (amd, bis, nd) = (amd?, bis?, nd?);
    let amd_nnz = amd.len_val();
    let mut bisected_nnz = bis.as_ref().map(|(s, _)| s.len_val());
    let mut nd_nnz = nd.as_ref().map(|(s, _)| s.len_val());
    let best = [Some(amd_nnz), nd_nnz]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(amd_nnz);
    let (kept, sym) = match (bis, nd) {
        (Some(bis), _) if bis.0.len_val() as f64 <= BISECTED_ALLOWANCE * best as f64 => {
            let sym = postordered(pencil, bis)?;
            bisected_nnz = Some(sym.len_val());
            (Order::Bisected, sym)
        }
        // faer amalgamates the postordered supernodes differently: the comparison with AMD
        // is repeated on the kept analysis (the 10⁴-DoF tet10 bracket: 2.21 M entries before
        // the postorder, 2.26 M after, AMD 2.21 M)
        (_, Some(nd)) if nd.0.len_val() < amd_nnz => {
            let sym = postordered(pencil, nd)?;
            nd_nnz = Some(sym.len_val());
            if sym.len_val() < amd_nnz {
                (Order::NestedDissection, sym)
            } else {
                (Order::Amd, amd)
            }
        }
        _ => (Order::Amd, amd),
    };
    let choice = OrderingChoice {
        kept,
        amd_nnz,
        bisected_nnz,
        nd_nnz,
    };
    Ok((sym, choice))
}

/// A custom order's first analysis and the order (row i of P A Pᵀ is row `fwd[i]` of A).
type Custom = (SymbolicCholesky<usize>, Vec<usize>);

/// The analysis on METIS's order, or `None` without the feature or when METIS fails.
fn nested_dissection_analysis(pencil: &Pencil, graph: &Graph) -> Result<Option<Custom>> {
    #[cfg(feature = "metis")]
    if let Some(order) = nested_dissection(graph) {
        return analyse_custom(pencil, order).map(Some);
    }
    let _ = (pencil, graph);
    Ok(None)
}

/// The analysis on the custom order `(fwd, inv)`, as faer keeps it (not in postorder).
fn analyse_custom(pencil: &Pencil, (fwd, inv): (Vec<usize>, Vec<usize>)) -> Result<Custom> {
    let perm = faer::perm::PermRef::new_checked(&fwd, &inv, pencil.n());
    let sym = analyse(pencil, SymmetricOrdering::Custom(perm))?;
    Ok((sym, fwd))
}

/// The analysis on a custom order with its supernodes renumbered in postorder: the LDLᵀ's
/// parallel subtrees must be contiguous.
fn postordered(pencil: &Pencil, (first, fwd): Custom) -> Result<SymbolicCholesky<usize>> {
    let (fwd, inv) = postorder(&first, &fwd);
    drop(first);
    let perm = faer::perm::PermRef::new_checked(&fwd, &inv, pencil.n());
    analyse(pencil, SymmetricOrdering::Custom(perm))
}

/// faer's supernodal symbolic Cholesky of the pencil's lower pattern on `ordering`.
fn analyse(
    pencil: &Pencil,
    ordering: SymmetricOrdering<'_, usize>,
) -> Result<SymbolicCholesky<usize>> {
    factorize_symbolic_cholesky(
        pattern::lower(pencil),
        Side::Lower,
        ordering,
        supernodal_params(),
    )
    .map_err(|e| Error::Factor(format!("symbolic analysis: {e:?}")))
}

/// The order `fwd` (row i of P A Pᵀ is row fwd[i] of A, the order `sym` was analysed on)
/// with the supernodes of `sym` renumbered in a postorder of their elimination tree (parent
/// of a supernode: the owner of the first row below it), each keeping its columns in order;
/// returned with its inverse. A postorder is a topological order, so the exact fill is
/// unchanged; faer's relaxed amalgamation of small supernodes may differ slightly (the 32³
/// cube: 119.5 M entries on METIS's order as given, 120.4 M in postorder).
fn postorder(sym: &SymbolicCholesky<usize>, fwd: &[usize]) -> (Vec<usize>, Vec<usize>) {
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    let n = fwd.len();
    let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
        let inv = inverse(fwd);
        return (fwd.to_vec(), inv);
    };
    let ns = s.n_supernodes();
    let (begin, end) = (s.supernode_begin(), s.supernode_end());
    let (_, parent) = supernode_tree(s);
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); ns];
    let mut roots = Vec::new();
    for (sn, p) in parent.into_iter().enumerate() {
        match p {
            Some(p) => children[p].push(sn),
            None => roots.push(sn),
        }
    }
    let mut order = Vec::with_capacity(n);
    // iterative depth-first search: a supernode is emitted after all its children
    let mut stack: Vec<(usize, usize)> = roots.iter().rev().map(|&r| (r, 0)).collect();
    while let Some((sn, next)) = stack.pop() {
        if let Some(&child) = children[sn].get(next) {
            stack.push((sn, next + 1));
            stack.push((child, 0));
        } else {
            order.extend(begin[sn]..end[sn]);
        }
    }
    let fwd: Vec<usize> = order.iter().map(|&c| fwd[c]).collect();
    let inv = inverse(&fwd);
    (fwd, inv)
}

/// The inverse of the permutation `fwd`.
fn inverse(fwd: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; fwd.len()];
    for (k, &f) in fwd.iter().enumerate() {
        inv[f] = k;
    }
    inv
}

/// METIS_NodeND on the graph of the pencil's pattern (both triangles, no diagonal): the
/// permutation (row i of P A Pᵀ is row fwd[i] of A) and its inverse, or `None` when the graph
/// does not fit METIS's 32-bit indices or METIS reports an error.
#[cfg(feature = "metis")]
fn nested_dissection(graph: &Graph) -> Option<(Vec<usize>, Vec<usize>)> {
    use metis_sys::idx_t;
    let n = graph.n();
    if graph.adjncy.len() > idx_t::MAX as usize || n > idx_t::MAX as usize {
        return None;
    }
    let mut adjncy: Vec<idx_t> = graph.adjncy.iter().map(|&v| v as idx_t).collect();
    let mut xadj: Vec<idx_t> = graph.xadj.iter().map(|&x| x as idx_t).collect();
    let mut nvtxs = n as idx_t;
    let mut options = [0 as idx_t; metis_sys::METIS_NOPTIONS as usize];
    let (mut perm, mut iperm) = (vec![0 as idx_t; n], vec![0 as idx_t; n]);
    // METIS seeds GKlib's random generator, whose state is a process global
    // (GKlib/random.c: `static uint64_t mt[NN]`), at every call: concurrent calls interleave
    // their draws and return orderings that differ from run to run (two in-process ranks would
    // then sweep with different orders). One call at a time keeps each ordering a function of
    // its graph alone.
    static METIS: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = METIS.lock().unwrap_or_else(|p| p.into_inner());
    // SAFETY: `options` has METIS_NOPTIONS entries, as METIS_SetDefaultOptions requires.
    // METIS_NodeND reads the CSR graph `xadj` (n + 1 entries, non-decreasing, ending at
    // adjncy.len()) and `adjncy` (neighbour indices < n, no self loops, symmetric by
    // construction in `Graph::new`), no vertex weights (null), and writes n entries each to `perm`
    // and `iperm`; all buffers live across the call and indices fit idx_t (checked above).
    let status = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_NodeND(
            &mut nvtxs,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    if status != metis_sys::rstatus_et_METIS_OK {
        return None;
    }
    let fwd: Vec<usize> = perm.iter().map(|&p| p as usize).collect();
    let inv: Vec<usize> = iperm.iter().map(|&p| p as usize).collect();
    // METIS's output is a permutation of 0..n; check rather than trust before faer sees it
    let mut seen = vec![false; n];
    for (k, &f) in fwd.iter().enumerate() {
        if f >= n || seen[f] || inv[f] != k {
            return None;
        }
        seen[f] = true;
    }
    Some((fwd, inv))
}

/// The graph of the pencil's pattern (both triangles, no diagonal) in compressed rows: the
/// neighbours of vertex i are `adjncy[xadj[i]..xadj[i + 1]]`, increasing.
struct Graph {
    xadj: Vec<usize>,
    adjncy: Vec<usize>,
}

impl Graph {
    fn new(pencil: &Pencil) -> Graph {
        let n = pencil.n();
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let mut xadj = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &ri[cp[j]..cp[j + 1]] {
                if i != j {
                    xadj[i + 1] += 1;
                    xadj[j + 1] += 1;
                }
            }
        }
        for i in 0..n {
            xadj[i + 1] += xadj[i];
        }
        let mut next: Vec<usize> = xadj[..n].to_vec();
        let mut adjncy = vec![0usize; xadj[n]];
        // column by column: vertex v's neighbours u < v arrive with the columns u, in
        // increasing order, before those below it (the rows of column v), which are increasing
        for j in 0..n {
            for &i in &ri[cp[j]..cp[j + 1]] {
                if i != j {
                    adjncy[next[i]] = j;
                    next[i] += 1;
                    adjncy[next[j]] = i;
                    next[j] += 1;
                }
            }
        }
        Graph { xadj, adjncy }
    }

    fn n(&self) -> usize {
        self.xadj.len() - 1
    }
}

/// At most this many restarts of the search for a pseudo-peripheral vertex.
const PERIPHERAL_RESTARTS: usize = 8;

/// Below this many unknowns a factorization is too small for two threads inside it.
const MIN_BISECTED: usize = 4096;

/// One level of dissection for two threads inside one factorization (docs/design.md §3.1):
/// a breadth-first search from a pseudo-peripheral vertex (George and Liu: restarted from a
/// vertex of least degree in the last level while the depth grows) numbers the levels; the
/// level that best balances the vertices before and after it is the separator (on a slender
/// body a cross-section). Each part is numbered level by level toward the separator (a
/// profile order), then the separator, so the elimination tree has two independent subtrees
/// under it. On a bar a level is a cross-section and the factor is a band of two levels:
/// 10 % fewer entries than AMD on the 10⁵ bar; on a chunky body the levels are large and
/// the analysis keeps AMD. `None` below [`MIN_BISECTED`] unknowns, for a disconnected
/// graph, or with fewer than three levels.
fn bisected(graph: &Graph) -> Option<(Vec<usize>, Vec<usize>)> {
    let n = graph.n();
    if n < MIN_BISECTED {
        return None;
    }
    let (xadj, adjncy) = (&graph.xadj, &graph.adjncy);
    let degree = |v: usize| xadj[v + 1] - xadj[v];
    // breadth-first levels from `root` into `level`, visiting order into `queue`; the depth
    let search = |root: usize, level: &mut Vec<usize>, queue: &mut Vec<usize>| {
        level.clear();
        level.resize(n, usize::MAX);
        queue.clear();
        level[root] = 0;
        queue.push(root);
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head];
            head += 1;
            for &w in &adjncy[xadj[v]..xadj[v + 1]] {
                if level[w] == usize::MAX {
                    level[w] = level[v] + 1;
                    queue.push(w);
                }
            }
        }
        queue.last().map_or(0, |&v| level[v])
    };
    let (mut level, mut queue) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let root = (0..n).min_by_key(|&v| degree(v)).unwrap_or(0);
    let mut depth = search(root, &mut level, &mut queue);
    if queue.len() < n {
        return None;
    }
    // George and Liu's restarts (a few suffice: on a bar the second search already starts
    // at the far end); a search that does not deepen the levels leaves them as they were
    let (mut next_level, mut next_queue) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..PERIPHERAL_RESTARTS {
        let far = queue
            .iter()
            .rev()
            .take_while(|&&v| level[v] == depth)
            .copied()
            .min_by_key(|&v| degree(v))
            .unwrap_or(root);
        let d = search(far, &mut next_level, &mut next_queue);
        if d <= depth {
            break;
        }
        std::mem::swap(&mut level, &mut next_level);
        std::mem::swap(&mut queue, &mut next_queue);
        depth = d;
    }
    drop((next_level, next_queue));
    if depth < 2 {
        return None;
    }
    // vertices before level m: before[m]
    let mut before = vec![0usize; depth + 2];
    for &l in &level {
        before[l + 1] += 1;
    }
    for l in 0..=depth {
        before[l + 1] += before[l];
    }
    let sep = (1..depth)
        .min_by_key(|&m| before[m].abs_diff(n - before[m + 1]))
        .expect("depth >= 2");
    // the part before the separator by increasing level, the part after it by decreasing
    // level, each toward the separator; then the separator
    let mut fwd = Vec::with_capacity(n);
    fwd.extend(queue.iter().filter(|&&v| level[v] < sep));
    fwd.extend(queue.iter().rev().filter(|&&v| level[v] > sep));
    fwd.extend(queue.iter().filter(|&&v| level[v] == sep));
    let inv = inverse(&fwd);
    Some((fwd, inv))
}

/// The symbolic parameters of every factorization on faer's Cholesky machinery: always
/// supernodal (the intranode LBLᵀ needs supernodes for its 2×2 pivots).
pub(super) fn supernodal_params() -> CholeskySymbolicParams<'static> {
    CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    }
}

/// The supernodal elimination tree of `s`: the supernode owning each column, and each
/// supernode's parent (the owner of the first row below it; `None` for a root).
pub(super) fn supernode_tree(
    s: &SymbolicSupernodalCholesky<usize>,
) -> (Vec<usize>, Vec<Option<usize>>) {
    let (begin, end) = (s.supernode_begin(), s.supernode_end());
    let mut owner = vec![0usize; s.nrows()];
    for sn in 0..s.n_supernodes() {
        owner[begin[sn]..end[sn]].fill(sn);
    }
    let parent = (0..s.n_supernodes())
        .map(|sn| s.supernode(sn).pattern().first().map(|&r| owner[r]))
        .collect();
    (owner, parent)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};

    /// On a bar of 2×3×150 elements (3×4 nodes per cross-section, N = 5436) the bisection's
    /// separator is one cross-section (36 DoFs), numbered last; the two parts before it have
    /// equal size and no entry of A joins them.
    #[test]
    fn the_bisection_of_a_bar_separates_two_halves_by_one_cross_section() {
        let spec = BoxSpec {
            elements: [2, 3, 150],
            ..BoxSpec::paper_bar()
        };
        let pencil = Pencil::new(&bar_model(&spec).unwrap());
        let n = pencil.n();
        let (fwd, inv) =
            bisected(&Graph::new(&pencil)).expect("a connected bar above the size limit");
        assert_eq!(inverse(&fwd), inv);
        let mut sorted = fwd.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        let separator = 3 * 4 * 3;
        let half = (n - separator) / 2;
        assert_eq!(2 * half + separator, n);
        let part = |v: usize| (inv[v] / half).min(2);
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        for j in 0..n {
            for &i in &ri[cp[j]..cp[j + 1]] {
                assert!(
                    part(i) == part(j) || part(i) == 2 || part(j) == 2,
                    "DoFs {i} and {j} join the halves"
                );
            }
        }
    }

    /// Too small, or not connected: no bisection.
    #[test]
    fn small_or_disconnected_patterns_are_not_bisected() {
        let paper = Pencil::new(&bar_model(&BoxSpec::paper_bar()).unwrap());
        assert!(paper.n() < MIN_BISECTED);
        assert!(bisected(&Graph::new(&paper)).is_none());
        // two bars side by side, without a common entry
        let spec = BoxSpec {
            elements: [2, 3, 150],
            ..BoxSpec::paper_bar()
        };
        let one = bar_model(&spec).unwrap();
        let n = one.n();
        let twice = |a: &crate::sparse::Csc| {
            let mut t = crate::sparse::Triplets::default();
            for j in 0..n {
                for (i, &v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                    t.push(i, j, v);
                    t.push(n + i, n + j, v);
                }
            }
            t.into_csc(2 * n, false)
        };
        let (two, _) = crate::model::Model::new(
            "two bars".into(),
            twice(&one.mass),
            twice(&one.stiffness),
            crate::model::Damping::None,
            None,
            3,
        )
        .unwrap();
        assert!(bisected(&Graph::new(&Pencil::new(&two))).is_none());
        assert!(bisected(&Graph::new(&Pencil::new(&one))).is_some());
    }
}
