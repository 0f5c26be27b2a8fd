//! The general scene of a model handle (docs/design.md §3.11, §6): remote points, and inputs
//! and outputs given as DoFs, as remote points' DoFs and as the columns of a sparse B / the
//! rows of a sparse C.
//!
//! `sparsemor_model_set_scene_general` couples the model once per scene
//! ([`sparsemor::coupled::couple`]): the handle keeps its original body and holds the coupled
//! body, its scene of DoFs and q = T z beside it, so setting a scene again couples the
//! original again. Every reduction then works on the coupled body; a ROM's basis is handed
//! out as T V (the original DoFs), its coordinates, inputs and outputs are DoFs of the coupled
//! model, named by `sparsemor_model_coordinate`.
//!
//! Entry points: `sparsemor_model_add_remote_point`, `sparsemor_model_set_scene_general`,
//! `sparsemor_model_coordinate_count`, `sparsemor_model_coordinate`.

use crate::error::{ffi_body, Failure, SparsemorStatus};
use crate::model::{csc_arrays, SparsemorModel};
use crate::pool::in_pool;
use crate::util::{obj, obj_mut, slice_in, write_opt, write_out};
use sparsemor::body::Body;
use sparsemor::coupled::{couple, Coordinate, Functional};
use sparsemor::coupling::{distributing_rows, rigid_elimination, Kind, RemotePoint, SparseRow};
use sparsemor::scene::Scene;
use sparsemor::sparse::Csc;
use std::collections::HashMap;

/// `kind` of `sparsemor_model_add_remote_point`: rigid coupling (RBE2, kinematic): the nodes
/// follow the point's rigid motion; their DoFs leave the model, the point's six enter it.
pub const SPARSEMOR_POINT_RIGID: u32 = 0;
/// `kind` of `sparsemor_model_add_remote_point`: distributing coupling (RBE3): the point moves
/// as the weighted least-squares rigid motion of its nodes, a force on it spreads over them;
/// no stiffness is added.
pub const SPARSEMOR_POINT_DISTRIBUTING: u32 = 1;

/// `sparsemor_model_coordinate`: DoF `a` of the original model.
pub const SPARSEMOR_COORDINATE_DOF: u32 = 0;
/// `sparsemor_model_coordinate`: DoF `b` (0..5 = x, y, z, rx, ry, rz) of remote point `a`.
pub const SPARSEMOR_COORDINATE_POINT: u32 = 1;
/// `sparsemor_model_coordinate`: the functional of column `a` of the inputs' matrix B.
pub const SPARSEMOR_COORDINATE_INPUT_COLUMN: u32 = 2;
/// `sparsemor_model_coordinate`: the functional of row `a` of the outputs' matrix C.
pub const SPARSEMOR_COORDINATE_OUTPUT_ROW: u32 = 3;

/// A general (rectangular) sparse matrix in compressed sparse column form, 0-based, borrowed
/// for one call: `col_ptr` has `ncols + 1` entries (starting at 0, non-decreasing, ending at
/// `nnz`), `row_idx` and `values` `nnz` each; each column's row indices `< nrows` and strictly
/// increasing; every value finite. Explicit zeros are allowed and dropped.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SparsemorSparse {
    /// Number of rows.
    pub nrows: usize,
    /// Number of columns.
    pub ncols: usize,
    /// Number of stored entries.
    pub nnz: usize,
    /// Column pointers, `ncols + 1` entries.
    pub col_ptr: *const usize,
    /// Row index of each stored entry, `nnz` entries.
    pub row_idx: *const usize,
    /// Value of each stored entry, `nnz` entries.
    pub values: *const f64,
}

