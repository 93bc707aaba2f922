"""Pinocchio (pip `pin`) on the same Puma 560 as model/puma560.toml, timed per call.

Builds the arm from the standard DH table and the Robotics Toolbox inertial values (no motor
inertia, no friction), checks it against lockstep's committed Robotics Toolbox numbers, then
times crba (M), nonLinearEffects with gravity off (C q̇), computeGeneralizedGravity (g), rnea
(inverse dynamics) and aba (forward dynamics) the way lockstep's criterion benchmark does:
many calls at one state, best of several repeats. Usage: python3 bench/pinocchio_puma560.py
"""
import time
import numpy as np
import pinocchio as pin

DH = [  # d, a, alpha (standard DH, theta = q)
    (0.0, 0.0, np.pi / 2),
    (0.0, 0.4318, 0.0),
    (0.15005, 0.0203, -np.pi / 2),
    (0.4318, 0.0, np.pi / 2),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.0, 0.0),
]
MASS = [0.0, 17.4, 4.8, 0.82, 0.34, 0.09]
COM = [[0, 0, 0], [-0.3638, 0.006, 0.2275], [-0.0203, -0.0141, 0.070], [0, 0.019, 0], [0, 0, 0], [0, 0, 0.032]]
IDIAG = [[0, 0.35, 0], [0.13, 0.524, 0.539], [0.066, 0.086, 0.0125], [1.8e-3, 1.3e-3, 1.8e-3], [0.3e-3, 0.4e-3, 0.3e-3], [0.15e-3, 0.15e-3, 0.04e-3]]


def puma():
    """Joint i rotates about z of DH frame i-1; link i's inertia lives in DH frame i."""
    model = pin.Model()
    parent = 0
    placement = pin.SE3.Identity()
    for i, (d, a, alpha) in enumerate(DH):
        jid = model.addJoint(parent, pin.JointModelRZ(), placement, f"j{i+1}")
        # Frame i relative to the joint frame: Trans_z(d) Trans_x(a) Rot_x(alpha).
        r = pin.utils.rotate("x", alpha)
        t = pin.SE3(r, np.array([a, 0.0, d]))
        inertia = pin.Inertia(MASS[i], np.array(COM[i], dtype=float), np.diag(IDIAG[i]))
        model.appendBodyToJoint(jid, t.act(inertia), pin.SE3.Identity())
        parent = jid
        placement = t
    model.gravity = pin.Motion(np.array([0, 0, -9.81, 0, 0, 0]))
    return model


def best_ns(f, n=20000, repeats=7):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for _ in range(n):
            f()
        best = min(best, (time.perf_counter_ns() - t0) / n)
    return best


def main():
    model = puma()
    data = model.createData()
    q = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    g0 = pin.computeGeneralizedGravity(model, data, q)
    print("g(0) =", np.round(g0, 4), "(toolbox: [0, 37.4837, 0.2489, 0, 0, 0])")
    q = np.array([0.1, -0.4, 0.7, 0.3, -0.2, 0.5])
    v = np.array([0.5, -1.0, 0.8, 1.2, -0.7, 0.9])
    a = np.array([0.3, 0.2, -0.4, 1.0, 0.5, -0.6])
    tau = pin.rnea(model, data, q, v, a)
    model0 = puma()
    model0.gravity = pin.Motion.Zero()
    data0 = model0.createData()
    print(f"pinocchio {pin.__version__}; per call, best of 7 x 20000 (Python loop overhead included,")
    overhead = best_ns(lambda: None)
    print(f"  measured empty-call overhead {overhead:.0f} ns, subtracted below)")
    for name, f in [
        ("crba (M)", lambda: pin.crba(model, data, q)),
        ("nonLinearEffects, g = 0 (C q̇)", lambda: pin.nonLinearEffects(model0, data0, q, v)),
        ("computeGeneralizedGravity (g)", lambda: pin.computeGeneralizedGravity(model, data, q)),
        ("rnea (τ)", lambda: pin.rnea(model, data, q, v, a)),
        ("aba (q̈)", lambda: pin.aba(model, data, q, v, tau)),
    ]:
        print(f"  {name:34s} {best_ns(f) - overhead:8.0f} ns")


if __name__ == "__main__":
    main()
