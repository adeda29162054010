"""Quality presets: samples, footprint filtering, precision and octave cap in one word.

One definition for the library, the command line and the service (``BakeSettings.quality``;
``BakeSettings.quality_settings()`` resolves a preset with the fields set explicitly). Chosen from ``texbake report`` (``bake.checks.sweep``) on
suzanne_blender_uv.obj (63k faces) at 1024^2, whole bake with a pre-made atlas, RMSE in
linear colour against a 256-sample point-sampled reference (figures: README, Benchmarks):

=========  ==============================
preset     settings
=========  ==============================
draft      1 sample, filtering, 5 octaves
default    1 sample, filtering
final      16 samples, point sampling
=========  ==============================

At one sample a texel the texel lookup and fixed costs dominate, so the octave cap of
``draft`` saves little there (it pays off for specs with many octaves); ``final``
point-samples because footprint filtering with several samples blurs each sample by a
whole texel (its error stays at that of one filtered sample), while point samples
converge to the texel mean. float32 made no measurable difference in time or error.
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
    # one filtered sample, octaves above the 5th replaced by their mean
    "draft": Quality(samples=1, filtering=True, precision="float64", max_octaves=5),
    # bake_mesh's defaults: one filtered sample, every octave
    "default": Quality(),
    # 16 stratified point samples a texel
    "final": Quality(samples=16, filtering=False, precision="float64", max_octaves=None),
}
