//! A model with its joints (docs/design.md §3.11): remote points and the scene's functionals
//! (inputs and outputs given as DoFs, as a point's `POINT:DIR`, or as rows of a sparse B or C)
//! turned into coordinates of one congruent model, so that the scene of that model is a list
//! of DoFs again and every reductor, check and export works on it unchanged.
//!
//! Two changes of variables, composed as q = T z with T = T₁T₂:
//! 1. the rigid (RBE2) points' elimination q = T₁ z₁ ([`crate::coupling::rigid_elimination`]);
//! 2. every distinct input and output functional, written in z₁ (a row c of the original DoFs
//!    becomes c T₁), made a coordinate z₁ = T₂ z ([`crate::coupling::functionals_as_coordinates`]).
//!
//! The model is M' = TᵀMT, K' = TᵀKT, D' = TᵀDT, K₄' = TᵀK₄T (Rayleigh damping and a loss
//! factor stay as they are: the congruence is linear). An output c q is the coordinate z_p; an input load b = cᵀ (a
//! distributing point's force, a DoF's unit force, a column of B) is the unit load at z_p,
//! since Tᵀcᵀ = e_p (S T = I). Its rigid modes are the original ones in the new coordinates,
//! V0' = S V0 (a point's rows are its own rigid motion): the body stays free or constrained
//! as it was, with its inertia relief (§3.2) on the new DoFs.
//!
//! Every remote point's six DoFs, named in the scene or not, are kept as rows over z
//! ([`Coupled::point_rows`]: a rigid point's are coordinates of z₁, a distributing point's its
//! weighted least-squares rows W T₁; either times T₂), and [`Joints`] keeps T and the model
//! before coupling: the exports write each point as an interface node (docs/design.md §3.9).
//!
//! Cost: each functional's pivot DoF is expressed through all DoFs of its support, so M' and
//! K' gain a dense block over the union of a functional's support (a distributing point over
//! s DoFs adds up to s² entries); [`Coupled::nnz`] reports it, and [`couple`] refuses a
//! scene past [`MAX_FILL_ENTRIES`] or [`MAX_ELIMINATION_ENTRIES`] before allocating. Where
//! those blocks outweigh the body, the model also carries its [`Coupling`] (the model after
//! the rigid elimination, T₂ and S = T₂⁻¹), through which its products and real
//! factorizations go ([`Congruent`]).
//!
//! Entry point: [`couple`].

use crate::coupling::{
    congruence, distributing_rows, functionals_as_coordinates, rigid_elimination, Kind,
    RemotePoint, SparseRow,
};
use crate::model::{Coupling, Damping, Model, Structural};
use crate::pencil::{Congruent, Pencil};
use crate::proportional::Split;
use crate::rigid::{centroid, rigid_modes, rigid_modes_about};
use crate::sparse::linear_combination;
use crate::{Error, Result};
use faer::Mat;
use std::collections::BTreeMap;
use std::sync::Arc;

/// One input or output of a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Functional {
    /// A DoF of the model (0-based).
    Dof(usize),
    /// A remote point's DoF: `point` indexes the points, `dir` is 0..6 (x, y, z, rx, ry, rz).
    Point {
        /// Which point.
        point: usize,
        /// Which of its six DoFs.
        dir: usize,
    },
    /// A row of C or a column of B, named (e.g. `C.mtx row 3`).
    Row(String, SparseRow),
}

/// What a DoF of the coupled model is.
#[derive(Clone, Debug, PartialEq)]
pub enum Coordinate {
    /// DoF i of the original model.
    Dof(usize),
    /// A remote point's DoF.
    Point {
        /// Which point.
        point: usize,
        /// Which of its six DoFs.
        dir: usize,
    },
    /// A functional given as a row, by its name.
    Row(String),
}

/// The coupled model and its scene.
#[derive(Clone, Debug)]
pub struct Coupled {
    /// M', K', D' and the rigid modes in the new coordinates; no node coordinates.
    pub model: Model,
    /// The inputs as DoFs of `model`, in the order given.
    pub inputs: Vec<usize>,
    /// The outputs as DoFs of `model`, in the order given.
    pub outputs: Vec<usize>,
    /// What each DoF of `model` is.
    pub coordinates: Vec<Coordinate>,
    /// Stored entries of K before and after (the dense blocks of the module doc).
    pub nnz: [usize; 2],
    /// The coupled model's size N' (the original N less 3 or 6 per rigidly coupled node plus 6
    /// per rigid point).
    pub n: usize,
    /// q = T z (N × N'): a state of the coupled model (a ROM's basis) as a state of the
    /// original model.
    pub t: crate::sparse::Csc,
    /// Each remote point's six DoFs (x, y, z, rx, ry, rz) as rows over z, whether the scene
    /// names them or not ([`point_rows`]): the point's motion in a state z.
    pub point_rows: Vec<[SparseRow; 6]>,
}

/// What the exports need of a coupled model beyond its matrices (docs/design.md §3.9,
/// §3.11): the model it came from, with its mesh nodes and M, and how to carry a state and
/// the points' motion back to it.
#[derive(Clone, Debug)]
pub struct Joints {
    /// The model before coupling.
    pub original: Model,
    /// Its remote points.
    pub points: Vec<RemotePoint>,
    /// What each DoF of the coupled model is ([`Coupled::coordinates`]).
    pub coordinates: Vec<Coordinate>,
    /// q = T z ([`Coupled::t`]).
    pub t: crate::sparse::Csc,
    /// The points' six rows over z ([`Coupled::point_rows`]).
    pub point_rows: Vec<[SparseRow; 6]>,
}

