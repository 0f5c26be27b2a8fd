//! The built-in box (bar): a free-free 3-D linear-elastic box meshed with 8-node trilinear
//! hexahedra, the embedded default model of sparsemor.
//!
//! Entry points: [`BoxSpec`] (what to mesh; [`BoxSpec::paper_bar`] is the paper's bar),
//! [`assemble`] (consistent mass `M` and stiffness `K` as full symmetric CSC matrices),
//! [`paper_io_dofs`] (the paper's nine input/output DoFs) (rigid modes: [`crate::rigid::rigid_modes`])
//! (the six rigid-body modes `V0`, eq. 15 of the paper).
//!
//! # The model
//!
//! The box $\[0,L_x\]\times\[0,L_y\]\times\[0,L_z\]$ is split into $n_x\times n_y\times n_z$
//! equal elements of size $h = (L_x/n_x, L_y/n_y, L_z/n_z)$. Node $(i,j,k)$ has index
//! `i + (nx+1)*(j + (ny+1)*k)` (x fastest) and coordinates $(i h_x, j h_y, k h_z)$; its
//! displacement DoFs are `3*node + d`, $d = 0,1,2$ for $x,y,z$. No DoF is constrained, so
//! $K$ is positive semi-definite with the six rigid-body modes as its null space.
//!
//! The element (`hex8.rs`) is the rectangular trilinear hexahedron, fully integrated.
//!
//! # Assembly
//!
//! All elements are identical, so $K_e$ and $M_e$ are computed once. A node couples with
//! its at most 27 neighbours; which neighbours and which elements they share depends only
//! on whether the node lies on the lower face, in the interior or on the upper face in each
//! direction (27 classes). For each class the column values are precomputed once
//! (summing the shared elements' contributions in a fixed order, so $K$ and $M$ are
//! *exactly* symmetric), the column pointers come from neighbour counts and a prefix sum,
//! and the row indices and values are written directly into CSC storage, in parallel
//! over z-slabs. No triplets are sorted and nothing is hashed: time and memory are
//! $O(\mathrm{nnz})$.
//!
//! The stiffness pattern has all 3×3 blocks of neighbouring nodes (up to 81 entries per
//! column). The mass matrix is $M_{\text{scalar}}\otimes I_3$, so it is stored with its own
//! pattern, only the $x$–$x$, $y$–$y$, $z$–$z$ couplings (a third of the stiffness
//! pattern, no stored zeros); its pattern is a subset of the stiffness pattern.

use super::hex8::Hex8;
use crate::{Error, Result};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rayon::prelude::*;

/// Rayleigh stiffness-proportional damping factor of the paper's bar: $D = \alpha M + \beta K$
/// with $\beta = 10^{-5}$ s (and $\alpha$ = [`PAPER_RAYLEIGH_ALPHA`] = 0).
pub const PAPER_RAYLEIGH_BETA: f64 = 1e-5;

/// Rayleigh mass-proportional damping factor of the paper's bar: $\alpha = 0$.
pub const PAPER_RAYLEIGH_ALPHA: f64 = 0.0;

/// The paper's frequency band of interest, in Hz: $[0, 1000]$.
pub const PAPER_BAND_HZ: [f64; 2] = [0.0, 1000.0];

/// Upper bound on the memory [`assemble`] may need (see
/// [`BoxSpec::memory_estimate_bytes`]): 1 TiB. Larger specs are rejected as impossible
/// instead of aborting on allocation.
pub const MAX_ASSEMBLY_BYTES: u64 = 1 << 40;

/// What to mesh: an axis-aligned box $\[0,L_x\]\times\[0,L_y\]\times\[0,L_z\]$ of homogeneous
/// isotropic linear-elastic material, split into equal hexahedral elements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxSpec {
    /// Elements along x, y, z: $(n_x, n_y, n_z)$, each ≥ 1.
    pub elements: [usize; 3],
    /// Edge lengths $(L_x, L_y, L_z)$ in metres, each > 0.
    pub size_m: [f64; 3],
    /// Total mass $m$ in kg (> 0); the density is $\rho = m/(L_xL_yL_z)$.
    pub mass_kg: f64,
    /// Young's modulus $E$ in Pa (> 0).
    pub young_pa: f64,
    /// Poisson's ratio $\nu$, $0 \le \nu < 0.5$.
    pub poisson: f64,
}

