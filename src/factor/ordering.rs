//! The fill-reducing ordering of the pencil's pattern (docs/design.md §3.1): AMD always, and
//! with cargo feature `metis` also METIS's nested dissection, keeping the one whose symbolic
//! Cholesky has fewer entries.
//!
//! Every sparse symmetric factorization of the crate (the complex LDLᵀ, the LBLᵀ forms, the
//! eigensolver's Cholesky and inertia counts) works on the one symbolic analysis chosen here.
//! Measured (README, `bench sweep`): on slender bars AMD and nested dissection are close; on a
//! chunky 3-D body (the 32³ cube) MKL PARDISO's METIS order left 2.3× fewer entries in its
//! factor than AMD, and the flops follow.

use super::cholesky::supernodal_params;
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, SymbolicCholesky, SymmetricOrdering,
};
use faer::Side;

/// Which ordering the analysis kept, and the factor sizes it compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderingChoice {
    /// True when METIS's nested dissection was kept, false for AMD.
    pub nested_dissection: bool,
    /// Entries of the symbolic Cholesky factor with AMD.
    pub amd_nnz: usize,
    /// Entries with nested dissection (`None` without the `metis` feature or when METIS
    /// failed, e.g. a pattern too large for its 32-bit indices).
    pub nd_nnz: Option<usize>,
}

impl std::fmt::Display for OrderingChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.nd_nnz {
            Some(nd) if self.nested_dissection => write!(
                f,
                "METIS nested dissection (nnz(L) {nd}; AMD {})",
                self.amd_nnz
            ),
            Some(nd) => write!(f, "AMD (nnz(L) {}; METIS {nd})", self.amd_nnz),
            None => write!(f, "AMD (nnz(L) {})", self.amd_nnz),
        }
    }
}

/// The symbolic Cholesky of the pencil's N×N lower pattern on the better of the orderings,
/// and what was compared.
///
/// # Errors
/// [`Error::Factor`] when the analysis fails (allocation, index overflow).
pub fn symbolic_cholesky_ordered(
    pencil: &Pencil,
) -> Result<(SymbolicCholesky<usize>, OrderingChoice)> {
    // the two orderings are independent: side by side when there are threads
    #[cfg(feature = "metis")]
    let (amd, nd) = rayon::join(
        || analyse(pencil, SymmetricOrdering::Amd),
        || match nested_dissection(pencil) {
            Some((fwd, inv)) => {
                let perm = faer::perm::PermRef::new_checked(&fwd, &inv, pencil.n());
                let nd = analyse(pencil, SymmetricOrdering::Custom(perm))?;
                // faer keeps a custom order as given; the LDLᵀ's parallel subtrees need the
                // supernodes in postorder
                let (fwd, inv) = postorder(&nd, &fwd);
                let perm = faer::perm::PermRef::new_checked(&fwd, &inv, pencil.n());
                analyse(pencil, SymmetricOrdering::Custom(perm)).map(Some)
            }
            None => Ok(None),
        },
    );
    #[cfg(feature = "metis")]
    let (amd, nd) = (amd?, nd?);
    #[cfg(not(feature = "metis"))]
    let (amd, nd): (_, Option<SymbolicCholesky<usize>>) =
        (analyse(pencil, SymmetricOrdering::Amd)?, None);
    let amd_nnz = amd.len_val();
    let nd_nnz = nd.as_ref().map(|s| s.len_val());
    let choice = OrderingChoice {
        nested_dissection: nd_nnz.is_some_and(|nnz| nnz < amd_nnz),
        amd_nnz,
        nd_nnz,
    };
    match nd {
        Some(nd) if choice.nested_dissection => Ok((nd, choice)),
        _ => Ok((amd, choice)),
    }
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
/// cube: 119.5 M entries before, 120.4 M after).
#[cfg(feature = "metis")]
fn postorder(sym: &SymbolicCholesky<usize>, fwd: &[usize]) -> (Vec<usize>, Vec<usize>) {
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    let n = fwd.len();
    let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
        let inv = inverse(fwd);
        return (fwd.to_vec(), inv);
    };
    let ns = s.n_supernodes();
    let (begin, end) = (s.supernode_begin(), s.supernode_end());
    let (_, parent) = super::ldlt::supernode_tree(s);
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
#[cfg(feature = "metis")]
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
fn nested_dissection(pencil: &Pencil) -> Option<(Vec<usize>, Vec<usize>)> {
    use metis_sys::idx_t;
    let n = pencil.n();
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut degree = vec![0usize; n];
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            if i != j {
                degree[i] += 1;
                degree[j] += 1;
            }
        }
    }
    let mut xadj = Vec::with_capacity(n + 1);
    xadj.push(0usize);
    for d in &degree {
        xadj.push(xadj.last().copied().unwrap_or(0) + d);
    }
    let edges = xadj[n];
    if edges > idx_t::MAX as usize || n > idx_t::MAX as usize {
        return None;
    }
    let mut next: Vec<usize> = xadj[..n].to_vec();
    let mut adjncy: Vec<idx_t> = vec![0; edges];
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            if i != j {
                adjncy[next[i]] = j as idx_t;
                next[i] += 1;
                adjncy[next[j]] = i as idx_t;
                next[j] += 1;
            }
        }
    }
    let mut xadj: Vec<idx_t> = xadj.into_iter().map(|x| x as idx_t).collect();
    let mut nvtxs = n as idx_t;
    let mut options = [0 as idx_t; metis_sys::METIS_NOPTIONS as usize];
    let (mut perm, mut iperm) = (vec![0 as idx_t; n], vec![0 as idx_t; n]);
    // METIS seeds GKlib's random generator, whose state is a process global
    // (GKlib/random.c: `static uint64_t mt[NN]`), at every call: concurrent calls interleave
    // their draws and return orderings that differ from run to run (seen as a sweep that was
    // not bit-identical between two in-process ranks). One call at a time keeps each ordering a
    // function of its graph alone.
    static METIS: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = METIS.lock().unwrap_or_else(|p| p.into_inner());
    // SAFETY: `options` has METIS_NOPTIONS entries, as METIS_SetDefaultOptions requires.
    // METIS_NodeND reads the CSR graph `xadj` (n + 1 entries, non-decreasing, ending at
    // adjncy.len()) and `adjncy` (neighbour indices < n, no self loops, symmetric by
    // construction above), no vertex weights (null), and writes n entries each to `perm`
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
