"""A .mtlx as a texbake material: --material FILE.mtlx on the command line (a real
process), a document's XML as a material (the service's way in), the bake's maps, GLB
(the Khronos validator) and baked .mtlx (MaterialX's validate), and the errors."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import MaterialX as mx
import numpy as np
import pytest
from conftest import ROOT, run_cli

from texbake.errors import MtlxError
from texbake.materials import evaluate_material, parse_material
from texbake.mtlx.material import material_from_mtlx
from texbake.output.images import read_image

DATA = Path(__file__).resolve().parents[2] / "data" / "mtlx"
MARBLE = DATA / "standard_surface_marble_solid.mtlx"  # MaterialX's resources/Materials/Examples/StandardSurface
TOOLS = ROOT / "tools"


def assert_valid_glb(path):
    """No errors from the Khronos glTF validator (tools/validate-gltf.mjs, as tests/texbake/output)."""
    if shutil.which("node") is None or not (TOOLS / "node_modules" / "gltf-validator").is_dir():
        message = "the Khronos glTF validator is not set up: run `npm ci` in tools/ (scripts/run does it)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(message)
        pytest.skip(message)
    out = subprocess.run(["node", str(TOOLS / "validate-gltf.mjs"), str(path)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    issues = json.loads(out.stdout)["issues"]
    assert issues["numErrors"] == 0, issues["messages"]


def validated(path: Path):
    """The MaterialX document at ``path``, validated against the standard library."""
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(path))
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.setDataLibrary(lib)
    valid, message = doc.validate()
    assert valid, message
    return doc


def test_marble_bakes_onto_a_shared_mesh(meshes, tmp_path):
    out = tmp_path / "out"
    done = run_cli("bake", meshes / "suzanne.ply", "-o", out, "--material", MARBLE, "--size", "128")
    assert done.returncode == 0, done.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["material"]["nodes"]["base_color"]["op"] == "mtlx"
    assert_valid_glb(out / "suzanne.glb")
    image = read_image(out / "base_color.png")[..., :3]  # decoded to linear
    covered = read_image(out / "coverage.png")[..., 0] > 0.5
    colours = image[covered]
    # the marble mixes (0.8, 0.8, 0.8) and (0.1, 0.1, 0.3): red equals green, blue at least red, all in between
    np.testing.assert_allclose(colours[:, 0], colours[:, 1], atol=0.01)
    assert (colours[:, 2] >= colours[:, 0] - 0.01).all() and colours[:, 0].min() < 0.4 and colours[:, 0].max() > 0.7
    doc = validated(out / "suzanne.mtlx")
    shader = doc.getNode("SR_marble1")
    image_node = shader.getInput("base_color").getConnectedNode()
    assert image_node.getCategory() == "image" and (out / image_node.getInputValue("file")).is_file()
    assert shader.getInput("subsurface_color").getNodeGraphString() == "NG_marble1"  # not baked: kept as it was


def test_unsupported_node_exits_2_with_one_line(tmp_path, meshes):
    doc = MARBLE.read_text().replace('<position name="obj_pos" type="vector3" />',
                                     '<image name="obj_pos" type="vector3"><input name="file" type="filename" value="p.exr" /></image>')
    path = tmp_path / "image.mtlx"
    path.write_text(doc)
    done = run_cli("bake", meshes / "suzanne.ply", "-o", tmp_path / "out", "--material", path, "--size", "32")
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "node 'NG_marble1/obj_pos': image: an image node reads a file" in lines[0] and "supported:" in lines[0]


def test_xml_text_is_a_material():
    """parse_material takes a document's XML (as the service's material setting does)."""
    m = parse_material(MARBLE.read_text())
    assert m.name == "Marble_3D" and m.channels == ["base_color", "roughness"]
    p = np.random.default_rng(0).uniform(-1, 1, (50, 3))
    direct = material_from_mtlx(MARBLE)
    np.testing.assert_array_equal(evaluate_material(m, p, bounds=[[-1] * 3, [1] * 3])["base_color"],
                                  evaluate_material(direct, p, bounds=[[-1] * 3, [1] * 3])["base_color"])


def test_texcoord_graph_is_refused_before_the_bake():
    text = MARBLE.read_text().replace('<position name="obj_pos" type="vector3" />',
                                      '<texcoord name="uv" type="vector2" />\n<convert name="obj_pos" type="vector3">'
                                      '<input name="in" type="vector2" nodename="uv" /></convert>')
    with pytest.raises(MtlxError, match="reads the texture coordinates"):
        material_from_mtlx(text)


def test_missing_file(tmp_path):
    with pytest.raises(MtlxError, match=r"nothere.mtlx: cannot read"):
        material_from_mtlx(tmp_path / "nothere.mtlx")


@pytest.mark.parametrize("mesh", ["bunny.ply", "fandisk.obj", "Duck.glb", "suzanne_blender_uv.obj"])
def test_marble_on_more_shared_meshes(meshes, tmp_path, mesh):
    from texbake import bake_mesh

    result = bake_mesh(meshes / mesh, {"material": material_from_mtlx(MARBLE), "size": 96})
    written = result.save(tmp_path)
    assert_valid_glb(written["glb"]["path"])
    validated(Path(written["mtlx"]["path"]))
    assert result.report["material"]["nodes"]["base_color"]["evaluations"] > 0


def test_a_node_two_channels_read_is_evaluated_once_a_batch(monkeypatch):
    """base_color and roughness from the marble's one fractal3d: its three Perlin octaves
    evaluated once for the batch (not once per channel), the values those of each channel alone."""
    from texbake.mtlx import noise

    text = MARBLE.read_text().replace('<input name="specular_roughness" type="float" value="0.1" />',
                                      '<input name="specular_roughness" type="float" nodegraph="NG_marble1" output="rough" />')
    text = text.replace('<output name="out" type="color3" nodename="color_mix" />',
                        '<output name="out" type="color3" nodename="color_mix" />\n    <output name="rough" type="float" nodename="noise" />')
    m = material_from_mtlx(text)
    calls = []
    perlin = noise.perlin_float
    monkeypatch.setattr(noise, "perlin_float", lambda p: calls.append(len(p)) or perlin(p))
    p = np.random.default_rng(8).uniform(-1, 1, (300, 3))
    both = evaluate_material(m, p, bounds=[[-1] * 3, [1] * 3])
    assert len(calls) == 3, calls  # three octaves, once
    alone = evaluate_material(m, p, bounds=[[-1] * 3, [1] * 3], channels=["roughness"])
    assert len(calls) == 6
    np.testing.assert_array_equal(both["roughness"], alone["roughness"])


def test_describe_mtlx_is_what_an_editor_shows():
    """The marble: its material (the one material_from_mtlx makes), shader, each channel's
    inputs (graph or constant), the subsurface inputs it gives but texbake does not bake;
    a document of two materials and no base colour warns of both."""
    from texbake.mtlx.material import describe_mtlx

    text = MARBLE.read_text()
    got = describe_mtlx(text, path="marble.mtlx")
    assert got["material"] == material_from_mtlx(text, path="marble.mtlx").model_dump(mode="json")
    assert got["shader"] == {"category": "standard_surface", "name": "SR_marble1"}
    assert got["channels"] == {"base_color": {"inputs": ["base_color", "base"], "graph": True},
                               "roughness": {"inputs": ["specular_roughness"], "graph": False}}
    assert len(got["warnings"]) == 1 and got["warnings"][0].endswith(
        ": subsurface, subsurface_color; the .mtlx a bake writes keeps them as they are"), got["warnings"]
    two = """<?xml version="1.0"?>
<materialx version="1.39">
  <gltf_pbr name="A" type="surfaceshader"><input name="roughness" type="float" value="0.3" /></gltf_pbr>
  <gltf_pbr name="B" type="surfaceshader"><input name="metallic" type="float" value="1" /></gltf_pbr>
  <surfacematerial name="MA" type="material"><input name="surfaceshader" type="surfaceshader" nodename="A" /></surfacematerial>
  <surfacematerial name="MB" type="material"><input name="surfaceshader" type="surfaceshader" nodename="B" /></surfacematerial>
</materialx>"""
    got = describe_mtlx(two, path="two.mtlx")
    assert got["material"]["name"] == "MA" and got["material"]["roughness"] == pytest.approx(0.3)
    assert got["warnings"] == ["the document has 2 materials: texbake reads 'MA', not 'MB'",
                               "the shader gives no base colour: the material's is 0.8 grey"]
