"""The bake's settings: one model, the whole input of a bake besides the mesh.

The library takes it (``bake_mesh(mesh, settings)``, or keyword arguments that build it),
the command line has one option per field, the service's ``settings`` form field is it,
and a batch manifest line is one (plus its ``mesh``). The limits are written here once;
the service may only tighten them (``texbake.service.core.config``).

The settings hold what the bake uses: ``quality`` names a preset (:data:`PRESETS`) of
``samples``, ``filtering``, ``precision`` and ``max_octaves``, resolved when the settings
are validated, so ``BakeSettings(quality="final").samples == 16``. Those of the four given
explicitly override the preset. ``samples`` above 1 given without ``filtering`` means
point samples: a filtered sample is already blurred by a whole texel, so averaging
several of them blurs twice, and their error stays that of one filtered sample. Being
resolved, ``model_dump()`` (``mode="json"`` for JSON) is the one serialisation: it
validates back to equal settings, and it is what the report, the service's job and its
dedup key hold.

Texture sets (:mod:`texbake.sets`): ``texture_set`` bakes one set per material (the
default) or one for the whole mesh; ``materials`` gives a material's set settings of its
own (:data:`SET_FIELDS`: its texture, size, ...), over the rest; ``names`` is the template
of the maps' file names (:func:`file_name`).
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    GetJsonSchemaHandler,
    PlainSerializer,
    StrictBool,
    TypeAdapter,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)
from pydantic_core import core_schema

from .errors import MaterialError, MtlxError, ParameterError, TextureError
from .formats import bits_problem, format_name
from .meshmaps.kinds import KINDS
from .validation import describe

NO_TEXTURE = "none"  # the texture of a bake of mesh maps only


def _texture(value: Any):
    """A texture name, JSON text or spec object; never a path (``parse_spec`` reads no files).
    ``"none"`` (or None) is no texture: a bake of its mesh maps alone (no albedo, no texel
    lookups of its own: the mesh maps' are the bake's)."""
    if value is None or value == NO_TEXTURE:
        return None
    from .textures.spec import parse_spec

    try:
        return parse_spec(value)
    except TextureError as exc:
        raise ValueError(str(exc)) from None


def _material(value: Any):
    """A built-in material's name, JSON text or a material object; never a path."""
    if value is None:
        return None
    from .materials.model import parse_material

    try:
        return parse_material(value)
    except (MaterialError, MtlxError) as exc:
        raise ValueError(str(exc)) from None


def _packing(value: Any):
    """Packing templates: built-in names, template objects, or JSON text of either (or a list of them)."""
    if value is None:
        return None
    if isinstance(value, str) and value.strip().startswith("["):
        import json

        try:
            value = json.loads(value)
        except json.JSONDecodeError as exc:
            raise ValueError(f"not valid JSON: {exc.msg}") from None
    from .materials.packing import parse_packing

    items = value if isinstance(value, (list, tuple)) else [value]
    try:
        templates = [parse_packing(item) for item in items]
    except ParameterError as exc:
        raise ValueError(exc.problem) from None
    names = [t.name for t in templates]
    if len(set(names)) < len(names):
        raise ValueError(f"two templates named {next(n for n in names if names.count(n) > 1)!r}")
    return templates


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {value}")
    return value


class _Takes:
    """A field validated by a plain function, whose JSON Schema is that of ``takes()``: the
    type of what it accepts, made when a schema is first asked for (the service's, an
    error's), not when the settings are imported. Pydantic's ``PlainValidator`` builds
    its ``json_schema_input_type`` at once: here that is every texture spec and the material
    model, validators and all, which a bake of mesh maps alone never uses."""

    def __init__(self, validate, takes) -> None:
        self.validate, self.takes = validate, takes

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        return core_schema.no_info_plain_validator_function(self.validate)

    def __get_pydantic_json_schema__(self, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler) -> dict:
        if handler.mode != "validation":  # what it serialises to: the serializer's own schema
            return handler(schema)
        return handler(_input_schema(self.takes))


@functools.cache
def _input_schema(takes) -> core_schema.CoreSchema:
    return TypeAdapter(takes()).core_schema


