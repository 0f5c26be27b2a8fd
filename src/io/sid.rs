//! The SID_FEM file of a ROM's elastic basis (docs/design.md §3.9, §4): Wallrapp's "Standard
//! Input Data" of a flexible body in the floating frame of reference (O. Wallrapp, "Standard
//! Input Data of Flexible Members in Multibody Systems", 1993; R. Schwertassek, O. Wallrapp,
//! "Dynamik flexibler Mehrkörpersysteme", 1999, ch. 6), the ASCII file FEMBS writes and
//! Simpack and the Modelica EMBS/FlexibleBodies libraries read, written by [`write()`] as
//! `body.SID_FEM`.
//!
//! **Layout** (pinned down from the files and readers of the open EMBS Modelica library,
//! vwaurich/EMBS_ModelicaLib: its sample `*.SID_FEM` files and C reader `ReadSID_C.h`; checked
//! against the MATLAB reader `h_fbody_sid_fem.m` of G. Orzechowski and J. Geisler's SID
//! classes, which cite the standard's table 6.2; welib's `yams/sid.py` for the invariants'
//! formulas): a first line `NNODES NQ :comment`, then
//!
//! ```text
//! part / new modal = / refmod (mass, nelastq, ielastq(k) = Eigen Mode k : f Hz) end refmod
//! frame / per node: new node = ID, rframe = body ref, origin, phi, psi, AP, end node / end frame
//! mdCM  J  Ct  Cr  Me  Gr  Ge  Oe  ksigma  Ke  De
//! end modal / end part
//! ```
//!
//! Every matrix is a `taylor` block M(q) = M0 + Σ_k M1_k q_k: `order` (0 or 1), `nrow`,
//! `ncol`, `nq`, `nqn` (0), `structure` (0 zero, 3 general; the diagonal, symmetric and
//! unit structures 1, 2, 4 are not used: not every reader expands them), then the nonzero
//! entries `m0( i, j) = v` and `m1( i, k, j) = v` (row, elastic coordinate,
//! column: the readers' nrow × nq × ncol), 1-based, numbers in Fortran `D` notation with 17
//! significant digits. `J` is the 6-vector (xx, yy, zz, xy, xz, yz) of the tensor
//! ∫(|r|²I − r rᵀ)dm about the body frame's origin; `Oe`'s six columns multiply
//! (ω1², ω2², ω3², ω1ω2, ω2ω3, ω1ω3); `Gr` (3 × 3r) and `Ge` (r × 3r) hold one 3-column block
//! per elastic coordinate, Gr(q̇) = Σ_k Gr_k q̇_k, as the EMBS and MATLAB readers and welib
//! take them (one sample file orders `Ge`'s columns by axis instead; the readers decide).
//! These conventions agree with the library's FEMBS-style sample `beam.SID_FEM` (11 modes):
//! there J1_k = (Gr_k + Gr_kᵀ)/2 and Oe0 = the combinations of −Gr_k/2 below hold to 5e-12,
//! and Cr1 is antisymmetric in its first two indices (row, q) to 1e-14.
//!
//! **Invariants** (3 translational DoFs per node, node-major; the body frame is the model's
//! coordinate system). A point of node p is at x_p + u_p, u = Φq (Φ the M-orthonormal,
//! rigid-free elastic basis of [`crate::reduce::flexible`]), so its body-frame velocity is
//! V = Σ_a T_a v0_a + Σ_b R_b(q) ω_b + Φq̇ with T_a the translation along e_a, R_b(q) the
//! rotation about e_b of the deformed body (node p: e_b × (x_p + u_p)), and the FE kinetic
//! energy
//!
//! ```text
//! T = ½ VᵀMV   (exact for the consistent mass: ω × r is linear in r, so the element
//!               interpolation reproduces the rigid velocity field)
//! ```
//!
//! With S_b Φ_k the nodal field e_b × φ_{k,p} and R_b = R_b(0), the coefficients of T are
//!
//! ```text
//! mass     = T_aᵀ M T_a                       m·c = mdCM0,  J0_ab = R_aᵀ M R_b  (rigid::inertia)
//! mdCM1_k  = ∫Φ_k dm        = (Ct0_k)ᵀ        Ct0_ka  = Φ_kᵀ M T_a
//! Cr0_kb   = Φ_kᵀ M R_b     = (∫ r̃ Φ_k dm)_b   Cr1_klb = Φ_kᵀ M S_b Φ_l   (∂Cr_kb/∂q_l)
//! A_k,ab   = R_aᵀ M S_b Φ_k = −(∫ x̃ Φ̃_k dm)_ab
//! J1_k     = A_k + A_kᵀ                        (∂J/∂q_k)
//! Gr_k     = 2 A_k = −2∫x̃Φ̃_k dm               (= J1_k − skew(Cr0_k): J̇ω + ω × Crᵀq̇)
//! Ge_j,kb  = 2 Cr1_kjb  (block j, row k)      (d/dt ∂T/∂q̇ − ∂T/∂q, terms in q̇ ω)
//! Oe0_k    = −(A_xx, A_yy, A_zz, A_xy+A_yx, A_yz+A_zy, A_xz+A_zx) of A_k   (−½ ωᵀJ1_kω)
//! B_kl,ab  = (S_aΦ_k)ᵀ M (S_bΦ_l),  Oe1_kl = the same six combinations of −B_kl
//! Me = ΦᵀMΦ,  Ke = ΦᵀKΦ,  De = ΦᵀDΦ            (the projected ROM)
//! ```
//!
//! all read off one Gram matrix G = Xᵀ(MX) of the N × (4r + 6) block X = [Φ, S_xΦ, S_yΦ,
//! S_zΦ, T, R]: one pass over M's entries, never a dense N × N product. Because Φ is
//! M-orthogonal to the rigid modes, Ct0 and Cr0 (and so mdCM1) vanish to rounding: the body
//! frame is a mean-axis (Buckens) frame. The identities above that exchange M's blocks (Gr_k
//! = J1_k − skew(Cr0_k), the antisymmetry of Cr1 in k, l) hold for a mass matrix that acts
//! alike on the three directions and couples none, as every solid element's consistent or
//! lumped mass does.
//!
//! Per node: `origin` (order 1: x_p, and u_p's Φ rows), `phi` (order 0: the 3 × r rows of
//! Φ), `psi` zero (a solid's nodes carry no rotational DoFs), `AP` the unit matrix written
//! entry by entry (order 0; its order-1 term skew(psi) is zero).
//!
//! **Remote points** (a ROM of a coupled model, docs/design.md §3.11; [`PointNode`]): each
//! point is one more node after the mesh nodes, numbered after the largest grid id in point
//! order ([`crate::io::dmig::point_grids`]), at the point's position, with `phi` its three
//! translations and `psi` its three small rotations in each mode (R_p Φ), and `AP` = I +
//! Σ_k skew(psi_k) q_k (order 1: the node frame turned by the point's rotation, skew(a) b =
//! a × b). The point is massless: the invariants are the original body's, from its M, its
//! mesh nodes and the mesh nodes' shapes TΦ ([`crate::reduce::flexible`]); the joint of the
//! multibody model attaches to the point's node.
//!
//! **Not written** (zero blocks or order 0 only, and why): the geometric stiffening terms —
//! `ksigma` (structure 0), the order-1 parts of `phi` and `Ct` and the stress part of
//! `Oe1` — need the stress states of unit loads, which a model of M and K does not hold;
//! the order-1 parts of `Gr` and `Ge` (second order in the deformation; the sample files
//! write them at order 0 too); rotational mode shapes `psi` and `AP`'s order-1 term (no rotational DoFs);
//! node stresses (`sigma`). Models with 6 DoFs per node are refused (their rotational inertia
//! and psi are not derived here). `Oe1` therefore holds the inertia part alone, the spin
//! softening −∫Φ_kᵀ ω̃ᵀω̃ Φ_l dm: without the stiffening that the omitted stress terms add, a
//! body spinning fast in the multibody code softens more than the real one.