impl BoxSpec {
    /// The bar of the paper (§4, Figure 1): 2×3×45 elements on 6×8×300 mm, 0.1 kg,
    /// $E = 2\cdot10^{10}$ Pa, $\nu = 0.3$ → 3·4·46 = 552 nodes, N = 1656 DoFs.
    ///
    /// The paper does not state $\nu$ or the mesh; 0.3 and 2×3×45 are the choices that give
    /// its 1656 DoFs with roughly cubic elements.
    pub fn paper_bar() -> Self {
        BoxSpec {
            elements: [2, 3, 45],
            size_m: [0.006, 0.008, 0.3],
            mass_kg: 0.1,
            young_pa: 2e10,
            poisson: 0.3,
        }
    }

    /// A 90-DoF bar for tests and examples: 1 × 2 × 4 elements, 0.02 × 0.03 × 0.2 m, 0.1 kg,
    /// E = 2e10 Pa, ν = 0.3; free, undamped. Small enough for dense references, with nodes off
    /// every line (a face of 2 × 3 nodes).
    pub fn small() -> Self {
        BoxSpec {
            elements: [1, 2, 4],
            size_m: [0.02, 0.03, 0.2],
            mass_kg: 0.1,
            young_pa: 2e10,
            poisson: 0.3,
        }
    }

    /// Number of nodes $(n_x+1)(n_y+1)(n_z+1)$ (saturating on overflow; [`Self::validate`]
    /// rejects such specs).
    pub fn n_nodes(&self) -> usize {
        let [nx, ny, nz] = self.elements;
        nx.saturating_add(1)
            .saturating_mul(ny.saturating_add(1))
            .saturating_mul(nz.saturating_add(1))
    }

    /// Number of DoFs $N = 3\cdot$[`Self::n_nodes`] (saturating on overflow).
    pub fn n_dofs(&self) -> usize {
        self.n_nodes().saturating_mul(3)
    }

    /// Index of node $(i,j,k)$: `i + (nx+1)*(j + (ny+1)*k)` (wrapping on overflow; only
    /// meaningful for a valid spec and $i\le n_x$, $j\le n_y$, $k\le n_z$).
    pub fn node_index(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.elements;
        let sx = nx.wrapping_add(1);
        let sy = ny.wrapping_add(1);
        i.wrapping_add(sx.wrapping_mul(j.wrapping_add(sy.wrapping_mul(k))))
    }

    /// Element edge lengths $h_d = L_d/n_d$ in metres.
    pub fn element_size(&self) -> [f64; 3] {
        std::array::from_fn(|d| self.size_m[d] / self.elements[d] as f64)
    }

    /// Volume $L_xL_yL_z$ in m³.
    pub fn volume(&self) -> f64 {
        self.size_m.iter().product()
    }

    /// Density $\rho = m / (L_xL_yL_z)$ in kg/m³.
    pub fn density(&self) -> f64 {
        self.mass_kg / self.volume()
    }

    /// Stored entries of the stiffness matrix (full symmetric storage):
    /// $9\prod_d (3 n_d + 1)$, every 3×3 block of two nodes that share an element.
    /// `None` on overflow.
    pub fn nnz_stiffness(&self) -> Option<usize> {
        self.nnz_mass()?.checked_mul(3)
    }

    /// Stored entries of the mass matrix (full symmetric storage): $3\prod_d (3 n_d + 1)$,
    /// only the equal-direction couplings of nodes that share an element.
    /// `None` on overflow.
    pub fn nnz_mass(&self) -> Option<usize> {
        self.elements.iter().try_fold(3usize, |acc, &n| {
            acc.checked_mul(n.checked_mul(3)?.checked_add(1)?)
        })
    }

