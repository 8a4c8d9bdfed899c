"""USD checked by OpenUSD itself (Pixar's usd-core, `pxr`): every file the
export writes opens as a stage whose BasisCurves prims are valid and hold the
HDF5 frames; and grooms written by pxr grow into rods (from_curves).

Run by ctest with the module on PYTHONPATH and the command-line tool in
MANYRODS_CLI.
"""

import os
import subprocess
import textwrap

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

import manyrods

SCENES = os.environ.get("MANYRODS_SCENES", os.path.join(os.path.dirname(__file__), "..", "..", "tools", "scenes"))
CLI = os.environ["MANYRODS_CLI"]

# Example scenes, each briefly: strands with a turning head (a moving sphere
# collider), cables on a floor plane, the seed cantilever (one rectangular rod).
EXPORTED = [("hair_turn.toml", 0.12), ("cable_pile.toml", 0.05), ("seed_cantilever.toml", 0.3)]


def run_and_export(tmp_path, scene, duration):
    h5, usda = tmp_path / (scene + ".h5"), tmp_path / (scene + ".usda")
    subprocess.run([CLI, "run", os.path.join(SCENES, scene), "-o", str(h5), "--duration", str(duration),
                    "--no-progress"], check=True, capture_output=True)
    subprocess.run([CLI, "export", str(h5), "--usd", str(usda)], check=True, capture_output=True)
    return h5, usda


def test_every_exported_file_is_a_valid_stage_holding_the_hdf5_frames(tmp_path):
    for scene, duration in EXPORTED:
        h5, usda = run_and_export(tmp_path, scene, duration)
        out = manyrods.read_output(str(h5))
        frames = len(out["time"])
        stage = Usd.Stage.Open(str(usda))
        assert stage, f"{scene}: OpenUSD does not open the export"
        # time: frame indices, played at the output rate
        interval = out["time"][1] - out["time"][0]
        assert stage.GetTimeCodesPerSecond() == stage.GetFramesPerSecond()
        np.testing.assert_allclose(stage.GetFramesPerSecond(), 1 / interval, rtol=1e-9)
        assert stage.GetStartTimeCode() == 0 and stage.GetEndTimeCode() == frames - 1
        assert UsdGeom.GetStageUpAxis(stage) in (UsdGeom.Tokens.y, UsdGeom.Tokens.z)

        curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
        groups = out["group_names"]
        assert len(curves) == len(groups), f"{scene}: one BasisCurves prim per rod group"
        offsets, rod_group = np.asarray(out["node_offsets"]), np.asarray(out["rod_group"])
        x = out["node_position"]
        for g, c in enumerate(curves):
            rods = np.flatnonzero(rod_group == g)
            counts = np.asarray(c.GetCurveVertexCountsAttr().Get())
            np.testing.assert_array_equal(counts, offsets[rods + 1] - offsets[rods])
            assert c.GetTypeAttr().Get() == UsdGeom.Tokens.linear
            assert c.GetWrapAttr().Get() == UsdGeom.Tokens.nonperiodic
            widths = np.asarray(c.GetWidthsAttr().Get())
            assert c.GetWidthsInterpolation() == UsdGeom.Tokens.vertex
            assert len(widths) == counts.sum()
            np.testing.assert_allclose(widths, np.repeat(np.asarray(out["rod_width"])[rods], counts), rtol=1e-7)
            samples = c.GetPointsAttr().GetTimeSamples()
            assert samples == list(range(frames)), f"{scene}: a points sample per frame"
            nodes = np.concatenate([np.arange(offsets[r], offsets[r + 1]) for r in rods])
            for t in samples:
                p = np.asarray(c.GetPointsAttr().Get(t))
                assert p.shape == (counts.sum(), 3)
                # point3f holds the HDF5 positions to float precision
                np.testing.assert_allclose(p, x[int(t)][nodes], rtol=0, atol=1e-6 * max(1.0, np.abs(x).max()))
                # the stored extent is what OpenUSD computes (points grown by half the widths)
                stored = np.asarray(c.GetExtentAttr().Get(t))
                computed = np.asarray(UsdGeom.Boundable.ComputeExtentFromPlugins(c, Usd.TimeCode(t)))
                np.testing.assert_allclose(stored, computed, rtol=0, atol=1e-6 * max(1.0, np.abs(computed).max()))


