"""The material model and its graph: parsing, the built-ins, shared nodes, and every kind of
graph error named by its node."""

import json

import pytest

from texbake.errors import MaterialError
from texbake.materials import BUILTINS, Material, parse_material
from texbake.materials.graph import CHANNELS

TURB = {"op": "texture", "texture": "turbulence", "output": "value"}


def test_channels_take_constants_textures_and_expressions():
    m = parse_material({
        "nodes": {"t": TURB},
        "base_color": {"name": "marble"},  # a texture spec: its colour
        "roughness": 0.4,
        "metallic": {"op": "threshold", "input": "t", "at": 0.6},
        "emissive": [0.1, 0.2, 0.3],
        "height": "t",
    })
    g = m.graph
    assert list(g.channels) == ["base_color", "roughness", "metallic", "height", "emissive"]
    assert g.nodes[g.channels["base_color"]].op == "texture" and g.nodes[g.channels["base_color"]].kind == "colour"
    assert m.constant("roughness") == 0.4 and m.constant("emissive") == (0.1, 0.2, 0.3) and m.constant("metallic") is None
    assert g.nodes["t"].kind == "scalar" and g.channels["height"] == "t"
    assert m.channels == ["base_color", "roughness", "metallic", "height", "emissive"]  # CHANNELS' order


def test_a_node_used_by_several_channels_is_one_node():
    m = parse_material({"nodes": {"t": TURB}, "base_color": {"op": "remap", "input": "t", "colormap": {}},
                        "roughness": "t", "metallic": {"op": "invert", "input": "t"},
                        # the same texture written in place twice: one node too
                        "occlusion": {"op": "multiply", "a": TURB, "b": 0.5}, "opacity": {"op": "add", "a": TURB, "b": 0.1}})
    textures = [n for n in m.graph.nodes.values() if n.op == "texture"]
    assert [t.id for t in textures] == ["t"]
    assert sorted(m.graph.users["t"]) == sorted(["base_color", "roughness", "metallic", "occlusion", "opacity"])


def test_materials_come_from_json_text_and_round_trip():
    data = {"name": "x", "nodes": {"t": TURB}, "base_color": {"op": "mix", "a": [1, 0, 0], "b": [0, 0, 1], "mask": "t"}}
    m = parse_material(json.dumps(data))
    assert m.name == "x" and parse_material(m) is m
    again = Material.model_validate(m.model_dump(mode="json"))
    assert again == m and again.graph.channels == m.graph.channels


@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_every_built_in_parses_and_gives_its_base_colour(name):
    m = parse_material(name)
    assert m.name == name and "base_color" in m.graph.channels
    m.nodes.clear()  # the material's own copy: the table of built-ins is not touched
    assert BUILTINS[name]["nodes"] and parse_material(name).nodes == BUILTINS[name]["nodes"]


@pytest.mark.parametrize(("material", "node", "words"), [
    ({"base_color": "rust"}, "base_color", "unknown node 'rust' (the material has no named nodes)"),
    ({"nodes": {"rust": 0.5}, "base_color": "rustt"}, "base_color", "unknown node 'rustt' (did you mean 'rust'?"),
    ({"base_color": "marble"}, "base_color", "a texture is written {'name': 'marble'}"),
    ({"base_color": {"op": "mixx", "a": 1}}, "base_color", "unknown op 'mixx' (did you mean 'mix'?"),
    ({"nodes": {"a": {"op": "invert", "input": "b"}, "b": {"op": "add", "a": "a", "b": 1}}, "base_color": "a"},
     "a", "a cycle: a -> b -> a"),
    ({"nodes": {"a": {"op": "invert", "input": {"op": "clamp", "input": "a"}}}, "base_color": "a"}, "a", "a cycle: a -> a"),
    ({"base_color": {"op": "mix", "a": 0, "b": 1, "mask": {"name": "marble"}}}, "base_color",
     "input 'mask' takes a scalar, got a colour"),
    ({"nodes": {"m": {"name": "marble"}}, "base_color": 0.5, "roughness": "m"}, "roughness",
     "the roughness channel takes a scalar, got a colour (node 'm')"),
    ({"base_color": {"op": "channel", "input": 0.5}}, "base_color", "input 'input' takes a colour, got a scalar"),
    ({"base_color": {"op": "mix", "a": 0, "b": 1}}, "base_color", "mix needs the input 'mask'"),
    ({"base_color": {"op": "smoothstep", "input": 0.5, "edge0": 0.6, "edge1": 0.4}}, "base_color",
     "edge1: expected more than edge0"),
    ({"base_color": {"op": "clamp", "input": 0.5, "maximum": 2}}, "base_color", "clamp takes no 'maximum'"),
    ({"base_color": {"op": "texture", "texture": {"name": "marbel"}}}, "base_color",
     "texture: unknown texture 'marbel' (did you mean 'marble'?"),
    ({"base_color": {"op": "texture", "texture": "flame", "output": "value"}}, "base_color", "texture 'flame' has no value"),
    ({"base_color": {"op": "mix", "a": [1, 2], "b": 0, "mask": 0.5}}, "base_color.a", "value"),
    ({"base_color": {"op": "remap", "input": 0.5}}, "base_color", "expected a colormap (to a colour) or a curve"),
    ({"base_color": {"op": "add", "a": True, "b": 1}}, "base_color.a", "expected a number"),
    ({"nodes": {"base_color": 1}, "base_color": 1}, "base_color", "may not be named after a channel"),
    ({"nodes": {"a.b": 1}, "base_color": 1}, "a.b", "a node's name is a letter"),
    ({"nodes": {"unused": {"op": "invert"}}, "base_color": 1}, "unused", "invert needs the input 'input'"),
])
def test_a_graph_error_is_one_line_naming_the_node(material, node, words):
    with pytest.raises(MaterialError) as info:
        parse_material(material)
    error = info.value
    assert error.node == node and words in error.problem, str(error)
    assert str(error).startswith(f"node {node!r}: ") and "\n" not in str(error)


@pytest.mark.parametrize(("material", "words"), [
    ({"base_color": 1, "roughnes": 0.5}, "material has no parameter 'roughnes' (did you mean 'roughness'?"),
    ({"roughness": 0.5}, "a material needs a base_color"),
    ({"base_color": 1, "height_scale": 0}, "height_scale: expected a number above 0"),
    ("glass", "unknown material 'glass' (built in: glazed_ceramic_checker, lava, oak_planks, polished_marble, rusted_iron)"),
    ("rusted_irn", "did you mean 'rusted_iron'?"),
    ("{\"base_color\": ", "not valid JSON"),
    (["base_color"], "expected a material's name or a material"),
])
def test_a_bad_material_is_named(material, words):
    with pytest.raises(MaterialError) as info:
        parse_material(material)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_a_material_string_is_never_read_as_a_path(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"base_color": 0.5}))
    with pytest.raises(MaterialError, match="unknown material"):
        parse_material(str(path))


def test_the_channels_and_their_kinds():
    assert CHANNELS == {"base_color": "colour", "roughness": "scalar", "metallic": "scalar", "normal": "colour",
                        "height": "scalar", "occlusion": "scalar", "emissive": "colour", "opacity": "scalar"}


def test_material_errors_cross_processes():
    import pickle

    error = MaterialError("mask", "a cycle")
    again = pickle.loads(pickle.dumps(error))
    assert (again.node, again.problem, str(again)) == ("mask", "a cycle", "node 'mask': a cycle")
