"""Exports and imports (issue 33): the Burley fit, each target's parametrisation, files parsed by the
target's own reader (MaterialX's validator, a YAML parse of the HDRP asset, the Unreal/Blender scripts
run against fake `unreal`/`bpy` modules), round trips within the stated error, units, bad input."""
from __future__ import annotations

import ast
import math
import sys
import types

import numpy as np
import pytest
import yaml
from scipy.integrate import quad

from skinviewer.cli import main
from skinviewer.engine import exchange as X
from skinviewer.ground.settings import Settings, load_preset, with_values
from skinviewer.physics import engines as E
from skinviewer.physics.profiles import deon_skin_profile

EXT = {"hdrp": ".asset", "unreal": ".py", "materialx": ".mtlx", "openpbr": ".mtlx", "blender": ".py"}


# -- physics ---------------------------------------------------------------------------------------

def test_fit_recovers_a_burley_profile_exactly():
    A, d = np.array([0.8, 0.45, 0.2]), np.array([1.2, 0.4, 0.15])
    fit = E.fit_burley(lambda r: E.burley_profile(r, A, d))
    assert np.allclose(fit.A, A, rtol=1e-5) and np.allclose(fit.d, d, rtol=1e-5)
    assert np.all(fit.error < 1e-5) and np.all(fit.rd_error < 1e-4)


def test_fit_error_matches_an_independent_integral():
    """The stated loss (relative L2 of r R(r)) agrees with adaptive quadrature on linear r, which
    shares nothing with the fit's log grid."""
    fit = E.fit_burley(deon_skin_profile)
    for c in range(3):
        def f(r, c=c):
            return (r * (deon_skin_profile(np.array([r]))[0, c] - fit(np.array([r]))[0, c])) ** 2

        def g(r, c=c):
            return (r * deon_skin_profile(np.array([r]))[0, c]) ** 2
        pts = [0.05, 0.2, 0.5, 1, 2, 5]
        num = quad(f, 0, 60, points=pts, limit=400)[0]
        den = quad(g, 0, 60, points=pts, limit=400)[0]
        assert math.sqrt(num / den) == pytest.approx(fit.error[c], rel=2e-3)
    assert 0.2 < fit.error.min() and fit.error.max() < 0.6  # a single Burley lobe loses this much of d'Eon's six


def test_fixed_albedo_fits_only_d():
    fit = E.fit_burley(deon_skin_profile, fixed_albedo=[1, 1, 1])
    assert np.allclose(fit.A, 1.0) and np.all(fit.rd_error < 1e-6)


def test_specular_and_unit_conversions():
    assert E.f0_to_ior(0.028) == pytest.approx(1.4019, abs=1e-4)  # seed 002: F0 0.028 is IOR 1.4
    assert E.ior_to_f0(1.5) == pytest.approx(0.04)  # HDRP's DEFAULT_SPECULAR_VALUE
    assert E.ior_to_f0(E.f0_to_ior(0.05)) == pytest.approx(0.05)
    assert E.beckmann_to_roughness(0.3) == pytest.approx(math.sqrt(0.3))
    assert E.roughness_to_beckmann(E.beckmann_to_roughness(0.37)) == pytest.approx(0.37)
    # Unreal: d = 10 l_cm / (0.6 s_86(A)); s_86(0.8) = 1.05
    skin = E.unreal_skin([0.8] * 3, [1, 1, 1], 0.3)
    assert skin.d_mm == pytest.approx(np.full(3, 3.0 / (0.6 * 1.05)))
    # Christensen-Burley radius: l = s_89(A) d; s_89(0.8) = 1.1
    cb = E.cb_skin([0.8] * 3, [1, 0.5, 0.25], 2.2)
    assert cb.d_mm == pytest.approx([2.0, 1.0, 0.5])


