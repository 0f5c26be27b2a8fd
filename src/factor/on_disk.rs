//! The real LDLᵀ with its factor on disk (docs/design.md §3.1, "Factor out of core"): for a
//! K − σM whose factor does not fit the memory budget.
//!
//! **Multifrontal factorization.** Supernodes are taken in order (children before parents).
//! Supernode s's front F (rows: its columns c₀..c₁, then its pattern) is assembled from A and
//! from its children's update blocks (extend-add through a row map), its first c₁ − c₀
//! columns are factored like the in-core panel (the same dense LDLᵀ and static pivots), and
//! its update block U_s = F₂₂ − L₂₁ D₁ L₂₁ᵀ (lower triangle, packed) waits in memory for the
//! parent. The factored panel [L₁₁; L₂₁] goes to an unnamed temporary file at once, in the
//! order and layout of L's values in memory, so the file is written front to back exactly
//! once. In memory at any time: one front (allocated zeroed for each supernode and touched
//! only in its lower triangle, so a large front's upper pages are never mapped), the update
//! blocks waiting for their parents, D⁻¹ and the solve's vectors, never L. The arithmetic of
//! each entry of L differs from the left-looking in-core factor only in the order of the
//! subtractions, so the two factors agree to rounding (tested).
//!
//! **Solves** read the panels back in chunks: forward in file order, backward in reverse; a
//! block solve reads the factor twice. The file is unnamed (O_TMPFILE, or unlinked as soon as
//! it is open): the system reclaims it when the factor is dropped or the process ends, however
//! it ends.

use super::backend::try_vec;
use super::ldlt::{
    factor_panel, par_for, pattern, permute, scale_rows, substitute_panel, supernodal, unpermute,
    Direction, Pivots, Rows, SolveScratch, Symbolic,
};
use super::ordering::supernode_tree;
use crate::{Error, Result};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Columns of L₂₁ per product of the update block: bounds the buffer of L₂₁D₁ to this many
/// columns of the largest pattern.
const UPDATE_BLOCK: usize = 256;

/// Bytes read from the file at once in a solve (more when one panel is larger); in tests a
/// few pages, so that the small factors there are read in many chunks.
const CHUNK_BYTES: usize = if cfg!(test) { 1 << 14 } else { 1 << 24 };

/// What the multifrontal factorization needs beyond the in-core analysis: the children of
/// each supernode in the supernodal elimination tree.
pub(super) struct Plan {
    children: Vec<Vec<usize>>,
}

impl Plan {
    /// The tree of the multifrontal factorization on `sy`.
    pub(super) fn new(sy: &Symbolic) -> Plan {
        let s = supernodal(&sy.sym);
        let (_, parent) = supernode_tree(s);
        let mut children = vec![Vec::new(); s.n_supernodes()];
        for (sn, p) in parent.into_iter().enumerate() {
            if let Some(p) = p {
                children[p].push(sn);
            }
        }
        Plan { children }
    }
}

/// A real LDLᵀ whose L lives in an unnamed file (see the module doc).
pub(super) struct OnDisk {
    symbolic: Box<Symbolic>,
    plan: Plan,
    /// The directory of the file (it has no name: for messages).
    dir: PathBuf,
    file: File,
    /// D⁻¹, in the order of L's columns.
    d_inv: Vec<f64>,
    /// The permuted right-hand sides of a solve, and the gathered pattern rows.
    x: Mat<f64>,
    solve: SolveScratch<f64>,
    /// Panels read back: supernodes `loaded.0..loaded.1`, L's values from that of the first.
    chunk: Vec<f64>,
    loaded: (usize, usize),
    /// Bytes written by factorizations and read by solves.
    pub(super) written: u64,
    pub(super) read: u64,
    /// Why a solve could not read L back, the first time (its solution is then NaN).
    failure: Option<String>,
}

