"""A sparsemor ROM as a free-floating flexible body in EXUDYN (docs/design.md §3.9).

    sparsemor reduce bar --method linefit --extra-interface 5 --ref-freqs 50,100,200,400,800 \\
        --keep-basis --out rom
    sparsemor export rom --model bar --format exudyn --out rom_exudyn
    python3 examples/exudyn_flexible_body.py rom_exudyn [--json]

Builds EXUDYN's ObjectFFRFreducedOrder from the export (nodes, the rigid-free elastic basis
Phi, the full M and K for the body's inertia terms), then
  (a) linearizes it and prints its eigenfrequencies next to the ROM's elastic ones;
  (b) applies a harmonic unit force at the first input DoF in the linearized system and prints
      the elastic deformation at the outputs in the floating frame, Phi[outputs] q, at --freq;
  (c) runs a free transient (initial velocity, spin and elastic deflection, trapezoidal rule)
      and prints the drift of linear and angular momentum.
With --json the numbers are printed as one JSON object (the integration test reads it).

Markers: interface/output DoF d of the model is mesh node d // 3, direction d % 3 (x, y, z);
the export lists them as `output_node`, `output_dir` (and `input_*`). A marker on that node is
    mbs.AddMarker(MarkerSuperElementPosition(bodyNumber=oFFRF, meshNodeNumbers=[node],
                                             weightingFactors=[1]))
and its `d % 3` component is the DoF (global frame; in the floating frame after A^T).
"""
import argparse
import json

import numpy as np
import scipy.sparse as sp

import exudyn as exu
from exudyn.FEM import FEMinterface, ObjectFFRFreducedOrderInterface
from exudyn.itemInterface import LoadForceVector, MarkerSuperElementPosition


def load_export(directory):
    """The export's arrays and an FEMinterface holding what ObjectFFRFreducedOrderInterface reads."""
    z = np.load(f"{directory}/flexible_body.npz")
    n = 3 * z["nodes"].shape[0]

    def csr(name):
        # symmetric matrices: the CSC arrays sparsemor writes are the CSR arrays too
        return sp.csr_matrix((z[f"{name}_data"], z[f"{name}_indices"], z[f"{name}_indptr"]),
                             shape=(n, n))

    fem = FEMinterface()
    fem.nodes = {"Position": z["nodes"]}
    fem.massMatrix = csr("massMatrix")
    fem.stiffnessMatrix = csr("stiffnessMatrix")
    fem.modeBasis = {"matrix": z["modeBasis"], "type": "NormalModes"}
    fem.surface = []  # the model directory has no elements: no surface triangles are known
    return z, fem


def build(fem, velocity=(0, 0, 0), omega=(0, 0, 0), modal=None, damping=(0.0, 0.0)):
    """A system with the free-floating body; returns (system container, mbs, the body's item
    dictionary, the ObjectFFRFreducedOrderInterface)."""
    cms = ObjectFFRFreducedOrderInterface(fem, rigidBodyNodeType="NodeType.RotationRotationVector")
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    body = cms.AddObjectFFRFreducedOrder(mbs, positionRef=[0, 0, 0], initialVelocity=list(velocity),
                                         initialAngularVelocity=list(omega),
                                         massProportionalDamping=damping[0],
                                         stiffnessProportionalDamping=damping[1])
    if modal is not None:
        mbs.SetNodeParameter(body["nGenericODE2"], "initialCoordinates", list(modal))
    return SC, mbs, body, cms


def eigenfrequencies(fem):
    """(a): eigenfrequencies (Hz) of the linearized free body, the six rigid ones dropped."""
    _, mbs, _, _ = build(fem)
    mbs.Assemble()
    lam, _ = mbs.ComputeODE2Eigenvalues(useAbsoluteValues=False)
    lam = np.sort(np.real(lam))
    return lam, np.sqrt(np.abs(lam[6:])) / (2 * np.pi)


def harmonic(fem, z, freq_hz):
    """(b): steady-state elastic deformation at the outputs, in the floating frame, for a unit
    harmonic force at the first input DoF: EXUDYN's linearized system (M, K, D of the frame
    and modal coordinates), the force's generalized load from EXUDYN's right-hand side, and
    the floating-frame deformation Phi[outputs] q_modal of the complex amplitude."""
    d = int(z["inputs"][0])
    _, mbs, body, _ = build(fem, damping=rayleigh(z))
    marker = mbs.AddMarker(MarkerSuperElementPosition(bodyNumber=body["oFFRFreducedOrder"],
                                                      meshNodeNumbers=[d // 3],
                                                      weightingFactors=[1]))
    force = [0.0, 0.0, 0.0]
    force[d % 3] = 1.0
    mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=force))
    mbs.Assemble()
    M, K, D = mbs.ComputeLinearizedSystem()
    solver = exu.MainSolverImplicitSecondOrder()
    settings = exu.SimulationSettings()
    settings.solution.file.write = False  # no solution/ in the working directory
    solver.InitializeSolver(mbs, settings)
    solver.ComputeODE2RHS(mbs)
    f = np.array(solver.GetSystemResidual())[: M.shape[0]]
    w = 2 * np.pi * freq_hz
    x = np.linalg.solve(K - w * w * M + 1j * w * D, f)
    phi = z["modeBasis"]
    r = phi.shape[1]
    return phi[z["outputs"], :] @ x[-r:]


