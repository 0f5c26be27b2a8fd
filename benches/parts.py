"""Tet10 linear-elastic FE models of CAD-like steel parts, written as sparsemor model directories.

Each part is built with gmsh's OpenCASCADE kernel (boxes, cylinders and wedges fused, holes cut),
meshed into linear tetrahedra of target size H, and given quadratic shape functions by
scikit-fem (`ElementVector(ElementTetP2())`): every tet has 10 nodes, its 4 vertices and its
6 edge midpoints (straight-sided, so curved faces are faceted at the vertex mesh). K is the
linear-elastic stiffness, M the consistent mass. The bodies are free-free.

Parts (lengths in metres):
  shaft    stepped crankshaft, 0.4 long: three coaxial cylinders (r 0.018/0.025/0.03) and a
           crank throw (two box webs and an offset pin).
  bracket  L bracket, 0.15 x 0.08 x 0.12: base and upright plates with a gusset, two bolt
           holes through each plate.
  plate    0.3 x 0.2 x 0.01 plate with four corner bolt holes and two larger lightening holes.
  housing  thin-walled open box, 0.2 x 0.15 x 0.1, wall 6 mm, with a flange round the rim
           that has four bolt holes.
  crank    crank arm (connecting-rod-like lever) in the x-y plane, bore axes along z, 0.2 between
           the bores: a big-end boss (r 0.036, 0.04 thick) with a bore of r 0.02 at the origin, a
           small-end boss (r 0.02, 0.026 thick) with a bore of r 0.01 at x = 0.2, joined by an
           I-section arm 0.028 deep (flanges 6 mm thick and 20 mm wide, web 8 mm), thinner
           than both bosses.

Material: steel, E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3; Rayleigh damping beta = 1e-5.

Two materials (--materials two): the tets whose centroid lies above the midpoint of the body's
x extent are aluminium (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3), the others steel. K and M
are the sums of the two materials' matrices, each assembled on its own tets. The damping is
material-wise stiffness-proportional, D = 1e-5 K_steel + 1e-6 K_aluminium (beta 10x apart),
which is no alpha M + beta K of the whole body (on the 2e4-DoF crank the least-squares fit
leaves 23% of |D|_F); D takes the rigid modes to 0 as K does. D is written as D.mtx
(symmetric, lower triangle, 17 significant digits) and model.toml has `damping = "D.mtx"`
instead of the [rayleigh] table. Scene, remote points and band are found as for one material
(the band on the two-material body). Each material's K is checked to take the rigid modes
to ~0, and its tet count and mass are printed.

Scene: three nodes at meaningful spots, the x, y, z DoFs of each as inputs and outputs
(the same 9 DoFs): shaft - both end-face centres and the crank pin; bracket - the edges of the
two bolt holes on the mounting (upright) face and the tip of the base; plate - two opposite
corners and the centre; housing - two opposite flange corners and the bottom centre. The
node nearest to each point is used. The band runs from 0 to a round number just above the
13th elastic eigenfrequency (scipy eigsh, shift-invert), unless --band gives it. With
--band, --no-check skips that eigsh and the checks on its modes (6 rigid, M definite): at
~10^6 DoF its sparse LU needs more time and memory than the reduction it prepares; sparsemor's
own run then checks definiteness and counts the band's modes.

Remote points (the crank always, the bracket with --remote): each bore or bolt-hole surface is
coupled to a reference point with six DoFs (x, y, z, rx, ry, rz) at the hole's centre on its
axis, written as a `[[remote_points]]` table after `[scene]` that selects the nodes by
`cylinder` (centre, axis, radius, length, tol: the nodes within tol of the cylinder surface
and within length/2 of the centre along the axis). The selection is checked to be exactly the
nodes of the mesh's boundary triangles on the hole, tet10 edge midpoints included (those lie
inside the circle by the chord's sagitta, so tol is not tiny: see remote_points()).
  crank    big_end and small_end, "distributing" (RBE3); the scene is the 6 DoFs of both points
           as inputs and outputs ("big_end:x" ... "small_end:rz", 12).
  bracket  base_a, base_b (the base's holes, y = 0.02, 0.06) and upright_a, upright_b (the
           upright's), "rigid" (RBE2); the scene is the 6 DoFs of upright_a and upright_b (12).
A distributing point's weights (--weights): "uniform" writes none (every node weighs 1);
"area" writes `weights = [..]`, one per selected node in increasing node order, proportional
to the node's tributary area on the surface's 6-node triangles (area_weights()).
The band is found on the uncoupled free body as for the other parts. RBE2 stiffens the body
(its coupled surfaces stay rigid), so the coupled bracket's eigenfrequencies are higher and
its band may hold fewer than 13 of them (not measured here); RBE3 adds no stiffness. Without --remote the other parts' output is as it
was (byte for byte).

Model directory: model.toml, K.mtx and M.mtx (Matrix Market, symmetric, lower triangle,
1-based), D.mtx with two materials, nodes.csv (x,y,z; vertices then edge midpoints). Node i
owns DoFs 3i, 3i+1, 3i+2.

Run:
  python3 benches/parts.py PART --size H --out DIR [--band F] [--remote] [--weights W]
                           [--materials one|two]
  python3 benches/parts.py all --out-root DIR [--weights W] [--materials one|two]

e.g. the two-material crank of about 2e4 DoFs:
  python3 benches/parts.py crank --size 0.008 --materials two --out DIR
--materials one (the default) writes what it wrote before the option (byte for byte).

`all` writes every part at two sizes (about 1e4 and 1e5 DoFs; the crank 2e4 and 1e5, with its
remote points) into DIR/<part>-<N>, both sizes of a part with the band found on the small one,
checks each model (6 rigid modes, M positive definite) and prints a table.

Needs: numpy, scipy, gmsh, scikit-fem (`pip install gmsh scikit-fem`; gmsh's wheel needs the
libGLU, libXcursor, libXinerama and libXft shared libraries on a bare Debian).
"""