def _texture_input():
    from .textures.spec import TEXTURES, TextureSpec

    return Union[Literal[tuple(TEXTURES)], Literal["none"], TextureSpec]  # noqa: UP007  # values, not annotations


def _material_input():
    from .materials.builtins import BUILTINS
    from .materials.model import Material

    return Union[Literal[tuple(BUILTINS)], Material, None]  # noqa: UP007


def _packing_input():
    from .materials.packing import PackTemplate

    return Union[list[Union[Literal["orm", "hdrp-mask"], PackTemplate]], None]  # noqa: UP007


Texture = Annotated[
    Any,
    _Takes(_texture, _texture_input),  # a name, "none" or a spec
    PlainSerializer(lambda spec: None if spec is None else spec.model_dump(mode="json"), return_type=Union[dict, None]),  # noqa: UP007
]
MaterialSetting = Annotated[
    Any,
    _Takes(_material, _material_input),  # a built-in's name or a material
    PlainSerializer(lambda m: None if m is None else m.model_dump(mode="json"), return_type=Union[dict, None]),  # noqa: UP007
]
Packing = Annotated[
    Any,
    _Takes(_packing, _packing_input),  # built-in names or templates
    PlainSerializer(lambda ts: None if ts is None else [t.model_dump(mode="json") for t in ts], return_type=Union[list, None]),  # noqa: UP007
]
Finite = Annotated[float, AfterValidator(_finite)]
MeshMapKind = Literal[KINDS]  # type: ignore[valid-type]  # texbake.meshmaps.kinds
MAX_TEXELS = 65536  # a side of the image
Texels = Annotated[int, Field(ge=1, le=MAX_TEXELS)]

# The quality presets: the values they give the fields they fix. Chosen from the error
# against run time of ``texbake report`` (``texbake.checks.sweep``; figures: README,
# Quality). ``final`` point-samples: point samples converge to the texel mean, while
# filtered ones would blur each sample by a whole texel. There is no cheaper preset: an
# octave cap raised the error many times over and saved no measurable time, since at one
# sample a texel the lookup, the surface and fixed costs take most of it.
PRESETS: dict[str, dict[str, Any]] = {
    "default": {"samples": 1, "filtering": True, "precision": "float64", "max_octaves": None},  # bake_mesh's defaults
    "final": {"samples": 16, "filtering": False, "precision": "float64", "max_octaves": None},  # 16 stratified point samples
}


# The settings a texture set may have of its own (``materials``); the others are the bake's.
SET_FIELDS = ("texture", "size", "quality", "samples", "filtering", "precision", "max_octaves", "margin", "uv", "charting",
              "shading", "light", "bump", "bump_strength", "frames", "seed", "material", "normal_convention", "packing")
NAME_FIELDS = ("mesh", "set", "map", "tile", "ext")  # the fields of a ``names`` template
DEFAULT_NAMES = "{set}_{map}.{tile}.{ext}"  # one set, no tiles: "albedo.png", as a bake of one material always wrote


