"""The baked mesh: GLB with the maps bound to its material (base colour, and
metallic-roughness, occlusion, normal and emissive where baked), and OBJ + MTL.

Vertices are written as they are, one per atlas vertex (seam vertices stay split).
UVs come in with v up (OpenGL, trimesh, OBJ); glTF puts the image origin at the top left,
so its TEXCOORD_0 is ``(u, 1 - v)``. Files are written to a temporary name beside the
final one, flushed, and renamed into place; :class:`OutputError` on any failure.

GLB layout (glTF 2.0 binary): a 12-byte header, a JSON chunk padded with spaces to a
multiple of 4 bytes, a BIN chunk padded with zeros; inside the BIN chunk every buffer
view starts on a 4-byte boundary. The sampler clamps to the edge: a baked atlas has
margins around its charts, not a repeating pattern, and REPEAT would let bilinear and
mipmap filtering at the image border blend in texels from the opposite border. glTF
reads a base colour and an emissive image as sRGB and a normal map as linear data, whatever
the PNG's colour chunks say; the maps' PNGs say the same (``texbake.output.images``).
"""

from __future__ import annotations

import json
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import OutputError, ParameterError
from .atomic import write_bytes
from .images import PNG_SIGNATURE

# glTF constants
_FLOAT, _UINT16, _UINT32 = 5126, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_LINEAR, _LINEAR_MIPMAP_LINEAR, _CLAMP = 9729, 9987, 33071
_TRIANGLES = 4


def _pad(data: bytes, fill: bytes) -> bytes:
    return data + fill * (-len(data) % 4)


def _mesh_arrays(vertices, faces, uv, normals):
    """Checked ``(k, 3)`` float64 vertices, ``(m, 3)`` int64 faces, ``(k, 2)`` uv, normals."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    t = np.asarray(uv, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise ParameterError("vertices", f"expected (k, 3) values, k > 0, got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
        raise ParameterError("faces", f"expected (m, 3) integer indices, m > 0, got shape {f.shape} {f.dtype}")
    if t.shape != (len(v), 2):
        raise ParameterError("uv", f"expected ({len(v)}, 2) values (one per vertex), got shape {t.shape}")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise ParameterError("faces", f"indices must lie in [0, {len(v)}), got [{f.min()}, {f.max()}]")
    if not (np.isfinite(v).all() and np.isfinite(t).all()):
        raise ParameterError("vertices", "vertices and uv must be finite (no NaN or infinity)")
    n = None
    if normals is not None:
        n = np.asarray(normals, dtype=np.float64)
        if n.shape != v.shape:
            raise ParameterError("normals", f"expected {v.shape} values, got shape {n.shape}")
        length = np.linalg.norm(n, axis=1)
        bad = ~(np.isfinite(length) & (length > 1e-12))
        if bad.any():
            raise ParameterError("normals", f"{int(bad.sum())} normals are zero or not finite")
        n = n / length[:, None]
    return v, f, t, n


SLOTS = ("baseColor", "metallicRoughness", "occlusion", "normal", "emissive")  # the material's texture slots write_glb fills


def _png(path: Path, slot: str, texture) -> bytes:
    if isinstance(texture, (bytes, bytearray, memoryview)):
        png = bytes(texture)
    else:
        try:
            png = Path(texture).read_bytes()
        except OSError as exc:
            raise OutputError(f"{path}: cannot read the {slot} texture {texture}: {exc.strerror or exc}") from None
    if not png.startswith(PNG_SIGNATURE):
        raise ParameterError("texture", f"{slot}: expected a PNG image (file or bytes)")
    return png


@dataclass
class GlbPart:
    """One primitive of a GLB (:func:`write_glb_parts`): a mesh with its UVs, and its own
    material's name and textures (as :func:`write_glb` takes them)."""

    vertices: np.ndarray  # (k, 3) float
    faces: np.ndarray  # (m, 3) int into vertices
    uv: np.ndarray  # (k, 2) float, v up
    textures: object  # a PNG (path or bytes) or a dict of PNGs by slot
    normals: np.ndarray | None = None  # (k, 3)
    tangents: np.ndarray | None = None  # (k, 4)
    material: str = "baked"
    base_factor: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    fields: dict | None = None  # more of its glTF material's fields (write_glb's material)


