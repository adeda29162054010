"""Writing a bake: maps with OpenImageIO, the textured mesh, and the report.

Every file is written to a temporary name, checked and renamed into place, so nothing
half-written is left under a final name; the temporary files a killed bake left in the
folder are removed by the next bake into it.

The maps' names come from the settings' ``names`` template (``texbake.settings.file_name``:
``{set}`` is the texture set's name where there are several, ``{tile}`` the UDIM tile),
so a bake of one material writes ``albedo.png`` and one of the truck's four
``truck_albedo.png``, ``wheels_albedo.png``...; ``report["outputs"]`` has each file under
its name less the extension (``albedo``, ``wheels_albedo``, ``albedo.1001``), and
``glb``, ``obj``, ``usd``.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..errors import OutputError, ParameterError
from ..formats import bits_problem, image_format
from ..settings import file_name
from .atomic import remove_stale
from .export import GlbPart, ObjPart, write_glb_parts, write_obj, write_obj_parts
from .images import write_image
from .report import write_json


def save_result(result, folder: Path, *, fmt: str = "png", bits: int | None = None, obj: bool = False) -> dict:
    """Write ``result`` (a ``BakeResult``) into ``folder``; return the files written.

    Maps, per texture set and UDIM tile, named by ``result.settings.names``: ``albedo``
    (or one per frame and ``flipbook``), ``lit``, ``normal`` when baked, and ``coverage``
    (PNG, 1 where the atlas covers a texel); mesh: ``<name>.glb``, one primitive per
    material (and per UDIM tile), each material (by its name; ``<name>_baked`` for a mesh
    of one) with its set's albedo (of the first frame) as base colour, the normal map (if
    baked) as normal texture with the tangents it was baked in, and, for a texture that
    emits light (the flame), the albedo as emissive, its base colour factor black (PNG
    copies ``<map>_gltf`` when the format is not PNG); ``<name>.obj`` + MTL if ``obj``;
    for UDIM tiles also ``<name>.usda`` and, with ``obj``, an OBJ whose materials name
    their maps with the ``<UDIM>`` token (:mod:`texbake.output.udim`); ``report.json``
    last, so its presence means the rest is complete. Colour maps are sRGB; the normal map
    and the coverage are data (a linear PNG: ``texbake.output.images``). A material's bake
    writes a map per channel (``base_color``, ``emissive`` colour; the rest data) and its
    packed maps (``orm``...), and each set's GLB material is whole (:func:`_slots`).
    """
    fmt = image_format(fmt)
    if bits is not None and (problem := bits_problem(fmt, bits)):
        raise ParameterError("bits", problem)
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{folder}: cannot create output folder: {exc.strerror}") from None
    remove_stale(folder)  # what a killed earlier bake into this folder left half-written

    start = time.perf_counter()
    name_of = _namer(result)
    jobs, owner = {}, {}  # file -> what to write, and its texture set
    for b in result.sets:
        for name, pixels in b.images.items():  # a normal map is no colour
            jobs[name_of(b, name, fmt)] = (pixels, bits, "linear" if is_colour(name) else "data")
        jobs[name_of(b, "coverage", "png")] = (b.coverage[:, :, None], None, "data")
        owner.update({file: b.name for file in jobs if file not in owner})
    with ThreadPoolExecutor(2, thread_name_prefix="texbake-write") as pool:  # two at once: OpenImageIO's compression releases the GIL
        futures = {file: pool.submit(write_image, folder / file, pixels, bits=b, colorspace=kind) for file, (pixels, b, kind) in jobs.items()}
        written = {_key(file): future.result() for file, future in futures.items()}

    glb_parts, obj_parts = [], []
    for b in result.sets:
        slots, factor, fields = _slots(b, folder, fmt, name_of, written)
        owner.update({path.name: b.name for path in slots.values() if path.name not in jobs})
        glb_parts += _glb_parts(b, slots, _material_name(result, b), factor, fields)
        obj_parts.append((b, slots.get("baseColor")))
    m = result.sets[0].mesh
    written["glb"] = write_glb_parts(folder / f"{m.name}.glb", glb_parts, name=m.name)
    written.update(_mtlx(result, folder, fmt, name_of))
    if any(b.tile is not None for b in result.sets):
        from .udim import USD_MISSING, write_udim

        written.update(write_udim(result, folder, name_of, fmt=fmt, obj=obj))
        if "usd" not in written:
            result.report = {**result.report, "warnings": [*result.report.get("warnings", []), USD_MISSING]}
    elif obj and len(obj_parts) == 1 and obj_parts[0][1] is not None:
        written["obj"] = write_obj(folder / f"{m.name}.obj", m.vertices, m.faces, m.uv, obj_parts[0][1].name, normals=m.normals)
    elif obj:  # several materials, or no colour map (texture none): no map_Kd
        written["obj"] = write_obj_parts(folder / f"{m.name}.obj", [ObjPart(b.mesh.vertices, b.mesh.faces, b.mesh.uv, None if texture is None else texture.name,
                                                                             b.name or _material_name(result, b), b.mesh.normals)
                                                                     for b, texture in obj_parts])

    result.report = _report(result.report, written, owner, time.perf_counter() - start)
    write_json(folder / "report.json", result.report)
    return written


def _mtlx(result, folder: Path, fmt: str, name_of) -> dict:
    """A baked MaterialX document per set whose material came from one (``texbake.mtlx.write``):
    ``<mesh>.mtlx`` (one set), or the set's ``material.mtlx`` by the names template; and
    ``<mesh>.usda``, the mesh of those sets with a ``UsdPreviewSurface`` bound to their maps."""
    out: dict = {}
    usd: list[tuple] = []
    for b in result.sets:
        material = b.settings.material
        origin = None if material is None or b.tile is not None else next(
            (n.params for n in material.graph.nodes.values() if n.op == "mtlx"), None)
        if origin is None:
            continue
        from ..mtlx.write import write_mtlx

        name = f"{b.mesh.name}.mtlx" if len(result.sets) == 1 else name_of(b, "material", "mtlx")
        maps = {c: name_of(b, c, fmt) for c in b.images if c in material.graph.channels or c == "normal"}
        out["mtlx" if len(result.sets) == 1 else _key(name)] = write_mtlx(origin.document, origin.path, maps, folder / name)
        usd.append((b.name, b.mesh.vertices, b.mesh.faces, b.mesh.uv, b.mesh.normals,
                    {USD_INPUTS[c]: file for c, file in maps.items() if c in USD_INPUTS}))
    from .udim import _write_usd, usd_available

    if usd and usd_available():  # the mesh with a UsdPreviewSurface on the maps (usd-core: texbake[usd])
        out["usd"] = _write_usd(folder / f"{result.sets[0].mesh.name}.usda", result.sets[0].mesh.name, usd)
    return out


# a material's maps as UsdPreviewSurface's inputs (the USD beside a baked .mtlx)
USD_INPUTS = {"base_color": "diffuseColor", "roughness": "roughness", "metallic": "metallic", "occlusion": "occlusion",
              "opacity": "opacity", "emissive": "emissiveColor", "normal": "normal", "height": "displacement"}


def _report(report: dict, written: dict, owner: dict[str, str], seconds: float) -> dict:
    """The bake's report with its ``outputs``, each set's, and the seconds of the writing."""
    report = dict(report)
    report["seconds"] = {**report.get("seconds", {}), "write": round(seconds, 4)}
    report["outputs"] = {k: {"path": Path(v["path"]).name, **{x: y for x, y in v.items() if x != "path"}} for k, v in written.items()}
    for entry in report.get("sets", []):
        entry["outputs"] = sorted(file for file, name in owner.items() if name == entry["name"])
    return report


def _namer(result):
    """``name_of(baked set, map, ext, tile=its tile)``: a map's file name (``texbake.settings.file_name``;
    ``tile="<UDIM>"`` names the maps of all its tiles);
    :class:`ParameterError` naming ``names`` when the template gives two maps one name."""
    from ..sets import file_stems

    names = list(dict.fromkeys(b.name for b in result.sets))
    stems = file_stems(names)
    template, mesh = result.settings.names, result.sets[0].mesh.name

    def name_of(b, map_name: str, ext: str, tile: int | str | None = -1) -> str:
        return file_name(template, mesh=mesh, set=stems[b.name] if len(names) > 1 else None, map=map_name,
                         tile=b.tile if tile == -1 else tile, ext=ext)

    files = [name_of(b, m, "png") for b in result.sets for m in [*b.images, "coverage"]]
    if len(set(files)) < len(files):
        twice = next(f for f in files if files.count(f) > 1)
        need = "{set}" if len(names) > 1 and "{set}" not in template else "{tile}"
        raise ParameterError("names", f"{template!r} names two maps {twice!r}: a bake of {len(names)} texture sets and "
                             f"{len(result.sets)} images needs {need} in it")
    return name_of


def _key(file: str) -> str:
    """A file's key in ``report["outputs"]``: its name less the extension."""
    return file.rsplit(".", 1)[0]


