"""The meshes of a bake in UDIM tiles: USD (``<mesh>.usda``) and OBJ + MTL whose materials
name their maps with the ``<UDIM>`` token (``albedo.<UDIM>.png``), the mesh's own layout,
tiles and all (glTF has no UDIM: its GLB puts each tile in a primitive of its own).

Each texture set is one mesh of its tiles' faces, UVs back in their tiles (``uv + offset``),
bound to one material whose maps are the set's through the token (a set without tiles
names its one map). USD: ``UsdPreviewSurface`` with a ``UsdUVTexture`` a map reading the
``st`` primvar (face-varying: seams stay split), Y up as glTF, binding what the GLB binds:
the albedo (the first frame's) as diffuse colour, or for a texture that emits light (the
flame) as emissive colour over black; the normal map (raw, ``2 n - 1``: tangent space, +Y
up, as UsdPreviewSurface's ``normal`` takes it); not the lit map, whose light is baked in
(as a surface's colour it would be lit again), as the GLB does not; written with usd-core
(``pip install 'texbake[usd]'``), imported here only; without it the OBJ + MTL is written
in its place and a warning says so (usd-core is 200 MB installed: an extra, not a base
dependency, so a bake that never meets a UDIM asset does not carry it).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np

from .atomic import write_bytes
from .export import ObjPart, write_obj_parts

TOKEN = "<UDIM>"


USD_MISSING = ("UDIM tiles: usd-core is not installed, so no <mesh>.usda was written; the OBJ + MTL "
               "(map_Kd albedo.<UDIM>) was written instead (pip install 'texbake[usd]' for the USD)")


def usd_available() -> bool:
    """Whether usd-core (``pxr``) can be imported, without importing it."""
    return importlib.util.find_spec("pxr") is not None


def write_udim(result, folder: Path, name_of, *, fmt: str, obj: bool) -> dict:
    """Write ``<mesh>.usda`` (and ``<mesh>.obj`` + MTL if ``obj``, or if usd-core is not
    installed) of ``result`` (a ``BakeResult`` with UDIM tiles) into ``folder``;
    ``name_of(baked set, map, ext, tile=...)``: the maps' file names, in format ``fmt``.
    Returns ``{"usd": ..., "obj": ...}`` as :func:`texbake.output.export.write_obj` returns its file."""
    sets = _joined(result)
    name = result.sets[0].mesh.name
    written = {}
    if usd_available():
        written["usd"] = _write_usd(folder / f"{name}.usda", name, [(s, v, f, uv, n, _usd_maps(first, name_of, fmt, tile))
                                                                     for s, first, tile, v, f, uv, n in sets])
    if obj or "usd" not in written:
        written["obj"] = write_obj_parts(folder / f"{name}.obj", [ObjPart(v, f, uv, None if _colour(first) is None else name_of(first, _colour(first), fmt, tile=tile), s, n)
                                                                  for s, first, tile, v, f, uv, n in sets])
    return written


def _colour(b) -> str | None:
    """A set's colour map: its albedo (a material's base colour), or its first frame's;
    None in a bake of mesh maps only (texture none)."""
    if "albedo" in b.images or "base_color" in b.images:
        return "albedo" if "albedo" in b.images else "base_color"
    return min((n for n in b.images if n.startswith("albedo_")), default=None)


def _usd_maps(b, name_of, fmt: str, tile) -> dict[str, str]:
    """The files a set's USD material reads, by its input (``diffuseColor`` or
    ``emissiveColor``, ``normal``), as the GLB binds them (texbake.output.save)."""
    colour = _colour(b)
    emits = b.settings.texture is not None and b.settings.texture.emits
    maps = {} if colour is None else {"emissiveColor" if emits else "diffuseColor": name_of(b, colour, fmt, tile=tile)}
    if "normal" in b.images:
        maps["normal"] = name_of(b, "normal", fmt, tile=tile)
    return maps


def _joined(result) -> list[tuple]:
    """Per texture set ``(name, its first BakedSet, the tile field: TOKEN or None, vertices,
    faces, uv in the tiles, normals)``: its tiles' meshes put together."""
    out = []
    for name in dict.fromkeys(b.name for b in result.sets):
        parts = [b for b in result.sets if b.name == name]
        offsets = np.cumsum([0] + [len(b.mesh.vertices) for b in parts])
        vertices = np.concatenate([b.mesh.vertices for b in parts])
        faces = np.concatenate([b.mesh.faces + k for b, k in zip(parts, offsets, strict=False)])
        uv = np.concatenate([b.mesh.uv + b.mesh.offset for b in parts])
        normals = None if any(b.mesh.normals is None for b in parts) else np.concatenate([b.mesh.normals for b in parts])
        out.append((name, parts[0], None if parts[0].tile is None else TOKEN, vertices, faces, uv, normals))
    return out