import argparse
import collections
import json
import math
import pathlib
import time

import gmsh
import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import scipy.spatial
from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, MeshTet, asm
from skfem.helpers import dot
from skfem.models.elasticity import lame_parameters, linear_elasticity

E = 210e9
NU = 0.3
RHO = 7850.0
RAYLEIGH_BETA = 1e-5
# beta: the material's stiffness-proportional damping with --materials two
Material = collections.namedtuple("Material", "name E nu rho beta")
STEEL = Material("steel", E, NU, RHO, RAYLEIGH_BETA)
ALUMINIUM = Material("aluminium", 70e9, 0.33, 2700.0, 1e-6)
# Shift for eigsh: just below zero, so K - sigma M is definite on a free body.
SIGMA = -1e3
# Rigid modes come out at |f| far below this; the first elastic mode of these parts is
# hundreds of Hz.
RIGID_HZ = 1.0
# The band ends just above this elastic mode (1-based), so it holds 13 or a few more.
BAND_MODE = 13


def cylinder_x(occ, x0, x1, r, y=0.0, z=0.0):
    return (3, occ.addCylinder(x0, y, z, x1 - x0, 0, 0, r))


def box(occ, lo, hi):
    return (3, occ.addBox(*lo, *(h - l for l, h in zip(lo, hi))))


def fuse(occ, parts):
    out, _ = occ.fuse(parts[:1], parts[1:])
    return out


def cut(occ, body, tools):
    out, _ = occ.cut(body, tools)
    return out


def shaft(occ):
    """A crankshaft: snout, two journals, a crank throw; the scene spans its length."""
    pieces = [
        cylinder_x(occ, 0.0, 0.06, 0.018),
        cylinder_x(occ, 0.06, 0.15, 0.025),
        box(occ, (0.15, -0.035, -0.03), (0.175, 0.085, 0.03)),
        cylinder_x(occ, 0.175, 0.225, 0.02, y=0.05),
        box(occ, (0.225, -0.035, -0.03), (0.25, 0.085, 0.03)),
        cylinder_x(occ, 0.25, 0.40, 0.03),
    ]
    fuse(occ, pieces)
    return [(0.0, 0.0, 0.0), (0.2, 0.07, 0.0), (0.4, 0.0, 0.0)]


# the bracket's plate thickness and bolt-hole radius, shared with its remote points
BRACKET_T = 0.012
BRACKET_HOLE_R = 0.006


