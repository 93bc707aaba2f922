"""Reference values of the Puma 560 from Peter Corke's Robotics Toolbox for Python.

Run once (`pip install roboticstoolbox-python`); the numbers it prints are committed in
generated/tests/puma560.rs. Motor inertia (Jm·G²) and friction are switched off so that the
toolbox computes the rigid-body model that model/puma560.toml describes.
"""
import numpy as np
import roboticstoolbox as rtb

robot = rtb.models.DH.Puma560()
for link in robot.links:
    link.Jm = 0.0
    link.B = 0.0
    link.Tc = [0.0, 0.0]
print("# gravity", robot.gravity)
np.set_printoptions(precision=17, floatmode="unique")
states = {
    "qz": robot.qz,
    "qn": robot.qn,
    "qr": robot.qr,
}
qd = np.array([0.5, -1.0, 0.8, 1.2, -0.7, 0.9])
qdd = np.array([0.3, 0.2, -0.4, 1.0, 0.5, -0.6])
for name, q in states.items():
    q = np.array(q, dtype=float)
    print(f"# {name} = {q.tolist()}")
    print("M =", robot.inertia(q).tolist())
    print("g =", robot.gravload(q).tolist())
    print("Cqd =", (robot.coriolis(q, qd) @ qd).tolist())
    print("C =", robot.coriolis(q, qd).tolist())
    print("tau =", robot.rne(q, qd, qdd).tolist())
print("# qd =", qd.tolist(), " qdd =", qdd.tolist())