def test_fit_edges_grid_quadrature_and_what_hdrp_and_the_skin_refuse():
    """Issue 36's mutation sample of engines.py. The grid's quadrature of int (r R)^2 dr against closed
    forms; a black channel fits A = 0 with a finite error; rd_error is relative (A fixed at 0.4 against a
    Burley profile of R_d = 0.5, eq. 2.84 integrating to A: |0.4 - 0.5| / 0.5 = 0.2); the fit's dict; HDRP's
    profile carries no albedo; a roughness outside [0, 1] and a bad HDRP distance are refused by name."""
    # r R = e^(-r) (R = e^(-r) / r): int_0^inf e^(-2r) dr = 1/2; r R = r e^(-r^2): int r^2 e^(-2 r^2) dr = sqrt(pi/2) / 8
    for prof, want in ((lambda r: np.exp(-r) / r, 0.5), (lambda r: np.exp(-r * r), math.sqrt(math.pi / 2) / 8)):
        g = E.r_grid(prof)
        f = g.r * prof(g.r)
        assert float(g.norm(f)) ** 2 == pytest.approx(want, rel=1e-4)
    A, d = np.array([0.6, 0.3, 0.0]), np.array([1.0, 0.5, 0.2])
    fit = E.fit_burley(lambda r: E.burley_profile(r, A, d))
    assert fit.A[2] == 0.0 and fit.d[2] == 1.0 and fit.error[2] == 0.0 and fit.rd_error[2] == 0.0
    assert fit.to_dict() == {"albedo": fit.A.tolist(), "d_mm": fit.d.tolist(), "error_rR": fit.error.tolist(),
                             "rd_target": fit.rd_target.tolist(), "rd_error": fit.rd_error.tolist()}
    half = E.fit_burley(lambda r: E.burley_profile(r, [0.5] * 3, [1.0] * 3), fixed_albedo=[0.4] * 3)
    np.testing.assert_allclose(half.rd_target, 0.5, rtol=1e-4)
    np.testing.assert_allclose(half.rd_error, 0.2, rtol=1e-3)
    hd = E.hdrp_skin((1.0, 0.5, 0.25), 2.0)
    assert hd.albedo_in_profile is False and E.unreal_skin([0.5] * 3, [1, 1, 1], 0.1).albedo_in_profile is True
    for r in (1.5, -0.1, math.nan):
        with pytest.raises(ValueError, match="^roughness must be in \\[0, 1\\]"):
            E.EngineSkin(np.full(3, 0.5), np.ones(3), roughness=r)
    with pytest.raises(ValueError, match="^scatteringDistance: expected 3 finite numbers"):
        E.hdrp_skin((1.0, math.nan, 1.0), 2.0)


@pytest.mark.parametrize("target", ["hdrp", "unreal", "cb"])
def test_parametrisations_invert(target):
    skin = E.EngineSkin([0.7, 0.4, 0.25], [0.9, 0.35, 0.2], 0.5, 1.38, albedo_in_profile=target != "hdrp")
    if target == "hdrp":
        v = E.hdrp_values(skin)
        back = E.hdrp_skin(v["scatteringDistance"], v["scatteringDistanceMultiplier"], v["ior"], v["smoothness"])
    elif target == "unreal":
        v = E.unreal_values(skin)
        back = E.unreal_skin(v["surface_albedo"], v["mean_free_path_color"], v["mean_free_path_distance"],
                             v["ior"], v["roughness"])
        assert np.allclose(back.A, skin.A)
    else:
        v = E.cb_values(skin)
        back = E.cb_skin(v["subsurface_color"], v["radius_color"], v["radius_scale_mm"], v["roughness"], v["ior"])
        assert np.allclose(back.A, skin.A)
    assert np.allclose(back.d_mm, skin.d_mm) and back.ior == pytest.approx(1.38) and back.roughness == pytest.approx(0.5)


# -- the targets' own readers ------------------------------------------------------------------------

def _export(tmp_path, target, s=None, **kw):
    out = tmp_path / f"skin{EXT[target]}"
    return X.export(s or Settings(), target, out, **kw), out