def _write_usd(path: Path, name: str, sets: list[tuple]) -> dict:
    """A USD stage of one mesh per set ``(name, vertices, faces, uv, normals, maps)``
    (:func:`_usd_maps`), each bound to its material; written atomically as ``.usda`` text."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt  # pip install usd-core

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, f"/{_prim(name)}")
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(stage, f"{root.GetPath()}/Materials")
    used: set[str] = set()
    for set_name, v, f, uv, n, maps in sets:
        prim = _unique(_prim(set_name), used)
        mesh = UsdGeom.Mesh.Define(stage, f"{root.GetPath()}/{prim}")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(v, dtype=np.float32)))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(f), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(f.ravel(), dtype=np.int32)))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateExtentAttr([Gf.Vec3f(*map(float, v.min(axis=0))), Gf.Vec3f(*map(float, v.max(axis=0)))])
        if n is not None:
            mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(n, dtype=np.float32)))
            mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(uv, dtype=np.float32)))
        material = _material(stage, f"{root.GetPath()}/Materials/{prim}", set_name, maps)
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    text = stage.GetRootLayer().ExportToString()
    write_bytes(path, text.encode())
    return {"path": str(path), "bytes": len(text.encode()), "meshes": len(sets)}


def _material(stage, where: str, name: str, maps: dict[str, str]):
    """A ``UsdPreviewSurface`` material at ``where`` reading each of ``maps`` (input ->
    a file beside the stage, ``<UDIM>`` for tiles) through the ``st`` primvar; with an
    emissive colour its diffuse colour is black."""
    from pxr import Gf, Sdf, UsdShade

    material = UsdShade.Material.Define(stage, where)
    material.GetPrim().SetCustomDataByKey("texbake:material", name)
    surface = UsdShade.Shader.Define(stage, f"{where}/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    surface.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    reader = UsdShade.Shader.Define(stage, f"{where}/TexCoords")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    if "emissiveColor" in maps and "diffuseColor" not in maps:  # the flame: its colour is light, not paint
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    for slot, image in maps.items():
        normal, scalar = slot == "normal", slot in _SCALAR_SLOTS
        shader_name = "Emissive" if slot == "emissiveColor" and "diffuseColor" in maps else _SHADER_NAMES[slot]
        texture = UsdShade.Shader.Define(stage, f"{where}/{shader_name}")
        texture.CreateIdAttr("UsdUVTexture")
        texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{image}")
        texture.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw" if normal or scalar else "auto")  # data maps
        texture.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
        texture.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
        texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        if normal:  # 0.5 + 0.5 n in the file: n = 2 x - 1
            texture.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
            texture.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
        if scalar:  # a material's one-channel map (texbake.mtlx): its red
            surface.CreateInput(slot, Sdf.ValueTypeNames.Float).ConnectToSource(texture.CreateOutput("r", Sdf.ValueTypeNames.Float))
            continue
        rgb = texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        kind = Sdf.ValueTypeNames.Normal3f if normal else Sdf.ValueTypeNames.Color3f
        surface.CreateInput(slot, kind).ConnectToSource(rgb)
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


_SHADER_NAMES = {"diffuseColor": "Albedo", "emissiveColor": "Albedo", "normal": "Normal", "roughness": "Roughness",
                 "metallic": "Metallic", "occlusion": "Occlusion", "opacity": "Opacity", "displacement": "Height"}
_SCALAR_SLOTS = ("roughness", "metallic", "occlusion", "opacity", "displacement")


def _prim(name: str) -> str:
    """A USD prim name from a set's or mesh's name: letters, digits and ``_``, not starting with a digit."""
    prim = re.sub(r"\W", "_", name, flags=re.ASCII) or "mesh"
    return f"_{prim}" if prim[0].isdigit() else prim


def _unique(name: str, used: set[str]) -> str:
    out, k = name, 1
    while out in used:
        k += 1
        out = f"{name}_{k}"
    used.add(out)
    return out
