"""Writing a bake: maps with OpenImageIO, the textured mesh, and the report.

Every file is written to a temporary name, checked and renamed into place, so nothing
half-written is left under a final name; the temporary files a killed bake left in the
folder are removed by the next bake into it.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

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
    coverage are data (a linear PNG: ``texbake.output.images``).
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
    jobs = {name: (folder / f"{name}.{fmt}", pixels, bits, "data" if name == "normal" else "linear")  # a normal map is no colour
            for name, pixels in result.images.items()}
    jobs["coverage"] = (folder / "coverage.png", result.coverage[:, :, None], None, "data")
    with ThreadPoolExecutor(2, thread_name_prefix="texbake-write") as pool:  # two at once: OpenImageIO's compression releases the GIL
        futures = {name: pool.submit(write_image, path, pixels, bits=b, colorspace=kind) for name, (path, pixels, b, kind) in jobs.items()}
        written = {name: future.result() for name, future in futures.items()}

    # the GLB's textures (glTF embeds PNG or JPEG only: PNG copies of other formats)
    colour = "albedo" if "albedo" in result.images else min(n for n in result.images if n.startswith("albedo_"))
    slot_maps = {"baseColor": colour, **({"normal": "normal"} if "normal" in result.images else {})}
    slots = {}
    for slot, name in slot_maps.items():
        slots[slot] = folder / f"{name}.png"
        if fmt != "png":
            slots[slot] = folder / f"{name}_gltf.png"
            written[f"{name}_gltf"] = write_image(slots[slot], result.images[name], colorspace="data" if name == "normal" else "linear")
    emits = result.settings.texture.emits  # the flame: its colour is light, not paint
    if emits:
        slots["emissive"] = slots["baseColor"]
    texture = slots["baseColor"]
    m = result.mesh
    written["glb"] = write_glb(folder / f"{m.name}.glb", m.vertices, m.faces, m.uv, slots, normals=m.normals, tangents=m.tangents,
                               name=m.name, base_factor=(0.0, 0.0, 0.0, 1.0) if emits else (1.0, 1.0, 1.0, 1.0))
    if obj:
        written["obj"] = write_obj(folder / f"{m.name}.obj", m.vertices, m.faces, m.uv, texture.name, normals=m.normals)

    report = dict(result.report)
    report["seconds"] = {**report.get("seconds", {}), "write": round(time.perf_counter() - start, 4)}
    report["outputs"] = {k: {"path": Path(v["path"]).name, **{x: y for x, y in v.items() if x != "path"}} for k, v in written.items()}
    write_json(folder / "report.json", report)
    result.report = report
    return written
