//! Model handle: M, K (CSC), damping, node coordinates, scene.

use crate::error::{ffi_body, Failure, SparsemorStatus};
use crate::scene::CoupledScene;
use crate::util::{obj, obj_mut, slice_in, write_out};
use sparsemor::body::Body;
use sparsemor::coupling::RemotePoint;
use sparsemor::io::import::{self, Dof};
use sparsemor::io::model_dir;
use sparsemor::model::{Damping, Model};
use sparsemor::scene::Scene;
use sparsemor::sparse::{from_parts, mirror_lower, Csc};
use std::ffi::{c_char, CStr};
use std::path::{Path, PathBuf};

/// `SparsemorCsc::storage`: both triangles are stored (full symmetric storage).
pub const SPARSEMOR_STORAGE_FULL: u32 = 0;
/// `SparsemorCsc::storage`: only the lower triangle (row >= column) is stored; the library
/// mirrors it to full storage.
pub const SPARSEMOR_STORAGE_LOWER: u32 = 1;

/// A square sparse matrix in compressed sparse column (CSC) form, 0-based, borrowed from the
/// caller for the duration of one call (the library copies what it keeps).
///
/// Requirements (each violation is `SPARSEMOR_STATUS_INVALID_ARGUMENT`, checked before
/// anything is built): `n >= 1`; `col_ptr` has `n + 1` entries, `col_ptr[0] == 0`,
/// non-decreasing, `col_ptr[n] == nnz`; `row_idx` and `values` have `nnz` entries; the row
/// indices of each column are `< n` and strictly increasing (sorted, no duplicates); every
/// value is finite. With `storage == SPARSEMOR_STORAGE_LOWER` every entry must have
/// row >= column. With `SPARSEMOR_STORAGE_FULL` the matrix must be symmetric (relative
/// asymmetry <= 1e-10, else `SPARSEMOR_STATUS_INVALID_MODEL`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SparsemorCsc {
    /// Number of rows = number of columns (N).
    pub n: usize,
    /// Number of stored entries.
    pub nnz: usize,
    /// Column pointers, `n + 1` entries.
    pub col_ptr: *const usize,
    /// Row index of each stored entry, `nnz` entries.
    pub row_idx: *const usize,
    /// Value of each stored entry, `nnz` entries.
    pub values: *const f64,
    /// `SPARSEMOR_STORAGE_FULL` or `SPARSEMOR_STORAGE_LOWER`.
    pub storage: u32,
}

/// Opaque model handle: the validated full-order model M q'' + D q' + K q = B u, y = C q,
/// prepared once as a body (its matrices held once, the rigid part, the symbolic analysis
/// computed by the first call that factors and reused by every later one; docs/design.md §2),
/// and its scene (inputs, outputs, band). Created by `sparsemor_model_new`, released by
/// `sparsemor_model_free`. Read-only functions may share one handle across threads;
/// `sparsemor_model_set_scene`, `sparsemor_model_add_remote_point`,
/// `sparsemor_model_set_scene_general` and `sparsemor_model_set_structural_damping` must not
/// run concurrently with anything else on the handle.
pub struct SparsemorModel {
    /// The original body, as created (never replaced by a coupled one; prepared again by
    /// `sparsemor_model_set_structural_damping`).
    pub(crate) body: Body,
    /// The scene of `sparsemor_model_set_scene` on the original body (unused while a general
    /// scene is set).
    pub(crate) scene: Option<Scene>,
    /// Node number and direction of every DoF, when the model was imported from FE files.
    pub(crate) dofs: Option<Vec<Dof>>,
    /// Remote points added by `sparsemor_model_add_remote_point`, in order (`point0`, ...).
    pub(crate) points: Vec<RemotePoint>,
    /// The coupled body and scene of `sparsemor_model_set_scene_general`.
    pub(crate) coupled: Option<CoupledScene>,
}

/// What the reductions work on: the original body and its scene, or the coupled body of a
/// general scene with its scene and q = T z.
pub(crate) struct Active<'a> {
    pub body: &'a Body,
    pub scene: &'a Scene,
    /// q = T z (N × N') when the body is a coupled one.
    pub t: Option<&'a Csc>,
}