def bracket(occ):
    """An L bracket bolted by its upright (x = 0 face); the base sticks out as a cantilever."""
    t = BRACKET_T
    body = fuse(occ, [
        box(occ, (0.0, 0.0, 0.0), (0.15, 0.08, t)),
        box(occ, (0.0, 0.0, 0.0), (t, 0.08, 0.12)),
        # gusset: a right-angle wedge in the corner, in the middle of the width
        (3, occ.addWedge(t, 0.034, t, 0.06, 0.012, 0.06)),
    ])
    r = BRACKET_HOLE_R
    holes = [(3, occ.addCylinder(0.11, y, -0.01, 0, 0, t + 0.02, r)) for y in (0.02, 0.06)]
    holes += [(3, occ.addCylinder(-0.01, y, 0.08, t + 0.02, 0, 0, r)) for y in (0.02, 0.06)]
    cut(occ, body, holes)
    return [(0.0, 0.02, 0.08 + r), (0.0, 0.06, 0.08 + r), (0.15, 0.04, t)]


def bracket_holes():
    """The bracket's four bolt holes: (name, centre, axis, radius, length)."""
    t, r = BRACKET_T, BRACKET_HOLE_R
    return [
        ("base_a", (0.11, 0.02, t / 2), (0.0, 0.0, 1.0), r, t),
        ("base_b", (0.11, 0.06, t / 2), (0.0, 0.0, 1.0), r, t),
        ("upright_a", (t / 2, 0.02, 0.08), (1.0, 0.0, 0.0), r, t),
        ("upright_b", (t / 2, 0.06, 0.08), (1.0, 0.0, 0.0), r, t),
    ]


def plate(occ):
    """A flat plate with bolt holes near the corners and two lightening holes beside the centre."""
    lx, ly, t = 0.3, 0.2, 0.01
    body = [box(occ, (0.0, 0.0, 0.0), (lx, ly, t))]
    holes = [(3, occ.addCylinder(x, y, -0.01, 0, 0, t + 0.02, 0.008))
             for x in (0.025, lx - 0.025) for y in (0.025, ly - 0.025)]
    holes += [(3, occ.addCylinder(x, ly / 2, -0.01, 0, 0, t + 0.02, 0.03)) for x in (0.075, 0.225)]
    cut(occ, body, holes)
    return [(0.0, 0.0, t), (lx / 2, ly / 2, t), (lx, ly, t)]


def housing(occ):
    """An open-top thin-walled box with a bolting flange round its rim."""
    lx, ly, lz, wall, tf, lip = 0.2, 0.15, 0.1, 0.006, 0.008, 0.025
    shell = fuse(occ, [
        box(occ, (0.0, 0.0, 0.0), (lx, ly, lz)),
        box(occ, (-lip, -lip, lz - tf), (lx + lip, ly + lip, lz)),
    ])
    tools = [box(occ, (wall, wall, wall), (lx - wall, ly - wall, lz + 0.01))]
    tools += [(3, occ.addCylinder(x, y, lz - tf - 0.01, 0, 0, tf + 0.02, 0.005))
              for x in (-lip / 2, lx + lip / 2) for y in (-lip / 2, ly + lip / 2)]
    cut(occ, shell, tools)
    return [(-lip, -lip, lz), (lx / 2, ly / 2, 0.0), (lx + lip, ly + lip, lz)]


# the crank's bores: (name, centre, radius, boss radius, boss thickness); axes along z
CRANK_BORES = [
    ("big_end", (0.0, 0.0, 0.0), 0.02, 0.036, 0.04),
    ("small_end", (0.2, 0.0, 0.0), 0.01, 0.02, 0.026),
]


def crank(occ):
    """A crank arm: two bored bosses, 0.2 apart, joined by an I-section arm thinner than both."""
    # arm: depth 0.028 (y), flanges 6 mm thick and 20 mm wide (z), web 8 mm; its ends lie
    # inside the bosses' rings, so only the flanges' and web's sides meet the bosses
    x0, x1 = 0.03, 0.186
    pieces = [(3, occ.addCylinder(c[0], c[1], -th / 2, 0, 0, th, rb))
              for _, c, _, rb, th in CRANK_BORES]
    pieces += [
        box(occ, (x0, 0.008, -0.01), (x1, 0.014, 0.01)),
        box(occ, (x0, -0.014, -0.01), (x1, -0.008, 0.01)),
        box(occ, (x0, -0.008, -0.004), (x1, 0.008, 0.004)),
    ]
    body = fuse(occ, pieces)
    bores = [(3, occ.addCylinder(c[0], c[1], -0.03, 0, 0, 0.06, r))
             for _, c, r, _, _ in CRANK_BORES]
    cut(occ, body, bores)
    return [c for _, c, _, _, _ in CRANK_BORES]


