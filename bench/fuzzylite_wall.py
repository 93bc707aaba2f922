"""Reference values for tests/control.rs: evaluate lockstep's FLL rule tables with fuzzylite.

    python3 -m venv /tmp/fl && /tmp/fl/bin/pip install pyfuzzylite==8.0.6
    /tmp/fl/bin/python bench/fuzzylite_wall.py RULES.fll > tests/data/fuzzylite_wall_rules.txt

RULES.fll is the `rules.fll` that `lockstep wall` writes (Kubica table with the Figure 5.6
modifications of model/control/freedom6s_wall.toml). Points: 300 pseudo-random (q, dq) over
and beyond the universes (fuzzylite's lock-range clamps them), and the example of 5.5.3.
"""
import random
import sys

import fuzzylite as fl

engine = fl.FllImporter().from_file(sys.argv[1])
q = engine.input_variable("q")
dq = engine.input_variable("dq")
u = engine.output_variable("u")
random.seed(3)
points = [(random.uniform(-0.6, 0.75), random.uniform(-11.0, 11.0)) for _ in range(300)]
points += [(x, 1.8) for x in (-0.0125, -0.025, 0.0, 0.004, -0.3)]
print(f"# fuzzylite {fl.__version__}: q (rad) dq (rad/s) u (N m)")
for a, b in points:
    q.value = a
    dq.value = b
    engine.process()
    value = u.value.item() if hasattr(u.value, "item") else u.value
    print(f"{a!r} {b!r} {float(value)!r}")