impl SparsemorModel {
    /// A handle for `model` (its body built in a call-local pool: faer's dense products
    /// would otherwise start rayon's global pool) with no scene yet.
    fn boxed(model: &Model, dofs: Option<Vec<Dof>>) -> Result<Box<Self>, Failure> {
        let body = crate::pool::in_pool(1, || Body::new(model))??;
        Ok(Box::new(SparsemorModel {
            body,
            scene: None,
            dofs,
            points: Vec::new(),
            coupled: None,
        }))
    }

    /// The body the reductions work on and its scene: the coupled ones after
    /// `sparsemor_model_set_scene_general`, else the original body and its scene, after
    /// checking that a scene was set.
    pub(crate) fn with_scene(&self) -> Result<Active<'_>, Failure> {
        if let Some(c) = &self.coupled {
            return Ok(Active {
                body: &c.body,
                scene: &c.scene,
                t: Some(&c.t),
            });
        }
        let scene = self.scene.as_ref().ok_or_else(|| {
            Failure::arg(
                "the model has no scene: call sparsemor_model_set_scene (inputs, outputs, band) \
                 or sparsemor_model_set_scene_general first",
            )
        })?;
        Ok(Active {
            body: &self.body,
            scene,
            t: None,
        })
    }

    /// The body ROMs of this handle belong to: the coupled one while a general scene is set.
    pub(crate) fn active_body(&self) -> &Body {
        self.coupled.as_ref().map_or(&self.body, |c| &c.body)
    }
}

/// A checked CSC matrix borrowed from the caller: column pointers, row indices, values.
pub(crate) type CscSlices<'a> = (&'a [usize], &'a [usize], &'a [f64]);

/// The caller's CSC arrays of a `shape[0]` × `shape[1]` matrix with `nnz` entries, checked:
/// the pointers valid, `col_ptr` starting at 0, non-decreasing and ending at `nnz` (named
/// `col_ptr[{cols}]` in messages), each column's row indices in range and strictly
/// increasing, every value finite.
///
/// # Safety
/// The pointers must be valid for the lengths they claim (`shape[1] + 1`, `nnz`).
pub(crate) unsafe fn csc_arrays<'a>(
    col_ptr: *const usize,
    row_idx: *const usize,
    values: *const f64,
    shape: [usize; 2],
    nnz: usize,
    cols: &str,
    what: &str,
) -> Result<CscSlices<'a>, Failure> {
    let [nrows, ncols] = shape;
    let np1 = ncols
        .checked_add(1)
        .ok_or_else(|| Failure::arg(format!("{what}: {cols} = {ncols} is too large")))?;
    // SAFETY: the caller's contract.
    let col_ptr = unsafe { slice_in(col_ptr, np1, &format!("{what}: col_ptr"))? };
    let row_idx = unsafe { slice_in(row_idx, nnz, &format!("{what}: row_idx"))? };
    let values = unsafe { slice_in(values, nnz, &format!("{what}: values"))? };
    if col_ptr[0] != 0 {
        return Err(Failure::arg(format!(
            "{what}: col_ptr[0] = {}; CSC column pointers start at 0",
            col_ptr[0]
        )));
    }
    if let Some(j) = (0..ncols).find(|&j| col_ptr[j + 1] < col_ptr[j]) {
        return Err(Failure::arg(format!(
            "{what}: col_ptr is not non-decreasing: col_ptr[{}] = {} < col_ptr[{j}] = {}",
            j + 1,
            col_ptr[j + 1],
            col_ptr[j]
        )));
    }
    if col_ptr[ncols] != nnz {
        return Err(Failure::arg(format!(
            "{what}: col_ptr[{cols}] = {} but nnz = {nnz}; they must agree",
            col_ptr[ncols]
        )));
    }
    for j in 0..ncols {
        let (a, b) = (col_ptr[j], col_ptr[j + 1]);
        for p in a..b {
            let i = row_idx[p];
            if i >= nrows {
                return Err(Failure::arg(format!(
                    "{what}: row index {i} in column {j} (entry {p}) is out of range 0..{}",
                    nrows.saturating_sub(1)
                )));
            }
            if p > a && i <= row_idx[p - 1] {
                return Err(Failure::arg(format!(
                    "{what}: column {j}: row indices must be strictly increasing (sorted, no duplicates), \
                     found {} then {i} at entries {}..{p}",
                    row_idx[p - 1],
                    p - 1
                )));
            }
            if !values[p].is_finite() {
                return Err(Failure::arg(format!(
                    "{what}: entry ({i}, {j}) is not finite ({})",
                    values[p]
                )));
            }
        }
    }
    Ok((col_ptr, row_idx, values))
}