def crank_bores():
    """The crank's two bore surfaces: (name, centre, axis, radius, length)."""
    return [(name, c, (0.0, 0.0, 1.0), r, th) for name, c, r, _, th in CRANK_BORES]


# part -> (builder, element sizes giving about 1e4 and 1e5 DoFs)
PARTS = {
    "shaft": (shaft, (0.017, 0.0066)),
    "bracket": (bracket, (0.02, 0.0043)),
    "plate": (plate, (0.023, 0.0058)),
    "housing": (housing, (0.03, 0.0075)),
    "crank": (crank, (0.008, 0.0037)),
}

# part -> (coupling, cylinders (name, centre, axis, radius, length), the points whose 6 DoFs
# make the scene); the crank always has its remote points, the bracket with --remote
REMOTE = {
    "crank": ("distributing", crank_bores(), ("big_end", "small_end")),
    "bracket": ("rigid", bracket_holes(), ("upright_a", "upright_b")),
}


def mesh(builder, h):
    """Linear tets of size about h: vertex coordinates (3, nv), tets (4, nt), scene points."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("part")
        points = builder(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h / 4)
        # at least this many elements round a full circle, so small holes keep their shape
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 8)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, elem_nodes = gmsh.model.mesh.getElementsByType(4)
    finally:
        gmsh.finalize()
    coords = coords.reshape(-1, 3)
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    tets = index[elem_nodes.astype(np.int64)].reshape(-1, 4)
    # gmsh keeps nodes of the geometry's points and curves that no tet uses: drop them, else
    # they would own DoFs with no mass and no stiffness
    used, tets = np.unique(tets, return_inverse=True)
    # scikit-fem wants C-contiguous (3, nv) and (4, nt) arrays
    p = np.ascontiguousarray(coords[used].T)
    t = np.ascontiguousarray(tets.reshape(-1, 4).T)
    return p, t, points


def mass_form(rho):
    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)
    return mass


def split_materials(p, t, materials):
    """[(Material, its tets' indices, or None for all)]: with "two", the tets whose centroid
    x is above the midpoint of the body's x extent are aluminium, the others steel."""
    if materials == "one":
        return [(STEEL, None)]
    centroid_x = p[0, t].mean(axis=0)
    mid = 0.5 * (p[0].min() + p[0].max())
    al = centroid_x > mid
    return [(STEEL, np.flatnonzero(~al)), (ALUMINIUM, np.flatnonzero(al))]


def material_matrices(mesh_, element, material, elements):
    """K and M of one material on the tets `elements` (None: all), in scikit-fem's DoF order."""
    # P2 strains are linear on a straight tet, so degree-2 quadrature integrates K exactly
    # (and three times faster than the default degree 4, which M needs)
    K = asm(linear_elasticity(*lame_parameters(material.E, material.nu)),
            Basis(mesh_, element, intorder=2, elements=elements))
    M = asm(mass_form(material.rho), Basis(mesh_, element, elements=elements))
    return K, M


def assemble(p, t, split):
    """K and M in node-major order (DoF 3i+k = component k of node i), the node coordinates,
    and each material's K and M (same order; K and M are their sums). split: split_materials().
    """
    mesh_ = MeshTet(p, t)
    element = ElementVector(ElementTetP2())
    basis = Basis(mesh_, element)
    # scikit-fem's DoF numbering depends on its version: take each node's x, y, z DoFs from
    # the basis instead of assuming an order
    per_node = np.hstack([basis.nodal_dofs, basis.edge_dofs])  # (3, nodes)
    perm = per_node.T.ravel()
    nodes = basis.doflocs[:, per_node[0]].T
    assert np.allclose(basis.doflocs[:, per_node[1]].T, nodes)
    assert np.allclose(basis.doflocs[:, per_node[2]].T, nodes)
    assert np.array_equal(np.sort(perm), np.arange(basis.N))
    check_components(basis, per_node)
    parts = []
    for material, elements in split:
        K, M = material_matrices(mesh_, element, material, elements)
        parts.append((symmetric(K[perm][:, perm]), symmetric(M[perm][:, perm])))
    K, M = parts[0]
    for K_m, M_m in parts[1:]:
        K, M = K + K_m, M + M_m
    return K, M, nodes, parts


def check_components(basis, per_node):
    """A field with DoF 3i+k = 1 for every node must be the unit translation along axis k."""
    for k in range(3):
        v = np.zeros(basis.N)
        v[per_node[k]] = 1.0
        u = basis.interpolate(v).value
        expected = np.zeros(3)
        expected[k] = 1.0
        assert np.allclose(u.reshape(3, -1).T, expected), f"DoF component {k} is not axis {k}"


def rigid_modes(nodes):
    """The 6 rigid-body modes (N, 6): translations along x, y, z, rotations about x, y, z
    through the nodes' centroid."""
    r = nodes - nodes.mean(axis=0)
    modes = np.zeros((3 * len(nodes), 6))
    for k in range(3):
        modes[k::3, k] = 1.0
        # rotation about axis k: u = e_k x r
        e = np.zeros(3)
        e[k] = 1.0
        modes[:, 3 + k] = np.cross(e, r).ravel()
    return modes


def rigid_residual(A, modes):
    """max over the rigid modes of |A u| / (|A|_F |u|): ~0 when A takes every rigid mode to 0."""
    return float(np.max(np.linalg.norm(A @ modes, axis=0)
                        / (sla.norm(A) * np.linalg.norm(modes, axis=0))))


def material_damping(split, parts, K, nodes):
    """D = sum of each material's beta K_m; raise unless each K_m and K take the rigid modes
    to ~0. Prints each material's tet count and mass."""
    modes = rigid_modes(nodes)
    for (material, elements), (K_m, M_m) in zip(split, parts):
        moved = rigid_residual(K_m, modes)
        if not moved < 1e-10:
            raise RuntimeError(f"{material.name}: K takes a rigid mode to {moved:.3g} (rel)")
        # u' M_m u for the unit x translation u is the material's mass
        print(f"  {material.name}: {len(elements)} tets, mass "
              f"{modes[:, 0] @ M_m @ modes[:, 0]:.4g} kg, "
              f"|K u_rigid| / |K| |u_rigid| <= {moved:.2g}")
    moved = rigid_residual(K, modes)
    if not moved < 1e-10:
        raise RuntimeError(f"K takes a rigid mode to {moved:.3g} (rel)")
    D = parts[0][0] * split[0][0].beta
    for (material, _), (K_m, _) in zip(split[1:], parts[1:]):
        D = D + K_m * material.beta
    return D


def symmetric(a):
    a = sp.csr_matrix(a)
    a = ((a + a.T) * 0.5).tocsr()
    a.eliminate_zeros()
    return a


def frequencies(K, M, count):
    """The lowest `count` eigenfrequencies in Hz (rigid ones near zero, signed)."""
    lam = sla.eigsh(K.tocsc(), k=count, M=M.tocsc(), sigma=SIGMA, which="LM",
                    return_eigenvectors=False)
    lam = np.sort(lam)
    return np.sign(lam) * np.sqrt(np.abs(lam)) / (2 * math.pi)


def round_up(x):
    """x rounded up to two significant digits."""
    step = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / step) * step


def band_from(freqs):
    elastic = freqs[np.abs(freqs) >= RIGID_HZ]
    return round_up(elastic[BAND_MODE - 1] * 1.001)


def scene_dofs(nodes, points):
    dofs = []
    for q in points:
        i = int(np.argmin(np.linalg.norm(nodes - np.asarray(q), axis=1)))
        dofs += [3 * i, 3 * i + 1, 3 * i + 2]
    return dofs


def cylinder_distance(nodes, centre, axis, radius):
    """Each node's |distance from the axis line - radius| and axial offset from the centre."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    d = nodes - np.asarray(centre, dtype=float)
    axial = d @ axis
    radial = np.linalg.norm(d - np.outer(axial, axis), axis=1)
    return np.abs(radial - radius), axial


def surface_nodes(p, t, nodes, centre, axis, radius, length):
    """The tet10 nodes of the boundary triangles whose vertices lie on the cylinder (exact),
    increasing, and each one's tributary area (same order; see area_weights())."""
    faces = np.sort(np.hstack([t[[0, 1, 2]], t[[0, 1, 3]], t[[0, 2, 3]], t[[1, 2, 3]]]).T, axis=1)
    faces, count = np.unique(faces, axis=0, return_counts=True)
    faces = faces[count == 1]
    off, axial = cylinder_distance(p.T, centre, axis, radius)
    on = (off <= 1e-9 * radius) & (np.abs(axial) <= length / 2 * (1 + 1e-9))
    faces = faces[on[faces].all(axis=1)]
    # each face's 6 nodes (its vertices, then the midpoints of edges 01, 02, 12), found among
    # the nodes by their coordinates
    x = p.T[faces]  # (faces, 3 vertices, 3)
    pts = [x[:, a] for a in range(3)]
    pts += [(x[:, a] + x[:, b]) / 2 for a, b in ((0, 1), (0, 2), (1, 2))]
    dist, idx = scipy.spatial.cKDTree(nodes).query(np.stack(pts, axis=1).reshape(-1, 3))
    assert dist.max() <= 1e-12 * radius, dist.max()
    idx = idx.reshape(-1, 6)
    chosen, inverse = np.unique(idx, return_inverse=True)
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    share = np.hstack([np.repeat(area[:, None] / 12, 3, axis=1),
                       np.repeat(area[:, None] / 4, 3, axis=1)])
    tributary = np.zeros(len(chosen))
    np.add.at(tributary, inverse.ravel(), share.ravel())
    return chosen, tributary


def area_weights(tributary):
    """RBE3 weights proportional to each node's tributary area, scaled to mean 1.

    A 6-node boundary triangle of area A splits at its edge midpoints into 4 linear triangles
    of A/4; each node takes a third of every sub-triangle it touches: a corner A/12, an edge
    midpoint A/4 (the three corners a quarter of the face together, the three midpoints three
    quarters). Summed over the surface's triangles, every weight is > 0 and the weights add up
    to the surface's (faceted) area before scaling. Uniform weights give every node the same
    share whatever area it stands for, and that area depends on the mesh.
    """
    return tributary / tributary.mean()


def remote_points(part, p, t, nodes, weights="uniform"):
    """The part's remote points, each a bore or hole surface selected by a cylinder.

    weights: "uniform" (none written: every node weighs 1) or "area" (area_weights(), one per
    selected node in increasing node order, as sparsemor pairs them); distributing points only,
    a rigid point takes none.

    tol is put half-way (geometrically) between the largest distance of a surface node from
    the cylinder (a mid-edge node of a chord, inside the circle by the chord's sagitta) and
    the smallest distance of any other node within the cylinder's length, rounded to two
    significant digits; the cylinder's selection is checked to equal the exact surface nodes.
    The length is the bore's plus tol, so nodes on the bore's edges are inside whatever the
    rounding of their axial coordinate.
    """
    kind, cylinders, _ = REMOTE[part]
    points = []
    for name, centre, axis, radius, length in cylinders:
        exact, tributary = surface_nodes(p, t, nodes, centre, axis, radius, length)
        off, axial = cylinder_distance(nodes, centre, axis, radius)
        within = np.abs(axial) <= length / 2 * (1 + 1e-9)
        inside = np.zeros(len(nodes), dtype=bool)
        inside[exact] = True
        dev_in = off[inside].max()
        dev_out = off[~inside & within].min()
        if not dev_in < dev_out:
            raise RuntimeError(f"{name}: a node off the surface is as close as the surface "
                               f"nodes ({dev_out:.3g} <= {dev_in:.3g})")
        tol = float(f"{math.sqrt(max(dev_in, 1e-3 * dev_out) * dev_out):.2g}")
        cyl_length = float(f"{length + tol:.6g}")
        chosen = np.flatnonzero((off <= tol) & (np.abs(axial) <= cyl_length / 2))
        if not np.array_equal(chosen, exact):
            raise RuntimeError(f"{name}: the cylinder selects {len(chosen)} nodes, the surface "
                               f"has {len(exact)}")
        w = area_weights(tributary) if weights == "area" and kind == "distributing" else None
        points.append(dict(name=name, kind=kind, position=centre, axis=axis, radius=radius,
                           length=cyl_length, tol=tol, nodes=chosen, dev_in=dev_in,
                           dev_out=dev_out, weights=w, area=tributary.sum()))
    return points


def remote_scene(part):
    return [f"{name}:{d}" for name in REMOTE[part][2] for d in ("x", "y", "z", "rx", "ry", "rz")]


def toml_floats(v):
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def remote_toml(points):
    text = ""
    for q in points:
        text += (
            "\n[[remote_points]]\n"
            f'name = "{q["name"]}"\n'
            f'kind = "{q["kind"]}"\n'
            f"position = {toml_floats(q['position'])}\n"
            f"cylinder = {{ center = {toml_floats(q['position'])}, "
            f"axis = {toml_floats(q['axis'])}, radius = {float(q['radius'])!r}, "
            f"length = {q['length']!r}, tol = {q['tol']!r} }}\n"
        )
        if q["weights"] is not None:
            # one per node of the cylinder's selection, in increasing node order
            text += f"weights = {toml_floats(q['weights'])}\n"
    return text


def write_model(out, name, K, M, nodes, dofs, band, remote=None, D=None):
    """D: an explicit damping matrix, written as D.mtx instead of the [rayleigh] table."""
    out.mkdir(parents=True, exist_ok=True)
    # DoF indices as before; remote points' "POINT:DIR" names as TOML basic strings
    scene = json.dumps(dofs) if remote else dofs
    for file, a in (("K.mtx", K), ("M.mtx", M)):
        scipy.io.mmwrite(out / file, sp.tril(a).tocoo(), symmetry="symmetric")
    if D is not None:
        scipy.io.mmwrite(out / "D.mtx", sp.tril(D).tocoo(), symmetry="symmetric", precision=17)
        damping = 'damping = "D.mtx"\n'
    else:
        damping = ""
    rayleigh = "" if D is not None else f"\n[rayleigh]\nalpha = 0.0\nbeta = {RAYLEIGH_BETA!r}\n"
    np.savetxt(out / "nodes.csv", nodes, delimiter=",", header="x,y,z", comments="",
               fmt="%.17g")
    (out / "model.toml").write_text(
        f'name = "{name}"\n'
        'mass = "M.mtx"\n'
        'stiffness = "K.mtx"\n'
        'nodes = "nodes.csv"\n'
        + damping
        + "dofs_per_node = 3\n"
        + rayleigh
        + "\n[scene]\n"
        f"inputs = {scene}\n"
        f"outputs = {scene}\n"
        f"band_hz = [0.0, {float(band)!r}]\n"
        + (remote_toml(remote) if remote else "")
    )


def check(M, freqs):
    """Raise unless M is positive definite and exactly 6 modes are rigid."""
    rigid = int(np.sum(np.abs(freqs) < RIGID_HZ))
    if rigid != 6:
        raise RuntimeError(f"{rigid} rigid modes, expected 6: {freqs[:8]}")
    # Jacobi scaling makes M's spectrum narrow, so Lanczos finds its smallest eigenvalue fast
    d = 1.0 / np.sqrt(M.diagonal())
    scaled = sp.diags(d) @ M @ sp.diags(d)
    lowest = sla.eigsh(scaled, k=1, which="SA", return_eigenvectors=False, tol=1e-6)[0]
    if not lowest > 0:
        raise RuntimeError(f"M is not positive definite: scaled lowest eigenvalue {lowest}")
    return lowest


def build(part, h, out_for, band=None, remote=False, weights="uniform", materials="one",
          checked=True):
    """Write one model into out_for(N); return a row of the summary table.

    materials: "one" (steel, Rayleigh damping) or "two" (split_materials(), D.mtx).
    checked=False (band given): no eigsh, no check of the modes, no frequencies printed."""
    start = time.perf_counter()
    builder, _ = PARTS[part]
    remote = remote or part == "crank"
    if remote and part not in REMOTE:
        raise ValueError(f"{part} has no remote points (only {', '.join(REMOTE)})")
    p, t, points = mesh(builder, h)
    split = split_materials(p, t, materials)
    K, M, nodes, parts = assemble(p, t, split)
    built = time.perf_counter() - start
    D = material_damping(split, parts, K, nodes) if materials == "two" else None
    if checked:
        freqs = frequencies(K, M, 30)
        lowest_m = check(M, freqs)
        band = band or band_from(freqs)
    else:
        freqs, lowest_m = np.zeros(0), float("nan")
    n = K.shape[0]
    out = out_for(n)
    if remote:
        coupled = remote_points(part, p, t, nodes, weights)
        dofs = remote_scene(part)
    else:
        coupled = None
        dofs = scene_dofs(nodes, points)
    name = f"{part} tet10 h={h:g}" + (", steel and aluminium" if D is not None else "")
    write_model(out, name, K, M, nodes, dofs, band, coupled, D)
    total = time.perf_counter() - start
    elastic = freqs[np.abs(freqs) >= RIGID_HZ]
    print(f"{out}: N = {n}, tets = {t.shape[1]}, nnz(K) = {K.nnz}, band = 0..{band:g} Hz, "
          + (f"({int(np.sum(elastic <= band))} elastic modes), " if checked else "")
          + f"built in {built:.1f} s, total {total:.1f} s"
          + (f"; min eig of Jacobi-scaled M {lowest_m:.3g}" if checked else ""))
    if remote:
        for q in coupled:
            print(f"  remote point {q['name']} ({q['kind']}) at {q['position']}: "
                  f"{len(q['nodes'])} nodes, tol {q['tol']:g} = {q['tol'] / h:.3g} h "
                  f"(surface nodes within {q['dev_in']:.3g}, others from {q['dev_out']:.3g}); "
                  f"area {q['area']:.4g} m^2, "
                  + ("no weights (rigid)" if q["kind"] == "rigid" else
                     "uniform weights" if q["weights"] is None else
                     f"area weights {q['weights'].min():.3g} .. {q['weights'].max():.3g}"))
    else:
        for q, i in zip(points, dofs[::3]):
            print(f"  scene node {i // 3} at {np.round(nodes[i // 3], 4)} for {q}")
    if checked:
        print("  rigid (Hz):  ", " ".join(f"{f:.3g}" for f in freqs[np.abs(freqs) < RIGID_HZ]))
        print("  elastic (Hz):", " ".join(f"{f:.1f}" for f in elastic))
    else:
        print("  modes not computed (--no-check)")
    return part, out, n, K.nnz, band, elastic, built, total


def all_parts(root, weights="uniform", materials="one"):
    rows = []
    for part, (_, sizes) in PARTS.items():
        band = None
        for h in sizes:
            row = build(part, h, lambda n: root / f"{part}-{n}", band, weights=weights,
                        materials=materials)
            # the fine model keeps the coarse one's band, so both hold the same modes
            band = row[4]
            rows.append(row)
    print()
    print("| part | model | N | nnz(K) | band Hz | build s | total s | first elastic Hz |")
    print("|---|---|---|---|---|---|---|---|")
    for part, out, n, nnz, band, elastic, built, total in rows:
        first = ", ".join(f"{f:.1f}" for f in elastic[:6])
        print(f"| {part} | {out} | {n} | {nnz} | {band:g} | {built:.1f} | {total:.1f} | {first} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("part", choices=[*PARTS, "all"])
    ap.add_argument("--size", type=float, help="target element size in m (one part)")
    ap.add_argument("--out", type=pathlib.Path, help="model directory (one part)")
    ap.add_argument("--band", type=float, help="upper end of the band in Hz (one part)")
    ap.add_argument("--out-root", type=pathlib.Path, help="folder for `all`")
    ap.add_argument("--remote", action="store_true",
                    help="the part's holes as remote points (bracket; the crank always)")
    ap.add_argument("--weights", choices=("uniform", "area"), default="uniform",
                    help="distributing points' weights: uniform (none written, 1 per node) or "
                         "area (each node's tributary area, mean 1); rigid points take none")
    ap.add_argument("--materials", choices=("one", "two"), default="one",
                    help="one: steel, Rayleigh damping; two: steel and aluminium split at the "
                         "middle of the x extent, material-wise damping written as D.mtx")
    ap.add_argument("--no-check", action="store_true",
                    help="with --band (one part): skip scipy's eigsh and the checks on its "
                         "modes, for bodies of ~10^6 DoF")
    args = ap.parse_args()
    if args.part == "all":
        if args.out_root is None:
            ap.error("all needs --out-root")
        if args.remote:
            ap.error("--remote is for one part")
        all_parts(args.out_root, args.weights, args.materials)
    else:
        if args.size is None or args.out is None:
            ap.error("one part needs --size and --out")
        if args.no_check and args.band is None:
            ap.error("--no-check needs --band (the band comes from the checked modes)")
        build(args.part, args.size, lambda n: args.out, args.band, args.remote, args.weights,
              args.materials, checked=not args.no_check)


if __name__ == "__main__":
    main()