def test_hdrp_asset_parses_as_unity_yaml(tmp_path):
    r, out = _export(tmp_path, "hdrp")
    docs = X.parse_unity_yaml(out.read_text())
    mono = docs[0]["MonoBehaviour"]
    assert mono["m_Script"]["guid"] == X.HDRP_SCRIPT_GUID and mono["m_Version"] == 2
    p = mono["profile"]
    for k in ("scatteringDistance", "scatteringDistanceMultiplier", "transmissionTint", "texturingMode",
              "smoothnessMultipliers", "lobeMix", "diffuseShadingPower", "transmissionMode", "thicknessRemap",
              "worldScale", "ior"):
        assert k in p
    d = np.array([p["scatteringDistance"][c] for c in "rgb"]) * p["scatteringDistanceMultiplier"]
    assert d == pytest.approx(r.fit.d, rel=1e-6)
    assert max(p["scatteringDistance"][c] for c in "rgb") == 1
    assert p["ior"] == pytest.approx(E.f0_to_ior(0.028), rel=1e-6) and p["worldScale"] == 1
    meta = yaml.safe_load((tmp_path / "skin.asset.meta").read_text())
    assert meta["NativeFormatImporter"]["mainObjectFileID"] == 11400000 and len(meta["guid"]) == 32


@pytest.mark.parametrize("target", ["materialx", "openpbr"])
def test_mtlx_is_valid_materialx(tmp_path, target):
    import MaterialX as mx
    r, out = _export(tmp_path, target)
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(out))
    doc.importLibrary(X._library())
    ok, msg = doc.validate()
    assert ok, msg
    cat = "open_pbr_surface" if target == "openpbr" else "standard_surface"
    (sh,) = [n for n in doc.getNodes() if n.getCategory() == cat]
    scale = sh.getInput("subsurface_radius" if target == "openpbr" else "subsurface_scale")
    assert scale.getUnit() == "millimeter" and scale.getUnitType() == "distance"
    radius = sh.getInputValue("subsurface_radius_scale" if target == "openpbr" else "subsurface_radius")
    mfp = np.array(list(radius)) * scale.getValue()
    assert E.cb_d_mm(r.fit.A, mfp) == pytest.approx(r.fit.d, rel=1e-5)
    assert len(doc.getMaterialNodes()) == 1


class _Recorder:
    def __init__(self, log, name="obj"):
        self._log, self._name, self._props = log, name, {}

    def get_editor_property(self, k):
        return self._props.setdefault(k, _Recorder(self._log, k))

    def set_editor_property(self, k, v):
        self._props[k] = v
        self._log[k] = v


def _fake_unreal(log):
    m = types.ModuleType("unreal")
    m.LinearColor = lambda r, g, b, a: (r, g, b, a)
    m.SubsurfaceProfile = object
    tools = types.SimpleNamespace(create_asset=lambda name, folder, cls, fac: (log.setdefault("asset", (folder, name)),
                                                                                _Recorder(log))[1])
    m.AssetToolsHelpers = types.SimpleNamespace(get_asset_tools=lambda: tools)
    m.EditorAssetLibrary = types.SimpleNamespace(save_loaded_asset=lambda a: log.setdefault("saved", True))
    m.log = lambda msg: log.setdefault("message", msg)
    return m


def test_unreal_script_runs_against_a_fake_unreal(tmp_path, monkeypatch):
    r, out = _export(tmp_path, "unreal")
    src = out.read_text()
    ast.parse(src)
    log: dict = {}
    monkeypatch.setitem(sys.modules, "unreal", _fake_unreal(log))
    exec(compile(src, str(out), "exec"), {"__name__": "__main__"})  # noqa: S102 (the exported script, fake module)
    assert log["saved"] and log["asset"] == ("/Game/Skin", "skin")
    A = np.array(log["surface_albedo"][:3])
    mfp_mm = np.array(log["mean_free_path_color"][:3]) * log["mean_free_path_distance"] * 10.0
    assert A == pytest.approx(r.fit.A, rel=1e-6)
    assert E.unreal_d_mm(A, mfp_mm) == pytest.approx(r.fit.d, rel=1e-5)
    assert log["enable_burley"] is True and log["enable_mean_free_path"] is True
    assert log["ior"] == pytest.approx(E.f0_to_ior(0.028), rel=1e-6)