/// The coupled model of `model` with remote `points` and the scene's `inputs` and `outputs`
/// (module doc).
///
/// # Errors
/// [`Error::InvalidSetting`] naming the point or functional: points on a model without node
/// coordinates, any check of [`rigid_elimination`] and [`distributing_rows`], a DoF or row out
/// of range, the same functional given twice as an input (or as an output), and functionals
/// that are linearly dependent. [`Error::InvalidModel`] when the coupled model fails
/// validation.
pub fn couple(
    model: &Model,
    points: &[RemotePoint],
    inputs: &[Functional],
    outputs: &[Functional],
) -> Result<Coupled> {
    let n = model.n();
    let dpn = model.dofs_per_node;
    let nodes = model.nodes.as_deref();
    if !points.is_empty() && nodes.is_none() {
        return Err(Error::InvalidSetting(
            "remote points need the model's node coordinates: add `nodes = \"nodes.csv\"`".into(),
        ));
    }
    let no_nodes: &[[f64; 3]] = &[];
    let nodes_or_none = nodes.unwrap_or(no_nodes);
    // 1. RBE2 elimination
    let rigid: Vec<usize> = (0..points.len())
        .filter(|&k| points[k].kind == Kind::Rigid)
        .collect();
    let rigid_points: Vec<RemotePoint> = rigid.iter().map(|&k| points[k].clone()).collect();
    let t1 = if rigid.is_empty() {
        None
    } else {
        Some(rigid_elimination(&rigid_points, nodes_or_none, dpn)?.t)
    };
    // z₁: the DoFs of nodes no rigid point couples (checked in range above), in order, then
    // six per rigid point
    let mut eliminated = vec![false; nodes_or_none.len()];
    for p in &rigid_points {
        for &i in &p.nodes {
            eliminated[i] = true;
        }
    }
    let kept: Vec<usize> = (0..n)
        .filter(|&q| !eliminated.get(q / dpn).copied().unwrap_or(false))
        .collect();
    let mut coordinates: Vec<Coordinate> = kept.iter().map(|&q| Coordinate::Dof(q)).collect();
    for &k in &rigid {
        coordinates.extend((0..6).map(|dir| Coordinate::Point { point: k, dir }));
    }
    let n1 = coordinates.len();
    // 2. the functionals as rows in z₁
    let rows_of_t1 = t1
        .as_ref()
        .map(|t| {
            t.as_ref()
                .transpose()
                .to_col_major()
                .map_err(|e| Error::Factor(format!("coupled model: {e:?}")))
        })
        .transpose()?;
    let in_z1 = |row: &SparseRow| -> SparseRow {
        let Some(rt) = &rows_of_t1 else {
            return row.clone();
        };
        let mut acc = BTreeMap::<usize, f64>::new();
        for (&i, &v) in row.idx.iter().zip(&row.val) {
            for (&j, &t) in rt.row_idx_of_col_raw(i).iter().zip(rt.val_of_col(i)) {
                *acc.entry(j).or_insert(0.0) += v * t;
            }
        }
        SparseRow {
            idx: acc.keys().copied().collect(),
            val: acc.values().copied().collect(),
        }
    };
    let mut distributing: BTreeMap<usize, [SparseRow; 6]> = BTreeMap::new();
    let mut unique: Vec<(SparseRow, Coordinate)> = Vec::new();
    // each distinct row's index in `unique`, keyed by its entries' bits (−0 as +0)
    let mut seen: std::collections::HashMap<(Vec<usize>, Vec<u64>), usize> =
        std::collections::HashMap::new();
    let mut pivot_index = |f: &Functional, what: &str| -> Result<usize> {
        let (row, label) = match f {
            Functional::Dof(i) => {
                if *i >= n {
                    return Err(Error::DofOutOfRange {
                        what: what.to_string(),
                        dof: *i,
                        n,
                    });
                }
                (
                    in_z1(&SparseRow {
                        idx: vec![*i],
                        val: vec![1.0],
                    }),
                    Coordinate::Dof(*i),
                )
            }
            Functional::Point { point, dir } => {
                let p = points.get(*point).filter(|_| *dir < 6).ok_or_else(|| {
                    Error::InvalidSetting(format!(
                        "{what}: no remote point {point} with DoF {dir} ({} points, DoFs 0..6)",
                        points.len()
                    ))
                })?;
                let label = Coordinate::Point {
                    point: *point,
                    dir: *dir,
                };
                // a rigid point's DoF is coordinate kept + 6·slot + dir of z₁ already
                let row = match rigid.iter().position(|&k| k == *point) {
                    Some(slot) => SparseRow {
                        idx: vec![n1 - 6 * rigid.len() + 6 * slot + dir],
                        val: vec![1.0],
                    },
                    None => {
                        if !distributing.contains_key(point) {
                            distributing.insert(*point, distributing_rows(p, nodes_or_none, dpn)?);
                        }
                        in_z1(&distributing[point][*dir])
                    }
                };
                (row, label)
            }
            Functional::Row(name, row) => {
                if let Some(&c) = row.idx.iter().find(|&&c| c >= n) {
                    return Err(Error::InvalidSetting(format!(
                        "{what}: {name} has an entry in column {c}, but the model has {n} DoFs"
                    )));
                }
                (in_z1(row), Coordinate::Row(name.clone()))
            }
        };
        let key = (
            row.idx.clone(),
            row.val.iter().map(|v| (v + 0.0).to_bits()).collect(),
        );
        Ok(*seen.entry(key).or_insert_with(|| {
            unique.push((row, label));
            unique.len() - 1
        }))
    };
    let mut scene = |list: &[Functional], what: &str| -> Result<Vec<usize>> {
        let idx = list
            .iter()
            .map(|f| pivot_index(f, what))
            .collect::<Result<Vec<_>>>()?;
        for (a, &k) in idx.iter().enumerate() {
            if let Some(b) = idx[..a].iter().position(|&j| j == k) {
                return Err(Error::InvalidSetting(format!(
                    "{what}: entries {b} and {a} are the same functional; give each once"
                )));
            }
        }
        Ok(idx)
    };
    let inputs = scene(inputs, "inputs")?;
    let outputs = scene(outputs, "outputs")?;
    let rows: Vec<SparseRow> = unique.iter().map(|(r, _)| r.clone()).collect();
    check_size(&rows)?;
    let change = functionals_as_coordinates(&rows, n1, "the scene's inputs and outputs")?;
    // every point's six DoFs as rows over z₁ (a rigid point's are coordinates of z₁), then
    // over z through T₂
    let over_z1 = (0..points.len())
        .map(|k| match rigid.iter().position(|&j| j == k) {
            Some(slot) => Ok(std::array::from_fn(|dir| SparseRow {
                idx: vec![n1 - 6 * rigid.len() + 6 * slot + dir],
                val: vec![1.0],
            })),
            None => {
                let w = match distributing.remove(&k) {
                    Some(w) => w,
                    None => distributing_rows(&points[k], nodes_or_none, dpn)?,
                };
                Ok(w.map(|r| in_z1(&r)))
            }
        })
        .collect::<Result<Vec<[SparseRow; 6]>>>()?;
    let point_rows = point_rows(&over_z1, &change.t)?;
    let pivots = change.coordinates;
    for ((_, label), &p) in unique.iter().zip(&pivots) {
        coordinates[p] = label.clone();
    }
    let t2 = change.t;
    let t = match &t1 {
        Some(t1) => faer::sparse::linalg::matmul::sparse_sparse_matmul(
            t1.as_ref(),
            t2.as_ref(),
            1.0,
            faer::Par::Seq,
        )
        .map_err(|e| Error::Factor(format!("coupled model: {e:?}")))?,
        None => t2.clone(),
    };
    let stiffness = congruence(&model.stiffness, &t)?;
    let mass = congruence(&model.mass, &t)?;
    let nnz = [model.stiffness.compute_nnz(), stiffness.compute_nnz()];
    // A₁ = T₁ᵀAT₁ (the model itself without rigid points) when going through it pays
    let first = if Congruent::pays(nnz[0], t2.compute_nnz(), nnz[1]) {
        Some(match &t1 {
            Some(t1) => (
                congruence(&model.stiffness, t1)?,
                congruence(&model.mass, t1)?,
            ),
            None => (model.stiffness.clone(), model.mass.clone()),
        })
    } else {
        None
    };
    let inner = first.as_ref().map(|(k1, m1)| (t1.as_ref(), m1, k1));
    let ((damping, structural), first_damping) =
        carried_damping(model, &t, &mass, &stiffness, inner)?;
    let (coupled, _) = Model::new(model.name.clone(), mass, stiffness, damping, None, dpn)?;
    let mut coupled = coupled.with_structural(structural)?;
    if let (Some((k1, m1)), Some((damping, structural))) = (first, first_damping) {
        // the model's own matrices, or congruences of them (exactly symmetric): validated
        // with the model, not again
        let first = Model {
            name: model.name.clone(),
            mass: m1,
            stiffness: k1,
            damping,
            nodes: None,
            dofs_per_node: dpn,
            rigid_modes: None,
            structural,
            coupling: None,
        };
        let s = inverse_of_t2(&rows, &pivots, n1);
        coupled.coupling = Some(Arc::new(Coupling { first, t: t2, s }));
    }
    if let Some(nodes) = nodes {
        coupled = coupled.with_rigid_modes(rigid_modes_in(
            nodes, dpn, points, &rigid, &kept, &rows, &pivots,
        ))?;
    }
    Ok(Coupled {
        model: coupled,
        inputs: inputs.iter().map(|&k| pivots[k]).collect(),
        outputs: outputs.iter().map(|&k| pivots[k]).collect(),
        coordinates,
        nnz,
        n: n1,
        t,
        point_rows,
    })
}

