"""Reading .mtlx documents: the shader's channels, nodegraph-defined nodes expanded from
the library's own definitions, defaults and geometric properties, and the errors."""

from pathlib import Path

import glsl_reference as ref
import numpy as np
import pytest

from texbake.errors import MtlxError
from texbake.mtlx import evaluate_mtlx, read_document
from texbake.mtlx.document import Ref

DATA = Path(__file__).resolve().parents[2] / "data" / "mtlx"
MARBLE = DATA / "standard_surface_marble_solid.mtlx"  # MaterialX's resources/Materials/Examples/StandardSurface


def document(body: str, shader: str, category: str = "standard_surface") -> str:
    """A document of ``body`` (nodes) and a ``category`` shader with the inputs ``shader``."""
    return f"""<?xml version="1.0"?>
<materialx version="1.39">
{body}
  <{category} name="SR" type="surfaceshader">
{shader}
  </{category}>
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR" />
  </surfacematerial>
</materialx>"""


def test_marble_channels():
    doc = read_document(MARBLE)
    assert doc.shader_category == "standard_surface" and doc.material_name == "Marble_3D"
    assert isinstance(doc.channels["base_color"], Ref)
    np.testing.assert_allclose(doc.channels["roughness"], [0.1], rtol=1e-7)
    assert set(doc.channels) == {"base_color", "roughness"}  # subsurface_color is no texbake channel


def test_marble_equals_its_graph_written_out():
    """The example graph on 10,000 points against its nodes written out by hand with the
    literal GLSL noise (glsl_reference), to 1e-5."""
    p = np.random.default_rng(11).uniform(-1.0, 1.0, (10_000, 3))
    got = evaluate_mtlx(MARBLE, p)["base_color"]
    noise = np.array([ref.mx_fractal3d_noise_float(q * 4.0, 3, 2.0, 0.5) for q in p])
    t = (0.5 + 0.5 * np.sin(6.0 * p.sum(axis=1) + 3.0 * noise)) ** 3.0
    bg, fg = np.float32([0.8, 0.8, 0.8]), np.float32([0.1, 0.1, 0.3])  # MaterialX holds colours in float32
    np.testing.assert_allclose(got, bg * (1 - t[:, None]) + fg * t[:, None], rtol=0, atol=1e-5)
    assert got[:, 2].std() > 0.05


def test_nodegraph_definitions_expanded():
    """range (a nodegraph in the library: remap, gamma, clamp), separate3 and convert are
    the library's own graphs; unset inputs take their definition's defaults."""
    body = """  <position name="p" type="vector3" />
  <convert name="pc" type="color3"><input name="in" type="vector3" nodename="p" /></convert>
  <separate3 name="s" type="multioutput"><input name="in" type="color3" nodename="pc" /></separate3>
  <range name="r" type="float">
    <input name="in" type="float" nodename="s" output="outg" />
    <input name="inlow" type="float" value="-1" />
    <input name="gamma" type="float" value="2" />
    <input name="doclamp" type="boolean" value="true" />
  </range>
  <combine3 name="c" type="color3">
    <input name="in1" type="float" nodename="r" /><input name="in2" type="float" nodename="s" output="outb" />
  </combine3>"""
    doc = read_document(document(body, '<input name="base_color" type="color3" nodename="c" />'))
    assert {op.category for op in doc.ops.values()} >= {"position", "remap", "power", "clamp", "combine3"}
    p = np.random.default_rng(1).uniform(-2.0, 2.0, (1000, 3))
    got = evaluate_mtlx(doc, p)["base_color"]
    x = (p[:, 1] + 1.0) / 2.0  # remap from [-1, 1]
    expected_r = np.clip(np.sign(x) * np.abs(x) ** 0.5, 0.0, 1.0)  # range's gamma: pow(x, 1/gamma), then clamp
    np.testing.assert_allclose(got[:, 0], expected_r, atol=1e-6)
    np.testing.assert_allclose(got[:, 1], p[:, 2], atol=1e-12)
    np.testing.assert_allclose(got[:, 2], 0.0)