def write_groom(path, curves, widths=None, primvar_widths=False, time_sampled=False, basis=None):
    """A groom as a content tool writes one, with pxr."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/groom")
    c = UsdGeom.BasisCurves.Define(stage, "/groom/guides")
    if basis:
        c.CreateTypeAttr(UsdGeom.Tokens.cubic)
        c.CreateBasisAttr(basis)
    else:
        c.CreateTypeAttr(UsdGeom.Tokens.linear)
    c.CreateCurveVertexCountsAttr(Vt.IntArray([len(k) for k in curves]))
    pts = Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for k in curves for p in k])
    if time_sampled:
        c.CreatePointsAttr().Set(pts, Usd.TimeCode(3.0))
        c.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0)] * len(pts)), Usd.TimeCode(7.0))
    else:
        c.CreatePointsAttr(pts)
    if widths is not None:
        w = Vt.FloatArray([float(widths)] * len(pts))
        if primvar_widths:
            pv = UsdGeom.PrimvarsAPI(c).CreatePrimvar("widths", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
            pv.Set(w)
        else:
            c.CreateWidthsAttr(w)
            c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    stage.GetRootLayer().Save()


def guides(n=5, points=9):
    out = []
    for i in range(n):
        s = np.linspace(0, 1, points)
        out.append(np.stack([0.01 * i + 0.002 * np.sin(3 * s), 0.003 * s * s, 0.08 * s], axis=1))
    return out


def groom_scene(tmp_path, groom_file, rods_extra=""):
    text = textwrap.dedent(f"""
        [simulation]
        dt = 2e-5
        duration = 0.01
        gravity = [0.0, 0.0, -9.81]
        [[rods]]
        name = "guides"
        from_curves = {{ file = "{groom_file}" }}
        material = {{ density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }}
        damping = {{ tau_shear = 1e-3, tau_extension = 1e-3 }}
        stiff = true
    """) + rods_extra
    return manyrods.parse_scene(text, str(tmp_path / "groom.toml"))


def test_a_groom_written_by_pxr_grows_into_rods(tmp_path):
    g = guides()
    for name, kw in [("widths.usda", {}), ("primvars.usda", {"primvar_widths": True}),
                     ("animated.usda", {"time_sampled": True})]:
        write_groom(tmp_path / name, g, widths=1.6e-4, **kw)
        scene = groom_scene(tmp_path, name)
        assert scene.rod_count == len(g), name
        batch = scene.build_batch()
        for r, k in enumerate(g):  # the curve's own points, as float32 in the file
            np.testing.assert_allclose(batch.node_position[:, batch.node_range(r)].T, k, rtol=0, atol=1e-8)
            rod = scene.rods[r]
            assert rod.section.a == np.float32(1.6e-4) / 2  # radius: half the width
            assert rod.root == "clamped"
        batch.step(batch.dt, 200)
        tip = batch.node_position[:, batch.node_range(0).stop - 1]
        assert np.all(np.isfinite(tip)) and tip[2] < g[0][-1][2]  # it sags under gravity


def test_a_cubic_groom_is_resampled_and_the_root_stays_on_its_curve(tmp_path):
    g = guides(n=2, points=10)
    write_groom(tmp_path / "cubic.usda", g, widths=1e-4, basis=UsdGeom.Tokens.catmullRom)
    try:
        groom_scene(tmp_path, "cubic.usda")
        raise AssertionError("a cubic groom without elements")
    except ValueError as e:
        assert "give `elements`" in str(e)
    text = (tmp_path / "cubic.usda").read_text()
    scene = manyrods.parse_scene(
        f"""[simulation]