    /// Bytes [`assemble`] allocates for its result: row indices and values of both
    /// matrices, two column-pointer arrays and the node coordinates. `None` on overflow.
    pub fn memory_estimate_bytes(&self) -> Option<u64> {
        let word = std::mem::size_of::<usize>() as u64;
        let nnz = self.nnz_stiffness()? as u64 + self.nnz_mass()? as u64;
        let n_nodes = self
            .elements
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul((n as u64).checked_add(1)?))?;
        let n_dofs = n_nodes.checked_mul(3)?;
        let idx_val = nnz.checked_mul(word + 8)?;
        let ptrs = n_dofs.checked_add(1)?.checked_mul(2 * word)?;
        let nodes = n_nodes.checked_mul(24)?;
        idx_val.checked_add(ptrs)?.checked_add(nodes)
    }

    /// Checks the spec: element counts ≥ 1, edge lengths, mass and Young's modulus finite
    /// and > 0, $0\le\nu<0.5$, finite positive density and element sizes, and a problem size
    /// whose counts do not overflow and whose memory estimate is at most
    /// [`MAX_ASSEMBLY_BYTES`].
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] naming the offending field and value.
    pub fn validate(&self) -> Result<()> {
        const AXES: [char; 3] = ['x', 'y', 'z'];
        let bad = |msg: String| Err(Error::InvalidSetting(msg));
        for (d, axis) in AXES.iter().enumerate() {
            if self.elements[d] == 0 {
                return bad(format!(
                    "box: elements[{d}] (along {}) is 0; every direction needs at least 1 element",
                    axis
                ));
            }
            let l = self.size_m[d];
            if !(l.is_finite() && l > 0.0) {
                return bad(format!(
                    "box: size_m[{d}] (length along {}) = {l} m; it must be finite and > 0",
                    axis
                ));
            }
        }
        if !(self.mass_kg.is_finite() && self.mass_kg > 0.0) {
            return bad(format!(
                "box: mass_kg = {}; it must be finite and > 0",
                self.mass_kg
            ));
        }
        if !(self.young_pa.is_finite() && self.young_pa > 0.0) {
            return bad(format!(
                "box: young_pa = {}; Young's modulus must be finite and > 0",
                self.young_pa
            ));
        }
        if !(self.poisson >= 0.0 && self.poisson < 0.5) {
            return bad(format!(
                "box: poisson = {}; Poisson's ratio must satisfy 0 <= nu < 0.5 \
                 (0.5 is incompressible and makes the D matrix singular)",
                self.poisson
            ));
        }
        let rho = self.density();
        if !(rho.is_finite() && rho > 0.0) {
            return bad(format!(
                "box: density mass/volume = {} kg / {} m^3 = {rho} kg/m^3 is not finite and \
                 positive; rescale the size or the mass",
                self.mass_kg,
                self.volume()
            ));
        }
        let h = self.element_size();
        if h.iter().any(|&h| !(h.is_finite() && h > 0.0)) {
            return bad(format!(
                "box: element size {h:?} m is not finite and positive (too many elements for \
                 the box size)"
            ));
        }
        match self.memory_estimate_bytes() {
            Some(b) if b <= MAX_ASSEMBLY_BYTES => Ok(()),
            Some(b) => bad(format!(
                "box: {:?} elements give N = {} DoFs needing about {:.1} GiB, more than the \
                 {} GiB limit; use fewer elements",
                self.elements,
                self.n_dofs(),
                b as f64 / (1u64 << 30) as f64,
                MAX_ASSEMBLY_BYTES >> 30
            )),
            None => bad(format!(
                "box: {:?} elements: the number of DoFs or matrix entries overflows; use fewer \
                 elements",
                self.elements
            )),
        }
    }
}

/// An assembled free-free FE body: $M\ddot q + K q = f$.
///
/// Both matrices are $N\times N$ with full symmetric storage (both triangles), row indices
/// sorted within each column, and exactly symmetric values. $M$ is positive definite,
/// $K$ positive semi-definite with the six rigid-body modes as null space.
#[derive(Debug, Clone)]
pub struct FeBody {
    /// Consistent mass matrix $M$ (pattern: equal-direction couplings of neighbouring nodes).
    pub mass: SparseColMat<usize, f64>,
    /// Stiffness matrix $K$ (pattern: full 3×3 blocks of neighbouring nodes).
    pub stiffness: SparseColMat<usize, f64>,
    /// Undeformed node coordinates in metres; node $i$ owns DoFs $3i, 3i+1, 3i+2$.
    pub nodes: Vec<[f64; 3]>,
}