/// The inputs (or the outputs) of a general scene, in three groups whose order is the order
/// of the ROM's Br columns (Cr rows): first `dofs`, then `point_dofs`, then the matrix's
/// columns (rows). Each group may be empty (a NULL array with length 0, a NULL `matrix`); at
/// least one input and one output in all.
///
/// - `dofs`: DoFs of the model (0-based, < N): a unit force there (an input), the
///   displacement there (an output).
/// - `point_dofs`: remote points' DoFs, coded `6·point + dir` with `point` the index from
///   `sparsemor_model_add_remote_point` and `dir` 0..5 = x, y, z, rx, ry, rz: a force or
///   moment on the point, the point's displacement or rotation.
/// - `matrix`: NULL, or for the inputs B (N×p): each column b a load pattern (the input u_j
///   applies the forces b u_j); for the outputs C (q×N): each row c an output y = c q (e.g.
///   the average displacement over a face).
///
/// The same functional may be both an input and an output (a DoF, a point's DoF, a column of
/// B equal to a row of C); within the inputs (or outputs) each must appear once. Functionals
/// that are linearly dependent (a column of B proportional but not equal to a row of C, a
/// column that combines others, a DoF among a row's support that another row pivots on) are
/// refused: scale them to be equal, or give each once.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SparsemorScenePart {
    /// DoFs, `n_dofs` entries (NULL when 0).
    pub dofs: *const usize,
    /// Number of DoFs.
    pub n_dofs: usize,
    /// Remote points' DoFs coded `6·point + dir`, `n_point_dofs` entries (NULL when 0).
    pub point_dofs: *const usize,
    /// Number of point DoFs.
    pub n_point_dofs: usize,
    /// NULL, or B (N×p) for the inputs, C (q×N) for the outputs.
    pub matrix: *const SparsemorSparse,
}

/// A general scene coupled: the coupled body, its scene of DoFs and q = T z, with what it was
/// coupled from (to couple again when the original body changes:
/// `sparsemor_model_set_structural_damping`).
pub(crate) struct CoupledScene {
    pub body: Body,
    pub scene: Scene,
    /// q = T z, N × N'.
    pub t: Csc,
    /// What every DoF of the coupled model is: (`SPARSEMOR_COORDINATE_*`, a, b).
    pub coordinates: Vec<(u32, usize, usize)>,
    /// The remote points it was coupled with (those added before the scene was set).
    pub points: Vec<RemotePoint>,
    /// Its inputs and outputs as given.
    pub functionals: [Vec<Functional>; 2],
}

/// Couples `body` (the handle's original one) with `points` and the functionals `ins`,
/// `outs` into a [`CoupledScene`] with the band `band_hz` (docs/design.md §3.11), in a
/// call-local pool.
pub(crate) fn couple_scene(
    body: &Body,
    points: &[RemotePoint],
    ins: Vec<Functional>,
    outs: Vec<Functional>,
    band_hz: [f64; 2],
) -> Result<CoupledScene, Failure> {
    in_pool(1, || -> Result<CoupledScene, Failure> {
        let original = body.to_model()?;
        let cp = couple(&original, points, &ins, &outs)?;
        let scene = Scene {
            inputs: cp.inputs,
            outputs: cp.outputs,
            band_hz,
        };
        scene.validate(cp.n, "scene")?;
        // the k-th row functional of a part is its matrix's column (row) k
        let matrix_rows = |list: &[Functional], kind: u32| {
            list.iter()
                .filter_map(|f| match f {
                    Functional::Row(name, _) => Some(name.clone()),
                    _ => None,
                })
                .enumerate()
                .map(move |(k, name)| (name, (kind, k)))
                .collect::<Vec<_>>()
        };
        let rows: HashMap<String, (u32, usize)> =
            matrix_rows(&ins, SPARSEMOR_COORDINATE_INPUT_COLUMN)
                .into_iter()
                .chain(matrix_rows(&outs, SPARSEMOR_COORDINATE_OUTPUT_ROW))
                .collect();
        let coordinates = cp
            .coordinates
            .iter()
            .map(|c| match c {
                Coordinate::Dof(i) => (SPARSEMOR_COORDINATE_DOF, *i, 0),
                Coordinate::Point { point, dir } => (SPARSEMOR_COORDINATE_POINT, *point, *dir),
                Coordinate::Row(name) => {
                    let (kind, k) = rows[name];
                    (kind, k, 0)
                }
            })
            .collect();
        Ok(CoupledScene {
            body: Body::new(&cp.model)?,
            scene,
            t: cp.t,
            coordinates,
            points: points.to_vec(),
            functionals: [ins, outs],
        })
    })?
}