/// Checks the caller's CSC arrays and copies them into a full-storage matrix.
///
/// # Safety
/// The pointers in `c` must be valid for the lengths they claim (`n + 1`, `nnz`).
pub(crate) unsafe fn csc_from_c(c: &SparsemorCsc, what: &str) -> Result<Csc, Failure> {
    let n = c.n;
    if n == 0 {
        return Err(Failure::arg(format!("{what}: n = 0; need n >= 1")));
    }
    let lower = match c.storage {
        SPARSEMOR_STORAGE_FULL => false,
        SPARSEMOR_STORAGE_LOWER => true,
        s => {
            return Err(Failure::arg(format!(
            "{what}: storage = {s}; use SPARSEMOR_STORAGE_FULL (0) or SPARSEMOR_STORAGE_LOWER (1)"
        )))
        }
    };
    // SAFETY: the caller's contract on the CSC struct.
    let (col_ptr, row_idx, values) =
        unsafe { csc_arrays(c.col_ptr, c.row_idx, c.values, [n, n], c.nnz, "n", what)? };
    if lower {
        for j in 0..n {
            if let Some(&i) = row_idx[col_ptr[j]..col_ptr[j + 1]].iter().find(|&&i| i < j) {
                return Err(Failure::arg(format!(
                    "{what}: entry ({i}, {j}) is above the diagonal but storage is SPARSEMOR_STORAGE_LOWER"
                )));
            }
        }
    }
    if !lower {
        return Ok(from_parts(
            n,
            n,
            col_ptr.to_vec(),
            row_idx.to_vec(),
            values.to_vec(),
        ));
    }
    let (cp, ri, src) = mirror_lower(n, col_ptr, row_idx);
    let v = src.iter().map(|&p| values[p]).collect();
    Ok(from_parts(n, n, cp, ri, v))
}

