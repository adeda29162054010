"""Texture sets: one per material (each its own atlas, maps and settings) or one for the
mesh, and the names of their files; a mesh of one material bakes as it always did."""

import json

import numpy as np
import pytest
from conftest import two_material_scene

import texbake
from texbake.errors import ParameterError
from texbake.mesh import load_mesh
from texbake.output.images import read_image
from texbake.sets import safe_name, texture_sets
from texbake.settings import BakeSettings, file_name


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("sets") / "cart.glb"
    two_material_scene(path)
    return path


def test_one_set_per_material_each_with_its_faces_and_settings(scene):
    mesh = load_mesh(scene)
    sets = sorted(texture_sets(mesh, BakeSettings(size=64, materials={"wheels": {"size": 32, "texture": "marble"}})), key=lambda s: s.name)
    assert [s.name for s in sets] == ["body", "wheels"] and [len(s.faces) for s in sets] == [12, 640]
    assert np.array_equal(np.sort(np.concatenate([s.faces for s in sets])), np.arange(len(mesh.faces)))
    for s in sets:  # each set's mesh is its faces, corner for corner
        assert np.array_equal(s.mesh.vertices[s.mesh.faces], mesh.vertices[mesh.faces[s.faces]])
    assert sets[0].mesh.uv is not None and sets[1].mesh.uv is None
    assert (sets[0].settings.size, sets[0].settings.texture.name) == (64, "checker")
    assert (sets[1].settings.size, sets[1].settings.texture.name) == (32, "marble")
    single = texture_sets(mesh, BakeSettings(texture_set="single"))
    assert len(single) == 1 and single[0].mesh is mesh and sorted(single[0].materials) == ["body", "wheels"]


def test_an_unknown_material_is_named_with_those_there_are(scene):
    mesh = load_mesh(scene)
    with pytest.raises(ParameterError, match=r"materials: .*cart.glb has no material 'bdy'; its materials: '(body|wheels)', '(body|wheels)'"):
        texture_sets(mesh, BakeSettings(materials={"bdy": {"texture": "wood"}}))
    with pytest.raises(ParameterError, match="texture_set='single' bakes one texture set"):
        BakeSettings.build(texture_set="single", materials={"body": {}})
    with pytest.raises(ParameterError, match=r"materials.body.format: not a known field|materials: 'body'"):
        BakeSettings.build(materials={"body": {"format": "exr"}})


def test_each_set_bakes_as_if_alone_and_keeps_its_own_uvs(scene, tmp_path):
    """The body's image in a bake where the wheels are marble is the body's image of a bake
    where all is checker: the sets share nothing but the texture's space (the whole mesh's
    bounding box)."""
    mixed = texbake.bake_mesh(scene, "checker", size=48, materials={"wheels": {"texture": "marble", "size": 32}})
    plain = texbake.bake_mesh(scene, "checker", size=48)
    marble = texbake.bake_mesh(scene, "marble", size=48, materials={"wheels": {"size": 32}})
    by = lambda r: {s.name: s for s in r.sets}
    assert sorted(s.name for s in mixed.sets) == ["body", "wheels"] and [s.tile for s in mixed.sets] == [None, None]
    assert by(mixed)["body"].atlas.method == "kept" and by(mixed)["wheels"].atlas.method != "kept"
    assert np.array_equal(by(mixed)["body"].images["albedo"], by(plain)["body"].images["albedo"])
    assert np.array_equal(by(mixed)["wheels"].images["albedo"], by(marble)["wheels"].images["albedo"])
    assert by(mixed)["wheels"].images["albedo"].shape == (32, 32, 3)
    with pytest.raises(AttributeError, match="2 texture sets and tiles"):
        mixed.images  # noqa: B018
    written = mixed.save(tmp_path / "out")
    assert {"body_albedo", "body_coverage", "wheels_albedo", "wheels_coverage", "glb"} <= set(written)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    sets = {s["name"]: s for s in report["sets"]}
    assert sets["wheels"]["settings"]["texture"]["name"] == "marble" and "settings" not in sets["body"]
    assert sets["body"]["outputs"] == ["body_albedo.png", "body_coverage.png"]
    assert report["texels"]["total"] == 48 * 48 + 32 * 32
    assert "body: kept" in report["atlas"]["method"] and "wheels: " in report["atlas"]["method"]
    saved = read_image(tmp_path / "out" / "wheels_albedo.png")
    assert saved.shape == (32, 32, 3)


def test_names_follow_the_template_and_leave_out_what_has_no_value():
    names = "{set}_{map}.{tile}.{ext}"
    assert file_name(names, mesh="cart", set=None, map="albedo", tile=None, ext="png") == "albedo.png"
    assert file_name(names, mesh="cart", set="body", map="albedo", tile=None, ext="png") == "body_albedo.png"
    assert file_name(names, mesh="cart", set=None, map="albedo", tile=1003, ext="exr") == "albedo.1003.exr"
    assert file_name("{mesh}-{set}-{map}-{tile}.{ext}", mesh="cart", set=None, map="lit", tile=None, ext="png") == "cart-lit.png"
    assert safe_name("blue paint/2") == "blue_paint_2"
    for bad, words in [("{map}", "needs {map} and {ext}"), ("{map}.{ext}/x", "not a path"), ("{map}{colour}.{ext}", "unknown field {colour}")]:
        with pytest.raises(ParameterError, match=words.replace("{", r"\{").replace("}", r"\}")):
            BakeSettings.build(names=bad)


def test_a_template_that_gives_two_maps_one_name_is_refused(scene, tmp_path):
    result = texbake.bake_mesh(scene, "checker", size=16, names="{map}.{ext}")
    with pytest.raises(ParameterError, match=r"names: '\{map\}.\{ext\}' names two maps 'albedo.png'.*needs \{set\}"):
        result.save(tmp_path / "o")
    named = texbake.bake_mesh(scene, "checker", size=16, names="{mesh}_{set}_{map}.{ext}").save(tmp_path / "p")
    assert "cart_body_albedo" in named and "cart_wheels_coverage" in named