COLOUR_MAPS = ("lit", "flipbook", "base_color", "emissive")  # and albedo, albedo_0000...: sRGB; every other map is data


def is_colour(name: str) -> bool:
    """Whether the map ``name`` is colour (written sRGB) rather than data (linear)."""
    return name in COLOUR_MAPS or name.startswith("albedo")


def _slots(b, folder: Path, fmt: str, name_of, written: dict) -> tuple[dict[str, Path], tuple, dict]:
    """``(slots, base colour factor, material fields)`` of a set's GLB material: the PNG of
    each texture slot (glTF embeds PNG or JPEG only: PNG copies ``<map>_gltf`` of other
    formats, and of what glTF reads otherwise: a material's base colour with the opacity
    as its alpha, a normal map with green up, an ORM map where the packing has none)."""
    images = b.images
    if b.settings.material is None:
        colours = sorted(n for n in images if n.startswith("albedo"))
        colour: str | None = "albedo" if "albedo" in images else colours[0] if colours else None  # None: texture none (mesh maps only)
        emits = b.settings.texture is not None and b.settings.texture.emits  # the flame: its colour is light, not paint
        slots: dict[str, str] = {**({} if colour is None else {"baseColor": colour}), **({"normal": "normal"} if "normal" in images else {}),
                                 **({"emissive": colour} if emits and colour is not None else {})}
        copies = {}
        if "normal" not in images and "source_normal" in images:  # a high-to-low bake's normal map (texbake.meshmaps.highpoly)
            slots["normal"] = "source_normal"
            if b.settings.normal_convention == "directx":  # glTF's is +Y
                normal = images["source_normal"]
                copies["source_normal"] = np.concatenate([normal[..., :1], 1.0 - normal[..., 1:2], normal[..., 2:]], axis=2)
        return _pngs(b, folder, fmt, name_of, written, slots, copies), (0.0, 0.0, 0.0, 1.0) if emits else (1.0, 1.0, 1.0, 1.0), {}
    from ..materials import DEFAULTS, PACKINGS, pack

    material, copies = b.settings.material, {}
    slots = {"baseColor": "base_color"}
    fields: dict = {}  # without a metallic-roughness map the GLB's factors are the defaults': metallic 0, roughness 1
    if "opacity" in images:  # glTF reads the opacity from the base colour's alpha
        copies["base_color"] = np.concatenate([images["base_color"], images["opacity"]], axis=2)
        fields.update(alphaMode=material.alpha_mode.upper(), **({"alphaCutoff": material.alpha_cutoff} if material.alpha_mode == "mask" else {}))
    if {"roughness", "metallic", "occlusion"} & set(images):
        if "orm" not in images:
            copies["orm"] = pack(PACKINGS["orm"], images, DEFAULTS)
        slots.update(metallicRoughness="orm", **({"occlusion": "orm"} if "occlusion" in images else {}))
    if "normal" in images:
        slots["normal"] = "normal"
        if b.settings.normal_convention == "directx":  # glTF's is +Y
            normal = images["normal"]
            copies["normal"] = np.concatenate([normal[..., :1], 1.0 - normal[..., 1:2], normal[..., 2:]], axis=2)
    if "emissive" in images:
        slots["emissive"] = "emissive"
    return _pngs(b, folder, fmt, name_of, written, slots, copies), (1.0, 1.0, 1.0, 1.0), fields


