"""Reference transfer functions of a model directory with remote points (numpy/scipy only).

An independent check of sparsemor's remote points (design.md §3.11): it shares no code with the
Rust side and builds the couplings the plain way, as a textbook would.

    H(s) = C (s^2 M + s D + K)^-1 B,   s = i 2 pi f,   D = alpha M + beta K ([rayleigh])
                                                        or the file named by `damping`

Remote points (`[[remote_points]]` in model.toml): a reference point with six DoFs
(x, y, z, rx, ry, rz) tied to a node set. A node at offset r = x_node - x_ref moves under the
point's rigid motion (t, theta) as u = t + theta x r = G(r) (t, theta), G(r) = [I, -[r]x].

  rigid (RBE2)          the point's six DoFs are extra unknowns and every coupled node's
                        translations are constrained to u_i = G(r_i) x_p (on a 6-DoF model its
                        rotations too, to theta_i = theta), by Lagrange multipliers:
                            [ A   0   Cq^T ] [q  ]   [f_q]
                            [ 0   0   Cx^T ] [x_p] = [f_p]
                            [ Cq  Cx  0    ] [lam]   [0  ]
                        with A = s^2 M + s D + K, Cq the coupled DoFs' selection and Cx = -G.
                        A force on the point is a unit entry of f_p; its response is x_p.
  distributing (RBE3)   the point moves as the weighted least-squares rigid motion of its
                        nodes' translations: x_p = W q, W = (sum w_i G_i^T G_i)^-1
                        [w_1 G_1^T ... w_k G_k^T] on the nodes' x, y, z DoFs. It adds no
                        stiffness; a force or moment on the point loads the body with W^T e_d
                        (virtual work), and its response is the row W_d q.

Each point selects its nodes in exactly one way (0-based rows of nodes.csv):
  nodes = [i, ...]                                        the listed nodes
  box = { min = [x0, y0, z0], max = [x1, y1, z1] }        nodes inside the closed box
  cylinder = { center, axis, radius, length, tol }       nodes with |distance from the axis
        line - radius| <= tol and |axial offset from center| <= length / 2
The selection is taken as sorted node indices; `weights` (distributing only) has one entry per
node in that order (default 1). `position` defaults to the selected nodes' centroid.

Scene names: a DoF index (integer, or a string of digits), "NODE:DIR" (node = row of nodes.csv,
DoF dofs_per_node * node + k) or "POINT:DIR" (a remote point's name, which does not start with
a digit), DIR one of x, y, z, rx, ry, rz. Models with a DoF map ([source], [import]) are not
read.

The result is the total H: on a free body it includes the rigid-body part (-1/(w^2 m) and its
rotational kin), which is finite at every f > 0; f = 0 is refused.

Run:
  python3 benches/remote_reference.py MODEL_DIR --freqs 100,500,1e3 [--out H.csv]
          [--inputs big_end:x,12] [--outputs ...]
  python3 benches/remote_reference.py --self-test

Output: CSV f_hz,output,input,re,im, one row per frequency, output and input (in that order of
nesting). --inputs/--outputs replace the scene's lists (comma-separated names as above).

Self-test: on small random models written to a temporary directory and read back, RBE2 by the
Lagrange system equals RBE2 by explicit elimination q = T z (dense, T^T A T) to 1e-10, for rigid
points, a distributing point and plain DoFs in one model (all three selection forms); an RBE3
point returns t exactly for a pure translation and (t, theta) for a rigid motion, and its fit
satisfies the weighted normal equations for any field; H is symmetric when inputs = outputs;
a rigid point on every node of a free body of point masses (K = D = 0) gives
H = -(sum m_i G_i^T G_i)^-1 / w^2.
"""

import argparse
import math
import pathlib
import sys
import tempfile
import tomllib

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla

DIRS = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}


