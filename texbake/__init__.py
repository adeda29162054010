"""texbake: bake 3D procedural (solid) textures into 2D maps and textured meshes.

    import texbake
    result = texbake.bake_mesh("bunny.ply", "checker", size=1024)
    result.save("out/bunny")
    texbake.bake_mesh("bunny.ply", material="rusted_iron").save("out/rust")  # a whole PBR texture set (texbake.Material)
"""

from .errors import AtlasError, BakeError, MaterialError, MeshError, OutputError, ParameterError, TextureError
from .version import __version__

__all__ = ["__version__", "BakeSettings", "Material", "bake_mesh", "BakeResult", "BakeError", "MaterialError", "MeshError", "ParameterError", "AtlasError", "TextureError", "OutputError"]


def __getattr__(name):  # the pipeline pulls in the heavy libraries: import it on first use
    if name in ("bake_mesh", "BakeResult"):
        from . import pipeline

        return getattr(pipeline, name)
    if name == "BakeSettings":
        from .settings import BakeSettings

        return BakeSettings
    if name == "Material":
        from .materials.model import Material

        return Material
    raise AttributeError(f"module 'bake' has no attribute {name!r}")