def test_blender_script_runs_against_a_fake_bpy(tmp_path, monkeypatch):
    r, out = _export(tmp_path, "blender")
    src = out.read_text()
    ast.parse(src)

    class Socket:
        default_value = None

    class Node:
        type = "BSDF_PRINCIPLED"

        def __init__(self):
            self.inputs = {k: Socket() for k in ("Base Color", "Subsurface Weight", "Subsurface Radius",
                                                  "Subsurface Scale", "Roughness", "IOR")}

    node = Node()
    mat = types.SimpleNamespace(use_nodes=False, node_tree=types.SimpleNamespace(nodes=[node]))
    bpy = types.ModuleType("bpy")
    bpy.data = types.SimpleNamespace(materials=types.SimpleNamespace(get=lambda n: None, new=lambda n: mat))
    bpy.context = types.SimpleNamespace(scene=types.SimpleNamespace(unit_settings=types.SimpleNamespace(scale_length=0.01)))
    monkeypatch.setitem(sys.modules, "bpy", bpy)
    exec(compile(src, str(out), "exec"), {"__name__": "__main__"})  # noqa: S102 (the exported script, fake module)
    ins = node.inputs
    assert mat.use_nodes and node.subsurface_method == "BURLEY"
    # 1 Blender unit = 1 cm here: Subsurface Scale is in scene units
    mfp_mm = np.array(ins["Subsurface Radius"].default_value) * ins["Subsurface Scale"].default_value * 10.0
    assert E.cb_d_mm(ins["Base Color"].default_value[:3], mfp_mm) == pytest.approx(r.fit.d, rel=1e-5)
    assert ins["Roughness"].default_value == pytest.approx(math.sqrt(0.3), rel=1e-6)


# -- round trips -------------------------------------------------------------------------------------

@pytest.mark.parametrize("target", ["hdrp", "unreal", "materialx", "openpbr", "blender"])
def test_round_trip_reproduces_the_profile_within_the_fit_error(tmp_path, target):
    s = Settings()
    r, out = _export(tmp_path, target, s)
    imp = X.read_any(out)
    assert imp.target == target
    cur = X.current_profile(s).profile
    err = E.relative_error(cur, imp.skin)
    assert err == pytest.approx(r.fit.error, abs=1e-4)  # what the file holds is the fit, nothing more lost
    assert np.allclose(imp.skin.d_mm, r.fit.d, rtol=1e-5)
    s2, gfit = X.settings_with(s, imp)
    assert s2.burley.mfp == pytest.approx(tuple(r.fit.d), rel=1e-5) and s2.burley.fit == "direct"
    assert len(s2.deon.gaussians) >= 3 and np.all(gfit.errors < 0.08)
    assert s2.specular.f0 == pytest.approx(0.028, rel=1e-5)


def test_round_trip_of_a_burley_technique_is_exact(tmp_path):
    s = with_values(Settings(), {"technique": "burley"})
    r, out = _export(tmp_path, "unreal", s)
    assert np.all(r.fit.error < 1e-5)
    imp = X.read_any(out)
    assert E.relative_error(X.current_profile(s).profile, imp.skin) == pytest.approx(np.zeros(3), abs=1e-5)


def test_units_survive_world_scale(tmp_path):
    """A head in mm (scene.mm_per_unit = 1) exports worldScale 0.001 m per unit; a default scene 1 = 1 m."""
    r, out = _export(tmp_path, "hdrp", with_values(Settings(), {"scene.mm_per_unit": 1.0}))
    assert X.read_any(out).metres_per_unit == pytest.approx(0.001)
    r, out = _export(tmp_path, "hdrp")
    assert X.read_any(out).metres_per_unit == pytest.approx(1.0)
    # the profile's distances stay in mm whatever the world scale
    assert X.read_any(out).skin.d_mm == pytest.approx(r.fit.d, rel=1e-6)