/// A damping and a structural damping.
type Carried = (Damping, Structural);

/// D' and H' of the coupled model (docs/design.md §3.12): an explicit D or K₄ that splits
/// into a proportional part and a low-rank remainder keeps the split exactly, as
/// αM' + βK' + TᵀET (and γM' + η₄K' + TᵀFT), instead of TᵀDT, whose rounding in the dense
/// blocks' cancellations would hide the proportional part from the coupled pencil's fit; any
/// other damping is carried by congruence. With `first` = (T₁, M₁, K₁), also the damping of
/// the model after the rigid points' elimination q = T₁z₁ (none: T₁ = I) whose congruence
/// that is (αM₁ + βK₁ + T₁ᵀET₁, …; T₁ᵀDT₁ for any other D), for the products and solves
/// through the coupling ([`Congruent`]).
fn carried_damping(
    model: &Model,
    t: &crate::sparse::Csc,
    mass: &crate::sparse::Csc,
    stiffness: &crate::sparse::Csc,
    first: Option<(
        Option<&crate::sparse::Csc>,
        &crate::sparse::Csc,
        &crate::sparse::Csc,
    )>,
) -> Result<(Carried, Option<Carried>)> {
    let eta = model.structural.eta;
    let explicit = matches!(model.damping, Damping::Matrix(_)) || model.structural.matrix.is_some();
    let by_congruence = |x: &Option<&crate::sparse::Csc>| x.map(|x| congruence(x, t)).transpose();
    let pencil = explicit.then(|| Pencil::new(model));
    let (p, remainder) = match pencil.as_ref().map(|p| p.split()) {
        Some(Split::Proportional(p)) => (*p, None),
        Some(Split::LowRank(p, r)) => (*p, Some(r.matrices(model.n()))),
        _ => {
            let damping = match &model.damping {
                Damping::Matrix(d) => Damping::Matrix(congruence(d, t)?),
                other => other.clone(),
            };
            let matrix = by_congruence(&model.structural.matrix.as_ref())?;
            let first = match first {
                Some((t1, _, _)) => {
                    let by_t1 = |x: &crate::sparse::Csc| match t1 {
                        Some(t1) => congruence(x, t1),
                        None => Ok(x.clone()),
                    };
                    let damping = match &model.damping {
                        Damping::Matrix(d) => Damping::Matrix(by_t1(d)?),
                        other => other.clone(),
                    };
                    let matrix = model.structural.matrix.as_ref().map(by_t1).transpose()?;
                    Some((damping, Structural { eta, matrix }))
                }
                None => None,
            };
            return Ok(((damping, Structural { eta, matrix }), first));
        }
    };
    let (e, f) = remainder.unwrap_or((None, None));
    let coupled = (by_congruence(&e.as_ref())?, by_congruence(&f.as_ref())?);
    let coupled = split_damping(model, &p, mass, stiffness, coupled);
    let first = match first {
        Some((t1, m1, k1)) => {
            let by_t1 = |x: Option<crate::sparse::Csc>| match (x, t1) {
                (Some(x), Some(t1)) => congruence(&x, t1).map(Some),
                (x, _) => Ok(x),
            };
            Some(split_damping(model, &p, m1, k1, (by_t1(e)?, by_t1(f)?)))
        }
        None => None,
    };
    Ok((coupled, first))
}