impl OnDisk {
    /// The factor of `symbolic` with its values in a new unnamed file in `dir`, for solves of
    /// up to `rhs` columns at once.
    ///
    /// # Errors
    /// [`Error::Io`] when no file can be made in `dir`.
    pub(super) fn new(symbolic: Box<Symbolic>, plan: Plan, dir: &Path, rhs: usize) -> Result<Self> {
        let file = tempfile::tempfile_in(dir).map_err(|e| Error::io(dir, e))?;
        let n = symbolic.sym.nrows();
        let max_pattern = symbolic.max_pattern;
        Ok(OnDisk {
            plan,
            dir: dir.to_path_buf(),
            file,
            d_inv: try_vec(n)?,
            x: Mat::zeros(n, rhs),
            solve: SolveScratch {
                gathered: Mat::zeros(max_pattern, rhs),
                top: Mat::zeros(0, rhs),
            },
            chunk: Vec::new(),
            loaded: (0, 0),
            written: 0,
            read: 0,
            failure: None,
            symbolic,
        })
    }

    /// Solves of up to this many columns at once.
    pub(super) fn width(&self) -> usize {
        self.x.ncols()
    }

    /// Entries of L.
    pub(super) fn factor_nnz(&self) -> usize {
        supernodal(&self.symbolic.sym).len_val()
    }

    /// Why a solve could not read L back, the first time, if one could not.
    pub(super) fn failure(&self) -> Option<Error> {
        self.failure.as_ref().map(|why| {
            Error::Factor(format!(
                "the factor on disk (an unnamed file in {}) could not be read back: {why}",
                self.dir.display()
            ))
        })
    }

    /// Factors the matrix with lower-pattern entries `a(p)` (multifrontal, the module doc),
    /// pivots below `tau` perturbed, writing L to the file.
    ///
    /// # Errors
    /// [`Error::Io`] when the file system of the file has not room for L or a write fails;
    /// [`Error::Factor`] when memory is short or a child's rows are not in its parent's front
    /// (an analysis not from a symbolic Cholesky).
    pub(super) fn factor(
        &mut self,
        a: &(impl Fn(usize) -> f64 + Sync),
        tau: f64,
        par: Par,
    ) -> Result<Pivots> {
        let sy = &*self.symbolic;
        let s = supernodal(&sy.sym);
        let (begin, end) = (s.supernode_begin(), s.supernode_end());
        let bytes = 8 * s.len_val() as u64;
        if let Some(free) = crate::memory::free_disk_bytes(&self.dir) {
            if free < bytes {
                return Err(Error::io(
                    &self.dir,
                    std::io::Error::new(
                        std::io::ErrorKind::StorageFull,
                        format!(
                            "the factor on disk needs {:.2} GB, the file system has {:.2} GB \
                             free: set TMPDIR to a larger disk or raise --memory-gb",
                            bytes as f64 / 1e9,
                            free as f64 / 1e9
                        ),
                    ),
                ));
            }
        }
        let io = |e| Error::io(&self.dir, e);
        self.loaded = (0, 0);
        self.file.set_len(0).map_err(io)?;
        self.file.seek(SeekFrom::Start(0)).map_err(io)?;
        let mut out = BufWriter::with_capacity(CHUNK_BYTES, &self.file);
        let mut ld: Vec<f64> = try_vec(UPDATE_BLOCK * sy.max_pattern)?;
        let mut dense: Vec<f64> = try_vec(sy.max_cols * sy.max_cols.div_ceil(2))?;
        let mut local = vec![usize::MAX; sy.sym.nrows()];
        let mut updates: Vec<Vec<f64>> = vec![Vec::new(); s.n_supernodes()];
        let mut pivots = Pivots::new(tau);
        for sn in 0..s.n_supernodes() {
            let (c0, c1) = (begin[sn], end[sn]);
            let pat = pattern(s, sn);
            let (ncols, npat) = (c1 - c0, pat.len());
            let nrows = ncols + npat;
            for (i, &r) in pat.iter().enumerate() {
                local[r] = ncols + i;
            }
            // a new zeroed front: a large one gets fresh pages from the system, and only its
            // lower triangle is ever touched, so the upper one stays unmapped
            let mut front = try_zeroed(nrows * nrows)?;
            let f = &mut front[..];
            sy.assemble(sn, f, a);
            for &c in &self.plan.children[sn] {
                let u = std::mem::take(&mut updates[c]);
                extend_add(f, nrows, (c0, c1), &local, pattern(s, c), &u)?;
            }
            let fm = MatMut::from_column_major_slice_mut(f, nrows, nrows);
            let (mut panel, rest) = fm.split_at_col_mut(ncols);
            factor_panel(panel.rb_mut(), &mut dense, &mut pivots, par);
            for j in 0..ncols {
                self.d_inv[c0 + j] = 1.0 / panel[(j, j)];
            }
            if npat > 0 {
                let mut f22 = rest.subrows_mut(ncols, npat);
                schur_update(panel.rb(), f22.rb_mut(), &mut ld, par);
                let mut u: Vec<f64> = try_vec(npat * (npat + 1) / 2)?;
                let mut at = 0;
                for j in 0..npat {
                    let col = f22.rb().col(j).try_as_col_major().expect("contiguous");
                    u[at..at + npat - j].copy_from_slice(&col.as_slice()[j..]);
                    at += npat - j;
                }
                updates[sn] = u;
            }
            for &r in pat {
                local[r] = usize::MAX;
            }
            out.write_all(bytemuck::cast_slice(&f[..nrows * ncols]))
                .map_err(io)?;
        }
        out.flush().map_err(io)?;
        drop(out);
        self.written += bytes;
        Ok(pivots)
    }