/// Creates a model from M, K and optional damping and node coordinates.
///
/// - `mass`, `stiffness`: required, both N×N (see `SparsemorCsc` for the checks).
/// - `damping`: NULL or an explicit symmetric N×N damping matrix D. When NULL,
///   D = `rayleigh_alpha`·M + `rayleigh_beta`·K (both finite and >= 0; 0, 0 = undamped).
///   Giving both a matrix and nonzero Rayleigh coefficients is an error.
/// - `nodes_xyz`: NULL, or `n_nodes`×3 coordinates (row-major: x, y, z of node 0, then node
///   1, ...) with node i owning DoFs `dofs_per_node`·i .. `dofs_per_node`·(i+1) − 1;
///   `dofs_per_node` is 3 or 6 and `n_nodes`·`dofs_per_node` must equal N. Node coordinates
///   let the library detect a free body (K·V0 = 0) and separate its rigid-body part; without
///   them the body is treated as constrained. When `nodes_xyz` is NULL, `n_nodes` must be 0
///   and `dofs_per_node` may be 0 (meaning 3).
///
/// All arrays are copied; the caller keeps ownership. On success `*model_out` receives a new
/// handle to be released with `sparsemor_model_free`; on failure it is set to NULL. Before
/// a reduction, set the scene with `sparsemor_model_set_scene`.
///
/// # Safety
/// `mass`, `stiffness` must point to valid `SparsemorCsc` descriptors whose arrays have the
/// lengths they claim; `damping` likewise or NULL; `nodes_xyz` NULL or `3·n_nodes` doubles;
/// `model_out` writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)] // the C signature: matrices, damping, nodes, out
pub unsafe extern "C" fn sparsemor_model_new(
    mass: *const SparsemorCsc,
    stiffness: *const SparsemorCsc,
    damping: *const SparsemorCsc,
    rayleigh_alpha: f64,
    rayleigh_beta: f64,
    nodes_xyz: *const f64,
    n_nodes: usize,
    dofs_per_node: usize,
    model_out: *mut *mut SparsemorModel,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(model_out, std::ptr::null_mut(), "model_out")? };
        let m = unsafe { csc_from_c(obj(mass, "mass")?, "mass matrix M")? };
        let k = unsafe { csc_from_c(obj(stiffness, "stiffness")?, "stiffness matrix K")? };
        let n = m.nrows();
        if k.nrows() != n {
            return Err(Failure::arg(format!(
                "stiffness matrix K is {0}×{0} but the mass matrix M is {n}×{n}",
                k.nrows()
            )));
        }
        let damping = if damping.is_null() {
            if !(rayleigh_alpha.is_finite()
                && rayleigh_beta.is_finite()
                && rayleigh_alpha >= 0.0
                && rayleigh_beta >= 0.0)
            {
                return Err(Failure::arg(format!(
                    "rayleigh_alpha = {rayleigh_alpha}, rayleigh_beta = {rayleigh_beta}: need finite values >= 0"
                )));
            }
            if rayleigh_alpha == 0.0 && rayleigh_beta == 0.0 {
                Damping::None
            } else {
                Damping::Rayleigh {
                    alpha: rayleigh_alpha,
                    beta: rayleigh_beta,
                }
            }
        } else {
            if rayleigh_alpha != 0.0 || rayleigh_beta != 0.0 {
                return Err(Failure::arg(
                    "both a damping matrix and Rayleigh coefficients were given; pass 0, 0 for alpha, beta with a matrix",
                ));
            }
            let d = unsafe { csc_from_c(obj(damping, "damping")?, "damping matrix D")? };
            if d.nrows() != n {
                return Err(Failure::arg(format!(
                    "damping matrix D is {0}×{0} but the mass matrix M is {n}×{n}",
                    d.nrows()
                )));
            }
            Damping::Matrix(d)
        };
        let (nodes, dpn) = if nodes_xyz.is_null() {
            if n_nodes != 0 {
                return Err(Failure::null(&format!(
                    "nodes_xyz (with n_nodes = {n_nodes})"
                )));
            }
            if dofs_per_node != 0 && dofs_per_node != 3 && dofs_per_node != 6 {
                return Err(Failure::arg(format!(
                    "dofs_per_node = {dofs_per_node}: use 3, 6 (or 0 without nodes)"
                )));
            }
            (None, 3)
        } else {
            let len = n_nodes
                .checked_mul(3)
                .ok_or_else(|| Failure::arg(format!("n_nodes = {n_nodes} is too large")))?;
            if n_nodes == 0 {
                return Err(Failure::arg(
                    "nodes_xyz is given but n_nodes = 0; pass NULL for no nodes",
                ));
            }
            let xyz = unsafe { slice_in(nodes_xyz, len, "nodes_xyz")? };
            let nodes: Vec<[f64; 3]> = xyz.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            (Some(nodes), dofs_per_node)
        };
        let (model, _) = Model::new("ffi".into(), m, k, damping, nodes, dpn)?;
        let h = SparsemorModel::boxed(&model, None)?;
        unsafe { write_out(model_out, Box::into_raw(h), "model_out")? };
        Ok(())
    })
}

/// `units` of `sparsemor_model_from_files`: the values as the files hold them.
pub const SPARSEMOR_UNITS_AS_IS: u32 = 0;
/// `units` of `sparsemor_model_from_files`: the files are in the consistent mm–t–s–N system;
/// convert to m–kg–s–N (M, K × 1e3, coordinates × 1e-3; eigenfrequencies unchanged).
pub const SPARSEMOR_UNITS_MM_T_S: u32 = 1;