/// S = T₂⁻¹: the identity with each pivot row `pivots[k]` replaced by the functional
/// `rows[k]` (z = S z₁; docs/design.md §3.11), N' × N'.
fn inverse_of_t2(rows: &[SparseRow], pivots: &[usize], n: usize) -> crate::sparse::Csc {
    let mut is_pivot = vec![false; n];
    pivots.iter().for_each(|&p| is_pivot[p] = true);
    let mut s = crate::sparse::Triplets::default();
    (0..n)
        .filter(|&i| !is_pivot[i])
        .for_each(|i| s.push(i, i, 1.0));
    for (row, &p) in rows.iter().zip(pivots) {
        row.idx
            .iter()
            .zip(&row.val)
            .for_each(|(&j, &v)| s.push(p, j, v));
    }
    s.into_csc(n, false)
}

/// The damping of a split (docs/design.md §3.12) on `mass` and `stiffness`: Rayleigh (or
/// none) for a proportional D, αM + βK + E with a remainder E; γM + (η₄ − η)K + F beside the
/// model's η for a K₄ (η₄ alone when γ = 0 and there is no F).
fn split_damping(
    model: &Model,
    p: &crate::proportional::Proportional,
    mass: &crate::sparse::Csc,
    stiffness: &crate::sparse::Csc,
    (e, f): (Option<crate::sparse::Csc>, Option<crate::sparse::Csc>),
) -> Carried {
    let eta = model.structural.eta;
    let damping = match (e, &model.damping) {
        (None, Damping::Matrix(_)) if p.alpha == 0.0 && p.beta == 0.0 => Damping::None,
        (None, Damping::Matrix(_)) => Damping::Rayleigh {
            alpha: p.alpha,
            beta: p.beta,
        },
        (Some(e), Damping::Matrix(_)) => Damping::Matrix(linear_combination(
            p.alpha,
            mass,
            p.beta,
            stiffness,
            Some(&e),
        )),
        (_, other) => other.clone(),
    };
    let matrix = match (f, model.structural.matrix.is_some()) {
        (_, false) => None,
        (None, true) if p.gamma == 0.0 => {
            let structural = Structural {
                eta: p.eta,
                matrix: None,
            };
            return (damping, structural);
        }
        (f, true) => Some(linear_combination(
            p.gamma,
            mass,
            p.eta - eta,
            stiffness,
            f.as_ref(),
        )),
    };
    (damping, Structural { eta, matrix })
}

/// The rows `over_z1` (functionals of z₁) as functionals of z, z₁ = T₂ z (module doc): a
/// point's six DoFs in the coupled model's coordinates, c T₂ for each row c. T₂ differs from
/// the identity only in its pivot rows, so a row gains entries only over the functionals'
/// support.
///
/// # Errors
/// [`Error::Factor`] when T₂ᵀ cannot be stored.
fn point_rows(over_z1: &[[SparseRow; 6]], t2: &crate::sparse::Csc) -> Result<Vec<[SparseRow; 6]>> {
    // the rows of T₂ as columns of T₂ᵀ
    let rows_of_t2 = t2
        .as_ref()
        .transpose()
        .to_col_major()
        .map_err(|e| Error::Factor(format!("coupled model: {e:?}")))?;
    let times_t2 = |c: &SparseRow| {
        let mut acc = BTreeMap::<usize, f64>::new();
        for (&i, &v) in c.idx.iter().zip(&c.val) {
            for (&j, &t) in rows_of_t2
                .row_idx_of_col_raw(i)
                .iter()
                .zip(rows_of_t2.val_of_col(i))
            {
                *acc.entry(j).or_insert(0.0) += v * t;
            }
        }
        SparseRow {
            idx: acc.keys().copied().collect(),
            val: acc.values().copied().collect(),
        }
    };
    Ok(over_z1
        .iter()
        .map(|rows| std::array::from_fn(|d| times_t2(&rows[d])))
        .collect())
}

