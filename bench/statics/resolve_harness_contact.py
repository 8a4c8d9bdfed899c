# bench/statics/resolve_harness_contact.py: the warm re-solve of a 10-cable harness WITH contact
# between the cables (40 elements each): five cables along x, clamped between a fixed connector and
# one driven by the host, lie across five cables along y (clamped at both ends) and press on them
# under gravity; the connector moves down 1 cm at a time. On one core:
#   OMP_NUM_THREADS=1 PYTHONPATH=build/python .venv/bin/python bench/statics/resolve_harness_contact.py
# (bench/RESULTS.md "Static re-solve of a harness", with contact).
import time, textwrap, manyrods
scene = manyrods.parse_scene(textwrap.dedent("""\
    [simulation]
    dt = "auto"
    duration = 10.0
    precision = "double"
    gravity = [0.0, 0.0, -9.81]
    [contact]
    rod_rod = true
    [[rods]]
    name = "upper"
    count = 5
    elements = 40
    length = 1.0
    start = [0.0, -0.08, 0.006]
    direction = [1.0, 0.0, 0.0]
    normal = [0.0, 0.0, 1.0]
    placement = { kind = "grid", spacing = [0.04, 0.04], columns = 5, axes = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }
    section = { shape = "circle", radius = 0.003 }
    material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }
    root = "clamped"
    tip = { kind = "clamped", motion = "host", name = "connector" }
    [[rods]]
    name = "lower"
    count = 5
    elements = 40
    length = 1.0
    start = [0.1, -0.5, 0.0]
    direction = [0.0, 1.0, 0.0]
    normal = [0.0, 0.0, 1.0]
    placement = { kind = "grid", spacing = [0.2, 0.2], columns = 5, axes = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]] }
    section = { shape = "circle", radius = 0.003 }
    material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }
    root = "clamped"
    tip = "clamped"
    """), "harness_contact.toml")
b = scene.build_batch()
t0 = time.perf_counter(); r = b.solve_static(); t1 = time.perf_counter()
print("cold solve: %.1f ms, %d iterations, %d increments, residual %.2e N" % (1e3 * (t1 - t0), r["iterations"], r["load_increments"], r["residual_force"]))
for k in range(1, 6):
    b.set_driver_pose("connector", translation=[0.0, 0.0, -0.01 * k], time=float(k))
    t0 = time.perf_counter(); r = b.solve_static(at=float(k)); t1 = time.perf_counter()
    print("1 cm move %d: %.1f ms, %d iterations, %d increments, residual %.2e N" % (k, 1e3 * (t1 - t0), r["iterations"], r["load_increments"], r["residual_force"]))