use crate::io::atomic;
use crate::io::dmig::{grids, point_grids};
use crate::io::import::Dof;
use crate::model::Model;
use crate::reduce::flexible::{ElasticBasis, PointNode};
use crate::rigid::{inertia, Inertia};
use crate::{Error, Result};
use faer::{Mat, MatRef};
use std::fmt::Write as _;
use std::path::Path;

/// The file [`write()`] writes.
pub const SID_FILE: &str = "body.SID_FEM";

/// The six tensor components of `J` (xx, yy, zz, xy, xz, yz).
pub const J_ORDER: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// The six products of `Oe`'s columns (ω1², ω2², ω3², ω1ω2, ω2ω3, ω1ω3).
pub const OE_ORDER: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)];

/// A `taylor` block: M0 (nrow × ncol) and, for order 1, M1_k (nrow × ncol) for k < nq.
#[derive(Clone, Debug, PartialEq)]
pub struct Taylor {
    /// Zero-order matrix.
    pub m0: Mat<f64>,
    /// First-order matrices, one per elastic coordinate (empty for order 0).
    pub m1: Vec<Mat<f64>>,
}

impl Taylor {
    fn zeroth(m0: Mat<f64>) -> Self {
        Self { m0, m1: Vec::new() }
    }

    fn first(m0: Mat<f64>, m1: Vec<Mat<f64>>) -> Self {
        Self { m0, m1 }
    }

