"""The baked mesh: GLB with the map bound as base colour, and OBJ + MTL.

Vertices are written as they are, one per atlas vertex (seam vertices stay split).
UVs come in with v up (OpenGL, trimesh); glTF puts the image origin at the top left, so
its TEXCOORD_0 is ``(u, 1 - v)``. Files are written to a temporary name and renamed.
"""

from __future__ import annotations

import json
import os
import struct
import uuid
from pathlib import Path

import numpy as np

from .errors import OutputError

# glTF constants
_FLOAT, _UINT16, _UINT32 = 5126, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_LINEAR, _LINEAR_MIPMAP_LINEAR, _CLAMP = 9729, 9987, 33071


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if tmp.stat().st_size != len(data):
            raise OutputError(f"{path}: short write (disk full?)")
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(f"{path}: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _pad(data: bytes, fill: bytes) -> bytes:
    return data + fill * (-len(data) % 4)


def write_glb(path, vertices, faces, uv, texture, *, normals=None, name: str = "baked") -> dict:
    """Write a GLB: one mesh, its UVs, and ``texture`` (PNG path or bytes) as base colour.

    ``vertices``: ``(k, 3)`` float (written as float32); ``faces``: ``(m, 3)`` int;
    ``uv``: ``(k, 2)`` float, v up; ``normals``: optional ``(k, 3)`` unit normals.
    The sampler clamps to the edge: an atlas has margins, not a repeating pattern.
    """
    path = Path(path)
    png = texture if isinstance(texture, bytes) else Path(texture).read_bytes()
    positions = np.ascontiguousarray(vertices, dtype=np.float32)
    texcoord = np.ascontiguousarray(np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]), dtype=np.float32)
    index_type = _UINT16 if len(positions) < 65535 else _UINT32
    indices = np.ascontiguousarray(faces, dtype=np.uint16 if index_type == _UINT16 else np.uint32).ravel()

    blobs, views, accessors = [], [], []

    def add_view(data: bytes, target=None) -> int:
        offset = sum(len(b) for b in blobs)
        blobs.append(_pad(data, b"\0"))
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(data)}
        if target:
            view["target"] = target
        views.append(view)
        return len(views) - 1

    def add_accessor(array: np.ndarray, kind: str, component: int, target, minmax=False) -> int:
        acc = {"bufferView": add_view(array.tobytes(), target), "componentType": component, "count": int(len(array) if kind != "SCALAR" else array.size), "type": kind}
        if minmax:
            acc["min"] = array.min(axis=0).tolist()
            acc["max"] = array.max(axis=0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    attributes = {
        "POSITION": add_accessor(positions, "VEC3", _FLOAT, _ARRAY_BUFFER, minmax=True),
        "TEXCOORD_0": add_accessor(texcoord, "VEC2", _FLOAT, _ARRAY_BUFFER),
    }
    if normals is not None:
        attributes["NORMAL"] = add_accessor(np.ascontiguousarray(normals, dtype=np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER)
    index_accessor = add_accessor(indices, "SCALAR", index_type, _ELEMENT_ARRAY_BUFFER)
    image_view = add_view(png)
    binary = b"".join(blobs)

    doc = {
        "asset": {"version": "2.0", "generator": "texbake"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"name": name, "primitives": [{"attributes": attributes, "indices": index_accessor, "material": 0, "mode": 4}]}],
        "materials": [{"name": f"{name}_baked", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": _LINEAR, "minFilter": _LINEAR_MIPMAP_LINEAR, "wrapS": _CLAMP, "wrapT": _CLAMP}],
        "images": [{"bufferView": image_view, "mimeType": "image/png"}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(binary)}],
    }
    chunk_json = _pad(json.dumps(doc, separators=(",", ":")).encode(), b" ")
    total = 12 + 8 + len(chunk_json) + 8 + len(binary)
    glb = b"".join([
        struct.pack("<4sII", b"glTF", 2, total),
        struct.pack("<I4s", len(chunk_json), b"JSON"), chunk_json,
        struct.pack("<I4s", len(binary), b"BIN\0"), binary,
    ])
    _atomic_write(path, glb)
    return {"path": str(path), "bytes": len(glb), "vertices": len(positions), "faces": len(indices) // 3}


def write_obj(path, vertices, faces, uv, image_filename: str, *, normals=None) -> dict:
    """Write ``path`` (OBJ) and an MTL beside it whose ``map_Kd`` names ``image_filename``."""
    path = Path(path)
    mtl = path.with_suffix(".mtl")
    material = f"{path.stem}_baked"
    _atomic_write(mtl, f"newmtl {material}\nKd 1 1 1\nKa 0 0 0\nKs 0 0 0\nmap_Kd {image_filename}\n".encode())
    lines = [f"mtllib {mtl.name}", f"usemtl {material}"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in np.asarray(vertices, dtype=np.float64)]
    lines += [f"vt {u:.9g} {v:.9g}" for u, v in np.asarray(uv, dtype=np.float64)]
    f1 = np.asarray(faces, dtype=np.int64) + 1
    if normals is not None:
        lines += [f"vn {x:.6g} {y:.6g} {z:.6g}" for x, y, z in np.asarray(normals)]
        lines += [f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}" for a, b, c in f1]
    else:
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f1]
    data = ("\n".join(lines) + "\n").encode()
    _atomic_write(path, data)
    return {"path": str(path), "bytes": len(data), "mtl": mtl.name}
