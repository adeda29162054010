"""Regenerate the golden images: `scripts/run python tests/data/golden/make.py`.

Each is a 64 x 64 8-bit sRGB PNG of one texture (defaults) baked onto
../shared/meshes/suzanne.ply with its own UVs, texture_space="unit", margin 2. Made by
texbake itself when the texture was checked by eye; tests/integration/test_golden.py compares new
bakes with them. Regenerate only on purpose, after looking at the new images.
"""

from pathlib import Path

from texbake import bake_mesh
from texbake.output.images import write_image

HERE = Path(__file__).resolve().parent
MESH = HERE.parents[3] / "shared" / "meshes" / "suzanne.ply"
TEXTURES = ["checker", "position", "noise", "turbulence", "fbm", "marble", "wood", "flame"]


def bake(name):
    return bake_mesh(MESH, name, size=64, margin=2).images["albedo"]


if __name__ == "__main__":
    for name in TEXTURES:
        write_image(HERE / f"{name}.png", bake(name))
        print("wrote", HERE / f"{name}.png")