/// The columns of the caller's sparse matrix as sparse vectors, after checking its arrays.
///
/// # Safety
/// The pointers in `s` valid for the lengths they claim (`ncols + 1`, `nnz`).
unsafe fn columns(s: &SparsemorSparse, what: &str) -> Result<Vec<SparseRow>, Failure> {
    // SAFETY: the caller's contract on the struct.
    let (col_ptr, row_idx, values) = unsafe {
        csc_arrays(
            s.col_ptr,
            s.row_idx,
            s.values,
            [s.nrows, s.ncols],
            s.nnz,
            "ncols",
            what,
        )?
    };
    let mut cols = Vec::with_capacity(s.ncols);
    for j in 0..s.ncols {
        let mut col = SparseRow::default();
        for p in col_ptr[j]..col_ptr[j + 1] {
            let (i, v) = (row_idx[p], values[p]);
            if v != 0.0 {
                col.idx.push(i);
                col.val.push(v);
            }
        }
        cols.push(col);
    }
    Ok(cols)
}

/// The rows of a q×ncols matrix given as its columns.
fn transpose(cols: &[SparseRow], nrows: usize) -> Vec<SparseRow> {
    let mut rows = vec![SparseRow::default(); nrows];
    for (j, c) in cols.iter().enumerate() {
        for (&i, &v) in c.idx.iter().zip(&c.val) {
            rows[i].idx.push(j);
            rows[i].val.push(v);
        }
    }
    rows
}

/// The functionals of one scene part, checked against the model's N and its points; the
/// matrix's functionals are named `inputs.matrix column k` / `outputs.matrix row k`.
///
/// # Safety
/// `part` NULL or a valid struct whose arrays have the lengths it claims.
unsafe fn functionals(
    part: *const SparsemorScenePart,
    input: bool,
    n: usize,
    n_points: usize,
) -> Result<Vec<Functional>, Failure> {
    let what = if input { "inputs" } else { "outputs" };
    // SAFETY: forwarded contract.
    let part = unsafe { obj(part, what)? };
    let mut list = Vec::new();
    let dofs = unsafe { slice_in(part.dofs, part.n_dofs, &format!("{what}.dofs"))? };
    for (k, &d) in dofs.iter().enumerate() {
        if d >= n {
            return Err(Failure::arg(format!(
                "{what}.dofs[{k}] = {d}: the model has DoFs 0..{}",
                n - 1
            )));
        }
        list.push(Functional::Dof(d));
    }
    let codes = unsafe {
        slice_in(
            part.point_dofs,
            part.n_point_dofs,
            &format!("{what}.point_dofs"),
        )?
    };
    for (k, &c) in codes.iter().enumerate() {
        let (point, dir) = (c / 6, c % 6);
        if point >= n_points {
            return Err(Failure::arg(format!(
                "{what}.point_dofs[{k}] = {c}: codes are 6·point + dir (dir 0..5 = x, y, z, \
                 rx, ry, rz), and point {point} does not exist ({n_points} remote points added \
                 with sparsemor_model_add_remote_point)"
            )));
        }
        list.push(Functional::Point { point, dir });
    }
    if !part.matrix.is_null() {
        let name = format!("{what}.matrix");
        let m = unsafe { obj(part.matrix, &name)? };
        let (need, have) = if input {
            (
                format!("B must be N×p with N = {n} rows (one per DoF of the model)"),
                m.nrows,
            )
        } else {
            (
                format!("C must be q×N with N = {n} columns (one per DoF of the model)"),
                m.ncols,
            )
        };
        if have != n {
            return Err(Failure::arg(format!(
                "{name} is {}×{}, but {need}",
                m.nrows, m.ncols
            )));
        }
        let cols = unsafe { columns(m, &name)? };
        let (vectors, unit) = if input {
            (cols, "column")
        } else {
            (transpose(&cols, m.nrows), "row")
        };
        for (k, v) in vectors.into_iter().enumerate() {
            if v.idx.is_empty() {
                return Err(Failure::arg(format!(
                    "{name}: {unit} {k} has no nonzero entry; every {unit} must be a functional"
                )));
            }
            list.push(Functional::Row(format!("{name} {unit} {k}"), v));
        }
    }
    if list.is_empty() {
        return Err(Failure::arg(format!(
            "{what}: no DoF, point DoF or matrix {}; give at least one",
            if input { "column" } else { "row" }
        )));
    }
    Ok(list)
}

