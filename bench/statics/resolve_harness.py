# bench/statics/resolve_harness.py: the warm re-solve of a 10-cable harness (40 elements each)
# after its far connector (a host motion) moves 1 cm, on one core:
#   OMP_NUM_THREADS=1 PYTHONPATH=build/python .venv/bin/python bench/statics/resolve_harness.py [--contact]
# Without --contact: ten cables side by side, no contact between them, the connector moving up.
# With --contact: five cables along x (between a fixed connector and the driven one) lie across
# five along y (clamped at both ends) and press on them under gravity (rod-rod contact), the
# connector moving down. (bench/RESULTS.md "Static re-solve of a harness".)
import sys, time, textwrap, manyrods

def cables(name, count, start, direction, spacing, across, tip):
    return textwrap.dedent("""\
        [[rods]]
        name = "%s"
        count = %d
        elements = 40
        length = 1.0
        start = %s
        direction = %s
        normal = [0.0, 0.0, 1.0]
        placement = { kind = "grid", spacing = [%g, %g], columns = %d, axes = [%s, [0.0, 0.0, 1.0]] }
        section = { shape = "circle", radius = 0.003 }
        material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }
        root = "clamped"
        tip = %s
        """) % (name, count, start, direction, spacing, spacing, count, across, tip)

contact = "--contact" in sys.argv[1:]
connector = '{ kind = "clamped", motion = "host", name = "connector" }'
text = '[simulation]\ndt = "auto"\nduration = 10.0\nprecision = "double"\ngravity = [0.0, 0.0, -9.81]\n'
if contact:
    text += "[contact]\nrod_rod = true\n"
    text += cables("upper", 5, "[0.0, -0.08, 0.006]", "[1.0, 0.0, 0.0]", 0.04, "[0.0, 1.0, 0.0]", connector)
    text += cables("lower", 5, "[0.1, -0.5, 0.0]", "[0.0, 1.0, 0.0]", 0.2, "[1.0, 0.0, 0.0]", '"clamped"')
else:
    text += cables("cable", 10, "[0.0, 0.0, 0.0]", "[1.0, 0.0, 0.0]", 0.02, "[0.0, 1.0, 0.0]", connector)
b = manyrods.parse_scene(text, "harness.toml").build_batch()
up = -0.01 if contact else 0.01  # (the upper cables pressed down on the lower ones)

def solve(label, **kw):
    t0 = time.perf_counter(); r = b.solve_static(**kw); t1 = time.perf_counter()
    print("%s: %.1f ms, %d iterations, %d increments, residual %.2e N" % (label, 1e3 * (t1 - t0), r["iterations"], r["load_increments"], r["residual_force"]))

solve("cold solve")
for k in range(1, 6):
    b.set_driver_pose("connector", translation=[0.0, 0.0, up * k], time=float(k))
    solve("1 cm move %d" % k, at=float(k))
if not contact:
    for steps in (1, 2):
        b.set_driver_pose("connector", translation=[0.0, 0.0, 0.05 + 0.01 * steps], time=5.0 + steps)
        solve("load_steps=%d" % steps, load_steps=steps, at=5.0 + steps)