def skew(r):
    """[r]x: skew(r) @ v = r x v."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def rigid_map(r):
    """G(r) = [I, -[r]x]: the 3 x 6 map from a point's (t, theta) to a node's translation."""
    return np.hstack([np.eye(3), -skew(r)])


# ---------------------------------------------------------------------------------------------
# reading


def read_matrix(path):
    a = scipy.io.mmread(str(path))
    return sp.csr_matrix(a)


def select_nodes(spec, nodes):
    """The sorted node indices one remote point selects."""
    forms = [k for k in ("nodes", "box", "cylinder") if k in spec]
    if len(forms) != 1:
        raise ValueError(f"remote point {spec.get('name')!r}: give exactly one of nodes, box, "
                         f"cylinder (got {forms})")
    if "nodes" in spec:
        chosen = np.unique(np.asarray(spec["nodes"], dtype=np.int64))
        if len(chosen) != len(spec["nodes"]):
            raise ValueError(f"remote point {spec['name']!r}: a node is listed twice")
        if chosen.size and (chosen[0] < 0 or chosen[-1] >= len(nodes)):
            raise ValueError(f"remote point {spec['name']!r}: node out of range")
    elif "box" in spec:
        lo = np.asarray(spec["box"]["min"], dtype=float)
        hi = np.asarray(spec["box"]["max"], dtype=float)
        chosen = np.flatnonzero(np.all((nodes >= lo) & (nodes <= hi), axis=1))
    else:
        c = spec["cylinder"]
        axis = np.asarray(c["axis"], dtype=float)
        axis = axis / np.linalg.norm(axis)
        d = nodes - np.asarray(c["center"], dtype=float)
        axial = d @ axis
        radial = np.linalg.norm(d - np.outer(axial, axis), axis=1)
        chosen = np.flatnonzero((np.abs(radial - c["radius"]) <= c["tol"])
                                & (np.abs(axial) <= c["length"] / 2))
    if chosen.size == 0:
        raise ValueError(f"remote point {spec['name']!r} selects no node")
    return chosen


def read_model(directory):
    """K, M, D (sparse CSR), nodes, dofs_per_node, remote points and the scene of a directory."""
    directory = pathlib.Path(directory)
    toml = tomllib.loads((directory / "model.toml").read_text())
    if "import" in toml or "source" in toml:
        raise ValueError("models with a DoF map ([import], [source]) are not supported")
    K = read_matrix(directory / toml["stiffness"])
    M = read_matrix(directory / toml["mass"])
    if "damping" in toml:
        D = read_matrix(directory / toml["damping"])
    else:
        ray = toml.get("rayleigh", {})
        D = ray.get("alpha", 0.0) * M + ray.get("beta", 0.0) * K
    per = int(toml.get("dofs_per_node", 3))
    if per not in (3, 6):
        raise ValueError(f"dofs_per_node = {per}: 3 or 6")
    nodes = None
    if "nodes" in toml:
        nodes = np.loadtxt(directory / toml["nodes"], delimiter=",", skiprows=1, ndmin=2)
        if nodes.shape[0] * per != K.shape[0]:
            raise ValueError(f"{nodes.shape[0]} nodes x {per} DoFs != N = {K.shape[0]}")
    points = []
    for spec in toml.get("remote_points", []):
        if nodes is None:
            raise ValueError("remote points need nodes.csv")
        name = spec["name"]
        if not name or name[0].isdigit() or not all(ch.isalnum() or ch == "_" for ch in name):
            raise ValueError(f"bad remote point name {name!r}")
        if any(q["name"] == name for q in points):
            raise ValueError(f"remote point {name!r} twice")
        kind = spec["kind"]
        if kind not in ("rigid", "distributing"):
            raise ValueError(f"remote point {name!r}: kind {kind!r}")
        sel = select_nodes(spec, nodes)
        if "position" in spec:
            position = np.asarray(spec["position"], dtype=float)
        else:
            position = nodes[sel].mean(axis=0)
        weights = np.ones(len(sel))
        if "weights" in spec:
            if kind != "distributing":
                raise ValueError(f"remote point {name!r}: weights are for distributing points")
            weights = np.asarray(spec["weights"], dtype=float)
            if weights.shape != (len(sel),):
                raise ValueError(f"remote point {name!r}: {len(weights)} weights for "
                                 f"{len(sel)} nodes")
        points.append(dict(name=name, kind=kind, nodes=sel, position=position,
                           weights=weights))
    rigid_nodes = np.concatenate([q["nodes"] for q in points if q["kind"] == "rigid"] or [[]])
    if len(np.unique(rigid_nodes)) != len(rigid_nodes):
        raise ValueError("a node is coupled by two rigid points")
    scene = toml["scene"]
    return dict(K=K, M=M, D=D, nodes=nodes, per=per, points=points,
                inputs=list(scene["inputs"]), outputs=list(scene["outputs"]))


# ---------------------------------------------------------------------------------------------
# couplings


def rbe3_rows(point, nodes, per):
    """W (6 x N, sparse): the point's weighted least-squares rigid motion of its nodes."""
    r = nodes[point["nodes"]] - point["position"]
    G = [rigid_map(ri) for ri in r]
    w = point["weights"]
    A = sum(wi * Gi.T @ Gi for wi, Gi in zip(w, G))
    ev = np.linalg.eigvalsh(A)
    if ev[0] <= 1e-12 * ev[-1]:
        raise ValueError(f"remote point {point['name']!r}: its nodes lie on a line")
    rhs = np.hstack([wi * Gi.T for wi, Gi in zip(w, G)])  # 6 x 3k
    W = np.linalg.solve(A, rhs)
    cols = (per * point["nodes"][:, None] + np.arange(3)).ravel()
    N = per * len(nodes)
    return sp.csr_matrix((W.ravel(), (np.repeat(np.arange(6), len(cols)), np.tile(cols, 6))),
                         shape=(6, N))