/// Adds a remote point: a reference point with six DoFs (x, y, z, rx, ry, rz) at `position`
/// tied to `n_nodes` nodes (0-based indices into the node coordinates given to
/// `sparsemor_model_new`), rigidly (`SPARSEMOR_POINT_RIGID`, RBE2) or distributing
/// (`SPARSEMOR_POINT_DISTRIBUTING`, RBE3; docs/design.md §3.11). `weights`: NULL (equal
/// weights), or `n_nodes` finite weights > 0, for a distributing point only. The point's index
/// (0, 1, ... in the order added; named `point0`, `point1`, ... in messages) goes to
/// `*index_out` (may be NULL); scene parts name its DoFs as `6·index + dir`.
///
/// The point is checked on its own here (nodes in range and distinct, a position that is no
/// coupled node's, nodes not on one line where the coupling needs a rotation); checks across
/// points (a node in two rigid points) come with `sparsemor_model_set_scene_general`, which
/// uses every point added so far: a rigid point changes the coupled model even where the
/// scene does not name it. Adding a point does not change a scene already set. The model
/// needs node coordinates.
///
/// # Safety
/// `model` a live handle not used concurrently; `position` 3 doubles; `nodes` `n_nodes`
/// values; `weights` NULL or `n_nodes` doubles; `index_out` NULL or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)] // the C signature
pub unsafe extern "C" fn sparsemor_model_add_remote_point(
    model: *mut SparsemorModel,
    kind: u32,
    position: *const f64,
    nodes: *const usize,
    n_nodes: usize,
    weights: *const f64,
    index_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj_mut(model, "model")? };
        let name = format!("point{}", m.points.len());
        let kind = match kind {
            SPARSEMOR_POINT_RIGID => Kind::Rigid,
            SPARSEMOR_POINT_DISTRIBUTING => Kind::Distributing,
            k => {
                return Err(Failure::arg(format!(
                    "kind = {k}: use SPARSEMOR_POINT_RIGID (0) or SPARSEMOR_POINT_DISTRIBUTING (1)"
                )))
            }
        };
        let xyz = m.body.nodes().ok_or_else(|| {
            Failure::arg(
                "remote points tie to nodes, and the model has no node coordinates: create it \
                 with nodes_xyz (sparsemor_model_new)",
            )
        })?;
        let p = unsafe { slice_in(position, 3, "position")? };
        if let Some(v) = p.iter().find(|v| !v.is_finite()) {
            return Err(Failure::arg(format!("position: {v} is not finite")));
        }
        if n_nodes == 0 {
            return Err(Failure::arg(format!(
                "{name}: n_nodes = 0; a remote point needs the nodes of the surface it ties to"
            )));
        }
        let list = unsafe { slice_in(nodes, n_nodes, "nodes")? }.to_vec();
        if let Some((k, &i)) = list.iter().enumerate().find(|(_, &i)| i >= xyz.len()) {
            return Err(Failure::arg(format!(
                "nodes[{k}] = {i}: the model has nodes 0..{}",
                xyz.len() - 1
            )));
        }
        let weights = if weights.is_null() {
            Vec::new()
        } else {
            if kind == Kind::Rigid {
                return Err(Failure::arg(
                    "weights: a rigid point has no weights (its nodes follow it); pass NULL",
                ));
            }
            let w = unsafe { slice_in(weights, n_nodes, "weights")? }.to_vec();
            if let Some((k, v)) = w
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v > 0.0))
            {
                return Err(Failure::arg(format!(
                    "weights[{k}] = {v}: weights must be finite and > 0"
                )));
            }
            w
        };
        let point = RemotePoint {
            name,
            position: [p[0], p[1], p[2]],
            nodes: list,
            weights,
            kind,
        };
        let dpn = m.body.dofs_per_node();
        // in a call-local pool: faer's dense eigensolver would otherwise start rayon's
        // global pool, whose threads outlive the call
        in_pool(1, || match kind {
            Kind::Rigid => rigid_elimination(std::slice::from_ref(&point), xyz, dpn).map(drop),
            Kind::Distributing => distributing_rows(&point, xyz, dpn).map(drop),
        })??;
        let index = m.points.len();
        unsafe { write_opt(index_out, index, "index_out")? };
        m.points.push(point);
        Ok(())
    })
}

