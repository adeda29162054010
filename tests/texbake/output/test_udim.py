"""A bake in UDIM tiles: each tile its own image, the layout kept; the GLB a primitive per
tile, the USD and the OBJ naming the maps with the <UDIM> token."""

import json
import struct

import numpy as np
import pytest
from conftest import udim_boxes

import texbake
from texbake.atlas.uvcheck import coverage_counts
from texbake.output.images import read_image


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    folder = tmp_path_factory.mktemp("udim")
    layout = udim_boxes(folder / "boxes.obj")
    result = texbake.bake_mesh(folder / "boxes.obj", "checker", size=64, margin=4, obj=True)
    written = result.save(folder / "out")
    return folder, layout, result, written


def test_each_tile_is_its_own_image_with_its_margin_inside(baked):
    folder, layout, result, written = baked
    assert [(s.name, s.tile) for s in result.sets] == [("default", t) for t in (1001, 1002, 1003, 1004)]
    for s in result.sets:
        k = s.tile - 1001
        assert s.mesh.offset == (k, 0) and len(s.mesh.faces) == 12
        assert np.allclose(np.sort((s.mesh.uv + s.mesh.offset)[s.mesh.faces].reshape(-1, 2), axis=0),
                           np.sort(layout["uv"][layout["tile"] == s.tile].reshape(-1, 2), axis=0))
        # the covered texels are those of the tile's own faces, at texel centres; the margin fills around them only
        local = layout["uv"][layout["tile"] == s.tile].reshape(-1, 2) - [k, 0]
        raster = coverage_counts(local, np.arange(len(local)).reshape(-1, 3), 64) > 0
        assert np.array_equal(s.coverage, raster)
        assert s.margin.any() and not (s.margin & s.coverage).any()
        assert read_image(folder / "out" / f"albedo.{s.tile}.png").shape == (64, 64, 3)
    assert {"albedo.1001", "albedo.1004", "coverage.1003", "glb", "usd", "obj"} <= set(written)
    report = json.loads((folder / "out" / "report.json").read_text())
    (entry,) = report["sets"]
    assert [t["tile"] for t in entry["tiles"]] == [1001, 1002, 1003, 1004] and entry["atlas"]["udim"]
    assert entry["texels"]["covered"] == sum(t["texels"]["covered"] for t in entry["tiles"]) == int(sum(s.coverage.sum() for s in result.sets))


def test_the_glb_has_a_primitive_per_tile_with_its_image(baked):
    from test_export import assert_valid

    folder, *_ = baked
    path = folder / "out" / "boxes.glb"
    data = path.read_bytes()
    doc = json.loads(data[20 : 20 + struct.unpack_from("<I", data, 12)[0]])
    assert [m["name"] for m in doc["materials"]] == [f"boxes_baked.{t}" for t in (1001, 1002, 1003, 1004)]
    assert len(doc["meshes"][0]["primitives"]) == 4 and len(doc["images"]) == 4
    assert assert_valid(path)["issues"]["numWarnings"] == 0


def test_the_usd_and_the_obj_keep_the_layout_and_name_the_tiles(baked):
    from pxr import Usd, UsdGeom, UsdShade

    folder, layout, *_ = baked
    stage = Usd.Stage.Open(str(folder / "out" / "boxes.usda"))
    (mesh,) = [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    st = np.array(UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st").Get())
    corners = st[np.array(mesh.GetFaceVertexIndicesAttr().Get())].reshape(-1, 3, 2)
    assert np.abs(np.sort(corners.reshape(-1, 2), axis=0) - np.sort(layout["uv"].reshape(-1, 2), axis=0)).max() < 1e-6
    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    files = [s.GetInput("file").Get().path for s in (UsdShade.Shader(p) for p in material.GetPrim().GetChildren())
             if s.GetIdAttr().Get() == "UsdUVTexture"]
    assert files == ["./albedo.<UDIM>.png"]
    text = (folder / "out" / "boxes.mtl").read_text()
    assert "map_Kd albedo.<UDIM>.png" in text
    vt = np.array([[float(x) for x in line.split()[1:]] for line in (folder / "out" / "boxes.obj").read_text().splitlines()
                   if line.startswith("vt ")])
    assert np.abs(np.sort(vt, axis=0) - np.sort(layout["uv"].reshape(-1, 2), axis=0)).max() < 1e-8


def test_without_usd_core_the_obj_is_written_in_its_place_with_a_warning(baked, tmp_path, monkeypatch):
    # usd-core is an extra (texbake[usd]): an install without it still gets a mesh that names the tiles
    from texbake.output import udim

    folder, _, result, _ = baked
    monkeypatch.setattr(udim, "usd_available", lambda: False)
    written = result.save(tmp_path / "out", obj=False)
    assert "usd" not in written and not (tmp_path / "out" / "boxes.usda").exists()
    assert "albedo.<UDIM>.png" in (tmp_path / "out" / "boxes.mtl").read_text()
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert udim.USD_MISSING in report["warnings"] and udim.USD_MISSING in result.warnings


def usd_inputs(folder, name):
    """``{surface input: (file, colour space, scale, bias)}`` of the USD's one material's
    textures, and ``{surface input: value}`` of the others."""
    from pxr import Usd, UsdGeom, UsdShade

    stage = Usd.Stage.Open(str(folder / f"{name}.usda"))
    (mesh,) = [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    surface = material.ComputeSurfaceSource()[0]
    found, values = {}, {}
    for given in surface.GetInputs():
        sources = given.GetConnectedSources()[0]
        if not sources:
            values[given.GetBaseName()] = given.Get()
        else:
            texture = UsdShade.Shader(sources[0].source.GetPrim())
            found[given.GetBaseName()] = (texture.GetInput("file").Get().path, texture.GetInput("sourceColorSpace").Get(),
                                          texture.GetInput("scale").Get(), texture.GetInput("bias").Get())
    return found, values


def test_the_usd_binds_the_normal_map_and_a_flames_light_as_the_glb_does(tmp_path):
    # As the GLB: the albedo as diffuse colour, the normal map raw as the surface's normal
    # (2 x - 1), the lit map not (its light is baked in); saved as EXR, the USD names the
    # EXRs; the flame's colour is emissive over a black diffuse.
    from pxr import Gf

    udim_boxes(tmp_path / "boxes.obj")
    result = texbake.bake_mesh(tmp_path / "boxes.obj", "checker", size=32, bump="noise", shading="full")
    result.save(tmp_path / "out", fmt="exr")
    found, _ = usd_inputs(tmp_path / "out", "boxes")
    assert found == {"diffuseColor": ("./albedo.<UDIM>.exr", "auto", None, None),
                     "normal": ("./normal.<UDIM>.exr", "raw", Gf.Vec4f(2, 2, 2, 1), Gf.Vec4f(-1, -1, -1, 0))}, found
    assert all((tmp_path / "out" / f"{m}.{t}.exr").is_file() for m in ("albedo", "normal", "lit") for t in (1001, 1002, 1003, 1004))
    flame = texbake.bake_mesh(tmp_path / "boxes.obj", "flame", size=16, frames=[0, 0.5])
    flame.save(tmp_path / "flame")
    found, values = usd_inputs(tmp_path / "flame", "boxes")
    assert found == {"emissiveColor": ("./albedo_0000.<UDIM>.png", "auto", None, None)}, found
    assert values["diffuseColor"] == Gf.Vec3f(0, 0, 0)
