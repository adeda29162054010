"""texbake's MaterialX evaluation against MaterialX's own GLSL, run by its own renderer.

    xvfb-run -a scripts/run python bench/bench_mtlx_glsl.py [--size 128]

Needs an X display for MaterialX's GL context: Xvfb (Debian's ``xvfb``) with Mesa's
software OpenGL (llvmpipe). Each case is a nodegraph whose points come from the texture
coordinates (``position = (u S, v S, 0.37 S)``, S a power of two, so each pixel centre's
point is exact) into a noise node (and, for MaterialX's marble example, its whole graph,
its ``position`` node replaced so): ``PyMaterialXRenderGlsl.GlslRenderer`` renders the
graph's output in texture space into a float32 framebuffer of size² pixels (16,384 at
128: at least 10,000 points), and, in a second pass, the points themselves; texbake
evaluates the same document (``texbake.mtlx.evaluate_mtlx``, float64) at the texture
coordinates of those points. The figure is the largest difference, target 1e-5.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MARBLE = ROOT / "tests" / "data" / "mtlx" / "standard_surface_marble_solid.mtlx"
TARGET = 1e-5

POINTS = """    <texcoord name="uv" type="vector2" />
    <separate2 name="uv_parts" type="multioutput"><input name="in" type="vector2" nodename="uv" /></separate2>
    <combine3 name="uvz" type="vector3">
      <input name="in1" type="float" nodename="uv_parts" output="outx" />
      <input name="in2" type="float" nodename="uv_parts" output="outy" />
      <input name="in3" type="float" value="0.37" />
    </combine3>
    <multiply name="{name}" type="vector3"><input name="in1" type="vector3" nodename="uvz" /><input name="in2" type="float" value="{scale}" /></multiply>
"""

# case -> (the node on the points "p", its type, the points' scale)
CASES = {
    "noise3d float": ('<noise3d name="v" type="float"><input name="position" type="vector3" nodename="p" />'
                      '<input name="amplitude" type="float" value="0.8" /><input name="pivot" type="float" value="0.1" /></noise3d>', "float", 16),
    "noise3d vector3": ('<noise3d name="v" type="vector3"><input name="position" type="vector3" nodename="p" /></noise3d>', "vector3", 16),
    "fractal3d float, 3 octaves": ('<fractal3d name="v" type="float"><input name="position" type="vector3" nodename="p" /></fractal3d>',
                                   "float", 4),
    "fractal3d vector3, 5 octaves": ('<fractal3d name="v" type="vector3"><input name="position" type="vector3" nodename="p" />'
                                     '<input name="octaves" type="integer" value="5" /></fractal3d>', "vector3", 4),
    "cellnoise3d": ('<cellnoise3d name="v" type="float"><input name="position" type="vector3" nodename="p" /></cellnoise3d>', "float", 16),
    "worleynoise3d float, distance": ('<worleynoise3d name="v" type="float"><input name="position" type="vector3" nodename="p" />'
                                      '<input name="jitter" type="float" value="0.9" /></worleynoise3d>', "float", 16),
    "worleynoise3d float, cell": ('<worleynoise3d name="v" type="float"><input name="position" type="vector3" nodename="p" />'
                                  '<input name="style" type="integer" value="1" /></worleynoise3d>', "float", 16),
    "worleynoise3d vector3, distances": ('<worleynoise3d name="v" type="vector3"><input name="position" type="vector3" nodename="p" />'
                                         '</worleynoise3d>', "vector3", 16),
    **{f"unifiednoise3d type {t} ({kind}: a library nodegraph)": (
        f'<unifiednoise3d name="v" type="float"><input name="position" type="vector3" nodename="p" />'
        f'<input name="type" type="integer" value="{t}" /><input name="freq" type="vector3" value="0.5, 0.5, 0.5" /></unifiednoise3d>',
        "float", 16) for t, kind in enumerate(["perlin", "cell", "worley", "fractal"])},
    "rotate3d then noise3d vector3": ('<rotate3d name="r" type="vector3"><input name="in" type="vector3" nodename="p" />'
                                      '<input name="amount" type="float" value="33" /><input name="axis" type="vector3" value="1, 2, 3" />'
                                      '</rotate3d><noise3d name="v" type="vector3"><input name="position" type="vector3" nodename="r" />'
                                      '</noise3d>', "vector3", 16),
}


def case_document(node: str, type_: str, scale: float) -> str:
    """A document: nodegraph NG with outputs ``points`` and ``value``, a shader reading ``value``."""
    colour = type_ != "float"
    convert = '<convert name="vc" type="color3"><input name="in" type="vector3" nodename="v" /></convert>' if colour else ""
    shader_input = ('<input name="base_color" type="color3" nodegraph="NG" output="value" />' if colour else
                    '<input name="specular_roughness" type="float" nodegraph="NG" output="value" />')
    return f"""<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="NG">
{POINTS.format(name="p", scale=scale)}    {node}
    {convert}
    <output name="points" type="vector3" nodename="p" />
    <output name="value" type="{'color3' if colour else 'float'}" nodename="{'vc' if colour else 'v'}" />
  </nodegraph>
  <standard_surface name="SR" type="surfaceshader">{shader_input}</standard_surface>
  <surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="SR" /></surfacematerial>