/// Sets a general scene: `inputs` and `outputs` (see `SparsemorScenePart`: DoFs, remote
/// points' DoFs, the columns of a sparse B / rows of a sparse C) and the band
/// [`band_lo_hz`, `band_hi_hz`] (finite, 0 <= lo < hi).
///
/// The model with every remote point added so far and these functionals is coupled into one
/// congruent model M' = TᵀMT, K' = TᵀKT, D' = TᵀDT, q = T z (docs/design.md §3.11), whose
/// scene is DoFs again; every reduction and `sparsemor_rom_transfer_error` then work on it.
/// A ROM's Br columns and Cr rows are in the order of the scene parts (dofs, then point
/// DoFs, then matrix columns / rows), and its transfer function is C A⁻¹ B of the original
/// model with these B and C. Indices the ABI exchanges with a reduction — the ROM's
/// coordinates, inputs and outputs (`sparsemor_rom_dofs`), the options' interface and
/// retained DoFs — are DoFs of the coupled model, 0 .. `sparsemor_model_coordinate_count`,
/// named by `sparsemor_model_coordinate`; the basis V (`SPARSEMOR_MATRIX_V`) is handed out
/// as T V, N×n in the original DoFs.
///
/// The original model stays in the handle: calling this again couples it again, and
/// `sparsemor_model_set_scene` returns to it. On failure the handle keeps the scene it had.
/// Cost: one congruence (a distributing point over s DoFs adds up to s² entries to M', K')
/// and the coupled body's preparation.
///
/// # Safety
/// `model` a live handle not used concurrently; `inputs`, `outputs` valid structs whose
/// arrays have the lengths they claim.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_set_scene_general(
    model: *mut SparsemorModel,
    inputs: *const SparsemorScenePart,
    outputs: *const SparsemorScenePart,
    band_lo_hz: f64,
    band_hi_hz: f64,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj_mut(model, "model")? };
        let n = m.body.n();
        let ins = unsafe { functionals(inputs, true, n, m.points.len())? };
        let outs = unsafe { functionals(outputs, false, n, m.points.len())? };
        if !(band_lo_hz.is_finite()
            && band_hi_hz.is_finite()
            && band_lo_hz >= 0.0
            && band_hi_hz > band_lo_hz)
        {
            return Err(Failure::arg(format!(
                "band [{band_lo_hz}, {band_hi_hz}] Hz: need finite 0 <= band_lo_hz < band_hi_hz"
            )));
        }
        let coupled = couple_scene(&m.body, &m.points, ins, outs, [band_lo_hz, band_hi_hz])?;
        m.coupled = Some(coupled);
        Ok(())
    })
}

/// The number of DoFs of the model the reductions work on: N' of the coupled model while a
/// general scene is set, else N.
///
/// # Safety
/// `model` a live handle; `n_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_coordinate_count(
    model: *const SparsemorModel,
    n_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        unsafe { write_out(n_out, m.active_body().n(), "n_out") }
    })
}

/// What DoF `index` (< `sparsemor_model_coordinate_count`) of the model the reductions work on
/// is: `*kind_out` one of `SPARSEMOR_COORDINATE_DOF` (`*a_out` the original DoF),
/// `SPARSEMOR_COORDINATE_POINT` (`*a_out` the remote point, `*b_out` its direction 0..5),
/// `SPARSEMOR_COORDINATE_INPUT_COLUMN` (`*a_out` the column of the inputs' matrix B; a column
/// equal to a row of C is named as the column) or `SPARSEMOR_COORDINATE_OUTPUT_ROW` (`*a_out`
/// the row of the outputs' matrix C); `*b_out` is 0 but for a point. Without a general scene
/// every DoF is `SPARSEMOR_COORDINATE_DOF` with `*a_out` = `index`. Use it to read
/// `sparsemor_rom_dofs` and to give an interface or retained DoFs on a coupled model.
/// `a_out`, `b_out` may be NULL.
///
/// # Safety
/// `model` a live handle; `kind_out` writable; `a_out`, `b_out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_coordinate(
    model: *const SparsemorModel,
    index: usize,
    kind_out: *mut u32,
    a_out: *mut usize,
    b_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        let n = m.active_body().n();
        if index >= n {
            return Err(Failure::arg(format!(
                "index = {index}: the model the reductions work on has DoFs 0..{}",
                n - 1
            )));
        }
        let (kind, a, b) = match &m.coupled {
            Some(c) => c.coordinates[index],
            None => (SPARSEMOR_COORDINATE_DOF, index, 0),
        };
        unsafe {
            write_out(kind_out, kind, "kind_out")?;
            write_opt(a_out, a, "a_out")?;
            write_opt(b_out, b, "b_out")
        }
    })
}
