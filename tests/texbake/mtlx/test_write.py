"""The baked .mtlx: each baked input an image node on its map (a normal through a
normalmap), the shader's factors set to 1, MaterialX's validate() passing."""

from pathlib import Path

import MaterialX as mx
import numpy as np
import pytest

from texbake import bake_mesh
from texbake.materials import evaluate_material
from texbake.mtlx.material import material_from_mtlx

GLTF = """<?xml version="1.0"?>
<materialx version="1.39">
  <position name="p" type="vector3" />
  <multiply name="p4" type="vector3"><input name="in1" type="vector3" nodename="p" /><input name="in2" type="float" value="4" /></multiply>
  <cellnoise3d name="cells" type="float"><input name="position" type="vector3" nodename="p4" /></cellnoise3d>
  <noise3d name="bumps" type="vector3">
    <input name="position" type="vector3" nodename="p4" /><input name="amplitude" type="vector3" value="0.2, 0.2, 0" />
    <input name="pivot" type="float" value="0.5" />
  </noise3d>
  <combine3 name="n" type="vector3">
    <input name="in1" type="float" nodename="bumps_x" /><input name="in2" type="float" nodename="bumps_y" /><input name="in3" type="float" value="1" />
  </combine3>
  <extract name="bumps_x" type="float"><input name="in" type="vector3" nodename="bumps" /><input name="index" type="integer" value="0" /></extract>
  <extract name="bumps_y" type="float"><input name="in" type="vector3" nodename="bumps" /><input name="index" type="integer" value="1" /></extract>
  <normalmap name="nm" type="vector3"><input name="in" type="vector3" nodename="n" /></normalmap>
  <gltf_pbr name="SR" type="surfaceshader">
    <input name="base_color" type="color3" value="0.5, 0.3, 0.2" />
    <input name="metallic" type="float" nodename="cells" />
    <input name="emissive" type="color3" value="1, 0.5, 0" />
    <input name="emissive_strength" type="float" value="0.5" />
    <input name="normal" type="vector3" nodename="nm" />
  </gltf_pbr>
  <surfacematerial name="Tiles" type="material"><input name="surfaceshader" type="surfaceshader" nodename="SR" /></surfacematerial>
</materialx>"""


@pytest.fixture(scope="module")
def baked(tmp_path_factory, meshes):
    out = tmp_path_factory.mktemp("gltf")
    result = bake_mesh(meshes / "suzanne.ply", {"material": material_from_mtlx(GLTF), "size": 64})
    result.save(out)
    return out, result


def test_channels_of_a_gltf_pbr():
    m = material_from_mtlx(GLTF)
    assert m.channels == ["base_color", "metallic", "normal", "emissive"]
    np.testing.assert_allclose(m.constant("emissive"), [0.5, 0.25, 0.0])  # emissive * emissive_strength
    p = np.random.default_rng(4).uniform(-1, 1, (200, 3))
    normal = evaluate_material(m, p, channels=["normal"])["normal"]
    assert normal[:, 2].min() == 1.0 and 0.2 < normal[:, 0].min() and normal[:, 0].max() < 0.8  # the normalmap's in


def test_written_document_validates(baked):
    out, result = baked
    path = out / "suzanne.mtlx"
    assert result.report["outputs"]["mtlx"]["path"] == "suzanne.mtlx"
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(path))
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.setDataLibrary(lib)
    valid, message = doc.validate()
    assert valid, message
    shader = doc.getNode("SR")
    for name, channel in [("metallic", "metallic"), ("base_color", "base_color"), ("emissive", "emissive")]:
        node = shader.getInput(name).getConnectedNode()
        assert node.getCategory() == "image", name
        assert Path(out / node.getInputValue("file")).is_file() and node.getInputValue("file").startswith(channel)
    colour = shader.getInput("base_color").getConnectedNode().getInput("file")
    assert colour.getColorSpace() == "srgb_texture"
    assert shader.getInput("metallic").getConnectedNode().getInput("file").getColorSpace() == ""  # data: no transform
    assert shader.getInputValue("emissive_strength") == 1.0  # its product is in the emissive map
    normalmap = shader.getInput("normal").getConnectedNode()
    assert normalmap.getCategory() == "normalmap" and normalmap.getInput("in").getConnectedNode().getCategory() == "image"


def test_usd_binds_every_map(baked):
    """<mesh>.usda opens with usd-core, its mesh bound to a UsdPreviewSurface reading each baked map."""
    from pxr import Usd, UsdShade

    out, result = baked
    stage = Usd.Stage.Open(str(out / "suzanne.usda"))
    assert stage is not None and result.report["outputs"]["usd"]["path"] == "suzanne.usda"
    mesh = next(p for p in stage.Traverse() if p.GetTypeName() == "Mesh")
    material, _ = UsdShade.MaterialBindingAPI(mesh).ComputeBoundMaterial()
    surface = material.ComputeSurfaceSource()[0]
    assert surface.GetIdAttr().Get() == "UsdPreviewSurface"
    bound = {}
    for name in ("diffuseColor", "metallic", "normal", "emissiveColor"):
        source = surface.GetInput(name).GetConnectedSources()[0][0].source
        texture = UsdShade.Shader(source.GetPrim())
        assert texture.GetIdAttr().Get() == "UsdUVTexture", name
        bound[name] = texture.GetInput("file").Get().path
        assert (out / bound[name]).is_file(), name
    assert bound["metallic"].endswith("metallic.png") and bound["emissiveColor"].endswith("emissive.png")
    assert surface.GetInput("diffuseColor").GetConnectedSources()[0][0].source.GetPrim().GetName() == "Albedo"


def test_normalmap_scale():
    """A normalmap's scale scales the tangent-space xy before it is normalised (mx_normalmap)."""
    scaled = GLTF.replace('<normalmap name="nm" type="vector3"><input name="in" type="vector3" nodename="n" />',
                          '<normalmap name="nm" type="vector3"><input name="in" type="vector3" nodename="n" />'
                          '<input name="scale" type="float" value="2" />')
    p = np.random.default_rng(4).uniform(-1, 1, (200, 3))
    plain = 2.0 * evaluate_material(material_from_mtlx(GLTF), p, channels=["normal"])["normal"] - 1.0
    twice = 2.0 * evaluate_material(material_from_mtlx(scaled), p, channels=["normal"])["normal"] - 1.0
    expected = plain * [2.0, 2.0, 1.0]
    np.testing.assert_allclose(twice, expected / np.linalg.norm(expected, axis=1, keepdims=True), atol=1e-12)