    /// X ← A⁻¹X in place for at most [`Self::width`] columns: P, L, D, Lᵀ, Pᵀ, L read from
    /// the file (forward in order, backward in reverse). On a read error X becomes NaN and
    /// the error is kept ([`Self::failure`]).
    pub(super) fn solve_block(&mut self, mut rhs: MatMut<'_, f64>, par: Par) {
        let k = rhs.ncols();
        let n = rhs.nrows();
        let mut x = std::mem::replace(&mut self.x, Mat::zeros(0, 0));
        let result = {
            let mut xk = x.as_mut().submatrix_mut(0, 0, n, k);
            permute(&self.symbolic.fwd, rhs.rb(), xk.rb_mut(), par);
            let ns = supernodal(&self.symbolic.sym).n_supernodes();
            self.substitute(Direction::Forward, xk.rb_mut(), par, 0..ns)
                .and_then(|()| {
                    scale_rows(xk.rb_mut(), &self.d_inv, par);
                    self.substitute(Direction::Backward, xk.rb_mut(), par, 0..ns)
                })
                .map(|()| unpermute(&self.symbolic.fwd, xk.rb(), rhs.rb_mut(), par))
        };
        self.x = x;
        if let Err(e) = result {
            rhs.fill(f64::NAN);
            self.failure.get_or_insert(e.to_string());
        }
    }

    /// One substitution over every supernode, panels read from the file.
    fn substitute(
        &mut self,
        direction: Direction,
        mut x: MatMut<'_, f64>,
        par: Par,
        all: std::ops::Range<usize>,
    ) -> Result<()> {
        let sns: Box<dyn Iterator<Item = usize>> = match direction {
            Direction::Forward => Box::new(all),
            Direction::Backward => Box::new(all.rev()),
        };
        for sn in sns {
            self.load(sn, direction)?;
            let s = supernodal(&self.symbolic.sym);
            let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
            let ncols = end[sn] - begin[sn];
            let pat = pattern(s, sn);
            let off = cpv[sn] - cpv[self.loaded.0];
            let panel = MatRef::from_column_major_slice(
                &self.chunk[off..off + (ncols + pat.len()) * ncols],
                ncols + pat.len(),
                ncols,
            );
            let (top, bot) = panel.split_at_row(ncols);
            let at = Rows {
                first: begin[sn],
                pattern: pat,
                r0: 0,
                top_pos: &[],
            };
            substitute_panel(direction, top, bot, &at, x.rb_mut(), &mut self.solve, par);
        }
        Ok(())
    }

