"""Quality presets: samples, footprint filtering, precision and octave cap in one word.

One definition for the library, the command line and the service (``BakeSettings.quality``;
``BakeSettings.quality_settings()`` resolves a preset with the fields set explicitly). Chosen from ``texbake report`` (``texbake.checks.sweep``) on
suzanne_blender_uv.obj (63k faces) at 1024^2, whole bake with a pre-made atlas, RMSE in
linear colour against a 256-sample point-sampled reference (figures: README, Benchmarks):

=========  ==============================
preset     settings
=========  ==============================
default    1 sample, filtering
final      16 samples, point sampling
=========  ==============================

``final`` point-samples because footprint filtering with several samples blurs each
sample by a whole texel (its error stays at that of one filtered sample), while point
samples converge to the texel mean. float32 made no measurable difference in time or
error. There is no ``draft``: its octave cap at 5 gave 14-23 times the error of
``default`` (issue 12) and saved no measurable time (marble at 1024^2: whole bakes of
0.66-0.83 s against 0.74-0.88 s, the texture stage 0.09-0.16 s against 0.10-0.21 s, in
alternating runs): at one sample a texel the texel lookup, the surface, the output
normals and fixed costs take most of the time, not the octaves.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Quality:
    """Settings a preset fixes (see ``bake_mesh`` for what each means)."""

    samples: int = 1
    filtering: bool = True
    precision: str = "float64"
    max_octaves: int | None = None


PRESETS: dict[str, Quality] = {
    # bake_mesh's defaults: one filtered sample, every octave
    "default": Quality(),
    # 16 stratified point samples a texel
    "final": Quality(samples=16, filtering=False, precision="float64", max_octaves=None),
}
