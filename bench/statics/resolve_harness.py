# bench/statics/resolve_harness.py: the warm re-solve of a 10-cable harness (40 elements each, no
# contact between cables) after its far connector (a host motion) moves 1 cm, on one core:
#   OMP_NUM_THREADS=1 PYTHONPATH=build/python .venv/bin/python bench/statics/resolve_harness.py
# (bench/RESULTS.md "Static re-solve of a harness").
import time, textwrap, manyrods
scene = manyrods.parse_scene(textwrap.dedent("""\
    [simulation]
    dt = "auto"
    duration = 10.0
    precision = "double"
    gravity = [0.0, 0.0, -9.81]
    [[rods]]
    name = "cable"
    count = 10
    elements = 40
    length = 1.0
    direction = [1.0, 0.0, 0.0]
    normal = [0.0, 0.0, 1.0]
    placement = { kind = "grid", spacing = [0.02, 0.02], columns = 10, axes = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }
    section = { shape = "circle", radius = 0.003 }
    material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }
    root = "clamped"
    tip = { kind = "clamped", motion = "host", name = "connector" }
    """), "harness.toml")
b = scene.build_batch()
t0 = time.perf_counter(); r = b.solve_static(); t1 = time.perf_counter()
print("cold solve: %.1f ms, %d iterations, %d increments" % (1e3 * (t1 - t0), r["iterations"], r["load_increments"]))
for k in range(1, 6):
    b.set_driver_pose("connector", translation=[0.0, 0.0, 0.01 * k], time=float(k))
    t0 = time.perf_counter(); r = b.solve_static(at=float(k)); t1 = time.perf_counter()
    print("1 cm move %d: %.1f ms, %d iterations, %d increments, residual %.2e N" % (k, 1e3 * (t1 - t0), r["iterations"], r["load_increments"], r["residual_force"]))
for steps in (1, 2):
    b.set_driver_pose("connector", translation=[0.0, 0.0, 0.05 + 0.01 * steps], time=5.0 + steps)
    t0 = time.perf_counter(); r = b.solve_static(load_steps=steps, at=5.0 + steps); t1 = time.perf_counter()
    print("load_steps=%d: %.1f ms, %d iterations, %d increments" % (steps, 1e3 * (t1 - t0), r["iterations"], r["load_increments"]))