def write_glb(path, vertices, faces, uv, textures, *, normals=None, tangents=None, name: str = "baked",
              base_factor: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0), material: dict | None = None) -> dict:
    """Write a GLB: one mesh, its UVs, and its material's textures, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.glb`` file; its folder must exist.
    vertices : (k, 3) array_like of float
        Positions, finite; written as float32.
    faces : (m, 3) array_like of int
        Triangles, indices in ``[0, k)``; written as uint16 below 65535 vertices, else
        uint32.
    uv : (k, 2) array_like of float
        One texture coordinate per vertex, OpenGL convention (v up); written as glTF's
        ``(u, 1 - v)`` in float32.
    textures : str, os.PathLike, bytes or dict
        A PNG (file path or bytes), bound as the base colour; or a dict of PNGs by slot:
        ``"baseColor"`` (required; sRGB colour, its alpha the opacity where the material's
        ``alphaMode`` reads it), ``"metallicRoughness"`` (data: G roughness, B metallic,
        with factors 1), ``"occlusion"`` (data: R), ``"normal"`` (a tangent-space normal
        map, +Y up: linear data) and ``"emissive"`` (sRGB, with ``emissiveFactor`` 1).
        Slots given the same PNG share one image (an ORM map as metallic-roughness and
        occlusion); the PNGs are embedded as they are.
    normals : (k, 3) array_like of float, optional
        Shading normals, non-zero and finite; normalised here.
    tangents : (k, 4) array_like of float, optional
        glTF tangents: unit xyz orthogonal to the normals and w = +1 or -1
        (:mod:`texbake.mesh.tangents`); needs ``normals``.
    name : str, optional
        The node's name (its material is ``<name>_baked``).
    base_factor : (4,) tuple of float, optional
        The base colour's factor: black for a texture that is light, not paint (the
        flame, bound as emissive).
    material : dict, optional
        More of the glTF material's fields, written over what the textures give (a
        baked material's ``alphaMode`` and ``alphaCutoff``, its factors where a channel
        has no map: ``{"pbrMetallicRoughness": {"metallicFactor": 0.0}}``).

    Returns
    -------
    dict
        ``path`` (str), ``bytes`` (the file's size), ``vertices`` and ``faces`` (counts).

    Raises
    ------
    ParameterError
        A bad array (its shape, dtype, range or finiteness), texture slot or non-PNG
        texture, naming the parameter.
    OutputError
        A texture file cannot be read, or the GLB cannot be written (a missing folder, a
        name taken by a folder); nothing is left under ``path``'s name.
    """
    part = GlbPart(vertices, faces, uv, textures, normals, tangents, f"{name}_baked", base_factor, material)
    return write_glb_parts(path, [part], name=name)


def write_glb_parts(path, parts: list[GlbPart], *, name: str = "baked") -> dict:
    """Write a GLB of one mesh (node ``name``) of one primitive per part, each with its
    own material (:class:`GlbPart`), atomically; :func:`write_glb` says what each array
    and texture may be, what is returned and raised. The same PNG in two parts (or two
    slots) is one image."""
    path = Path(path)
    checked = []
    for part in parts:
        v, f, t, n = _mesh_arrays(part.vertices, part.faces, part.uv, part.normals)
        checked.append((v, f, t, n, _checked_tangents(part.tangents, n, len(v)), _slot_pngs(path, part.textures)))
    buffer = _Buffer()
    primitives = []
    for k, (v, f, t, n, tangents, _) in enumerate(checked):
        attributes = _attributes(buffer, v, t, n, tangents)
        small = len(v) < 65535  # 65535 itself is the primitive-restart value
        indices = np.ascontiguousarray(f, dtype=np.uint16 if small else np.uint32).ravel()
        index_accessor = buffer.accessor(indices, "SCALAR", _UINT16 if small else _UINT32, _ELEMENT_ARRAY_BUFFER)
        primitives.append({"attributes": attributes, "indices": index_accessor, "material": k, "mode": _TRIANGLES})
    images: list[bytes] = list(dict.fromkeys(png for *_, pngs in checked for png in pngs.values()))  # one image (and texture) per distinct PNG
    image_views = [buffer.view(png) for png in images]
    materials = [_material(part.material, {slot: {"index": images.index(png)} for slot, png in pngs.items()}, part.base_factor,
                           part.fields) for part, (*_, pngs) in zip(parts, checked, strict=True)]
    binary = b"".join(buffer.blobs)
    doc = {
        "asset": {"version": "2.0", "generator": "texbake"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"name": name, "primitives": primitives}],
        "materials": materials,
        "textures": [{"sampler": 0, "source": i} for i in range(len(images))],
        "samplers": [{"magFilter": _LINEAR, "minFilter": _LINEAR_MIPMAP_LINEAR, "wrapS": _CLAMP, "wrapT": _CLAMP}],
        "images": [{"bufferView": view, "mimeType": "image/png"} for view in image_views],
        "accessors": buffer.accessors,
        "bufferViews": buffer.views,
        "buffers": [{"byteLength": len(binary)}],
    }
    glb = _glb(doc, binary)
    write_bytes(path, glb)
    return {"path": str(path), "bytes": len(glb), "vertices": sum(len(c[0]) for c in checked), "faces": sum(len(c[1]) for c in checked)}


