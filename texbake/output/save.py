"""Writing a bake: maps with OpenImageIO, the textured mesh, and the report.

Every file is written to a temporary name, checked and renamed into place, so nothing
half-written is left under a final name; the temporary files a killed bake left in the
folder are removed by the next bake into it.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..errors import OutputError, ParameterError
from ..formats import bits_problem, image_format
from .atomic import remove_stale
from .export import write_glb, write_obj
from .images import write_image
from .report import write_json


def save_result(result, folder: Path, *, fmt: str = "png", bits: int | None = None, obj: bool = False) -> dict:
    """Write ``result`` (a ``BakeResult``) into ``folder``; return the files written.

    Maps: ``albedo.<fmt>`` (or one per frame and ``flipbook``), ``lit``, ``normal`` when
    baked, and ``coverage.png`` (1 where the atlas covers a texel); mesh: ``<name>.glb``
    with the albedo (of the first frame) bound as base colour, the normal map (if baked)
    as normal texture with the tangents it was baked in, and, for a texture that emits
    light (the flame), the albedo as emissive, its base colour factor black (PNG copies ``<map>_gltf.png`` when the
    format is not PNG); ``<name>.obj`` + MTL if ``obj``; ``report.json`` last, so its
    presence means the rest is complete. Colour maps are sRGB; the normal map and the
    coverage are data (a linear PNG: ``texbake.output.images``). A material's bake writes
    a map per channel (``base_color``, ``emissive`` colour; the rest data) and its packed
    maps (``orm``...), and its GLB's material is whole (:func:`_glb_textures`).
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
    jobs = {name: (folder / f"{name}.{fmt}", pixels, bits, "linear" if is_colour(name) else "data")  # a normal map is no colour
            for name, pixels in result.images.items()}
    jobs["coverage"] = (folder / "coverage.png", result.coverage[:, :, None], None, "data")
    with ThreadPoolExecutor(2, thread_name_prefix="texbake-write") as pool:  # two at once: OpenImageIO's compression releases the GIL
        futures = {name: pool.submit(write_image, path, pixels, bits=b, colorspace=kind) for name, (path, pixels, b, kind) in jobs.items()}
        written = {name: future.result() for name, future in futures.items()}

    slots, factor, material = _glb_textures(result, folder, fmt, written)
    texture = slots["baseColor"]
    m = result.mesh
    written["glb"] = write_glb(folder / f"{m.name}.glb", m.vertices, m.faces, m.uv, slots, normals=m.normals, tangents=m.tangents,
                               name=m.name, base_factor=factor, material=material)
    if obj:
        written["obj"] = write_obj(folder / f"{m.name}.obj", m.vertices, m.faces, m.uv, texture.name, normals=m.normals)

    report = dict(result.report)
    report["seconds"] = {**report.get("seconds", {}), "write": round(time.perf_counter() - start, 4)}
    report["outputs"] = {k: {"path": Path(v["path"]).name, **{x: y for x, y in v.items() if x != "path"}} for k, v in written.items()}
    write_json(folder / "report.json", report)
    result.report = report
    return written


COLOUR_MAPS = ("lit", "flipbook", "base_color", "emissive")  # and albedo, albedo_0000...: sRGB; every other map is data


def is_colour(name: str) -> bool:
    """Whether the map ``name`` is colour (written sRGB) rather than data (linear)."""
    return name in COLOUR_MAPS or name.startswith("albedo")


def _glb_textures(result, folder: Path, fmt: str, written: dict) -> tuple[dict[str, Path], tuple, dict]:
    """``(slots, base colour factor, material fields)`` of the GLB's material: the PNG of each
    texture slot (glTF embeds PNG or JPEG only: PNG copies ``<map>_gltf.png`` of other
    formats, and of what glTF reads otherwise: a base colour with the opacity as its alpha,
    a normal map with green up, an ORM map where the packing has none)."""
    images = result.images
    if result.settings.material is None:
        colour = "albedo" if "albedo" in images else min(n for n in images if n.startswith("albedo_"))
        emits = result.settings.texture.emits  # the flame: its colour is light, not paint
        slots = {"baseColor": colour, **({"normal": "normal"} if "normal" in images else {}), **({"emissive": colour} if emits else {})}
        return _pngs(result, folder, fmt, written, slots, {}), (0.0, 0.0, 0.0, 1.0) if emits else (1.0, 1.0, 1.0, 1.0), {}
    from ..materials import DEFAULTS, PACKINGS, pack

    copies: dict[str, object] = {}
    slots = {"baseColor": "base_color"}
    fields: dict = {}  # without a metallic-roughness map the GLB's factors are the defaults': metallic 0, roughness 1
    if "opacity" in images:  # glTF reads the opacity from the base colour's alpha
        copies["base_color"] = np.concatenate([images["base_color"], images["opacity"]], axis=2)
        mode = result.settings.material.alpha_mode
        fields.update(alphaMode=mode.upper(), **({"alphaCutoff": result.settings.material.alpha_cutoff} if mode == "mask" else {}))
    if {"roughness", "metallic", "occlusion"} & set(images):
        if "orm" not in images:
            copies["orm"] = pack(PACKINGS["orm"], images, DEFAULTS)
        slots.update(metallicRoughness="orm", **({"occlusion": "orm"} if "occlusion" in images else {}))
    if "normal" in images:
        slots["normal"] = "normal"
        if result.settings.normal_convention == "directx":  # glTF's is +Y
            copies["normal"] = np.concatenate([images["normal"][..., :1], 1.0 - images["normal"][..., 1:2], images["normal"][..., 2:]], axis=2)
    if "emissive" in images:
        slots["emissive"] = "emissive"
    return _pngs(result, folder, fmt, written, slots, copies), (1.0, 1.0, 1.0, 1.0), fields


def _pngs(result, folder: Path, fmt: str, written: dict, slots: dict[str, str], copies: dict) -> dict[str, Path]:
    """The PNG of each slot's map: the map's own file, or a ``<map>_gltf.png`` written of
    ``copies[map]`` (or of the map, in a format that is not PNG)."""
    out = {}
    for slot, name in slots.items():
        out[slot] = folder / f"{name}.png"
        if fmt != "png" or name in copies:
            out[slot] = folder / f"{name}_gltf.png"
            if f"{name}_gltf" not in written:
                pixels = copies.get(name, result.images.get(name))
                written[f"{name}_gltf"] = write_image(out[slot], pixels, colorspace="linear" if is_colour(name) else "data")
    return out