    /// Makes supernode `sn`'s panel part of the chunk in memory: when it is not, reads a
    /// chunk of consecutive panels from it on (forward) or up to it (backward).
    fn load(&mut self, sn: usize, direction: Direction) -> Result<()> {
        if (self.loaded.0..self.loaded.1).contains(&sn) {
            return Ok(());
        }
        let s = supernodal(&self.symbolic.sym);
        let cpv = s.col_ptr_for_val();
        let ns = s.n_supernodes();
        let room = (CHUNK_BYTES / 8).max(cpv[sn + 1] - cpv[sn]);
        let (first, last) = match direction {
            Direction::Forward => {
                let last = (sn + 1..=ns)
                    .take_while(|&e| cpv[e] - cpv[sn] <= room)
                    .last()
                    .unwrap_or(sn + 1);
                (sn, last)
            }
            Direction::Backward => {
                let first = (0..=sn)
                    .rev()
                    .take_while(|&b| cpv[sn + 1] - cpv[b] <= room)
                    .last()
                    .unwrap_or(sn);
                (first, sn + 1)
            }
        };
        let len = cpv[last] - cpv[first];
        if self.chunk.len() < len {
            self.chunk = try_vec(len)?;
        }
        self.loaded = (0, 0);
        let io = |e| Error::io(&self.dir, e);
        self.file
            .seek(SeekFrom::Start(8 * cpv[first] as u64))
            .map_err(io)?;
        self.file
            .read_exact(bytemuck::cast_slice_mut(&mut self.chunk[..len]))
            .map_err(io)?;
        self.read += 8 * len as u64;
        self.loaded = (first, last);
        Ok(())
    }
}

/// `len` zeros, fallibly, from zeroed memory (not written: see [`OnDisk::factor`]).
fn try_zeroed(len: usize) -> Result<Box<[f64]>> {
    bytemuck::allocation::try_zeroed_slice_box(len)
        .map_err(|()| Error::Factor(format!("cannot allocate a front of {len} entries")))
}

/// Adds a child's update block `u` (packed lower triangle by columns on the child's pattern
/// rows `rows`) into the front `f` (`nrows` × `nrows`, column-major) of the supernode with
/// columns `cols`, whose pattern rows have `local` set.
fn extend_add(
    f: &mut [f64],
    nrows: usize,
    cols: (usize, usize),
    local: &[usize],
    rows: &[usize],
    u: &[f64],
) -> Result<()> {
    let at: Vec<usize> = rows
        .iter()
        .map(|&r| {
            if (cols.0..cols.1).contains(&r) {
                Ok(r - cols.0)
            } else if local[r] != usize::MAX {
                Ok(local[r])
            } else {
                Err(Error::Factor(
                    "multifrontal factorization: a child's row outside its parent's front".into(),
                ))
            }
        })
        .collect::<Result<_>>()?;
    let mut next = 0;
    for (j, &cj) in at.iter().enumerate() {
        let col = &mut f[cj * nrows..(cj + 1) * nrows];
        for (&ri, &v) in at[j..].iter().zip(&u[next..]) {
            col[ri] += v;
        }
        next += at.len() - j;
    }
    Ok(())
}