def _slot_pngs(path: Path, textures) -> dict[str, bytes]:
    """The PNG bytes of each texture slot :func:`write_glb` was given."""
    slots = dict(textures) if isinstance(textures, dict) else {"baseColor": textures}
    unknown = sorted(set(slots) - set(SLOTS))
    if unknown:  # a dict without baseColor is a plain white material (a bake of mesh maps only: its normal map)
        raise ParameterError("textures", f"expected PNGs of the slots {', '.join(SLOTS)}, got {sorted(slots)}")
    return {slot: _png(path, slot, texture) for slot, texture in slots.items()}


def _checked_tangents(tangents, normals: np.ndarray | None, k: int) -> np.ndarray | None:
    """``(k, 4)`` float64 tangents, checked: finite, given with normals, unit xyz, w = +-1."""
    if tangents is None:
        return None
    tangents = np.asarray(tangents, dtype=np.float64)
    if normals is None or tangents.shape != (k, 4) or not np.isfinite(tangents).all():
        raise ParameterError("tangents", f"expected ({k}, 4) finite values with normals, got shape {tangents.shape}")
    if not (np.abs(np.linalg.norm(tangents[:, :3], axis=1) - 1) < 1e-6).all() or not np.isin(tangents[:, 3], (-1.0, 1.0)).all():
        raise ParameterError("tangents", "xyz must be unit length and w +1 or -1")
    return tangents


class _Buffer:
    """The BIN chunk as it is laid out: its pieces, each padded to 4 bytes, and the buffer
    views and accessors that index it, offset by offset."""

    def __init__(self) -> None:
        self.blobs: list[bytes] = []
        self.views: list[dict] = []
        self.accessors: list[dict] = []
        self.offset = 0

    def view(self, data: bytes, target=None) -> int:
        """Append ``data`` as a buffer view; its index."""
        view = {"buffer": 0, "byteOffset": self.offset, "byteLength": len(data)}
        if target:
            view["target"] = target
        padded = _pad(data, b"\0")
        self.blobs.append(padded)
        self.offset += len(padded)
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, array: np.ndarray, kind: str, component: int, target, minmax: bool = False) -> int:
        """Append ``array`` as a buffer view and an accessor of it; the accessor's index."""
        count = array.size if kind == "SCALAR" else len(array)
        acc = {"bufferView": self.view(array.tobytes(), target), "componentType": component, "count": int(count), "type": kind}
        if minmax:  # float32 values, exactly as stored
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _attributes(buffer: _Buffer, v: np.ndarray, t: np.ndarray, n: np.ndarray | None, tangents: np.ndarray | None) -> dict[str, int]:
    """The primitive's vertex attributes (accessor indices), written into ``buffer`` as float32."""
    positions = np.ascontiguousarray(v, dtype=np.float32)
    attributes = {"POSITION": buffer.accessor(positions, "VEC3", _FLOAT, _ARRAY_BUFFER, minmax=True)}
    if n is not None:
        attributes["NORMAL"] = buffer.accessor(np.ascontiguousarray(n, dtype=np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER)
    if tangents is not None:
        tangent32 = tangents.astype(np.float32)
        tangent32[:, :3] /= np.linalg.norm(tangent32[:, :3], axis=1, keepdims=True)  # unit length in float32 too
        attributes["TANGENT"] = buffer.accessor(np.ascontiguousarray(tangent32), "VEC4", _FLOAT, _ARRAY_BUFFER)
    texcoord = np.ascontiguousarray(np.column_stack([t[:, 0], 1.0 - t[:, 1]]), dtype=np.float32)  # glTF: v down
    attributes["TEXCOORD_0"] = buffer.accessor(texcoord, "VEC2", _FLOAT, _ARRAY_BUFFER)
    return attributes


def _material(name: str, texture: dict[str, dict], base_factor, extra: dict | None = None) -> dict:
    """A material named ``name``: base colour, and metallic-roughness, occlusion, normal and
    emissive where ``texture`` has them; ``extra`` written over it."""
    pbr: dict = {**({"baseColorTexture": texture["baseColor"]} if "baseColor" in texture else {}), "metallicFactor": 0.0, "roughnessFactor": 1.0}
    material: dict = {"name": name, "pbrMetallicRoughness": pbr}
    if tuple(base_factor) != (1.0, 1.0, 1.0, 1.0):
        pbr["baseColorFactor"] = [float(x) for x in base_factor]
    if "metallicRoughness" in texture:  # the texture's values as they are
        pbr.update(metallicRoughnessTexture=texture["metallicRoughness"], metallicFactor=1.0, roughnessFactor=1.0)
    if "occlusion" in texture:
        material["occlusionTexture"] = texture["occlusion"]
    if "normal" in texture:
        material["normalTexture"] = texture["normal"]
    if "emissive" in texture:
        material["emissiveTexture"], material["emissiveFactor"] = texture["emissive"], [1.0, 1.0, 1.0]
    for key, value in (extra or {}).items():
        material[key] = {**material.get(key, {}), **value} if isinstance(value, dict) else value
    return material


def _glb(doc: dict, binary: bytes) -> bytes:
    """The GLB container: header, JSON chunk (space padded), BIN chunk."""
    chunk_json = _pad(json.dumps(doc, separators=(",", ":"), allow_nan=False).encode(), b" ")
    total = 12 + 8 + len(chunk_json) + 8 + len(binary)
    return b"".join([
        struct.pack("<4sII", b"glTF", 2, total),
        struct.pack("<I4s", len(chunk_json), b"JSON"), chunk_json,
        struct.pack("<I4s", len(binary), b"BIN\0"), binary,
    ])


def write_obj(path, vertices, faces, uv, image_filename, *, normals=None) -> dict:
    """Write ``path`` (OBJ) and an MTL beside it whose ``map_Kd`` names the image.

    ``image_filename`` is written relative to the OBJ's folder (an absolute path is made
    relative), with forward slashes. UVs are written as given (v up, as OBJ wants).
    Returns path, bytes, mtl (its file name), vertices, faces.
    """
    path = Path(path)
    v, f, t, n = _mesh_arrays(vertices, faces, uv, normals)
    image = Path(image_filename)
    if image.is_absolute():
        image = Path(os.path.relpath(image, path.parent.resolve()))
    image_ref = image.as_posix()
    if any(ch in image_ref for ch in "\n\r"):
        raise ParameterError("image_filename", "must not contain line breaks")
    mtl = path.with_suffix(".mtl")
    material = f"{path.stem}_baked".replace(" ", "_")
    write_bytes(mtl, f"newmtl {material}\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd {image_ref}\n".encode())
    lines = ["# texbake", f"mtllib {mtl.name}", f"usemtl {material}"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v]
    lines += [f"vt {a:.9g} {b:.9g}" for a, b in t]
    f1 = f + 1
    if n is not None:
        lines += [f"vn {x:.7g} {y:.7g} {z:.7g}" for x, y, z in n]
        lines += [f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}" for a, b, c in f1]
    else:
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f1]
    data = ("\n".join(lines) + "\n").encode()
    write_bytes(path, data)
    return {"path": str(path), "bytes": len(data), "mtl": mtl.name, "vertices": len(v), "faces": len(f)}