</materialx>"""


def marble_document() -> str:
    """MaterialX's marble example, its object-space position replaced by the points (from -1 to 1)."""
    text = MARBLE.read_text()
    points = POINTS.format(name="p01", scale=2.0) + ('    <subtract name="obj_pos" type="vector3"><input name="in1" type="vector3" '
                                                       'nodename="p01" /><input name="in2" type="float" value="1" /></subtract>\n'
                                                       '    <output name="points" type="vector3" nodename="p01" />\n')
    return text.replace('    <position name="obj_pos" type="vector3" />\n', points)


class Renderer:
    """MaterialX's GLSL renderer, in texture space, into a float32 framebuffer."""

    def __init__(self, size: int):
        import MaterialX as mx
        from MaterialX import PyMaterialXGenGlsl as gen_glsl
        from MaterialX import PyMaterialXGenShader as gen_shader
        from MaterialX import PyMaterialXRender as render
        from MaterialX import PyMaterialXRenderGlsl as render_glsl

        self.mx, self.render, self.size = mx, render, size
        self.library = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), self.library)
        self.generator = gen_glsl.GlslShaderGenerator.create()
        self.context = gen_shader.GenContext(self.generator)
        self.context.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
        self.renderer = render_glsl.GlslRenderer.create(size, size, render.BaseType.FLOAT)
        self.renderer.initialize()
        self.renderer.setImageHandler(render_glsl.GLTextureHandler.create(render.StbImageLoader.create()))

    def output(self, text: str, graph: str, output: str) -> np.ndarray:
        """``(size², 4)`` float64: the nodegraph's output rendered over the UV square."""
        mx = self.mx
        doc = mx.createDocument()
        mx.readFromXmlString(doc, text)
        doc.setDataLibrary(self.library)
        element = doc.getNodeGraph(graph).getOutput(output)
        shader = self.generator.generate(f"{graph}_{output}", element, self.context)
        self.renderer.createProgram(shader)
        self.renderer.renderTextureSpace(mx.Vector2(0.0, 0.0), mx.Vector2(1.0, 1.0))
        image = self.render.Image.create(self.size, self.size, 4, self.render.BaseType.FLOAT)
        image.createResourceBuffer()
        image = self.renderer.captureImage(image)
        return np.array([image.getTexelColor(x, y).asTuple() for y in range(self.size) for x in range(self.size)], dtype=np.float64)


def compare(renderer: Renderer, text: str, graph: str, output: str, scale: float, channel: str, width: int) -> tuple[float, int, float]:
    """``(largest difference, points, spread of the values)`` of texbake against the render."""
    from texbake.mtlx import evaluate_mtlx

    points = renderer.output(text, graph, "points")[:, :3]
    theirs = renderer.output(text, graph, output)[:, :width]
    texcoords = points[:, :2] / scale  # exact: scale is a power of two
    ours = evaluate_mtlx(text, points, texcoords=texcoords, channels=[channel])[channel][:, :width]
    return float(np.abs(ours - theirs).max()), len(points), float(theirs.std())


def rows(size: int) -> list:
    renderer = Renderer(size)
    out = []
    for name, (node, type_, scale) in CASES.items():
        width = 1 if type_ == "float" else 3
        diff, n, spread = compare(renderer, case_document(node, type_, scale), "NG", "value", scale,
                                  "roughness" if width == 1 else "base_color", width)
        out.append((name, diff, n, spread))
    diff, n, spread = compare(renderer, marble_document(), "NG_marble1", "out", 2.0, "base_color", 3)
    out.append(("standard_surface_marble_solid (its graph: fractal3d, sin, power, mix)", diff, n, spread))
    return out


def main() -> None:
    sys.path.insert(0, str(ROOT / "bench"))
    from _rows import emit

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    table = [(f"mtlx {name} vs MaterialX's GLSL (PyMaterialXRenderGlsl, Mesa llvmpipe, float32), {n} points, max |difference|",
              f"{diff:.1e}", f"target <= {TARGET:.0e}: {'met' if diff <= TARGET else 'NOT met'} (values' std {spread:.3f})")
             for name, diff, n, spread in rows(args.size)]
    emit(table, args.markdown)


if __name__ == "__main__":
    main()