class BakeSettings(BaseModel):
    """What to bake and how: every setting of a bake, preset resolved (see the module).

    Frozen; build it with keywords (``BakeSettings(texture="marble", size=2048)``), from a
    dict or JSON (``model_validate``, ``model_validate_json``), or with :meth:`build`,
    which raises :class:`~texbake.errors.ParameterError` naming the bad field. Each
    field's ``description`` says what it does (the command line's help and the service's
    JSON Schema show the same text).

    Attributes
    ----------
    texture : TextureSpec or None
        The texture baked into the albedo map (given as a name, JSON text or a dict);
        ``"none"``: no albedo, a bake of the ``maps`` only.
    size : int or (int, int)
        Image width and height in texels, 1 to 65536 (one number: square).
    quality : {"default", "final"}
        The preset the four fields below started from; ``None`` given means "default".
    samples : int
        Stratified samples a texel, 1 to 1024.
    filtering : bool
        Whether each sample is antialiased over its texel's footprint.
    precision : {"float64", "float32"}
        The dtype texture-space points are held in before the texture sees them.
    max_octaves : int or None
        Cap on the octaves of noise-based textures (None: the spec's own count).
    margin, uv, charting, texture_space : int, str, str, str
        How the atlas is made and filled: margin texels, UV policy, chart cutting, and
        the space the texture is evaluated in.
    shading, light, bump, bump_strength, frames : str, (3,) float, TextureSpec or None, float, list of float or None
        Which maps are made besides the albedo: a lit map, a normal map, animation frames.
    cage, seed, max_faces, unwrap_deadline : float or None, int, int, float
        Transfer ray length, the seed of the sample jitter, the face limit, the seconds
        of CPU time each xatlas worker may use.
    format, bits, obj : {"png", "exr", "tif"}, int or None, bool
        How :meth:`texbake.pipeline.BakeResult.save` writes the maps (and an OBJ).
    texture_set : {"per-material", "single"}
        One texture set (its own atlas and maps) per material, or one for the whole mesh.
    materials : dict of str to MaterialSettings, or None
        Settings of a material's texture set of its own (any of :data:`SET_FIELDS`), by
        material name: ``{"body": {"texture": "marble"}, "wheels": {"texture": "checker", "size": 512}}``.
    names : str
        The maps' file names: a template of ``{mesh}``, ``{set}``, ``{map}``, ``{tile}`` and
        ``{ext}`` (:func:`file_name`).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    texture: Texture = Field("checker", validate_default=True, description="texture: a name or a spec object (see `texbake textures`)")
    size: Texels | tuple[Texels, Texels] = Field(1024, description="image size in texels: one number (square), or width and height")
    quality: Literal["default", "final"] = Field(
        "default", description="preset of samples, filtering, precision and octave cap; those set explicitly override it")
    samples: int = Field(1, ge=1, le=1024, description="samples per texel, stratified (default: the preset's)")
    filtering: StrictBool = Field(True, description="antialias by the texel footprint (default: the preset's; off when samples > 1 is given without it)")
    precision: Literal["float64", "float32"] = Field("float64", description="texture-space points as float64 or rounded to float32 (default: the preset's)")
    max_octaves: int | None = Field(None, ge=1, le=30, description="cap on the octaves of noise-based textures; none: the spec's own (default: the preset's)")
    adaptive: float = Field(0.0, ge=0.0, le=1.0, description="with one filtered sample: the share of texels given 2x2 filtered sub-samples, those whose sample differs most from its neighbours' (1 + 4 x share samples a texel); 0: off")
    margin: int = Field(16, ge=0, le=4096, description="texels of margin filled around charts")
    uv: Literal["auto", "unwrap", "keep"] = Field("auto", description="keep the mesh's UVs when usable (auto), always unwrap, or require them")
    charting: Literal["auto", "planar", "xatlas"] = Field(
        "auto", description="how an unwrap cuts charts: planar (faces grouped by normal, as Smart UV Project), xatlas "
        "(fewer seams and less stretch on small organic meshes, slower), or auto: planar for CAD-like meshes and "
        "meshes of over 6k faces, xatlas otherwise")
    texture_space: Literal["unit", "object"] = Field("unit", description="unit: the bounding box scaled to start at 0 with its longest side 1; object: coordinates as they are")
    shading: Literal["decal", "ambient-diffuse", "full"] = Field("decal", description="decal: albedo only; the others also bake a lit map")
    light: tuple[Finite, Finite, Finite] = Field((0.3, 0.5, 0.8), description="light direction x, y, z for lit maps")
    bump: Texture | None = Field(None, description="texture whose luminance is bumped into a tangent-space normal map")
    bump_strength: Finite = Field(1.0, description="scale of the bump")
    frames: list[Finite] | None = Field(None, min_length=1, max_length=1024, description="times to bake an animated texture (the flame) at")
    cage: Finite | None = Field(None, gt=0, description="maximum transfer ray distance from a source mesh (default: 5% of the bounding-box diagonal)")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="seed of the sample jitter and the error probe")
    max_faces: int = Field(5_000_000, ge=1, le=100_000_000, description="meshes with more faces are rejected")
    unwrap_deadline: Finite = Field(120.0, gt=0, le=86400, description="seconds of CPU time each xatlas worker may use before a fallback atlas is used")
    format: Literal["png", "exr", "tif"] = Field("png", description="image format of the maps")
    bits: Literal[8, 16, 32] | None = Field(None, description="png 8 or 16; exr 16 (half) or 32; tif 8, 16 or 32 (default: png 8, exr 16, tif 16)")
    obj: StrictBool = Field(False, description="also write OBJ + MTL")
    material: MaterialSetting = Field(
        None, description="a material: a built-in's name (see `texbake materials`) or a material object (on the command "
        "line also a .json/.yaml file); its channels are baked each as its own map, instead of the texture")
    normal_convention: Literal["opengl", "directx"] = Field(
        "opengl", description="the normal map's green channel: opengl (+Y, as glTF) or directx (-Y); the GLB always gets +Y")
    packing: Packing = Field(
        None, description="maps packing a material's scalar channels into one image each: built-in orm (R occlusion, G "
        "roughness, B metallic) and hdrp-mask (R metallic, G occlusion, B detail, A smoothness), or templates like "
        '{"name": "rma", "channels": ["roughness", "metallic", "occlusion"]}; default with a material: orm')
    texture_set: Literal["per-material", "single"] = Field(
        "per-material", description="per-material: one texture set (its own atlas and maps) per material; single: one for the whole mesh")
    materials: dict[str, MaterialSettings] | None = Field(
        None, description="a material's texture set's own settings, by material name: JSON (or, on the command line, a "
        '.json/.yaml file) like {"body": {"texture": "marble"}, "wheels": {"texture": "checker", "size": 512}}; '
        f"each may set {', '.join(SET_FIELDS)}")
    maps: list[MeshMapKind] | None = Field(
        None, description="mesh maps baked beside the texture's: ao (ambient occlusion), bent_normal, thickness, "
        "curvature, position_object, position_world, normal_object, normal_world, id_material, id_part, id_chart")
    map_rays: int = Field(64, ge=1, le=4096, description="rays a texel of the ao, bent_normal and thickness maps")
    map_distance: Finite | None = Field(None, gt=0, description="the longest ray of the ao, bent_normal and thickness maps "
                                        "(default: the bounding-box diagonal)")
    curvature_scale: Finite | None = Field(None, gt=0, description="the curvature map's scale, a length: a sphere of radius r "
                                           "gets 0.5 + 0.5 scale / r (default: 2% of the bounding-box diagonal)")
    front_distance: Finite | None = Field(None, gt=0, description="high to low without a cage mesh: how far out along the "
                                          "normal the source_* maps' rays start (default: cage, else 5% of the bounding-box diagonal)")
    back_distance: Finite | None = Field(None, gt=0, description="how far past the target surface (or the cage's) they reach "
                                         "(default: as front_distance)")
    occluders: Literal["all", "set"] = Field("all", description="what the ao and bent_normal rays hit: every face of the mesh "
                                             "(all) or only the texture set's")
    names: str = Field(DEFAULT_NAMES, description="the maps' file names: a template of {mesh}, {set}, {map}, {tile} and {ext}; "
                       "a field without a value ({set} in a bake of one texture set, {tile} without UDIM tiles) is left out "
                       "with one separator beside it")

    @model_validator(mode="before")
    @classmethod
    def _resolve_preset(cls, data: Any) -> Any:
        """The preset's values for those of its fields not given (a bad preset name is
        left to the field's own check, which names it)."""
        if not isinstance(data, dict):
            return data
        name = "default" if data.get("quality") is None else data["quality"]
        preset = PRESETS.get(name) if isinstance(name, str) else None
        if preset is None:
            return data
        resolved = {**preset, **data, "quality": name}
        if data.get("material") is not None and data.get("packing") is None:
            resolved["packing"] = ["orm"]  # what the GLB's metallic-roughness and occlusion textures are
        if "samples" in data and "filtering" not in data and _above_one(data["samples"]):
            resolved["filtering"] = False  # several samples converge to the texel mean; filtering each would blur it twice
        return resolved

    @field_validator("format", mode="before")
    @classmethod
    def _format_name(cls, value):
        return format_name(value) if isinstance(value, str) else value

    @field_validator("names")
    @classmethod
    def _names_template(cls, value: str) -> str:
        if problem := names_problem(value):
            raise ValueError(problem)
        return value

    @model_validator(mode="after")
    def _consistent(self):
        if self.bits is not None and (problem := bits_problem(self.format, self.bits)):
            raise ValueError(f"bits: {problem}")
        if self.texture is None and self.material is None:
            if not self.maps:
                raise ValueError("texture: none bakes mesh maps only: list them in maps (or give a texture)")
            for name, value, plain in (("shading", self.shading, "decal"), ("bump", self.bump, None), ("frames", self.frames, None)):
                if value != plain:
                    raise ValueError(f"{name}: {value!r} needs a texture (texture is none: mesh maps only)")
        if self.frames is not None and "time" not in type(self.texture).model_fields:
            raise ValueError(f"frames: texture {self.texture.name!r} has no time to animate")
        if self.material is not None and self.frames is not None:
            raise ValueError("frames: a material bakes one set of maps, not frames")
        if self.material is not None and self.bump is not None:
            raise ValueError("bump: a material's normal map comes from its height (or normal) channel")
        if self.material is not None:
            read = {n.params.map for n in self.material.graph.nodes.values() if n.op == "mesh_map"}
            if missing := sorted(read - set(self.maps or ())):
                raise ValueError(f"maps: the material reads mesh maps {', '.join(missing)}: list them in maps")
        if self.material is None and self.packing is not None:
            raise ValueError("packing: packs a material's channels; give a material")
        if self.materials and self.texture_set == "single":
            raise ValueError("materials: texture_set='single' bakes one texture set for the whole mesh; per-material "
                             "settings need texture_set='per-material'")
        for name in self.materials or {}:
            try:
                self.for_material(name)  # a set's settings must hold together too
            except ParameterError as exc:
                raise ValueError(f"materials: {name!r}: {exc.name.split('.', 2)[-1]}: {exc.problem}") from None
        return self

    def for_material(self, name: str) -> BakeSettings:
        """The settings of material ``name``'s texture set: these, with ``materials[name]``'s
        fields on top (a new ``quality`` brings its preset), and no ``materials``.
        :class:`ParameterError` names ``materials.NAME.FIELD`` where they do not hold together."""
        own = (self.materials or {}).get(name)
        if own is None:
            return self if self.materials is None else self.model_copy(update={"materials": None})
        given = own.model_dump(exclude_unset=True, exclude_none=True)
        base = {**self._overrides(), "materials": None}
        if "quality" in given:  # the set's preset, not the fields the bake's gave
            base = {k: v for k, v in base.items() if k not in PRESETS["default"]}
        try:
            return type(self).model_validate({**base, **given})
        except ValidationError as exc:
            error = parameter_error(exc)
            raise ParameterError(f"materials.{name}.{error.name}", error.problem) from None

    @property
    def normal_map(self) -> bool:
        """Whether the bake makes a normal map: a bump texture, or a material's height or normal channel."""
        if self.material is not None:
            return bool({"height", "normal"} & set(self.material.channels))
        return self.bump is not None

    @property
    def tangents(self) -> bool:
        """Whether the output mesh gets tangents: a normal map, or a source_normal mesh map, is baked in their frame."""
        return self.normal_map or "source_normal" in (self.maps or ())

    @property
    def width_height(self) -> tuple[int, int]:
        """``(width, height)`` in texels."""
        return (self.size, self.size) if isinstance(self.size, int) else self.size

    @classmethod
    def build(cls, settings: BakeSettings | dict | None = None, **options) -> BakeSettings:
        """Settings from a model or a dict, with keyword ``options`` on top; a bad one
        raises :class:`ParameterError` naming it.

        On a model, ``options`` replace what it was built from: its fields that its preset
        and the defaults would not give (:meth:`_overrides`), so a new ``quality`` brings
        its preset's values for the rest.
        """
        data = {} if settings is None else settings
        if isinstance(data, BakeSettings):
            if not options:
                return data
            data = data._overrides()
        try:
            return cls.model_validate({**data, **options})
        except ValidationError as exc:
            raise parameter_error(exc) from None

    def _overrides(self) -> dict[str, Any]:
        """The preset's name and the fields whose values it and the defaults would not
        give: ``samples`` if not the preset's, and the rest where they differ from what the
        preset gives beside that ``samples`` (an implied ``filtering=False`` is not one)."""
        samples = {} if self.samples == PRESETS[self.quality]["samples"] else {"samples": self.samples}
        plain = type(self)(quality=self.quality, **samples).model_dump()
        given = {name: value for name, value in self.model_dump().items() if value != plain[name]}
        if self.material is not None and given.get("packing") == [{"name": "orm", "channels": ["occlusion", "roughness", "metallic"]}]:
            del given["packing"]  # a material's default, not given
        return {**given, **samples, "quality": self.quality}