impl Coupled {
    /// The coupled model and its [`Joints`] to `original` with `points` (the arguments
    /// [`couple`] was given).
    pub fn split(self, original: Model, points: Vec<RemotePoint>) -> (Model, Joints) {
        (
            self.model,
            Joints {
                original,
                points,
                coordinates: self.coordinates,
                t: self.t,
                point_rows: self.point_rows,
            },
        )
    }
}

/// Largest dense elimination block r × |support| of the functionals (8 bytes an entry:
/// 400 MB).
pub const MAX_ELIMINATION_ENTRIES: usize = 50_000_000;

/// Largest dense fill Σ s² (s the size of each distinct support) that M' and K' may gain:
/// 2·10⁸ entries, about 3.2 GB in each.
pub const MAX_FILL_ENTRIES: usize = 200_000_000;

/// Refuses functionals whose dense elimination block or fill (module doc) would pass
/// [`MAX_ELIMINATION_ENTRIES`] or [`MAX_FILL_ENTRIES`], before anything is allocated.
fn check_size(rows: &[SparseRow]) -> Result<()> {
    let mut support: Vec<usize> = rows.iter().flat_map(|r| r.idx.iter().copied()).collect();
    support.sort_unstable();
    support.dedup();
    let block = rows.len().saturating_mul(support.len());
    let mut supports: Vec<&[usize]> = rows.iter().map(|r| r.idx.as_slice()).collect();
    supports.sort_unstable();
    supports.dedup();
    let fill = supports.iter().fold(0usize, |acc, s| {
        acc.saturating_add(s.len().saturating_mul(s.len()))
    });
    if block > MAX_ELIMINATION_ENTRIES || fill > MAX_FILL_ENTRIES {
        return Err(Error::InvalidSetting(format!(
            "the scene's {} functionals run over {} DoFs: their elimination block ({block} \
             entries, limit {MAX_ELIMINATION_ENTRIES}) or the dense fill of the coupled \
             matrices ({fill} entries, limit {MAX_FILL_ENTRIES}) is too large; select fewer \
             nodes for a distributing point (a ring of the bore rather than its whole \
             surface), make it rigid, or give fewer matrix rows",
            rows.len(),
            support.len()
        )));
    }
    Ok(())
}