def rayleigh(z):
    """(alpha, beta) of the model's Rayleigh damping, (0, 0) without."""
    return tuple(z["rayleigh"]) if "rayleigh" in z.files else (0.0, 0.0)


def momentum(mbs, body, fem_mass, nodes):
    """Linear and angular momentum (about the global origin) of the deformed moving body:
    velocities of all mesh nodes (global frame) weighted with the full mass matrix; valid when
    M = M_s (x) I_3 (consistent mass of isotropic solid elements, equal lumped nodal masses),
    which commutes with the frame rotation, as EXUDYN's body itself assumes."""
    obj = body["oFFRFreducedOrder"]
    nn = nodes.shape[0]
    v = np.array([mbs.GetObjectOutputSuperElement(obj, exu.OutputVariableType.Velocity, i)
                  for i in range(nn)])
    r = np.array([mbs.GetObjectOutputSuperElement(obj, exu.OutputVariableType.Position, i)
                  for i in range(nn)])
    p = (fem_mass @ v.reshape(-1)).reshape(nn, 3)
    return p.sum(axis=0), np.cross(r, p).sum(axis=0)


def transient(fem, z, t_end, steps):
    """(c): free transient; returns the relative drift of linear and angular momentum."""
    modal = 1e-6 * np.ones(z["modeBasis"].shape[1])
    SC, mbs, body, _ = build(fem, velocity=(0.1, -0.2, 0.05), omega=(20.0, 10.0, -30.0), modal=modal)
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = steps
    s.timeIntegration.generalizedAlpha.spectralRadius = 1.0  # trapezoidal rule, no dissipation
    s.timeIntegration.newton.relativeTolerance = 1e-12
    s.timeIntegration.newton.absoluteTolerance = 1e-14
    s.timeIntegration.verboseMode = 0
    s.solution.file.write = False
    p0, h0 = momentum(mbs, body, fem.massMatrix, z["nodes"])
    mbs.SolveDynamic(s)
    p1, h1 = momentum(mbs, body, fem.massMatrix, z["nodes"])
    return (float(np.linalg.norm(p1 - p0) / np.linalg.norm(p0)),
            float(np.linalg.norm(h1 - h0) / np.linalg.norm(h0)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("export", help="directory written by `sparsemor export --format exudyn`")
    ap.add_argument("--json", action="store_true", help="print the numbers as one JSON object")
    ap.add_argument("--freq", type=float, default=300.0, help="frequency (Hz) of the harmonic force")
    ap.add_argument("--t-end", type=float, default=0.1, help="length (s) of the free transient")
    ap.add_argument("--steps", type=int, default=4000, help="time steps of the free transient")
    args = ap.parse_args()
    z, fem = load_export(args.export)
    lam, f_exu = eigenfrequencies(fem)
    f_rom = z["eigenfrequencies_hz"]
    y = harmonic(fem, z, args.freq)
    out = {"rigid_lambdas": lam[:6].tolist(), "exudyn_hz": f_exu.tolist(), "rom_hz": f_rom.tolist(),
           "freq_hz": args.freq, "input": int(z["inputs"][0]),
           "response_re": y.real.tolist(), "response_im": y.imag.tolist()}
    out["drift_linear"], out["drift_angular"] = transient(fem, z, args.t_end, args.steps)
    if args.json:
        print(json.dumps(out))
    else:
        for a, b in zip(f_exu, f_rom):
            print(f"EXUDYN {a:12.4f} Hz   ROM {b:12.4f} Hz   rel diff {abs(a - b) / b:.1e}")
        print(f"harmonic unit force at DoF {out['input']}, {args.freq} Hz: deformation at the outputs")
        for d, v in zip(z["outputs"], y):
            print(f"  DoF {d:6d}  {v.real:+.6e} {v.imag:+.6e}i")
        print(f"free transient, {args.t_end} s in {args.steps} steps: relative momentum drift "
              f"linear {out['drift_linear']:.2e}, angular {out['drift_angular']:.2e}")


if __name__ == "__main__":
    main()