/// Creates a model from the files an FE code wrote, as `sparsemor import` reads them
/// (docs/design.md §4): an ANSYS `.full` (binary); ANSYS APDL-Math Matrix Market exports with
/// their DoF mapping vector and node table; Abaqus `*MATRIX GENERATE` output with its `.inp`
/// deck. The format of each file is detected from its first bytes; a matrix's role comes from
/// its name (`STIF`/`K`, `MASS`/`M`) or an explicit `K=` / `M=` prefix on the path.
///
/// - `paths`: `n_paths` NUL-terminated UTF-8 paths.
/// - `stiffness_scale`: K is multiplied by it (1 for none; e.g. 1e-2 for the Abaqus rotor of
///   the data README); must be finite and > 0.
/// - `units`: `SPARSEMOR_UNITS_AS_IS` or `SPARSEMOR_UNITS_MM_T_S`.
///
/// The model is undamped and has no scene (set it with `sparsemor_model_set_scene`); DoFs the
/// source constrained are removed. `sparsemor_model_dof` gives the node number and direction
/// of each remaining DoF. On failure `*model_out` is NULL and the message names the file and
/// the line or byte offset.
///
/// # Safety
/// `paths` must point to `n_paths` valid NUL-terminated strings; `model_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_from_files(
    paths: *const *const c_char,
    n_paths: usize,
    stiffness_scale: f64,
    units: u32,
    model_out: *mut *mut SparsemorModel,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(model_out, std::ptr::null_mut(), "model_out")? };
        if n_paths == 0 {
            return Err(Failure::arg("n_paths = 0: give the files to read"));
        }
        let ptrs = unsafe { slice_in(paths, n_paths, "paths")? };
        let mut files = Vec::with_capacity(n_paths);
        for (i, &p) in ptrs.iter().enumerate() {
            if p.is_null() {
                return Err(Failure::null(&format!("paths[{i}]")));
            }
            // SAFETY: non-null; NUL termination is the caller's contract.
            let s = unsafe { CStr::from_ptr(p) }
                .to_str()
                .map_err(|_| Failure::arg(format!("paths[{i}] is not valid UTF-8")))?;
            files.push(PathBuf::from(s));
        }
        if units > SPARSEMOR_UNITS_MM_T_S {
            return Err(Failure::arg(format!(
                "units = {units}: use SPARSEMOR_UNITS_AS_IS (0) or SPARSEMOR_UNITS_MM_T_S (1)"
            )));
        }
        let mut imported = import::read(&files)?;
        if stiffness_scale != 1.0 {
            imported.scale_stiffness(stiffness_scale)?;
        }
        if units == SPARSEMOR_UNITS_MM_T_S {
            imported.mm_to_m();
        }
        let dofs = imported.dofs.clone();
        let name = files[0].display().to_string();
        let (model, _) = imported.into_model(name)?;
        let h = SparsemorModel::boxed(&model, Some(dofs))?;
        unsafe { write_out(model_out, Box::into_raw(h), "model_out")? };
        Ok(())
    })
}

/// Creates a model from a model directory (docs/formats.md: `model.toml` naming M, K, an
/// optional D and node table, or the FE files to read in place), validated as every
/// `sparsemor` command reads it. The directory's scene (`[scene]`: inputs, outputs, band) is
/// set (change it with `sparsemor_model_set_scene`); an imported directory's DoF map names
/// the DoFs for `sparsemor_model_dof`. On failure `*model_out` is NULL and the message names
/// the file and the field.
///
/// # Safety
/// `path` a valid NUL-terminated string; `model_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_from_dir(
    path: *const c_char,
    model_out: *mut *mut SparsemorModel,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(model_out, std::ptr::null_mut(), "model_out")? };
        if path.is_null() {
            return Err(Failure::null("path"));
        }
        // SAFETY: non-null; NUL termination is the caller's contract.
        let dir = unsafe { CStr::from_ptr(path) }
            .to_str()
            .map_err(|_| Failure::arg("path is not valid UTF-8"))?;
        let dir = Path::new(dir);
        let (model, scene, _) = model_dir::read(dir)?;
        let dofs = model_dir::read_dof_map(dir)?;
        let mut h = SparsemorModel::boxed(&model, dofs)?;
        h.scene = Some(scene);
        unsafe { write_out(model_out, Box::into_raw(h), "model_out")? };
        Ok(())
    })
}