/// V0' = S V0₁ (module doc): the original rigid modes about the nodes' centroid on the kept
/// DoFs, each rigid point's own rigid motion on its six, and pivot row p_k replaced by
/// functional k applied to V0₁.
fn rigid_modes_in(
    nodes: &[[f64; 3]],
    dpn: usize,
    points: &[RemotePoint],
    rigid: &[usize],
    kept: &[usize],
    rows: &[SparseRow],
    pivots: &[usize],
) -> Mat<f64> {
    let v0 = rigid_modes(nodes, dpn);
    let positions: Vec<[f64; 3]> = rigid.iter().map(|&k| points[k].position).collect();
    let at_points = rigid_modes_about(&positions, 6, centroid(nodes));
    // V0₁: z₁ is the kept DoFs in order, then six per rigid point
    let v01 = Mat::<f64>::from_fn(kept.len() + 6 * rigid.len(), 6, |i, j| match kept.get(i) {
        Some(&q) => v0[(q, j)],
        None => at_points[(i - kept.len(), j)],
    });
    let mut v = v01.clone();
    for (row, &p) in rows.iter().zip(pivots) {
        for j in 0..6 {
            v[(p, j)] = row
                .idx
                .iter()
                .zip(&row.val)
                .map(|(&i, &x)| x * v01[(i, j)])
                .sum();
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use crate::sparse::Csc;
    use faer::c64;

    fn small_bar() -> Model {
        let mut m = bar_model(&BoxSpec::small()).unwrap();
        m.damping = Damping::Rayleigh {
            alpha: 0.0,
            beta: 1e-5,
        };
        m
    }

    /// H(iω) = C (K + iωβK − ω²M)⁻¹ B, dense.
    fn transfer(k: &Csc, m: &Csc, b: &Mat<f64>, c: &Mat<f64>, omega: f64, beta: f64) -> Mat<c64> {
        let (k, m) = (k.as_ref().to_dense(), m.as_ref().to_dense());
        let a = Mat::<c64>::from_fn(k.nrows(), k.ncols(), |i, j| {
            c64::new(
                k[(i, j)] - omega * omega * m[(i, j)],
                omega * beta * k[(i, j)],
            )
        });
        let bc = Mat::<c64>::from_fn(b.nrows(), b.ncols(), |i, j| c64::new(b[(i, j)], 0.0));
        let x = faer::linalg::solvers::Solve::solve(&a.partial_piv_lu(), &bc);
        let cc = Mat::<c64>::from_fn(c.nrows(), c.ncols(), |i, j| c64::new(c[(i, j)], 0.0));
        cc * x
    }

    fn dense_rows(rows: &[SparseRow], n: usize) -> Mat<f64> {
        let mut c = Mat::<f64>::zeros(rows.len(), n);
        for (i, r) in rows.iter().enumerate() {
            for (&j, &v) in r.idx.iter().zip(&r.val) {
                c[(i, j)] += v;
            }
        }
        c
    }

    fn selection(dofs: &[usize], n: usize) -> Mat<f64> {
        Mat::from_fn(n, dofs.len(), |i, j| f64::from(dofs[j] == i))
    }

    /// A distributing point, a DoF and a general row: the coupled model's response at its
    /// DoFs equals C A⁻¹ B of the original with B = Cᵀ of the same functionals.
    #[test]
    fn coupled_transfer_function_equals_the_original_with_b_and_c_applied() {
        let model = small_bar();
        let nodes = model.nodes.clone().unwrap();
        let top: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i][2] > 0.199).collect();
        let point = RemotePoint {
            name: "tip".into(),
            position: [0.01, 0.015, 0.21],
            nodes: top,
            weights: Vec::new(),
            kind: Kind::Distributing,
        };
        let general = SparseRow {
            idx: vec![4, 9, 20],
            val: vec![0.5, -1.25, 2.0],
        };
        let functionals = vec![
            Functional::Point { point: 0, dir: 0 },
            Functional::Point { point: 0, dir: 5 },
            Functional::Dof(7),
            Functional::Row("C.mtx row 0".into(), general.clone()),
        ];
        let cp = couple(
            &model,
            std::slice::from_ref(&point),
            &functionals[..3],
            &functionals,
        )
        .unwrap();
        let rows = distributing_rows(&point, &nodes, 3).unwrap();
        let c = dense_rows(
            &[
                rows[0].clone(),
                rows[5].clone(),
                SparseRow {
                    idx: vec![7],
                    val: vec![1.0],
                },
                general,
            ],
            model.n(),
        );
        let b = c.transpose().to_owned();
        let b3 = Mat::from_fn(model.n(), 3, |i, j| b[(i, j)]);
        for omega in [300.0, 4000.0] {
            let want = transfer(&model.stiffness, &model.mass, &b3, &c, omega, 1e-5);
            let m2 = &cp.model;
            let got = transfer(
                &m2.stiffness,
                &m2.mass,
                &selection(&cp.inputs, m2.n()),
                &selection(&cp.outputs, m2.n()).transpose().to_owned(),
                omega,
                1e-5,
            );
            let err = (&got - &want).norm_l2() / want.norm_l2();
            assert!(err < 1e-10, "ω = {omega}: relative difference {err:e}");
        }
        assert_eq!(
            cp.coordinates[cp.outputs[0]],
            Coordinate::Point { point: 0, dir: 0 }
        );
        assert_eq!(cp.coordinates[cp.outputs[2]], Coordinate::Dof(7));
    }

    /// A 2 × 2 × 12 bar (351 DoFs), Rayleigh β = 1e-5: long enough that a point over every
    /// node has a dense block larger than the bar's K.
    fn through_bar() -> Model {
        let mut m = bar_model(&BoxSpec {
            elements: [2, 2, 12],
            ..BoxSpec::small()
        })
        .unwrap();
        m.damping = Damping::Rayleigh {
            alpha: 0.0,
            beta: 1e-5,
        };
        m
    }

    /// That bar with a rigid point at its base and a distributing one over every node,
    /// damped by `damping` (D, K₄ and η; Rayleigh β = 1e-5 when `damping` is `None`), coupled:
    /// the point's dense block outweighs the bar, so it goes through the coupling.
    fn coupled_through(damping: Option<(Csc, Option<Csc>, f64)>) -> Coupled {
        let mut model = through_bar();
        if let Some((d, k4, eta)) = damping {
            model.damping = Damping::Matrix(d);
            model.structural = Structural { eta, matrix: k4 };
        }
        let nodes = model.nodes.clone().unwrap();
        let base: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i][2] < 1e-9).collect();
        let points = [
            RemotePoint {
                name: "base".into(),
                position: [0.01, 0.015, -0.01],
                nodes: base,
                weights: Vec::new(),
                kind: Kind::Rigid,
            },
            RemotePoint {
                name: "all".into(),
                position: [0.013, 0.017, 0.104],
                nodes: (0..nodes.len()).collect(),
                weights: Vec::new(),
                kind: Kind::Distributing,
            },
        ];
        let io: Vec<Functional> = (0..6)
            .map(|dir| Functional::Point { point: 1, dir })
            .chain([Functional::Point { point: 0, dir: 2 }])
            .collect();
        let cp = couple(&model, &points, &io, &io).unwrap();
        assert!(cp.model.coupling.is_some(), "a point over every node pays");
        cp
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]
        /// Products through the coupling, Tᵀ(X(T z)), equal the formed X' z for M, K, D
        /// (Rayleigh, split into αM + βK + a dashpot, material-like) and H (η, K₄), and so do
        /// A(iω)x and the damping and structural terms: to 1e-12 of the product's size.
        #[test]
        fn products_through_the_coupling_equal_the_formed_ones(
            kind in 0usize..4,
            c in 1.0f64..100.0,
            eta in 0.0f64..0.05,
            seed in 0u64..1000,
        ) {
            let base = through_bar();
            let n0 = base.n();
            let lin = |a: f64, b: f64, extra: &[(usize, usize, f64)]| {
                let mut t = crate::sparse::Triplets::default();
                extra.iter().for_each(|&(i, j, v)| t.push(i, j, v));
                let e = t.into_csc(n0, false);
                linear_combination(a, &base.mass, b, &base.stiffness, Some(&e))
            };
            let dashpot = [(2, 2, c), (47, 47, c), (2, 47, -c), (47, 2, -c)];
            let diagonal: Vec<(usize, usize, f64)> = (0..n0).map(|i| (i, i, c)).collect();
            let damping = match kind {
                0 => None,
                1 => Some((lin(0.0, 1e-5, &dashpot), None, 0.0)),
                2 => Some((lin(2.0, 1e-5, &diagonal), None, eta)),
                _ => Some((lin(0.0, 1e-5, &[]), Some(lin(0.0, 0.01, &diagonal)), eta)),
            };
            let cp = coupled_through(damping);
            let through = Pencil::new(&cp.model);
            proptest::prop_assert!(through.through_coupling().is_some());
            let formed = Pencil::new(&Model { coupling: None, ..cp.model.clone() });
            proptest::prop_assert!(formed.through_coupling().is_none());
            let n = cp.model.n();
            let mut random = crate::random::Xorshift::new(seed + 1);
            let x = Mat::from_fn(n, 6, |_, _| random.next_centred());
            let close = |a: &Mat<f64>, b: &Mat<f64>| (a - b).norm_l2() <= 1e-12 * b.norm_l2();
            use crate::pencil::Coefficient::*;
            for which in [Mass, Stiffness, Damping, Structural] {
                let (a, b) = (through.mul(which, x.as_ref()), formed.mul(which, x.as_ref()));
                proptest::prop_assert!(close(&a, &b) || b.norm_l2() == 0.0 && a.norm_l2() == 0.0);
            }
            let terms = |p: &Pencil| {
                let (m, k) = (p.mul(Mass, x.as_ref()), p.mul(Stiffness, x.as_ref()));
                let d = p.damping_term(&m, &k, |d| d(x.as_ref()));
                let h = p.structural_term(&k, || p.mul(Structural, x.as_ref()));
                (d, h)
            };
            let ((d1, h1), (d2, h2)) = (terms(&through), terms(&formed));
            proptest::prop_assert!(close(&d1, &d2));
            proptest::prop_assert!(h1.zip(h2).is_none_or(|(a, b)| close(&a, &b)));
            let xc = Mat::<c64>::from_fn(n, 2, |i, j| c64::new(x[(i, j)], x[(i, j + 2)]));
            let (mut a, mut b) = (Mat::<c64>::zeros(n, 2), Mat::<c64>::zeros(n, 2));
            through.apply(2.0e3, xc.as_ref(), a.as_mut());
            formed.apply(2.0e3, xc.as_ref(), b.as_mut());
            proptest::prop_assert!((&a - &b).norm_l2() <= 1e-12 * b.norm_l2());
        }
    }

    /// Factorizations through the coupling take A₁, which has no dense block, and solve the
    /// coupled A' = TᵀA₁T as S A₁⁻¹ Sᵀ: the Cholesky factor of K' − σM' below the spectrum,
    /// the indefinite LDLᵀ inside it (which counts as many eigenvalues below σ as the formed
    /// pencil's) and the complex LDLᵀ of K' + iH' + s²M' solve to a backward error below
    /// 1e-12, measured with the coupled products.
    #[test]
    fn factorizations_through_the_coupling_solve_the_coupled_model() {
        use crate::factor::{
            count_eigenvalues_below, symbolic_cholesky, Cholesky, ComplexLdlt, ShiftedIndefinite,
            Storage,
        };
        use crate::pencil::Coefficient::{Mass, Stiffness, Structural};
        use faer::Par;
        let base = through_bar();
        let k4 = linear_combination(0.0, &base.mass, 0.01, &base.stiffness, None);
        let d = linear_combination(0.0, &base.mass, 1e-5, &base.stiffness, None);
        let cp = coupled_through(Some((d, Some(k4), 0.02)));
        let through = Pencil::new(&cp.model);
        let formed = Pencil::new(&Model {
            coupling: None,
            ..cp.model.clone()
        });
        assert!(through.through_coupling().is_some());
        assert!(2 * through.factored().nnz() < formed.nnz());
        let n = cp.model.n();
        let mut random = crate::random::Xorshift::new(7);
        let b = Mat::from_fn(n, 3, |_, _| random.next_centred());
        let sym = Arc::new(symbolic_cholesky(&through).unwrap());
        // ‖(K − σM)x − b‖ / (‖K − σM‖₁‖x‖ + ‖b‖) with the coupled products
        let backward = |sigma: f64, x: &Mat<f64>| {
            let r = through.mul(Stiffness, x.as_ref()) - through.mul(Mass, x.as_ref()) * sigma - &b;
            let norm = formed.norm_1(Stiffness) + sigma.abs() * formed.norm_1(Mass);
            r.norm_l2() / (norm * x.norm_l2() + b.norm_l2())
        };
        let below = -(2.0 * std::f64::consts::PI * 10.0).powi(2);
        let mut chol =
            Cholesky::with_rhs(&through, sym.clone(), Par::Seq, 3, Storage::IN_CORE).unwrap();
        chol.factor(&through, below, Par::Seq).unwrap();
        let mut x = b.clone();
        chol.solve_block(x.as_mut(), Par::Seq);
        assert!(backward(below, &x) < 1e-12, "{:e}", backward(below, &x));
        let inside = (2.0 * std::f64::consts::PI * 3000.0).powi(2);
        let mut ldlt =
            ShiftedIndefinite::new(sym.clone(), &through, inside, 3, Par::Seq, Storage::IN_CORE)
                .unwrap();
        let count = count_eigenvalues_below(&formed, inside).unwrap();
        assert!(count > 6, "the band holds elastic modes");
        assert_eq!(ldlt.below(), count);
        let mut x = b.clone();
        ldlt.solve_in_place(x.as_mut(), Par::Seq);
        assert!(backward(inside, &x) < 1e-12, "{:e}", backward(inside, &x));
        // K + iH + s²M at s = 1000: complex symmetric, real part positive definite
        let s2 = 1e6;
        let mut complex = ComplexLdlt::new(&through, sym, 3, usize::MAX)
            .unwrap()
            .unwrap();
        let (mut re, mut im) = (vec![0.0; through.factored().nnz()], vec![0.0; 0]);
        through.factored().fill_shifted(-s2, &mut re);
        im.resize(re.len(), 0.0);
        through.factored().fill_structural(&mut im);
        assert_eq!(complex.factor(&re, &im, Par::Seq).unwrap(), 0);
        let mut x = Mat::<c64>::from_fn(n, 3, |i, j| c64::new(b[(i, j)], 0.0));
        complex.solve(x.as_mut(), Par::Seq);
        let part = |f: fn(&c64) -> f64| Mat::from_fn(n, 3, |i, j| f(&x[(i, j)]));
        let (xr, xi) = (part(|z| z.re), part(|z| z.im));
        let a =
            |v: &Mat<f64>| through.mul(Stiffness, v.as_ref()) + through.mul(Mass, v.as_ref()) * s2;
        let h = |v: &Mat<f64>| through.mul(Structural, v.as_ref());
        let (rr, ri) = (a(&xr) - h(&xi) - &b, a(&xi) + h(&xr));
        let r = (rr.norm_l2().powi(2) + ri.norm_l2().powi(2)).sqrt();
        let norm = formed.norm_1(Stiffness) + s2 * formed.norm_1(Mass) + formed.norm_1(Structural);
        let x_norm = (xr.norm_l2().powi(2) + xi.norm_l2().powi(2)).sqrt();
        let e = r / (norm * x_norm + b.norm_l2());
        assert!(e < 1e-12, "{e:e}");
    }

    /// A coupling that no longer matches the model is not used: the damping dropped after
    /// coupling, or the stiffness scaled.
    #[test]
    fn a_coupling_that_no_longer_matches_the_model_is_ignored() {
        let cp = coupled_through(None);
        assert!(Pencil::new(&cp.model).through_coupling().is_some());
        let undamped = Model {
            damping: Damping::None,
            ..cp.model.clone()
        };
        assert!(Pencil::new(&undamped).through_coupling().is_none());
        let mut scaled = cp.model.clone();
        scaled
            .stiffness
            .val_mut()
            .iter_mut()
            .for_each(|v| *v *= 2.0);
        assert!(Pencil::new(&scaled).through_coupling().is_none());
    }

    /// The coupled model's rigid modes are the original ones: T V0' = V0 (rigid motions are
    /// exact for both couplings), and K' V0' = 0 on the free bar.
    #[test]
    fn rigid_modes_carry_over_to_the_coupled_coordinates() {
        let model = small_bar();
        let nodes = model.nodes.clone().unwrap();
        let pick = |z: f64| -> Vec<usize> {
            (0..nodes.len())
                .filter(|&i| (nodes[i][2] - z).abs() < 1e-9)
                .collect()
        };
        let points = [
            RemotePoint {
                name: "base".into(),
                position: [0.01, 0.015, -0.01],
                nodes: pick(0.0),
                weights: Vec::new(),
                kind: Kind::Rigid,
            },
            RemotePoint {
                name: "tip".into(),
                position: [0.01, 0.015, 0.21],
                nodes: pick(0.2),
                weights: Vec::new(),
                kind: Kind::Distributing,
            },
        ];
        let io = [
            Functional::Point { point: 0, dir: 3 },
            Functional::Point { point: 1, dir: 2 },
        ];
        let cp = couple(&model, &points, &io, &io).unwrap();
        let v0 = cp.model.rigid_modes.clone().unwrap();
        let k = cp.model.stiffness.as_ref().to_dense();
        let kv = &k * &v0;
        assert!(kv.norm_l2() < 1e-12 * k.norm_l2() * v0.norm_l2());
        assert_eq!(cp.n, model.n() - 3 * pick(0.0).len() + 6);
        assert_eq!(
            cp.coordinates[cp.inputs[0]],
            Coordinate::Point { point: 0, dir: 3 }
        );
    }

    /// Thousands of output rows: the dense elimination block would pass its limit, refused
    /// before anything of that size is allocated.
    #[test]
    fn too_many_functionals_are_refused_with_the_sizes() {
        let model = bar_model(&BoxSpec {
            elements: [10, 10, 25],
            ..BoxSpec::small()
        })
        .unwrap();
        let outputs: Vec<Functional> = (0..7200).map(Functional::Dof).collect();
        let e = couple(&model, &[], &[Functional::Dof(0)], &outputs)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("7200 functionals run over 7200 DoFs") && e.contains("limit 50000000"),
            "{e}"
        );
    }

    #[test]
    fn the_same_input_twice_is_refused_by_position() {
        let model = small_bar();
        let e = couple(
            &model,
            &[],
            &[Functional::Dof(3), Functional::Dof(3)],
            &[Functional::Dof(3)],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("inputs: entries 0 and 1"), "{e}");
    }
}