/// Assembles the consistent mass and stiffness matrices of the box described by `spec`
/// (see the module documentation for the element and the assembly).
///
/// Runs in $O(\mathrm{nnz})$ time and memory
/// ([`BoxSpec::memory_estimate_bytes`]), filling z-slabs in parallel on the current rayon
/// pool; the result does not depend on the number of threads.
///
/// # Errors
/// [`Error::InvalidSetting`] if [`BoxSpec::validate`] rejects the spec.
pub fn assemble(spec: &BoxSpec) -> Result<FeBody> {
    spec.validate()?;
    let grid = Grid::new(spec.elements);
    let elem = Hex8::new(
        spec.element_size(),
        spec.young_pa,
        spec.poisson,
        spec.density(),
    );
    let templates = ClassTemplates::new(&grid, &elem);

    // Column pointers from neighbour counts (K: 3 rows per neighbour, M: 1).
    let n = grid.n_dofs();
    let mut kptr = Vec::with_capacity(n + 1);
    let mut mptr = Vec::with_capacity(n + 1);
    kptr.push(0usize);
    mptr.push(0usize);
    let (mut kacc, mut macc) = (0usize, 0usize);
    for k in 0..grid.nn[2] {
        for j in 0..grid.nn[1] {
            for i in 0..grid.nn[0] {
                let cnt = grid.neighbour_count(i, j, k);
                for _ in 0..3 {
                    kacc += 3 * cnt;
                    macc += cnt;
                    kptr.push(kacc);
                    mptr.push(macc);
                }
            }
        }
    }
    debug_assert_eq!(Some(kacc), spec.nnz_stiffness());
    debug_assert_eq!(Some(macc), spec.nnz_mass());

    let mut krow = vec![0usize; kacc];
    let mut kval = vec![0f64; kacc];
    let mut mrow = vec![0usize; macc];
    let mut mval = vec![0f64; macc];

    // Split the outputs into z-slabs (contiguous column ranges) and fill them in parallel.
    let layers = grid.nn[2];
    let n_slabs = (4 * rayon::current_num_threads()).clamp(1, layers);
    let per_slab = layers.div_ceil(n_slabs);
    let mut slabs = Vec::with_capacity(n_slabs);
    {
        let (mut kr, mut kv, mut mr, mut mv) = (
            krow.as_mut_slice(),
            kval.as_mut_slice(),
            mrow.as_mut_slice(),
            mval.as_mut_slice(),
        );
        let mut k0 = 0;
        while k0 < layers {
            let k1 = (k0 + per_slab).min(layers);
            let c0 = 3 * grid.node(0, 0, k0);
            let c1 = 3 * grid.node(0, 0, k1);
            let (klen, mlen) = (kptr[c1] - kptr[c0], mptr[c1] - mptr[c0]);
            let (a, rest) = std::mem::take(&mut kr).split_at_mut(klen);
            kr = rest;
            let (b, rest) = std::mem::take(&mut kv).split_at_mut(klen);
            kv = rest;
            let (c, rest) = std::mem::take(&mut mr).split_at_mut(mlen);
            mr = rest;
            let (e, rest) = std::mem::take(&mut mv).split_at_mut(mlen);
            mv = rest;
            slabs.push((k0..k1, a, b, c, e));
            k0 = k1;
        }
    }
    slabs.into_par_iter().for_each(|(ks, kr, kv, mr, mv)| {
        fill_slab(&grid, &templates, ks, kr, kv, mr, mv);
    });

    let ksym = SymbolicSparseColMat::new_checked(n, n, kptr, None, krow);
    let msym = SymbolicSparseColMat::new_checked(n, n, mptr, None, mrow);
    let stiffness = SparseColMat::new(ksym, kval);
    let mass = SparseColMat::new(msym, mval);

    let h = spec.element_size();
    let mut nodes = Vec::with_capacity(grid.n_nodes());
    for k in 0..grid.nn[2] {
        for j in 0..grid.nn[1] {
            for i in 0..grid.nn[0] {
                let idx = [i, j, k];
                nodes.push(std::array::from_fn(|d| {
                    // i * L / n, exact at both ends of the box.
                    if idx[d] == grid.ne[d] {
                        spec.size_m[d]
                    } else {
                        idx[d] as f64 * h[d]
                    }
                }));
            }
        }
    }
    Ok(FeBody {
        mass,
        stiffness,
        nodes,
    })
}