def rigid_constraints(points, nodes, per, N):
    """Cq (m x N) and Cx (m x 6 P) of the rigid points: Cq q + Cx x = 0."""
    rigid = [q for q in points if q["kind"] == "rigid"]
    rows_q, cols_q, rows_x, cols_x, vals_x = [], [], [], [], []
    m = 0
    for k, point in enumerate(rigid):
        for i in point["nodes"]:
            G = rigid_map(nodes[i] - point["position"])
            for a in range(3):
                rows_q.append(m + a)
                cols_q.append(per * i + a)
                for b in range(6):
                    if G[a, b] != 0.0:
                        rows_x.append(m + a)
                        cols_x.append(6 * k + b)
                        vals_x.append(-G[a, b])
            m += 3
            if per == 6:  # rotations: theta_i = theta
                for a in range(3):
                    rows_q.append(m + a)
                    cols_q.append(per * i + 3 + a)
                    rows_x.append(m + a)
                    cols_x.append(6 * k + 3 + a)
                    vals_x.append(-1.0)
                m += 3
    Cq = sp.csr_matrix((np.ones(len(rows_q)), (rows_q, cols_q)), shape=(m, N))
    Cx = sp.csr_matrix((vals_x, (rows_x, cols_x)), shape=(m, 6 * len(rigid)))
    return rigid, Cq, Cx


def parse_name(name, model):
    """('dof', j) | ('rigid', k, d) | ('distributing', point, d)."""
    per, nodes = model["per"], model["nodes"]
    N = model["K"].shape[0]
    if isinstance(name, int) or (isinstance(name, str) and name.isdigit()):
        j = int(name)
        if not 0 <= j < N:
            raise ValueError(f"DoF {name} out of range (N = {N})")
        return ("dof", j)
    head, sep, dirn = str(name).partition(":")
    if not sep or dirn not in DIRS:
        raise ValueError(f"bad DoF name {name!r}")
    d = DIRS[dirn]
    if head.isdigit():
        i = int(head)
        if nodes is not None and i >= len(nodes) or d >= per or per * i + d >= N:
            raise ValueError(f"{name!r}: no such DoF")
        return ("dof", per * i + d)
    rigid = [q for q in model["points"] if q["kind"] == "rigid"]
    for k, point in enumerate(rigid):
        if point["name"] == head:
            return ("rigid", k, d)
    for point in model["points"]:
        if point["name"] == head:
            return ("distributing", point, d)
    raise ValueError(f"{name!r}: no remote point {head!r}")


def vectors(names, model, N, n_rigid, rows_cache):
    """The columns (N + 6 P) for loads at `names`, or equally the rows for responses."""
    out = sp.lil_matrix((N + 6 * n_rigid, len(names)))
    for c, name in enumerate(names):
        p = parse_name(name, model)
        if p[0] == "dof":
            out[p[1], c] = 1.0
        elif p[0] == "rigid":
            out[N + 6 * p[1] + p[2], c] = 1.0
        else:
            point, d = p[1], p[2]
            if point["name"] not in rows_cache:
                rows_cache[point["name"]] = rbe3_rows(point, model["nodes"], model["per"])
            row = rows_cache[point["name"]].getrow(d).tocoo()
            for j, v in zip(row.col, row.data):
                out[j, c] = v
    return out.tocsc()