# -- the CLI and bad input -------------------------------------------------------------------------

def _cli(argv, capsys):
    code = main(argv)
    o = capsys.readouterr()
    return code, o.out, o.err


def test_export_cli_prints_the_loss_and_import_cli_writes_a_preset(tmp_path, capsys):
    out = tmp_path / "skin.mtlx"
    code, text, err = _cli(["export", "--to", "materialx", "--out", str(out)], capsys)
    assert code == 0, err
    assert "err r.R(r)" in text and "subsurface_color" in text and "roughness" in text
    preset = tmp_path / "imported.json"
    code, text, err = _cli(["import", str(out), "--preset-out", str(preset)], capsys)
    assert code == 0, err
    s = load_preset(preset)
    assert s.burley.fit == "direct" and len(s.deon.gaussians) >= 3


def _one_line(code, err):
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


HDRP_HEAD = ("%YAML 1.1\n%TAG !u! tag:unity3d.com,2011:\n--- !u!114 &11400000\nMonoBehaviour:\n"
             "  m_Script: {fileID: 11500000, guid: GUID, type: 3}\n  m_Name: x\n  profile:\n")


def _hdrp(tmp_path, body, guid=X.HDRP_SCRIPT_GUID, version=2):
    p = tmp_path / "x.asset"
    p.write_text(HDRP_HEAD.replace("GUID", guid) + body + f"  m_Version: {version}\n")
    return p


def test_bad_inputs_give_one_line(tmp_path, capsys):
    mat = tmp_path / "m.asset"
    mat.write_text("%YAML 1.1\n%TAG !u! tag:unity3d.com,2011:\n--- !u!21 &2100000\nMaterial:\n  m_Name: skin\n")
    assert "no MonoBehaviour" in _one_line(*_cli(["import", str(mat)], capsys)[::2])
    other = _hdrp(tmp_path, "    scatteringDistance: {r: 1, g: 1, b: 1, a: 1}\n", guid="0" * 32)
    assert "another script" in _one_line(*_cli(["import", str(other)], capsys)[::2])
    neg = _hdrp(tmp_path, "    scatteringDistance: {r: -1, g: 1, b: 1, a: 1}\n    scatteringDistanceMultiplier: 1\n")
    assert "must be > 0" in _one_line(*_cli(["import", str(neg)], capsys)[::2])
    nan = _hdrp(tmp_path, "    scatteringDistance: {r: .nan, g: 1, b: 1, a: 1}\n")
    assert "finite" in _one_line(*_cli(["import", str(nan)], capsys)[::2])
    js = tmp_path / "v.json"
    js.write_text('{"Roughness0": 1}')
    assert "which engine" in _one_line(*_cli(["import", str(js)], capsys)[::2])
    js.write_text('{"target": "unreal", "SurfaceAlbedo": [0.8, 0.5, 0.3], "MeanFreePathColor": [1, 0.5, 0.3], '
                  '"MeanFreePathDistance": "NaN"}')
    assert "finite" in _one_line(*_cli(["import", str(js)], capsys)[::2])
    binf = tmp_path / "x.uasset"
    binf.write_bytes(b"\xc1\x83\x2a\x9e\x00\xff")
    assert "not text" in _one_line(*_cli(["import", str(binf)], capsys)[::2])
    assert "folder" in _one_line(*_cli(["import", str(tmp_path)], capsys)[::2])
    bad = tmp_path / "bad.mtlx"
    bad.write_text("<materialx><bad")
    assert "not a MaterialX document" in _one_line(*_cli(["import", str(bad)], capsys)[::2])
    py = tmp_path / "evil.py"
    py.write_text("import os\nVALUES = dict(a=os.getcwd())\n")
    assert "not a literal" in _one_line(*_cli(["import", str(py)], capsys)[::2])