/// The paper's input/output DoFs (Figure 2): the $x,y,z$ DoFs of three nodes on the edge
/// $x = 0, y = 0$ — the corner at $z = 0$ ($k = 0$), the node closest to mid-length
/// ($k = \lfloor n_z/2\rfloor$: the lower one of the two when $n_z$ is odd), and the corner
/// at $z = L_z$ ($k = n_z$). Nine DoFs, node by node, each $x, y, z$.
///
/// For the paper bar ($n_z = 45$): nodes 0, 264, 540 → DoFs 0–2, 792–794, 1620–1622.
/// Only meaningful for a valid spec (it does not validate; indices wrap on absurd sizes).
pub fn paper_io_dofs(spec: &BoxSpec) -> Vec<usize> {
    let nz = spec.elements[2];
    [0, nz / 2, nz]
        .iter()
        .flat_map(|&k| {
            let node = spec.node_index(0, 0, k);
            (0..3).map(move |d| node.wrapping_mul(3).wrapping_add(d))
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// Grid and per-class column templates

/// Index arithmetic of the structured grid.
#[derive(Debug, Clone, Copy)]
struct Grid {
    /// Elements per direction.
    ne: [usize; 3],
    /// Nodes per direction (ne + 1).
    nn: [usize; 3],
}

impl Grid {
    fn new(ne: [usize; 3]) -> Self {
        Grid {
            ne,
            nn: ne.map(|n| n + 1),
        }
    }
    fn n_nodes(&self) -> usize {
        self.nn.iter().product()
    }
    fn n_dofs(&self) -> usize {
        3 * self.n_nodes()
    }
    fn node(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.nn[0] * (j + self.nn[1] * k)
    }
    /// Class of grid index `i` in a direction with `n` elements: bit 0 = has a lower
    /// neighbour (i > 0), bit 1 = has an upper neighbour (i < n). Always 1, 2 or 3.
    fn class(i: usize, n: usize) -> usize {
        usize::from(i > 0) | (usize::from(i < n) << 1)
    }
    fn neighbour_count(&self, i: usize, j: usize, k: usize) -> usize {
        let c = |i: usize, n: usize| 1 + usize::from(i > 0) + usize::from(i < n);
        c(i, self.ne[0]) * c(j, self.ne[1]) * c(k, self.ne[2])
    }
}

/// The column block of one node class: its neighbours (ascending node index) and the
/// values of its three stiffness columns and its (shared) mass column.
#[derive(Debug, Clone, Default)]
struct ColumnTemplate {
    /// Node-index offsets of the neighbours, ascending.
    offsets: Vec<isize>,
    /// `k[d][3p + e]`: stiffness entry (row = DoF e of neighbour p, column = DoF d).
    k: [Vec<f64>; 3],
    /// `m[p]`: scalar mass coupling with neighbour p (same for every direction).
    m: Vec<f64>,
}

/// Templates for all 27 node classes, indexed by `cx + 4 cy + 16 cz`.
#[derive(Debug)]
struct ClassTemplates(Vec<ColumnTemplate>);

impl ClassTemplates {
    fn new(grid: &Grid, el: &Hex8) -> Self {
        let sx = grid.nn[0] as isize;
        let sxy = (grid.nn[0] * grid.nn[1]) as isize;
        let mut all = vec![ColumnTemplate::default(); 64];
        for cz in 1..4 {
            for cy in 1..4 {
                for cx in 1..4 {
                    let cls = [cx, cy, cz];
                    let mut t = ColumnTemplate::default();
                    // Neighbour offsets valid for this class, per direction (ascending).
                    let nb = |d: usize| -> Vec<isize> {
                        [-1isize, 0, 1]
                            .into_iter()
                            .filter(|&o| match o {
                                -1 => cls[d] & 1 != 0,
                                1 => cls[d] & 2 != 0,
                                _ => true,
                            })
                            .collect()
                    };
                    // Element offsets (element index − node index) of elements containing
                    // the node: −1 needs a lower neighbour, 0 an upper one. Ascending.
                    let el_off = |d: usize| -> Vec<isize> {
                        [-1isize, 0]
                            .into_iter()
                            .filter(|&o| {
                                if o == -1 {
                                    cls[d] & 1 != 0
                                } else {
                                    cls[d] & 2 != 0
                                }
                            })
                            .collect()
                    };
                    let (ex, ey, ez) = (el_off(0), el_off(1), el_off(2));
                    for &dk in &nb(2) {
                        for &dj in &nb(1) {
                            for &di in &nb(0) {
                                t.offsets.push(di + sx * dj + sxy * dk);
                                let mut kb = [[0.0; 3]; 3]; // kb[d][e]
                                let mut mb = 0.0;
                                // Shared elements, ascending element index (fixed order ⇒
                                // exactly symmetric sums).
                                for &ek in &ez {
                                    for &ej in &ey {
                                        for &ei in &ex {
                                            let lm = [di - ei, dj - ej, dk - ek];
                                            if lm.iter().any(|&l| !(0..=1).contains(&l)) {
                                                continue;
                                            }
                                            let a_n = (-ei + 2 * -ej + 4 * -ek) as usize;
                                            let a_m = (lm[0] + 2 * lm[1] + 4 * lm[2]) as usize;
                                            for (d, kbd) in kb.iter_mut().enumerate() {
                                                for (e, v) in kbd.iter_mut().enumerate() {
                                                    *v += el.k[3 * a_m + e][3 * a_n + d];
                                                }
                                            }
                                            mb += el.m[a_m][a_n];
                                        }
                                    }
                                }
                                for (col, kbd) in t.k.iter_mut().zip(&kb) {
                                    col.extend_from_slice(kbd);
                                }
                                t.m.push(mb);
                            }
                        }
                    }
                    all[cx + 4 * cy + 16 * cz] = t;
                }
            }
        }
        ClassTemplates(all)
    }
}

/// Writes the columns of the nodes in z-layers `ks` into the given output slices (which
/// start at the first entry of the first of those columns).
fn fill_slab(
    grid: &Grid,
    templates: &ClassTemplates,
    ks: std::ops::Range<usize>,
    krow: &mut [usize],
    kval: &mut [f64],
    mrow: &mut [usize],
    mval: &mut [f64],
) {
    let (mut pk, mut pm) = (0usize, 0usize);
    for k in ks {
        let cz = Grid::class(k, grid.ne[2]);
        for j in 0..grid.nn[1] {
            let cy = Grid::class(j, grid.ne[1]);
            for i in 0..grid.nn[0] {
                let cx = Grid::class(i, grid.ne[0]);
                let t = &templates.0[cx + 4 * cy + 16 * cz];
                let node = grid.node(i, j, k);
                let nb = t.offsets.len();
                for d in 0..3 {
                    let rows = &mut krow[pk..pk + 3 * nb];
                    for (r, &off) in rows.chunks_exact_mut(3).zip(&t.offsets) {
                        let base = 3 * node.wrapping_add_signed(off);
                        r[0] = base;
                        r[1] = base + 1;
                        r[2] = base + 2;
                    }
                    kval[pk..pk + 3 * nb].copy_from_slice(&t.k[d]);
                    pk += 3 * nb;
                    for (r, &off) in mrow[pm..pm + nb].iter_mut().zip(&t.offsets) {
                        *r = 3 * node.wrapping_add_signed(off) + d;
                    }
                    mval[pm..pm + nb].copy_from_slice(&t.m);
                    pm += nb;
                }
            }
        }
    }
    debug_assert_eq!(pk, krow.len());
    debug_assert_eq!(pm, mrow.len());
}

/// The paper's scene on the box of `spec`: inputs = outputs = [`paper_io_dofs`], band
/// [`PAPER_BAND_HZ`].
pub fn paper_scene(spec: &BoxSpec) -> crate::scene::Scene {
    let io = paper_io_dofs(spec);
    crate::scene::Scene {
        inputs: io.clone(),
        outputs: io,
        band_hz: PAPER_BAND_HZ,
    }
}

/// The built-in model as a validated [`crate::model::Model`]: the box of `spec` with the
/// paper's damping (Rayleigh α = 0, β = 10⁻⁵). Its scene is [`paper_scene`].
///
/// # Errors
/// As [`assemble`].
pub fn bar_model(spec: &BoxSpec) -> Result<crate::model::Model> {
    let body = assemble(spec)?;
    let name = format!(
        "bar {}x{}x{}",
        spec.elements[0], spec.elements[1], spec.elements[2]
    );
    let damping = crate::model::Damping::Rayleigh {
        alpha: PAPER_RAYLEIGH_ALPHA,
        beta: PAPER_RAYLEIGH_BETA,
    };
    let (model, _) = crate::model::Model::new(
        name,
        body.mass,
        body.stiffness,
        damping,
        Some(body.nodes),
        3,
    )?;
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_spec(elements: [usize; 3]) -> BoxSpec {
        BoxSpec {
            elements,
            size_m: [0.3, 0.5, 0.7],
            mass_kg: 2.0,
            young_pa: 1e9,
            poisson: 0.25,
        }
    }

    #[test]
    fn paper_bar_counts() {
        let s = BoxSpec::paper_bar();
        assert_eq!(s.n_nodes(), 552);
        assert_eq!(s.n_dofs(), 1656);
        assert_eq!(s.node_index(0, 0, 22), 264);
        assert_eq!(s.nnz_stiffness(), Some(9 * 7 * 10 * 136));
        assert_eq!(s.nnz_mass(), Some(3 * 7 * 10 * 136));
    }

    #[test]
    fn element_mass_is_closed_form() {
        let h = [0.3, 0.2, 0.5];
        let rho = 7.0;
        let el = Hex8::new(h, 1.0, 0.3, rho);
        let v = h[0] * h[1] * h[2];
        for a in 0..8 {
            for b in 0..8 {
                let f: f64 = (0..3)
                    .map(|d| {
                        if (a >> d) & 1 == (b >> d) & 1 {
                            2.0
                        } else {
                            1.0
                        }
                    })
                    .product();
                let exact = rho * v / 216.0 * f;
                assert!((el.m[a][b] - exact).abs() <= 1e-14 * exact, "{a} {b}");
            }
        }
    }

    #[test]
    fn element_stiffness_rigid_modes_and_patch() {
        let h = [0.3, 0.2, 0.5];
        let (young, nu) = (2e10, 0.3);
        let el = Hex8::new(h, young, nu, 1.0);
        let kmax = el.k.iter().flatten().fold(0.0f64, |a, &b| a.max(b.abs()));
        // Exactly symmetric.
        for p in 0..24 {
            for q in 0..24 {
                assert_eq!(el.k[p][q], el.k[q][p]);
            }
        }
        // Rigid motions give zero forces.
        let pos: Vec<[f64; 3]> = (0..8)
            .map(|a| std::array::from_fn(|d| ((a >> d) & 1) as f64 * h[d]))
            .collect();
        let v0 = crate::rigid::rigid_modes(&pos, 3);
        for c in 0..6 {
            for p in 0..24 {
                let f: f64 = (0..24).map(|q| el.k[p][q] * v0[(q, c)]).sum();
                assert!(f.abs() <= 1e-12 * kmax, "mode {c} row {p}: {f}");
            }
        }
        // Patch test: a uniform uniaxial strain u = (eps x, 0, 0) stores energy
        // ½ (λ+2μ) eps² V.
        let eps = 1e-3;
        let u: Vec<f64> = (0..24)
            .map(|q| if q % 3 == 0 { eps * pos[q / 3][0] } else { 0.0 })
            .collect();
        let energy: f64 = (0..24)
            .flat_map(|p| (0..24).map(move |q| (p, q)))
            .map(|(p, q)| 0.5 * u[p] * el.k[p][q] * u[q])
            .sum();
        let lambda = young * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = young / (2.0 * (1.0 + nu));
        let exact = 0.5 * (lambda + 2.0 * mu) * eps * eps * h[0] * h[1] * h[2];
        assert!(
            (energy - exact).abs() <= 1e-12 * exact,
            "{energy} vs {exact}"
        );
        // Uniform shear gamma_xy: u = (gamma y, 0, 0) → energy ½ μ γ² V.
        let u: Vec<f64> = (0..24)
            .map(|q| if q % 3 == 0 { eps * pos[q / 3][1] } else { 0.0 })
            .collect();
        let energy: f64 = (0..24)
            .flat_map(|p| (0..24).map(move |q| (p, q)))
            .map(|(p, q)| 0.5 * u[p] * el.k[p][q] * u[q])
            .sum();
        let exact = 0.5 * mu * eps * eps * h[0] * h[1] * h[2];
        assert!(
            (energy - exact).abs() <= 1e-12 * exact,
            "{energy} vs {exact}"
        );
    }

    /// Reference: naive dense scatter of the element matrices.
    fn dense_reference(spec: &BoxSpec) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let g = Grid::new(spec.elements);
        let el = Hex8::new(
            spec.element_size(),
            spec.young_pa,
            spec.poisson,
            spec.density(),
        );
        let n = g.n_dofs();
        let mut k = vec![vec![0.0; n]; n];
        let mut m = vec![vec![0.0; n]; n];
        for ek in 0..g.ne[2] {
            for ej in 0..g.ne[1] {
                for ei in 0..g.ne[0] {
                    let glob: Vec<usize> = (0..8)
                        .map(|a| g.node(ei + (a & 1), ej + ((a >> 1) & 1), ek + ((a >> 2) & 1)))
                        .collect();
                    for a in 0..8 {
                        for b in 0..8 {
                            for d in 0..3 {
                                m[3 * glob[a] + d][3 * glob[b] + d] += el.m[a][b];
                                for e in 0..3 {
                                    k[3 * glob[a] + d][3 * glob[b] + e] +=
                                        el.k[3 * a + d][3 * b + e];
                                }
                            }
                        }
                    }
                }
            }
        }
        (k, m)
    }

    #[test]
    fn assembly_matches_naive_scatter() {
        for elements in [[1, 1, 1], [2, 1, 3], [3, 2, 2], [1, 4, 1]] {
            let spec = small_spec(elements);
            let body = assemble(&spec).unwrap();
            let (kref, mref) = dense_reference(&spec);
            let kd = body.stiffness.to_dense();
            let md = body.mass.to_dense();
            let n = spec.n_dofs();
            assert_eq!(kd.nrows(), n);
            let kscale = kref.iter().flatten().fold(0.0f64, |a, &b| a.max(b.abs()));
            let mscale = mref.iter().flatten().fold(0.0f64, |a, &b| a.max(b.abs()));
            for r in 0..n {
                for c in 0..n {
                    assert!((kd[(r, c)] - kref[r][c]).abs() <= 1e-14 * kscale);
                    assert!((md[(r, c)] - mref[r][c]).abs() <= 1e-14 * mscale);
                }
            }
            // Pattern: stiffness holds every block of neighbouring nodes (nonzero or not),
            // mass exactly the nonzero equal-direction couplings.
            let (msym, mvals) = body.mass.parts();
            assert_eq!(mvals.len(), spec.nnz_mass().unwrap());
            assert!(mvals.iter().all(|&v| v > 0.0));
            assert_eq!(msym.row_idx().len(), spec.nnz_mass().unwrap());
            let (ksym, _) = body.stiffness.parts();
            assert_eq!(ksym.row_idx().len(), spec.nnz_stiffness().unwrap());
        }
    }

    #[test]
    fn assembly_is_exactly_symmetric() {
        let body = assemble(&small_spec([3, 2, 4])).unwrap();
        for mat in [&body.stiffness, &body.mass] {
            let d = mat.to_dense();
            for r in 0..d.nrows() {
                for c in 0..d.ncols() {
                    assert_eq!(d[(r, c)], d[(c, r)]);
                }
            }
        }
    }

    #[test]
    fn nodes_layout() {
        let spec = small_spec([2, 3, 4]);
        let body = assemble(&spec).unwrap();
        assert_eq!(body.nodes.len(), spec.n_nodes());
        let n = spec.node_index(1, 2, 3);
        assert_eq!(body.nodes[n], [0.15, 0.5 * 2.0 / 3.0, 0.7 * 3.0 / 4.0]);
        assert_eq!(*body.nodes.last().unwrap(), spec.size_m);
    }

    #[test]
    fn io_dofs() {
        let s = BoxSpec::paper_bar();
        assert_eq!(
            paper_io_dofs(&s),
            vec![0, 1, 2, 792, 793, 794, 1620, 1621, 1622]
        );
        let mut even = s;
        even.elements[2] = 10;
        let mid = 3 * even.node_index(0, 0, 5);
        assert_eq!(paper_io_dofs(&even)[3..6], [mid, mid + 1, mid + 2]);
    }

    #[test]
    fn validation_rejects_bad_specs() {
        let ok = BoxSpec::paper_bar();
        assert!(ok.validate().is_ok());
        let cases: Vec<(BoxSpec, &str)> = vec![
            (
                BoxSpec {
                    elements: [0, 3, 45],
                    ..ok
                },
                "elements[0]",
            ),
            (
                BoxSpec {
                    size_m: [0.006, -1.0, 0.3],
                    ..ok
                },
                "size_m[1]",
            ),
            (
                BoxSpec {
                    size_m: [0.006, 0.008, f64::NAN],
                    ..ok
                },
                "size_m[2]",
            ),
            (BoxSpec { mass_kg: 0.0, ..ok }, "mass_kg"),
            (
                BoxSpec {
                    young_pa: f64::INFINITY,
                    ..ok
                },
                "young_pa",
            ),
            (BoxSpec { poisson: 0.5, ..ok }, "poisson"),
            (
                BoxSpec {
                    poisson: -0.1,
                    ..ok
                },
                "poisson",
            ),
            (
                BoxSpec {
                    poisson: f64::NAN,
                    ..ok
                },
                "poisson",
            ),
            (
                BoxSpec {
                    size_m: [1e-200, 1e-200, 1e-200],
                    ..ok
                },
                "density",
            ),
            (
                BoxSpec {
                    elements: [100_000, 100_000, 100_000],
                    ..ok
                },
                "GiB",
            ),
            (
                BoxSpec {
                    elements: [usize::MAX, 2, 2],
                    ..ok
                },
                "overflows",
            ),
        ];
        for (spec, needle) in cases {
            match assemble(&spec) {
                Err(Error::InvalidSetting(msg)) => {
                    assert!(msg.contains(needle), "{needle:?} not in {msg:?}")
                }
                other => panic!("{spec:?}: expected InvalidSetting, got {other:?}"),
            }
        }
    }
}