    /// The expansion's order (1 when it has M1 terms).
    pub fn order(&self) -> usize {
        usize::from(!self.m1.is_empty())
    }

    fn is_zero(&self) -> bool {
        self.m0.col_iter().all(|c| c.iter().all(|&v| v == 0.0))
            && self
                .m1
                .iter()
                .all(|m| m.col_iter().all(|c| c.iter().all(|&v| v == 0.0)))
    }
}

/// The body invariants of the SID (see the module doc), one Taylor block each.
#[derive(Clone, Debug)]
pub struct Invariants {
    /// Total mass, centre of mass and inertia ([`inertia`]).
    pub rigid: Inertia,
    /// m·c (3 × 1), order 1.
    pub md_cm: Taylor,
    /// Inertia tensor about the origin as (xx, yy, zz, xy, xz, yz) (6 × 1), order 1.
    pub j: Taylor,
    /// ∫Φᵀdm (r × 3), order 0.
    pub ct: Taylor,
    /// ∫Φᵀ r̃ᵀ dm (r × 3), order 1.
    pub cr: Taylor,
    /// ΦᵀMΦ (r × r).
    pub me: Taylor,
    /// [Gr_1 … Gr_r] (3 × 3r), order 0.
    pub gr: Taylor,
    /// [Ge_1 … Ge_r] (r × 3r), order 0.
    pub ge: Taylor,
    /// Centrifugal terms (r × 6), order 1 (inertia part).
    pub oe: Taylor,
    /// Geometric stiffening (r × 1): zero, not computed (module doc, "Not written").
    pub ksigma: Taylor,
    /// ΦᵀKΦ (r × r).
    pub ke: Taylor,
    /// ΦᵀDΦ (r × r; zero when the ROM is undamped).
    pub de: Taylor,
}

