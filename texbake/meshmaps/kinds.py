"""The mesh map kinds: their names (``BakeSettings.maps``), image channels and what each needs.

No imports of texbake: ``texbake.settings`` reads the names from here.
"""

from __future__ import annotations

# name -> channels of its image
CHANNELS: dict[str, int] = {
    "ao": 1,  # ambient occlusion: the share of cosine-weighted hemisphere rays that hit nothing (1 open)
    "bent_normal": 3,  # the mean unoccluded direction, object space, 0.5 + 0.5 n
    "thickness": 1,  # the mean distance of rays into the mesh to its far side, over the rays' length (1 thick)
    "curvature": 1,  # 0.5 flat, above convex, below concave
    "position_object": 3,  # the point in the bounding box, each axis 0 to 1
    "position_world": 3,  # the point in the bounding box's cube (one scale for every axis: proportions kept)
    "normal_object": 3,  # the shading normal, 0.5 + 0.5 n
    "normal_world": 3,  # the same in the scene's frame (the loaded mesh has its node transforms applied)
    "id_material": 3,  # a flat colour per material
    "id_part": 3,  # per part (a scene's mesh, an OBJ group)
    "id_chart": 3,  # per UV chart (faces joined by shared UV vertices)
    "source_normal": 3,  # high to low: the source mesh's normal in the target's tangent frame (texbake.meshmaps.highpoly)
    "source_height": 1,  # the source's height over the target, 0.5 at the target
    "source_missed": 1,  # 1 where the ray found no source
}
KINDS = tuple(CHANNELS)
RAY_KINDS = ("ao", "bent_normal", "thickness")  # the kinds that cast hemisphere rays
SOURCE_KINDS = ("source_normal", "source_height", "source_missed")  # the kinds of a high-to-low bake (a source mesh)