def transfer(model, freqs, inputs=None, outputs=None):
    """H (len(freqs), outputs, inputs) by the Lagrange system, one sparse LU per frequency."""
    K, M, D = model["K"], model["M"], model["D"]
    N = K.shape[0]
    inputs = model["inputs"] if inputs is None else inputs
    outputs = model["outputs"] if outputs is None else outputs
    rigid, Cq, Cx = rigid_constraints(model["points"], model["nodes"], model["per"], N)
    P, m = len(rigid), Cq.shape[0]
    cache = {}
    B = vectors(inputs, model, N, P, cache)
    C = vectors(outputs, model, N, P, cache).T.tocsr()
    B = sp.vstack([B, sp.csr_matrix((m, len(inputs)))]).tocsc()
    C = sp.hstack([C, sp.csr_matrix((len(outputs), m))]).tocsr()
    H = np.zeros((len(freqs), len(outputs), len(inputs)), dtype=complex)
    for k, f in enumerate(freqs):
        if not f > 0:
            raise ValueError(f"frequency {f}: the total H needs f > 0")
        s = 2j * math.pi * f
        A = (K + s * D + s * s * M).astype(complex)
        # equilibrate: constraint rows of size 1 beside entries of size |A_ii| cost the LU
        # digits (5e-6 apart from sparsemor on the tet10 bracket; 3e-12 scaled). The scaling
        # changes only the multipliers, not q or the points' motion.
        c = abs(A.diagonal()).mean()
        S = sp.bmat([[A, None, c * Cq.T], [None, sp.csr_matrix((6 * P, 6 * P)), c * Cx.T],
                     [c * Cq, c * Cx, None]], format="csc")
        lu = sla.splu(S, permc_spec="MMD_AT_PLUS_A")
        X = lu.solve(B.toarray().astype(complex))
        H[k] = C @ X
    return H


# ---------------------------------------------------------------------------------------------
# self-test


def write_mtx(path, a):
    scipy.io.mmwrite(str(path), sp.tril(sp.csr_matrix(a)).tocoo(), symmetry="symmetric")


def random_model(rng, n_nodes):
    """Nodes in the unit cube and SPD K, M on 3 DoFs per node (sparse-ish, well conditioned)."""
    nodes = rng.uniform(0.0, 1.0, (n_nodes, 3))
    N = 3 * n_nodes
    R = sp.random(N, N, density=0.08, random_state=rng) + sp.eye(N)
    K = (R.T @ R + sp.eye(N)).toarray() * 1e4
    Q = sp.random(N, N, density=0.05, random_state=rng)
    Mm = (Q.T @ Q).toarray() * 0.1 + np.eye(N)
    return nodes, K, Mm


def elimination_reference(model, freqs, inputs, outputs):
    """H by q = T z, z = (uncoupled DoFs, rigid points' DoFs), dense T^T A T z = T^T b."""
    K, M, D = (a.toarray() for a in (model["K"], model["M"], model["D"]))
    nodes, per, N = model["nodes"], model["per"], K.shape[0]
    rigid = [q for q in model["points"] if q["kind"] == "rigid"]
    coupled = sorted(per * i + a for q in rigid for i in q["nodes"] for a in range(3))
    free = [j for j in range(N) if j not in set(coupled)]
    T = np.zeros((N, len(free) + 6 * len(rigid)))
    T[free, np.arange(len(free))] = 1.0
    for k, q in enumerate(rigid):
        for i in q["nodes"]:
            T[per * i: per * i + 3, len(free) + 6 * k: len(free) + 6 * k + 6] = \
                rigid_map(nodes[i] - q["position"])

    def vec(name):
        """(column in q space, column in point space) of a load or response."""
        p = parse_name(name, model)
        v = np.zeros(N)
        x = np.zeros(6 * len(rigid))
        if p[0] == "dof":
            v[p[1]] = 1.0
        elif p[0] == "rigid":
            x[6 * p[1] + p[2]] = 1.0
        else:
            v = rbe3_rows(p[1], nodes, per).toarray()[p[2]]
        return v, x

    def reduced(name):
        v, x = vec(name)
        z = T.T @ v
        z[len(free):] += x
        return z

    Bz = np.column_stack([reduced(n) for n in inputs])
    # a response at the rigid point is the z coordinate itself; at a DoF or RBE3 row, c T z
    Cz = np.vstack([(lambda v, x: T.T @ v + np.concatenate([np.zeros(len(free)), x]))(*vec(n))
                    for n in outputs])
    H = []
    for f in freqs:
        s = 2j * math.pi * f
        A = K + s * D + s * s * M
        H.append(Cz @ np.linalg.solve(T.T @ A @ T, Bz))
    return np.array(H)


def rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def self_test():
    rng = np.random.default_rng(7)
    failures = 0

    def check(what, err, limit):
        nonlocal failures
        ok = err <= limit
        failures += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {what}: {err:.3g} (limit {limit:g})")

    # 1. G(r) x = t + theta x r; the RBE3 fit: exact for rigid motions, normal equations for
    # any field
    r, x = rng.standard_normal(3), rng.standard_normal(6)
    check("G(r) (t, theta) = t + theta x r",
          np.max(np.abs(rigid_map(r) @ x - (x[:3] + np.cross(x[3:], r)))), 1e-15)
    nodes = rng.uniform(-1, 1, (12, 3))
    w = rng.uniform(0.5, 2.0, 12)
    point = dict(name="p", kind="distributing", nodes=np.arange(12),
                 position=np.array([0.1, -0.2, 0.3]), weights=w)
    W = rbe3_rows(point, nodes, 3).toarray()
    t = np.array([0.3, -1.2, 0.7])
    check("RBE3 of a pure translation returns t", np.max(np.abs(W @ np.tile(t, 12) - np.r_[t, 0, 0, 0])), 1e-14)
    x = np.r_[t, 0.05, -0.02, 0.08]
    u = np.concatenate([rigid_map(r) @ x for r in nodes - point["position"]])
    check("RBE3 of a rigid motion returns (t, theta)", np.max(np.abs(W @ u - x)), 1e-14)
    u = rng.standard_normal(36)
    xf = W @ u
    G = [rigid_map(r) for r in nodes - point["position"]]
    normal = sum(wi * Gi.T @ (u[3 * i: 3 * i + 3] - Gi @ xf) for i, (wi, Gi) in enumerate(zip(w, G)))
    check("RBE3 fit satisfies the weighted normal equations", np.max(np.abs(normal)), 1e-13)

    # 2. a model directory with two rigid points (nodes, box), a distributing point (cylinder),
    # plain DoFs and a NODE:DIR, read back and solved both ways
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        nodes, K, Mm = random_model(rng, 40)
        # a cylinder of 6 nodes round the z axis through (0.5, 0.5), radius 0.2, z in 0.4..0.6
        ang = np.linspace(0, 2 * math.pi, 6, endpoint=False)
        nodes[30:36] = np.column_stack([0.5 + 0.2 * np.cos(ang), 0.5 + 0.2 * np.sin(ang),
                                        np.linspace(0.4, 0.6, 6)])
        # a box well away from the rest: nodes 36..39 moved into [2, 2.1]^3
        nodes[36:40] = 2.0 + 0.1 * rng.uniform(0, 1, (4, 3))
        # (nodes 0..29 lie in the unit cube: off the cylinder's surface and outside the box)
        write_mtx(tmp / "K.mtx", K)
        write_mtx(tmp / "M.mtx", Mm)
        np.savetxt(tmp / "nodes.csv", nodes, delimiter=",", header="x,y,z", comments="",
                   fmt="%.17g")
        inputs = '["r1:x", "r1:rz", "r2:ry", "d1:x", "d1:rx", 5, "3:z"]'
        outputs = '["r1:y", "r2:rz", "d1:z", "d1:ry", 7, "11:x", "r1:x"]'
        (tmp / "model.toml").write_text(
            'name = "self-test"\nmass = "M.mtx"\nstiffness = "K.mtx"\nnodes = "nodes.csv"\n'
            "dofs_per_node = 3\n\n[rayleigh]\nalpha = 0.5\nbeta = 1e-4\n\n[scene]\n"
            f"inputs = {inputs}\noutputs = {outputs}\nband_hz = [0.0, 100.0]\n\n"
            '[[remote_points]]\nname = "r1"\nkind = "rigid"\nnodes = [20, 12, 15, 17]\n'
            "position = [0.4, 0.6, 0.5]\n\n"
            '[[remote_points]]\nname = "r2"\nkind = "rigid"\n'
            "box = { min = [1.99, 1.99, 1.99], max = [2.11, 2.11, 2.11] }\n\n"
            '[[remote_points]]\nname = "d1"\nkind = "distributing"\n'
            "cylinder = { center = [0.5, 0.5, 0.5], axis = [0.0, 0.0, 2.0], radius = 0.2, "
            "length = 0.21, tol = 1e-9 }\n"
            "weights = [1.0, 2.0, 0.5, 1.5, 1.0, 3.0]\n")
        model = read_model(tmp)
        sel = {q["name"]: q["nodes"].tolist() for q in model["points"]}
        check("selections (nodes, box, cylinder)",
              float(sel != {"r1": [12, 15, 17, 20], "r2": [36, 37, 38, 39],
                            "d1": [30, 31, 32, 33, 34, 35]}), 0)
        freqs = [0.7, 3.0, 11.0]
        H = transfer(model, freqs)
        ref = elimination_reference(model, freqs, model["inputs"], model["outputs"])
        check("RBE2 Lagrange == RBE2 elimination (mixed scene)", rel(H, ref), 1e-10)
        names = model["inputs"]
        Hs = transfer(model, freqs, names, names)
        check("H symmetric with inputs = outputs",
              rel(Hs, np.transpose(Hs, (0, 2, 1))), 1e-10)
        check("symmetric H equals elimination too",
              rel(Hs, elimination_reference(model, freqs, names, names)), 1e-10)

    # 3. physics: a rigid point on every node of a free body of point masses (K = 0, D = 0)
    # moves as a rigid body: H = -(sum_i m_i G_i^T G_i)^-1 / w^2
    n = 10
    nodes = rng.uniform(-1, 1, (n, 3))
    masses = rng.uniform(1.0, 3.0, n)
    model = dict(K=sp.csr_matrix((3 * n, 3 * n)), M=sp.diags(np.repeat(masses, 3)).tocsr(),
                 D=sp.csr_matrix((3 * n, 3 * n)), nodes=nodes, per=3,
                 points=[dict(name="all", kind="rigid", nodes=np.arange(n),
                              position=np.zeros(3), weights=np.ones(n))])
    names = [f"all:{d}" for d in DIRS]
    f = 2.0
    H = transfer(model, [f], names, names)[0]
    Mr = sum(mi * rigid_map(ri).T @ rigid_map(ri) for mi, ri in zip(masses, nodes))
    check("RBE2 over a free rigid body of point masses: -Mr^-1 / w^2",
          rel(H, -np.linalg.inv(Mr) / (2 * math.pi * f) ** 2), 1e-10)
    print("self-test", "failed" if failures else "passed")
    return failures == 0