def _set_field(name: str):
    """A :data:`SET_FIELDS` field as ``MaterialSettings`` has it: its type and limits, or None (the bake's)."""
    info = BakeSettings.model_fields[name]
    kind = Annotated[(info.annotation, *info.metadata)] if info.metadata else info.annotation
    return Optional[kind], Field(None, description=info.description)  # noqa: UP045  # a value, not an annotation


MaterialSettings = create_model(  # type: ignore[call-overload]
    "MaterialSettings", __config__=ConfigDict(extra="forbid", frozen=True), __doc__="A texture set's own settings (``BakeSettings.materials``).",
    **{name: _set_field(name) for name in SET_FIELDS})
BakeSettings.model_rebuild()


def names_problem(template: str) -> str | None:
    """Why ``template`` is not a ``names`` template, or None: only the fields of
    :data:`NAME_FIELDS`, ``{map}`` and ``{ext}`` among them, no folder."""
    fields = re.findall(r"\{([^{}]*)\}", template)
    unknown = sorted(set(fields) - set(NAME_FIELDS))
    if unknown:
        return f"unknown field {{{unknown[0]}}} (a template has {', '.join('{' + f + '}' for f in NAME_FIELDS)})"
    if "map" not in fields or "ext" not in fields:
        return f"a template needs {{map}} and {{ext}}, got {template!r}"
    if re.sub(r"\{[^{}]*\}", "", template).count("{") or re.sub(r"\{[^{}]*\}", "", template).count("}"):
        return f"unbalanced braces in {template!r}"
    if any(c in template for c in "/\\\0") or template.startswith("."):
        return f"a file name, not a path nor a hidden file, got {template!r}"
    return None