def test_hsv_round_trip_and_luminance():
    body = """  <position name="p" type="vector3" />
  <convert name="pc" type="color3"><input name="in" type="vector3" nodename="p" /></convert>
  <rgbtohsv name="hsv" type="color3"><input name="in" type="color3" nodename="pc" /></rgbtohsv>
  <hsvtorgb name="rgb" type="color3"><input name="in" type="color3" nodename="hsv" /></hsvtorgb>
  <luminance name="lum" type="color3"><input name="in" type="color3" nodename="pc" /></luminance>
  <extract name="y" type="float"><input name="in" type="color3" nodename="lum" /><input name="index" type="integer" value="1" /></extract>"""
    shader = '<input name="base_color" type="color3" nodename="rgb" />\n<input name="specular_roughness" type="float" nodename="y" />'
    p = np.random.default_rng(2).uniform(0.0, 1.0, (1000, 3))
    out = evaluate_mtlx(document(body, shader), p)
    np.testing.assert_allclose(out["base_color"], p, atol=1e-9)
    np.testing.assert_allclose(out["roughness"][:, 0], p @ np.float32([0.2722287, 0.6740818, 0.0536895]), atol=1e-7)


def test_shader_factors_multiply():
    """standard_surface's base_color is base * base_color: both baked into the channel."""
    shader = '<input name="base" type="float" value="0.5" />\n<input name="base_color" type="color3" value="0.2, 0.4, 0.8" />'
    doc = read_document(document("", shader))
    np.testing.assert_allclose(doc.channels["base_color"], [0.1, 0.2, 0.4], rtol=1e-6)


@pytest.mark.parametrize("category, inputs", [("gltf_pbr", ("base_color", "roughness", "metallic")),
                                              ("open_pbr_surface", ("base_color", "specular_roughness", "base_metalness")),
                                              ("UsdPreviewSurface", ("diffuseColor", "roughness", "metallic"))])
def test_other_shaders(category, inputs):
    body = '  <position name="p" type="vector3" />\n  <noise3d name="n" type="float"><input name="position" type="vector3" nodename="p" /></noise3d>'
    shader = "\n".join([f'<input name="{inputs[0]}" type="color3" value="0.1, 0.2, 0.3" />',
                        f'<input name="{inputs[1]}" type="float" nodename="n" />', f'<input name="{inputs[2]}" type="float" value="1" />'])
    doc = read_document(document(body, shader, category))
    assert isinstance(doc.channels["roughness"], Ref)
    np.testing.assert_allclose(doc.channels["metallic"], [1.0])
    p = np.random.default_rng(3).uniform(-5, 5, (100, 3))
    np.testing.assert_allclose(evaluate_mtlx(doc, p)["roughness"][:, 0], [ref.mx_perlin_noise_float(q) for q in p], atol=1e-12)


def test_image_is_unsupported_naming_node_and_category():
    body = '  <image name="wood" type="color3"><input name="file" type="filename" value="wood.png" /></image>'
    with pytest.raises(MtlxError, match=r"^<mtlx>: node 'wood': image: an image node reads a file.*\(supported: .*noise3d"):
        read_document(document(body, '<input name="base_color" type="color3" nodename="wood" />'))


def test_shading_node_is_unsupported():
    body = '  <viewdirection name="v" type="vector3" />\n  <dotproduct name="d" type="float"><input name="in1" type="vector3" nodename="v" /></dotproduct>'
    with pytest.raises(MtlxError, match=r"node 'v': viewdirection: a shading node"):
        read_document(document(body, '<input name="specular_roughness" type="float" nodename="d" />'))


def test_bad_documents():
    with pytest.raises(MtlxError, match="not a readable MaterialX document"):
        read_document("<materialx><unclosed")
    with pytest.raises(MtlxError, match="no surface shader"):
        read_document('<?xml version="1.0"?>\n<materialx version="1.39"><position name="p" type="vector3" /></materialx>')
    with pytest.raises(MtlxError, match="not a valid MaterialX document"):
        read_document(document('  <add name="a" type="float"><input name="in1" type="float" nodename="missing" /></add>',
                               '<input name="specular_roughness" type="float" nodename="a" />'))