impl Invariants {
    /// The blocks of the body part with their SID names, in the file's order.
    pub fn named(&self) -> [(&'static str, &Taylor); 11] {
        [
            ("mdCM", &self.md_cm),
            ("J", &self.j),
            ("Ct", &self.ct),
            ("Cr", &self.cr),
            ("Me", &self.me),
            ("Gr", &self.gr),
            ("Ge", &self.ge),
            ("Oe", &self.oe),
            ("ksigma", &self.ksigma),
            ("Ke", &self.ke),
            ("De", &self.de),
        ]
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(b: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[b] = 1.0;
    e
}

/// Checks the model for a SID: node coordinates, 3 DoFs per node, Φ with N rows.
fn check(model: &Model, phi: MatRef<'_, f64>) -> Result<()> {
    if model.nodes.is_none() {
        return Err(Error::InvalidSetting(format!(
            "model '{}' has no node coordinates (nodes.csv): a SID needs them",
            model.name
        )));
    }
    if model.dofs_per_node != 3 {
        return Err(Error::InvalidSetting(format!(
            "model '{}' has dofs_per_node = {}: the SID export takes 3 translational DoFs \
             per node (rotational mode shapes psi are not derived)",
            model.name, model.dofs_per_node
        )));
    }
    if phi.nrows() != model.n() {
        return Err(Error::InvalidSetting(format!(
            "the elastic basis has {} rows, model '{}' has N = {}",
            phi.nrows(),
            model.name,
            model.n()
        )));
    }
    Ok(())
}

/// The body invariants of the elastic basis `flex` of a ROM of `model` (see the module doc):
/// one pass over M's entries for the Gram matrix Xᵀ(MX), the rest from the projected ROM.
///
/// # Errors
/// [`Error::InvalidSetting`] when the model has no node coordinates, not 3 DoFs per node, a
/// total mass that is not positive, or Φ does not have N rows.
pub fn invariants(model: &Model, flex: &ElasticBasis) -> Result<Invariants> {
    let phi = flex.phi.as_ref();
    check(model, phi)?;
    let rigid = inertia(model)?;
    let nodes = model.nodes.as_deref().unwrap_or_default();
    let (n, r) = (model.n(), phi.ncols());
    // X = [Φ (r), S_bΦ_l (col r + 3·... b-major: r + b·r + l), T_a (4r + a), R_b (4r + 3 + b)]
    let w = 4 * r + 6;
    let s_col = |b: usize, l: usize| r + b * r + l;
    let (t_col, r_col) = (4 * r, 4 * r + 3);
    let mut x = Mat::<f64>::zeros(n, w);
    for (p, xp) in nodes.iter().enumerate() {
        for k in 0..r {
            let u = [phi[(3 * p, k)], phi[(3 * p + 1, k)], phi[(3 * p + 2, k)]];
            for b in 0..3 {
                let s = cross(unit(b), u);
                for d in 0..3 {
                    x[(3 * p + d, s_col(b, k))] = s[d];
                }
            }
            for d in 0..3 {
                x[(3 * p + d, k)] = u[d];
            }
        }
        for b in 0..3 {
            let rb = cross(unit(b), *xp);
            for d in 0..3 {
                x[(3 * p + d, r_col + b)] = rb[d];
            }
            x[(3 * p + b, t_col + b)] = 1.0;
        }
    }
    // Y = M X, column by column of M (full storage: M_ij for every stored (i, j))
    let m = &model.mass;
    let mut y = Mat::<f64>::zeros(n, w);
    for c in 0..w {
        let xc = x.col(c);
        let mut yc = y.col_mut(c);
        for j in 0..m.ncols() {
            let xj = xc[j];
            if xj == 0.0 {
                continue;
            }
            for (&i, &v) in m
                .symbolic()
                .row_idx_of_col_raw(j)
                .iter()
                .zip(m.val_of_col(j))
            {
                yc[i] += v * xj;
            }
        }
    }
    let g = x.transpose() * &y;
    let gs = |i: usize, j: usize| 0.5 * (g[(i, j)] + g[(j, i)]);

    let md_cm = Taylor::first(
        Mat::from_fn(3, 1, |a, _| rigid.mass * rigid.center[a]),
        (0..r)
            .map(|k| Mat::from_fn(3, 1, |a, _| gs(k, t_col + a)))
            .collect(),
    );
    // J0 about the origin: the rotational block of Rᵀ M R
    let j0 = |a: usize, b: usize| 0.5 * (rigid.mrb[3 + a][3 + b] + rigid.mrb[3 + b][3 + a]);
    let a_k = |k: usize, a: usize, b: usize| gs(r_col + a, s_col(b, k));
    let j = Taylor::first(
        Mat::from_fn(6, 1, |i, _| j0(J_ORDER[i].0, J_ORDER[i].1)),
        (0..r)
            .map(|k| {
                Mat::from_fn(6, 1, |i, _| {
                    let (a, b) = J_ORDER[i];
                    a_k(k, a, b) + a_k(k, b, a)
                })
            })
            .collect(),
    );
    let ct = Taylor::zeroth(Mat::from_fn(r, 3, |k, a| gs(k, t_col + a)));
    let cr1 = |k: usize, l: usize, b: usize| gs(k, s_col(b, l));
    let cr = Taylor::first(
        Mat::from_fn(r, 3, |k, b| gs(k, r_col + b)),
        (0..r)
            .map(|l| Mat::from_fn(r, 3, |k, b| cr1(k, l, b)))
            .collect(),
    );
    let gr = Taylor::zeroth(Mat::from_fn(3, 3 * r, |a, c| 2.0 * a_k(c / 3, a, c % 3)));
    let ge = Taylor::zeroth(Mat::from_fn(r, 3 * r, |k, c| 2.0 * cr1(k, c / 3, c % 3)));
    let six = |f: &dyn Fn(usize, usize) -> f64, i: usize| {
        let (a, b) = OE_ORDER[i];
        if a == b {
            -f(a, a)
        } else {
            -(f(a, b) + f(b, a))
        }
    };
    let oe = Taylor::first(
        Mat::from_fn(r, 6, |k, i| six(&|a, b| a_k(k, a, b), i)),
        (0..r)
            .map(|l| Mat::from_fn(r, 6, |k, i| six(&|a, b| gs(s_col(a, k), s_col(b, l)), i)))
            .collect(),
    );
    let rom = &flex.rom;
    Ok(Invariants {
        rigid,
        md_cm,
        j,
        ct,
        cr,
        me: Taylor::zeroth(rom.mr.clone()),
        gr,
        ge,
        oe,
        ksigma: Taylor::zeroth(Mat::zeros(r, 1)),
        ke: Taylor::zeroth(rom.kr.clone()),
        de: Taylor::zeroth(rom.dr.clone()),
    })
}

/// A number in Fortran `D` notation with 17 significant digits (a leading blank for ≥ 0).
pub fn fortran(v: f64) -> String {
    let s = format!("{:.16e}", v);
    let (mant, exp) = s.split_once('e').unwrap_or((s.as_str(), "0"));
    let e: i32 = exp.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    let lead = if mant.starts_with('-') { "" } else { " " };
    format!("{lead}{mant}D{sign}{:02}", e.abs())
}

/// `name` padded to the value column at `indent`, then `= value`.
fn line(s: &mut String, indent: usize, name: &str, value: &str) {
    let _ = writeln!(
        s,
        "{:indent$}{name:<width$}={value}",
        "",
        width = 48 - indent
    );
}

fn taylor(s: &mut String, indent: usize, name: &str, t: &Taylor, nq: usize) {
    let structure = if t.is_zero() { 0 } else { 3 };
    let order = if structure == 0 { 0 } else { t.order() };
    let _ = writeln!(s, "{:indent$}{name}", "");
    let i2 = 26;
    for (key, v) in [
        ("order", order),
        ("nrow", t.m0.nrows()),
        ("ncol", t.m0.ncols()),
        ("nq", nq),
        ("nqn", 0),
        ("structure", structure),
    ] {
        line(s, i2, key, &format!("{v:5}"));
    }
    if structure == 3 {
        let m0 = &t.m0;
        for i in 0..m0.nrows() {
            for j in 0..m0.ncols() {
                if m0[(i, j)] != 0.0 {
                    line(
                        s,
                        i2,
                        &format!("m0( {}, {})", i + 1, j + 1),
                        &fortran(m0[(i, j)]),
                    );
                }
            }
        }
        for j in 0..m0.ncols() {
            for i in 0..m0.nrows() {
                for (k, m1) in t.m1.iter().enumerate() {
                    if m1[(i, j)] != 0.0 {
                        line(
                            s,
                            i2,
                            &format!("m1( {}, {}, {})", i + 1, k + 1, j + 1),
                            &fortran(m1[(i, j)]),
                        );
                    }
                }
            }
        }
    }
    let _ = writeln!(s, "{:indent$}end {name}", "");
}

/// The text of the SID_FEM file (see the module doc) for the elastic basis `flex` of a ROM
/// of `model`, with `points` as more nodes after the mesh nodes (none for a model without
/// remote points).
///
/// # Errors
/// As [`invariants`], [`grids`] and [`point_grids`]; [`Error::InvalidSetting`] when an
/// invariant or a point's shape is not finite, or a point's shapes are not 6 × r.
pub fn text(
    model: &Model,
    flex: &ElasticBasis,
    dof_map: Option<&[Dof]>,
    points: &[PointNode],
) -> Result<String> {
    let inv = invariants(model, flex)?;
    let labels = grids(model, dof_map)?;
    let point_ids = point_grids(&labels, points.len())?;
    let nodes = model.nodes.as_deref().unwrap_or_default();
    let phi = flex.phi.as_ref();
    let r = phi.ncols();
    let blocks = inv.named();
    for (name, t) in &blocks {
        let finite = t.m0.col_iter().all(|c| c.iter().all(|v| v.is_finite()))
            && t.m1
                .iter()
                .all(|m| m.col_iter().all(|c| c.iter().all(|v| v.is_finite())));
        if !finite {
            return Err(Error::InvalidSetting(format!(
                "model '{}': the SID invariant {name} is not finite",
                model.name
            )));
        }
    }
    for p in points {
        let finite = p.shapes.col_iter().all(|c| c.iter().all(|v| v.is_finite()))
            && p.position.iter().all(|v| v.is_finite());
        if (p.shapes.nrows(), p.shapes.ncols()) != (6, phi.ncols()) || !finite {
            return Err(Error::InvalidSetting(format!(
                "remote point {}: its shapes must be 6 × {} and finite, with a finite position",
                p.name,
                phi.ncols()
            )));
        }
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:5} {:3}    :No. nodes, No. modes: sparsemor {} {} ROM of model '{}', elastic basis, \
         inertia invariants only, no geometric stiffening",
        nodes.len() + points.len(),
        r,
        env!("CARGO_PKG_VERSION"),
        flex.rom.method(),
        model.name
    );
    let _ = writeln!(s, " part");
    line(&mut s, 6, "new modal", "");
    let _ = writeln!(s, "           refmod");
    line(&mut s, 16, "mass", &fortran(inv.rigid.mass));
    line(&mut s, 16, "nelastq", &format!("{r:6}"));
    for (k, f) in flex.eigenfrequencies_hz.iter().enumerate() {
        line(
            &mut s,
            16,
            &format!("ielastq ({:4})", k + 1),
            &format!(" Eigen Mode {:4} : {f:.16e} Hz", k + 1),
        );
    }
    let _ = writeln!(s, "           end refmod");
    let _ = writeln!(s, "           frame");
    for (p, xp) in nodes.iter().enumerate() {
        line(&mut s, 16, "new node", &format!("{:8}", labels[3 * p].0));
        line(&mut s, 21, "rframe", "    body ref");
        let rows = |k: usize| Mat::from_fn(3, 1, |a, _| phi[(3 * p + a, k)]);
        let origin = Taylor::first(Mat::from_fn(3, 1, |a, _| xp[a]), (0..r).map(rows).collect());
        taylor(&mut s, 21, "origin", &origin, r);
        let shapes = Taylor::zeroth(Mat::from_fn(3, r, |a, k| phi[(3 * p + a, k)]));
        taylor(&mut s, 21, "phi", &shapes, r);
        taylor(&mut s, 21, "psi", &Taylor::zeroth(Mat::zeros(3, r)), r);
        taylor(&mut s, 21, "AP", &Taylor::zeroth(Mat::identity(3, 3)), r);
        let _ = writeln!(s, "                end node");
    }
    for (p, id) in points.iter().zip(point_ids) {
        line(&mut s, 16, "new node", &format!("{id:8}"));
        line(&mut s, 21, "rframe", "    body ref");
        let sh = &p.shapes;
        let rows = |at: usize| Mat::from_fn(3, r, |a, k| sh[(at + a, k)]);
        let column = |k: usize| Mat::from_fn(3, 1, |a, _| sh[(a, k)]);
        let origin = Taylor::first(
            Mat::from_fn(3, 1, |a, _| p.position[a]),
            (0..r).map(column).collect(),
        );
        taylor(&mut s, 21, "origin", &origin, r);
        taylor(&mut s, 21, "phi", &Taylor::zeroth(rows(0)), r);
        taylor(&mut s, 21, "psi", &Taylor::zeroth(rows(3)), r);
        let skew = |k: usize| {
            let t = [sh[(3, k)], sh[(4, k)], sh[(5, k)]];
            Mat::from_fn(3, 3, |a, b| cross(t, unit(b))[a])
        };
        let ap = Taylor::first(Mat::identity(3, 3), (0..r).map(skew).collect());
        taylor(&mut s, 21, "AP", &ap, r);
        let _ = writeln!(s, "                end node");
    }
    let _ = writeln!(s, "           end frame");
    for (name, t) in &blocks {
        taylor(&mut s, 11, name, t, r);
    }
    let _ = writeln!(s, "      end modal");
    let _ = writeln!(s, " end part");
    Ok(s)
}

/// Writes `body.SID_FEM` (see the module doc) for the elastic basis `flex` of a ROM of
/// `model`, with `points` as interface nodes, into the new directory `dir`.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty (naming it), as [`text`]; I/O
/// errors.
pub fn write(
    dir: &Path,
    model: &Model,
    flex: &ElasticBasis,
    dof_map: Option<&[Dof]>,
    points: &[PointNode],
) -> Result<()> {
    let s = text(model, flex, dof_map, points)?;
    atomic::write_dir(dir, |tmp| atomic::write_bytes(&tmp.join(SID_FILE), s))
}