# ---------------------------------------------------------------------------------------------


def split_names(text):
    return [int(x) if x.strip().isdigit() else x.strip() for x in text.split(",") if x.strip()]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model", nargs="?", type=pathlib.Path)
    ap.add_argument("--freqs", help="comma-separated frequencies in Hz (> 0)")
    ap.add_argument("--inputs", help="replace the scene's inputs (comma-separated names)")
    ap.add_argument("--outputs", help="replace the scene's outputs (comma-separated names)")
    ap.add_argument("--out", type=pathlib.Path, help="CSV file (default stdout)")
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args()
    if args.self_test:
        sys.exit(0 if self_test() else 1)
    if args.model is None or args.freqs is None:
        ap.error("MODEL_DIR and --freqs are needed (or --self-test)")
    model = read_model(args.model)
    inputs = split_names(args.inputs) if args.inputs else model["inputs"]
    outputs = split_names(args.outputs) if args.outputs else model["outputs"]
    freqs = [float(f) for f in args.freqs.split(",")]
    H = transfer(model, freqs, inputs, outputs)
    lines = ["f_hz,output,input,re,im"]
    for k, f in enumerate(freqs):
        for i, o in enumerate(outputs):
            for j, n in enumerate(inputs):
                lines.append(f"{f!r},{o},{n},{float(H[k, i, j].real)!r},{float(H[k, i, j].imag)!r}")
    text = "\n".join(lines) + "\n"
    if args.out:
        args.out.write_text(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
