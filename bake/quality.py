"""Quality presets: samples, footprint filtering, precision and octave cap in one word.

One definition for the library (``bake_mesh(quality=...)``) and the command line
(``--quality``). Chosen from ``texbake report`` (``bake.checks.sweep``) on
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

from dataclasses import asdict, dataclass
from typing import TypedDict, cast

from .errors import ParameterError

PRECISIONS = ("float64", "float32")


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


class _FromPreset:
    """Default of the settings a preset fixes: "not given", so the preset's value is used."""

    def __repr__(self) -> str:
        return "<from the quality preset>"


FROM_PRESET = _FromPreset()


class Settings(TypedDict):
    """``Quality``'s fields as :func:`resolve` returns them."""

    samples: int
    filtering: bool
    precision: str
    max_octaves: int | None


def resolve(quality: str | None, **given) -> Settings:
    """The settings of preset ``quality`` (``None``: ``"default"``), with the ``given``
    ones that are not ``FROM_PRESET`` overriding it. Returns a dict of ``Quality``'s fields."""
    if quality is not None and quality not in PRESETS:
        raise ParameterError("quality", f"expected one of {tuple(PRESETS)}, got {quality!r}")
    settings = asdict(PRESETS[quality or "default"])
    unknown = set(given) - set(settings)
    if unknown:
        raise ParameterError(sorted(unknown)[0], "not a quality setting")
    settings.update({k: v for k, v in given.items() if v is not FROM_PRESET})
    return cast(Settings, settings)
