"""Pinocchio 4 (pip `pin`) reading lockstep's URDFs: reference values for generated/tests/urdf.rs.

For each URDF shipped in model/urdf/ that the tests compare (the Staubli TX40 from FIGAROH,
the Panda, and the UR5 with its y axes and rpy origins), Pinocchio builds the fixed-base model from the URDF itself and evaluates, at ten
random states (seeded), the inertia matrix M (crba), gravity g (computeGeneralizedGravity),
the Coriolis matrix C (computeCoriolisMatrix) and C(q, qd) qd (nonLinearEffects - g), inverse
dynamics tau (rnea) and forward dynamics qdd (aba) for a random torque. The numbers are
written as Rust constants to generated/tests/data/pinocchio_<model>.rs, which is committed;
Pinocchio reads each URDF with its rpy angles that lie within 1e-9 rad of a multiple of pi/2
set to that multiple, as lockstep reads them (URDFs print pi/2 as 1.57079632679, 5e-12 rad
short, which moves the UR5's C qd by 1e-10 relative: the input's rounding, not a difference of
the two dynamics codes).
run again only to refresh them:

    pip install pin==4.1.0
    python3 bench/pinocchio_urdf.py
"""
import os
import re
import tempfile
import numpy as np
import pinocchio as pin

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
# name, URDF, whether forward dynamics is also compared with the last joint locked (the TX40's
# link 6 has no inertia about its axis in the URDF: its full M is singular, in Pinocchio's aba
# as in lockstep's forward dynamics, so its q̈ is compared on joints 1-5 with q6 locked).
MODELS = [("tx40", "model/urdf/tx40.urdf", True), ("panda_urdf", "model/urdf/panda.urdf", False),
          ("ur5", "model/urdf/ur5.urdf", False)]


def rust_array(v):
    v = np.asarray(v)
    if v.ndim == 2:
        return "[" + ", ".join(rust_array(r) for r in v) + "]"
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def snapped_urdf(path):
    """The URDF text with rpy angles within 1e-9 of k*pi/2 written as k*pi/2 (to 17 digits)."""

    def snap(x):
        k = round(x / (np.pi / 2))
        return repr(k * (np.pi / 2)) if abs(x - k * np.pi / 2) < 1e-9 else repr(x)

    text = open(path).read()
    return re.sub(r'rpy="([^"]*)"', lambda m: 'rpy="' + " ".join(snap(float(v)) for v in m.group(1).split()) + '"', text)


def main():
    for name, rel, lock_last in MODELS:
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as tmp:
            tmp.write(snapped_urdf(os.path.join(ROOT, rel)))
        model = pin.buildModelFromUrdf(tmp.name)
        os.unlink(tmp.name)
        data = model.createData()
        nv = model.nv
        rng = np.random.default_rng(20261128)
        states = []
        for _ in range(10):
            q = rng.uniform(-np.pi, np.pi, nv)
            qd = rng.uniform(-2.0, 2.0, nv)
            qdd = rng.uniform(-3.0, 3.0, nv)
            tau_in = rng.uniform(-5.0, 5.0, nv)
            m = pin.crba(model, data, q)
            m = np.triu(m) + np.triu(m, 1).T
            g = pin.computeGeneralizedGravity(model, data, q).copy()
            c = pin.computeCoriolisMatrix(model, data, q, qd).copy()
            cqd = pin.nonLinearEffects(model, data, q, qd).copy() - g
            tau = pin.rnea(model, data, q, qd, qdd).copy()
            acc = pin.aba(model, data, q, qd, tau_in).copy()
            locked = None
            if lock_last:
                # The last joint locked at q[-1]: Pinocchio's reduced model of the first nv-1.
                reduced = pin.buildReducedModel(model, [model.njoints - 1], q)
                rdata = reduced.createData()
                locked = pin.aba(reduced, rdata, q[:-1], qd[:-1], tau_in[:-1]).copy()
            states.append((q, qd, qdd, tau_in, m, g, c, cqd, tau, acc, locked))
        out = os.path.join(ROOT, "generated", "tests", "data", f"pinocchio_{name}.rs")
        with open(out, "w") as f:
            f.write(f"// Printed by bench/pinocchio_urdf.py with Pinocchio {pin.__version__} from {rel}. Do not edit.\n")
            f.write(f"pub const NV: usize = {nv};\n")
            f.write("#[rustfmt::skip]\npub const STATES: [super::PinocchioState<NV>; 10] = [\n")
            for (q, qd, qdd, tau_in, m, g, c, cqd, tau, acc, _) in states:
                f.write("    super::PinocchioState {\n")
                for k, v in [("q", q), ("qd", qd), ("qdd", qdd), ("tau_in", tau_in), ("m", m), ("g", g),
                             ("c", c), ("cqd", cqd), ("tau", tau)]:
                    f.write(f"        {k}: {rust_array(v)},\n")
                f.write(f"        qdd_of_tau_in: {'None' if lock_last else 'Some(' + rust_array(acc) + ')'},\n")
                f.write("    },\n")
            f.write("];\n")
            if lock_last:
                f.write("/// Forward dynamics with the last joint locked: q̈ of the others for tau_in's first nv-1.\n")
                f.write("#[rustfmt::skip]\npub const LOCKED_LAST_QDD: [[f64; NV - 1]; 10] = [\n")
                for st in states:
                    f.write(f"    {rust_array(st[10])},\n")
                f.write("];\n")
        print(f"{name}: nv {nv}, wrote {out}")


if __name__ == "__main__":
    main()