def test_unifiednoise3d_expands_to_primitives():
    """unifiednoise3d is a library nodegraph (switch, rotate3d, the four noises...): it
    expands and evaluates, each type a different noise."""
    values = []
    for kind in range(4):
        body = f'  <unifiednoise3d name="u" type="float"><input name="type" type="integer" value="{kind}" /></unifiednoise3d>'
        doc = read_document(document(body, '<input name="specular_roughness" type="float" nodename="u" />'))
        values.append(evaluate_mtlx(doc, np.random.default_rng(7).uniform(-3, 3, (500, 3)))["roughness"][:, 0])
        assert values[-1].std() > 0.05 and 0.0 <= values[-1].min() and values[-1].max() <= 1.0  # clampoutput: [outmin, outmax]
    assert all(not np.allclose(values[i], values[j]) for i in range(4) for j in range(i))


def test_rotate3d():
    """mx_rotate_vector3 (v' = v M): x rotated 90 degrees about z is -y; lengths kept."""
    body = """  <position name="p" type="vector3" />
  <rotate3d name="r" type="vector3"><input name="in" type="vector3" nodename="p" /><input name="amount" type="float" value="90" />
    <input name="axis" type="vector3" value="0, 0, 2" /></rotate3d>
  <convert name="c" type="color3"><input name="in" type="vector3" nodename="r" /></convert>"""
    doc = read_document(document(body, '<input name="base_color" type="color3" nodename="c" />'))
    np.testing.assert_allclose(evaluate_mtlx(doc, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])["base_color"], [[0, -1, 0], [1, 0, 0]], atol=1e-12)


def test_error_inside_a_definition_names_the_documents_node():
    body = '  <tiledimage name="tiles" type="color3"><input name="file" type="filename" value="t.png" /></tiledimage>'
    with pytest.raises(MtlxError, match=r"node \"tiles \(tiledimage, defined by the library's NG_tiledimage_color3\): its \w+\": image: "):
        read_document(document(body, '<input name="base_color" type="color3" nodename="tiles" />'))


@pytest.mark.parametrize("space, expected", [
    ("srgb_texture", [0.21404114, 0.03310477, 0.00154799]),  # the sRGB curve
    ("acescg", [1.705051 * 0.5 - 0.621792 * 0.2 - 0.083259 * 0.02, -0.130256 * 0.5 + 1.140805 * 0.2 - 0.010548 * 0.02,
                -0.024003 * 0.5 - 0.128969 * 0.2 + 1.152972 * 0.02]),  # ACEScg to Rec.709 (v' = v M, as cmlib writes it)
    ("lin_rec709", [0.5, 0.2, 0.02]),
])
def test_colour_constants_through_their_colour_space(space, expected):
    """A colour constant in another colour space goes through the library's own transform
    (cmlib's nodegraphs) to texbake's lin_rec709, and stays a constant."""
    doc = read_document(document("", f'<input name="base_color" type="color3" value="0.5, 0.2, 0.02" colorspace="{space}" />'))
    np.testing.assert_allclose(doc.channels["base_color"], expected, atol=1e-6)


def test_unknown_colour_space():
    with pytest.raises(MtlxError, match=r"node 'SR': colour space 'bogus' has no transform to lin_rec709 .*\(it has: acescg, "):
        read_document(document("", '<input name="base_color" type="color3" value="0.5, 0.2, 0.02" colorspace="bogus" />'))


def test_an_include_in_text_is_refused_before_materialx_reads_it(tmp_path):
    """MaterialX follows an xi:include in XML text to any path on this machine (the service's
    documents are text): refused, naming it, even where the file it names is a document."""
    included = tmp_path / "red.mtlx"
    included.write_text(document("", '<input name="base_color" type="color3" value="1, 0, 0" />'))
    text = f'<?xml version="1.0"?>\n<materialx version="1.39">\n  <xi:include href="{included}" />\n</materialx>'
    with pytest.raises(MtlxError, match=r"^doc.mtlx: includes another file \(<xi:include href=.*red.mtlx\" />\): a document given as "
                                         "text reads no other file"):
        read_document(text, path="doc.mtlx")
    import MaterialX as mx

    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)  # what it would have read: the included shader
    assert [n.getName() for n in doc.getNodes()] == ["SR", "M"]