dt = 2e-5
duration = 0.01
[[rods]]
from_curves = {{ file = "cubic.usda", elements = 24 }}
material = {{ density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }}
""", str(tmp_path / "c.toml"))
    assert "catmullRom" in text
    for r in range(2):
        nodes = np.asarray(scene.rods[r].nodes)
        assert nodes.shape == (25, 3)
        # nonperiodic Catmull-Rom starts at the second control point and ends at the second to last
        np.testing.assert_allclose(nodes[0], g[r][1], atol=1e-8)
        np.testing.assert_allclose(nodes[-1], g[r][-2], atol=1e-8)
        seg = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
        assert seg.max() / seg.min() < 1.01  # equal arc length, chords within the curvature's sagitta


def test_prim_transforms_are_applied_as_openusd_computes_them(tmp_path):
    # A groom under a parent Xform (translate, rotateXYZ, uniform scale) whose
    # curves prim has its own ops (orient, an inverted rotateZ, a translate with
    # a suffix, a matrix transform): the rods' nodes are where OpenUSD's
    # ComputeLocalToWorldTransform puts the points (independent: pxr), and the
    # widths grow by the scale. A !resetXformStack! drops the parent's.
    g = guides(n=2, points=6)
    for reset in (False, True):
        path = tmp_path / f"xf{int(reset)}.usda"
        stage = Usd.Stage.CreateNew(str(path))
        head = UsdGeom.Xform.Define(stage, "/head")
        hx = UsdGeom.Xformable(head)
        hx.AddTranslateOp().Set(Gf.Vec3d(0.1, -0.2, 0.3))
        hx.AddRotateXYZOp().Set(Gf.Vec3f(10, 20, 30))
        hx.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
        c = UsdGeom.BasisCurves.Define(stage, "/head/guides")
        cx = UsdGeom.Xformable(c)
        if reset:
            cx.SetResetXformStack(True)
        cx.AddTranslateOp(opSuffix="pivot").Set(Gf.Vec3d(0.01, 0.02, 0.03))
        cx.AddOrientOp().Set(Gf.Quatf(0.9, 0.1, 0.3, 0.2).GetNormalized())
        rz = cx.AddRotateZOp()
        rz.Set(25.0)
        m = Gf.Matrix4d().SetTranslate(Gf.Vec3d(0.0, 0.05, 0.0)) * Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 1, 0), 40))
        cx.AddTransformOp().Set(m)
        cx.AddRotateZOp(isInverseOp=True)  # undoes nothing here: !invert!xformOp:rotateZ after the matrix
        c.CreateTypeAttr(UsdGeom.Tokens.linear)
        c.CreateCurveVertexCountsAttr(Vt.IntArray([len(k) for k in g]))
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for k in g for p in k]))
        c.CreateWidthsAttr(Vt.FloatArray([1e-4] * sum(len(k) for k in g)))
        c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        stage.GetRootLayer().Save()
        world = UsdGeom.Xformable(stage.GetPrimAtPath("/head/guides")).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        scene = groom_scene(tmp_path, path.name)
        pts = iter([p for k in g for p in k])
        for r, k in enumerate(g):
            want = np.array([list(world.Transform(Gf.Vec3d(*map(float, np.float32(next(pts)))))) for _ in k])
            np.testing.assert_allclose(np.asarray(scene.rods[r].nodes), want, rtol=0, atol=1e-7)
        scale = 1.0 if reset else 2.0
        np.testing.assert_allclose(scene.rods[0].section.a, scale * np.float32(1e-4) / 2, rtol=1e-6)


def test_a_binary_usd_groom_is_read_through_openusd(tmp_path):
    # .usdc: the Python module converts it with pxr (the command line refuses it with that advice)
    g = guides(n=3, points=7)
    write_groom(tmp_path / "groom.usda", g, widths=1.2e-4)
    Usd.Stage.Open(str(tmp_path / "groom.usda")).Export(str(tmp_path / "groom.usdc"))
    a, b = groom_scene(tmp_path, "groom.usda"), groom_scene(tmp_path, "groom.usdc")
    assert b.rod_count == 3
    for r in range(3):
        np.testing.assert_array_equal(np.asarray(a.rods[r].nodes), np.asarray(b.rods[r].nodes))


def test_a_tapered_groom_exports_its_widths_per_vertex_and_grows_back_tapered(tmp_path):
    # A groom of tapered strands (taper = { root, tip }) run and exported:
    # the USD widths are per vertex, the nodes' own (2 r at each node, the
    # mean of its elements'), OpenUSD's computed extent matches the stored
    # one, and the export grown back with from_curves is tapered as the
    # original (each element's width within 1e-6 relative: float widths).
    scene = manyrods.parse_scene(textwrap.dedent("""
        [simulation]
        dt = 2e-5
        duration = 0.002
        output_interval = 0.001
        gravity = [0.0, 0.0, -9.81]
        [[rods]]
        name = "strand"
        count = 2
        elements = 8
        length = 0.05
        placement = { kind = "grid", spacing = [0.01, 0.01] }
        section = { shape = "circle", taper = { root = 1e-4, tip = 4e-5 } }
        material = { density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }
        stiff = true
    """), str(tmp_path / "t.toml"))
    batch = scene.build_batch()
    batch.step(2e-5, 10)
    batch.save(str(tmp_path / "t.h5"))
    subprocess.run([CLI, "export", str(tmp_path / "t.h5"), "--usd", str(tmp_path / "t.usda")], check=True,
                   capture_output=True)
    stage = Usd.Stage.Open(str(tmp_path / "t.usda"))
    curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
    assert len(curves) == 1
    w = np.asarray(curves[0].GetWidthsAttr().Get())
    assert curves[0].GetWidthsInterpolation() == UsdGeom.Tokens.vertex and w.shape == (18,)
    f = np.array(scene.rods[0].section_scale)
    want = 2e-4 * np.concatenate([[f[0]], 0.5 * (f[:-1] + f[1:]), [f[-1]]])
    np.testing.assert_allclose(w[:9], want, rtol=1e-6)
    grown = manyrods.parse_scene(textwrap.dedent("""
        [simulation]
        dt = 2e-5
        duration = 0.002
        [[rods]]
        from_curves = { file = "t.usda" }
        material = { density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }
    """), str(tmp_path / "g.toml"))
    g = grown.rods[0]
    mean = w[:9].mean()
    np.testing.assert_allclose(np.array(g.section_scale) * mean, 0.5 * (w[:8] + w[1:9]), rtol=1e-6)