/// Node number and direction of DoF `index` (0-based row/column of M and K): the FE code's
/// node number and the direction key 1–6 (x, y, z, rx, ry, rz; ANSYS's and Abaqus's numbering)
/// for a model from `sparsemor_model_from_files`; for a model from `sparsemor_model_new` with
/// nodes, the 0-based node index and 1 + index mod `dofs_per_node`.
///
/// # Safety
/// `model` a live handle; `node_out`, `direction_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_dof(
    model: *const SparsemorModel,
    index: usize,
    node_out: *mut u64,
    direction_out: *mut u32,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        let n = m.body.n();
        if index >= n {
            return Err(Failure::arg(format!(
                "index = {index}: the model has DoFs 0..{}",
                n.saturating_sub(1)
            )));
        }
        let (node, dir) = match (&m.dofs, m.body.nodes().is_some()) {
            (Some(dofs), _) => (dofs[index].node, dofs[index].dir as u32 + 1),
            (None, true) => {
                let dpn = m.body.dofs_per_node();
                ((index / dpn) as u64, (index % dpn) as u32 + 1)
            }
            (None, false) => {
                return Err(Failure::arg(
                    "the model has no DoF map: it was created without nodes and not imported",
                ))
            }
        };
        unsafe { write_out(node_out, node, "node_out")? };
        unsafe { write_out(direction_out, dir, "direction_out")? };
        Ok(())
    })
}

/// Releases a model. NULL is a no-op. Any ROM made from it stays valid (ROMs do not borrow
/// the model).
///
/// # Safety
/// `model` must be NULL or a handle from `sparsemor_model_new` not yet freed.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_free(model: *mut SparsemorModel) -> SparsemorStatus {
    ffi_body!({
        if !model.is_null() {
            // SAFETY: a live handle from Box::into_raw (caller contract).
            drop(unsafe { Box::from_raw(model) });
        }
        Ok(())
    })
}

/// Number of DoFs N of the model as created (also with a general scene set: the coupled
/// model's size is `sparsemor_model_coordinate_count`).
///
/// # Safety
/// `model` a live handle; `n_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_n(
    model: *const SparsemorModel,
    n_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        unsafe { write_out(n_out, m.body.n(), "n_out") }
    })
}

/// True (1) when the model is a free body: it has node coordinates and K·V0 = 0 for its
/// rigid-body modes V0, so the reductions separate the rigid part (docs/design.md §3.2).
///
/// # Safety
/// `model` a live handle; `free_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_is_free(
    model: *const SparsemorModel,
    free_out: *mut i32,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        let free = m.body.rigid().is_some();
        unsafe { write_out(free_out, i32::from(free), "free_out") }
    })
}

/// Sets the scene: the input DoFs (unit forces, the columns of B), the output DoFs (the rows
/// of C; both 0-based, non-empty, unique, < N) and the band [`band_lo_hz`, `band_hi_hz`]
/// (finite, 0 <= lo < hi). The band is used by SEREP (eigensolver shift) and by
/// `sparsemor_options_set_reference_count`. The arrays are copied. It replaces any scene set
/// before, a general one (`sparsemor_model_set_scene_general`) included: the reductions then
/// work on the original model again.
///
/// # Safety
/// `model` a live handle not used concurrently; `inputs`/`outputs` valid for their lengths.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_set_scene(
    model: *mut SparsemorModel,
    inputs: *const usize,
    n_inputs: usize,
    outputs: *const usize,
    n_outputs: usize,
    band_lo_hz: f64,
    band_hi_hz: f64,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj_mut(model, "model")? };
        if n_inputs == 0 || n_outputs == 0 {
            return Err(Failure::arg(format!(
                "scene: n_inputs = {n_inputs}, n_outputs = {n_outputs}; need at least one of each"
            )));
        }
        let inputs = unsafe { slice_in(inputs, n_inputs, "inputs")? }.to_vec();
        let outputs = unsafe { slice_in(outputs, n_outputs, "outputs")? }.to_vec();
        let scene = Scene {
            inputs,
            outputs,
            band_hz: [band_lo_hz, band_hi_hz],
        };
        scene.validate(m.body.n(), "scene")?;
        m.scene = Some(scene);
        m.coupled = None;
        Ok(())
    })
}