def _pngs(b, folder: Path, fmt: str, name_of, written: dict, slots: dict[str, str], copies: dict) -> dict[str, Path]:
    """The PNG of each slot's map: the map's own file, or a ``<map>_gltf`` PNG written of
    ``copies[map]`` (or of the map, in a format that is not PNG)."""
    out = {}
    for slot, name in slots.items():
        out[slot] = folder / name_of(b, name, "png")
        if fmt != "png" or name in copies:
            out[slot] = folder / name_of(b, f"{name}_gltf", "png")
            if _key(out[slot].name) not in written:
                pixels = copies.get(name, b.images.get(name))
                written[_key(out[slot].name)] = write_image(out[slot], pixels, colorspace="linear" if is_colour(name) else "data")
    return out


def _material_name(result, b) -> str:
    """The GLB material of a set (a tile's: ``.TILE`` after it): ``<mesh>_baked`` for a
    mesh of one material, as before there were sets, else the material's name."""
    materials = {m for s in result.sets for m in s.materials}
    base = f"{b.mesh.name}_baked" if len(materials) == 1 else b.name
    return base if b.tile is None else f"{base}.{b.tile}"


def _glb_parts(b, slots: dict[str, Path], material: str, factor: tuple, fields: dict) -> list[GlbPart]:
    """A set's primitives: one, or one per material where the set holds several (texture_set="single")."""
    m = b.mesh
    if m.material is None:
        return [GlbPart(m.vertices, m.faces, m.uv, slots, m.normals, m.tangents, material, factor, fields)]
    parts = []
    for k, name in enumerate(m.material_names):
        faces = m.faces[m.material == k]
        if not len(faces):
            continue
        used, local = np.unique(faces, return_inverse=True)
        normals, tangents = (None if a is None else a[used] for a in (m.normals, m.tangents))
        suffix = "" if b.tile is None else f".{b.tile}"
        parts.append(GlbPart(m.vertices[used], local.reshape(-1, 3), m.uv[used], slots, normals, tangents, name + suffix, factor, fields))
    return parts