def test_newer_schema_imports_and_lists_unknown_fields(tmp_path, capsys):
    p = _hdrp(tmp_path, "    scatteringDistance: {r: 1, g: 0.5, b: 0.25, a: 1}\n    scatteringDistanceMultiplier: 2\n"
                        "    ior: 1.4\n    worldScale: 1\n    futureKnob: 3\n", version=7)
    code, out, err = _cli(["import", str(p)], capsys)
    assert code == 0, err
    assert "m_Version 7 is newer" in out and "skipped (not used here): profile.futureKnob" in out
    imp = X.read_any(p)
    assert imp.skin.d_mm == pytest.approx([2.0, 1.0, 0.5])


def test_mtlx_with_several_materials(tmp_path, capsys):
    import MaterialX as mx
    skin = E.EngineSkin([0.8, 0.5, 0.3], [1.0, 0.4, 0.2])
    doc = X.materialx_doc(skin, "a", "materialx")
    other = X.materialx_doc(E.EngineSkin([0.8, 0.5, 0.3], [2.0, 0.8, 0.4]), "b", "materialx")
    for child in other.getChildren():
        doc.addChildOfCategory(child.getCategory(), child.getName()).copyContentFrom(child)
    p = tmp_path / "two.mtlx"
    p.write_text(mx.writeToXmlString(doc))
    line = _one_line(*_cli(["import", str(p)], capsys)[::2])
    assert "2 surface shaders" in line and "a_shader" in line and "b_shader" in line
    imp = X.read_any(p, material="b")
    assert imp.skin.d_mm == pytest.approx([2.0, 0.8, 0.4], rel=1e-5)


def test_export_bad_out_and_nothing_half_written(tmp_path, capsys, monkeypatch):
    assert "writes a .asset" in _one_line(*_cli(["export", "--to", "hdrp", "--out", str(tmp_path / "x.yaml")],
                                               capsys)[::2])
    assert list(tmp_path.iterdir()) == []
    real = X.atomic_write_text

    def fail_on_meta(path, text):
        if str(path).endswith(".meta"):
            raise OSError(28, "No space left on device")
        real(path, text)
    monkeypatch.setattr(X, "atomic_write_text", fail_on_meta)
    with pytest.raises(OSError):
        X.export(Settings(), "hdrp", tmp_path / "skin.asset")
    assert list(tmp_path.iterdir()) == []  # the .asset without its .meta is not left behind


def test_export_of_a_profile_lab_model(tmp_path, capsys):
    """--profile-model fits the model itself (not the Gaussians fitted to it); Burley's own model
    exports without loss, a bad material name is one line."""
    out = tmp_path / "b.py"
    code, text, err = _cli(["export", "--to", "unreal", "--profile-model", "burley:Skin1", "--out", str(out)], capsys)
    assert code == 0, err
    assert "Burley (dmfp) of Skin1" in text and text.count(" 0.00%") >= 6  # shape and R_d, three channels
    r = X.export(Settings(), "unreal", out, model="dipole:Skin1")
    assert r.description == "the Skin1 dipole" and np.all((r.fit.error > 0.1) & (r.fit.error < 0.6))
    assert "unknown material" in _one_line(*_cli(["export", "--to", "unreal", "--profile-model", "dipole:Nope",
                                                   "--out", str(tmp_path / "c.py")], capsys)[::2])
    assert not (tmp_path / "c.py").exists()


def test_json_of_the_values_an_engine_shows(tmp_path, capsys):
    """Unreal's details panel names (spaces), with fields this tool has no use for: read, listed."""
    js = tmp_path / "unreal.json"
    js.write_text('{"Surface Albedo": [0.8, 0.8, 0.8], "Mean Free Path Color": [1, 0.5, 0.25], '
                  '"Mean Free Path Distance": 0.3, "Boundary Color Bleed": [1, 1, 1], "Extinction Scale": 1}')
    code, out, err = _cli(["import", str(js)], capsys)
    assert code == 0, err
    assert "skipped (not used here): Boundary Color Bleed, Extinction Scale" in out
    imp = X.read_any(js)
    assert imp.target == "unreal"
    assert imp.skin.d_mm == pytest.approx(np.array([1, 0.5, 0.25]) * 3.0 / (0.6 * 1.05))