@dataclass
class ObjPart:
    """One material's faces in an OBJ (:func:`write_obj_parts`): its mesh, and the image
    its material's ``map_Kd`` names (``albedo.<UDIM>.png`` for UDIM tiles)."""

    vertices: np.ndarray  # (k, 3) float
    faces: np.ndarray  # (m, 3) int into vertices
    uv: np.ndarray  # (k, 2) float, v up, as written (UDIM tiles: beyond the unit square)
    image: str | None  # relative to the OBJ's folder; None: no map_Kd (a bake of mesh maps only)
    material: str
    normals: np.ndarray | None = None


def write_obj_parts(path, parts: list[ObjPart]) -> dict:
    """Write ``path`` (OBJ) of several materials, ``usemtl`` each part's, and the MTL beside
    it with each material's ``map_Kd`` (:func:`write_obj` for one). Material names are
    written with spaces as ``_``. Returns path, bytes, mtl, vertices, faces."""
    path = Path(path)
    mtl = path.with_suffix(".mtl")
    lines, mtl_lines, offset = ["# texbake", f"mtllib {mtl.name}"], [], 0
    vertices = faces = 0
    for part in parts:
        v, f, t, n = _mesh_arrays(part.vertices, part.faces, part.uv, part.normals)
        if any(ch in (part.image or "") + part.material for ch in "\n\r"):
            raise ParameterError("image_filename", "must not contain line breaks")
        material = part.material.replace(" ", "_")
        mtl_lines += [f"newmtl {material}", "Ka 0 0 0", "Kd 1 1 1", "Ks 0 0 0", "illum 1", *([] if part.image is None else [f"map_Kd {part.image}"]), ""]
        lines.append(f"usemtl {material}")
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v]
        lines += [f"vt {a:.9g} {b:.9g}" for a, b in t]
        f1 = f + 1 + offset
        if n is not None:
            lines += [f"vn {x:.7g} {y:.7g} {z:.7g}" for x, y, z in n]
            lines += [f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}" for a, b, c in f1]
        else:
            lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f1]
        offset += len(v)
        vertices, faces = vertices + len(v), faces + len(f)
    write_bytes(mtl, "\n".join(mtl_lines).encode())
    data = ("\n".join(lines) + "\n").encode()
    write_bytes(path, data)
    return {"path": str(path), "bytes": len(data), "mtl": mtl.name, "vertices": vertices, "faces": faces}