/// F₂₂ ← F₂₂ − L₂₁ D₁ L₂₁ᵀ (lower triangle) from the factored panel [L₁₁ with D₁ on its
/// diagonal; L₂₁], in products of [`UPDATE_BLOCK`] columns; `ld` holds (L₂₁D₁)ᵀ of a block,
/// column-major (faer's GEMM is faster on it than on a transposed operand).
fn schur_update(panel: MatRef<'_, f64>, mut f22: MatMut<'_, f64>, ld: &mut [f64], par: Par) {
    let ncols = panel.ncols();
    let npat = f22.nrows();
    let l21 = panel.subrows(ncols, npat);
    for b in (0..ncols).step_by(UPDATE_BLOCK) {
        let w = UPDATE_BLOCK.min(ncols - b);
        let mut ld_t = MatMut::from_column_major_slice_mut(&mut ld[..w * npat], w, npat);
        ld_t.copy_from(l21.subcols(b, w).transpose());
        for col in ld_t.rb_mut().col_iter_mut() {
            for (j, v) in col.iter_mut().enumerate() {
                *v *= panel[(b + j, b + j)];
            }
        }
        triangular::matmul(
            f22.rb_mut(),
            BlockStructure::TriangularLower,
            Accum::Add,
            l21.subcols(b, w),
            BlockStructure::Rectangular,
            ld_t.rb(),
            BlockStructure::Rectangular,
            -1.0,
            par_for(npat * npat * w / 2, par),
        );
    }
}

#[cfg(test)]
mod tests {
    use crate::factor::RealLdlt;
    use crate::factor::{symbolic_cholesky, Storage};
    use crate::fe::{assemble, BoxSpec};
    use crate::model::{Damping, Model};
    use crate::pencil::Pencil;
    use crate::Error;
    use faer::{Mat, Par};
    use std::sync::Arc;

    /// A free steel block of 5 × 4 × 6 hex8 elements (N = 630): a branching elimination
    /// tree, so fronts take several children's update blocks.
    fn block() -> Pencil {
        let body = assemble(&BoxSpec {
            elements: [5, 4, 6],
            ..BoxSpec::paper_bar()
        })
        .unwrap();
        let model = Model::new(
            "block".into(),
            body.mass,
            body.stiffness,
            Damping::None,
            None,
            3,
        );
        Pencil::new(&model.unwrap().0)
    }

    /// On an indefinite K − σM of a branching tree the factor on disk has the in-memory
    /// factor's negative pivots and solutions (to rounding); its file has no name, so the
    /// directory it is in stays empty; a directory that cannot hold it is an I/O error that
    /// names the directory.
    #[test]
    fn the_factor_on_disk_is_the_factor_in_memory() {
        let pencil = block();
        let sym = Arc::new(symbolic_cholesky(&pencil).unwrap());
        let sigma = (2.0 * std::f64::consts::PI * 4000.0).powi(2);
        let mut vals = vec![0.0; pencil.nnz()];
        pencil.fill_shifted(sigma, &mut vals);
        let b = Mat::<f64>::from_fn(pencil.n(), 4, |i, j| ((i * 5 + j * 3) % 7) as f64 - 3.0);
        let dir = std::env::temp_dir().join(format!("sparsemor-on-disk-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let on_disk = Storage {
            dir: Some(&dir),
            budget: usize::MAX,
        };
        let mut results = Vec::new();
        for storage in [Storage::IN_CORE, on_disk] {
            let mut f = RealLdlt::new(&pencil, sym.clone(), 4, storage)
                .unwrap()
                .unwrap();
            let pivots = f.factor(&vals, Par::rayon(2)).unwrap();
            let mut x = b.clone();
            f.solve(x.as_mut(), Par::rayon(2));
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
            results.push((pivots.negative, pivots.perturbed, x));
        }
        std::fs::remove_dir(&dir).unwrap();
        let (memory, disk) = (&results[0], &results[1]);
        assert!(memory.0 > 6, "an interior shift");
        assert_eq!((memory.0, memory.1), (disk.0, disk.1));
        assert!((&memory.2 - &disk.2).norm_max() <= 1e-10 * memory.2.norm_max());
        let missing = Storage {
            dir: Some(&dir),
            budget: usize::MAX,
        };
        match RealLdlt::new(&pencil, sym, 1, missing) {
            Err(Error::Io { path, .. }) => assert_eq!(path, dir),
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("a factor file in a missing directory"),
        }
    }
}