def file_name(template: str, *, mesh: str, set: str | None, map: str, tile: int | str | None, ext: str) -> str:
    """A map's file name from a ``names`` template: ``file_name("{set}_{map}.{tile}.{ext}",
    mesh="truck", set="wheels", map="albedo", tile=None, ext="png") == "wheels_albedo.png"``.
    A field without a value (``set`` or ``tile`` None) is left out with the separator
    (``_``, ``.`` or ``-``) after it, or before it at the end."""
    values = {"mesh": mesh, "set": set, "map": map, "tile": None if tile is None else str(tile), "ext": ext}
    for key in ("set", "tile"):
        if values[key] is None:
            template = re.sub(rf"\{{{key}\}}[._-]|[._-]?\{{{key}\}}", "", template, count=1)
    return template.format(**{k: v for k, v in values.items() if v is not None})


def _above_one(samples: Any) -> bool:
    """Whether a ``samples`` value as given (before validation) is above 1; False for a
    value that is not a number (the field's own check reports it)."""
    try:
        return float(samples) > 1
    except (TypeError, ValueError):
        return False


# what a field allows, where its JSON Schema's words would be clumsy
ALLOWED = {"size": f"a whole number from 1 to {MAX_TEXELS} (or width,height)", "light": "3 finite numbers (x,y,z)"}


def describe_errors(errors: Sequence[Mapping[str, Any]]) -> list[tuple[str, str]]:
    """``(field, problem)`` for each bad setting of a failed validation (pydantic's error
    dicts, located from the settings' top): the field, the value and what is allowed."""
    return describe(errors, _schema(), hints=ALLOWED)


@functools.cache
def _schema() -> dict:
    return BakeSettings.model_json_schema()


def parameter_error(error: ValidationError) -> ParameterError:
    """One :class:`ParameterError` for a failed validation, naming the first bad field
    (``size: expected a whole number from 1 to 65536 (or width,height), got 'abc'``); any
    others follow it, ``; field: problem`` each."""
    problems = describe_errors(error.errors(include_url=False))
    (name, problem), rest = problems[0], problems[1:]
    return ParameterError(name or "settings", "; ".join([problem, *(f"{n or 'settings'}: {p}" for n, p in rest)]))
