"""The baked MaterialX document: the same shader, each input texbake baked read from its
map by an ``image`` node (a normal through ``normalmap``), ready for any MaterialX or USD
pipeline on the baked mesh (its UVs: the atlas'; ``texcoord`` 0).

An input the bake did not cover (``subsurface_color``, ``coat``...) keeps its graph or
value; the shader's factors that were multiplied into a baked channel (``base``,
``emission``) are set to 1, their product being in the map. Colour maps (base colour,
emissive) are read as ``srgb_texture``, every other map as data (texbake writes them so).
"""

from __future__ import annotations

from pathlib import Path

from ..output.atomic import write_bytes
from .document import SHADERS, _surface_shader, load

COLOUR_CHANNELS = ("base_color", "emissive")


def write_mtlx(source: str, where: str, maps: dict[str, str], path: Path) -> dict:
    """Write the document ``source`` (XML text; ``where``: its name in messages) with each
    channel of ``maps`` (channel -> the map's file name, relative to ``path``'s folder)
    read from its map, to ``path``; ``{"path": ...}``. Raises :class:`MtlxError` for a
    document that does not read (it was read before the bake: it does)."""
    import MaterialX as mx

    doc = load(source, where)
    shader, _ = _surface_shader(doc, where)
    spec = SHADERS[shader.getCategory()]
    nodedef = shader.getNodeDef()
    for channel, file in maps.items():
        if channel not in spec:
            continue
        first, *factors = spec[channel]
        wanted = nodedef.getActiveInput(first).getType() if nodedef is not None else "color3"
        image_type = "vector3" if channel == "normal" else wanted
        image = doc.addNode("image", f"texbake_{channel}", image_type)
        file_input = image.setInputValue("file", file, "filename")
        if channel in COLOUR_CHANNELS:  # data maps: no transform (the document's linear space)
            file_input.setColorSpace("srgb_texture")
        feeds = image
        if channel == "normal":
            feeds = doc.addNode("normalmap", "texbake_normalmap", "vector3")
            feeds.addInput("in", "vector3").setConnectedNode(image)
        _connect(shader, first, wanted, feeds)
        for name in factors:
            factor = _fresh_input(shader, name, nodedef.getActiveInput(name).getType() if nodedef is not None else "float")
            factor.setValueString("1")
    valid, message = doc.validate()
    if not valid:  # pragma: no cover - what this writes is valid (tested)
        raise ValueError(f"the baked document is not valid MaterialX: {message.strip().splitlines()[0]}")
    write_bytes(path, mx.writeToXmlString(doc).encode())
    return {"path": str(path)}


def _fresh_input(shader, name: str, type_: str):
    """The shader's input ``name``, its value and connections cleared (added if it had none)."""
    inp = shader.getInput(name)
    if inp is None:
        return shader.addInput(name, type_)
    for attribute in ("nodename", "nodegraph", "output", "interfacename", "value", "colorspace"):
        inp.removeAttribute(attribute)
    return inp


def _connect(shader, name: str, type_: str, node) -> None:
    _fresh_input(shader, name, type_).setConnectedNode(node)

