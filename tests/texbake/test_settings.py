"""texbake.settings: presets resolved when the settings are made, explicit fields over them,
one serialisation that validates back to the same settings, and errors that name the field."""

import json

import pytest

import texbake
from texbake.errors import ParameterError
from texbake.settings import PRESETS, BakeSettings

PRESET_FIELDS = ("samples", "filtering", "precision", "max_octaves")


def preset_fields(settings: BakeSettings) -> dict:
    return {name: getattr(settings, name) for name in PRESET_FIELDS}


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_a_preset_is_resolved_into_the_fields(name):
    settings = BakeSettings(quality=name)
    assert settings.quality == name and preset_fields(settings) == PRESETS[name]
    assert set(PRESETS[name]) == set(PRESET_FIELDS)


def test_final_holds_what_the_bake_uses():
    final = BakeSettings(quality="final")
    assert (final.samples, final.filtering) == (16, False)
    assert BakeSettings.build(None, quality="final").samples == 16
    assert BakeSettings.model_validate_json('{"quality": "final"}').samples == 16


def test_no_preset_is_the_default_preset_and_the_field_defaults():
    plain, named, none = BakeSettings(), BakeSettings(quality="default"), BakeSettings.model_validate({"quality": None})
    assert plain == named == none and plain.quality == "default"
    assert preset_fields(plain) == PRESETS["default"]
    assert {name: BakeSettings.model_fields[name].default for name in PRESET_FIELDS} == PRESETS["default"]


@pytest.mark.parametrize("given, expected", [
    ({"quality": "final", "samples": 4}, {"samples": 4, "filtering": False}),
    ({"quality": "final", "filtering": True}, {"samples": 16, "filtering": True}),
    ({"quality": "final", "max_octaves": 3, "precision": "float32"}, {"samples": 16, "max_octaves": 3, "precision": "float32"}),
    ({"samples": 16}, {"samples": 16, "filtering": False}),  # several samples given alone: point samples
    ({"samples": "16"}, {"samples": 16, "filtering": False}),  # as JSON or a form may spell it
    ({"samples": 16, "filtering": True}, {"samples": 16, "filtering": True}),  # unless filtering is asked for
    ({"samples": 1}, {"samples": 1, "filtering": True}),
    ({"quality": "default", "samples": 4}, {"samples": 4, "filtering": False}),
    ({"quality": "final", "samples": 1}, {"samples": 1, "filtering": False}),  # one sample: the preset's filtering stays
])
def test_explicit_fields_override_the_preset(given, expected):
    settings = BakeSettings(**given)
    assert {name: getattr(settings, name) for name in expected} == expected
    assert settings.quality == given.get("quality", "default")


ROUND_TRIP = [
    {},
    {"quality": "final"},
    {"quality": "final", "samples": 4, "filtering": True},  # must not come back as the preset's 16 point samples
    {"samples": 4},
    {"texture": "marble", "size": [64, 32], "max_octaves": 3, "precision": "float32", "bump": {"name": "noise", "scale": 9},
     "shading": "full", "light": [0, 1, 0], "cage": 0.5, "format": "tiff", "bits": 32, "obj": True},
    {"texture": "flame", "frames": [0, 0.25], "seed": 7, "max_faces": 10, "unwrap_deadline": 3, "charting": "planar"},
]


@pytest.mark.parametrize("given", ROUND_TRIP)
def test_the_dump_validates_back_to_the_same_settings(given):
    settings = BakeSettings(**given)
    python, as_json = settings.model_dump(), settings.model_dump(mode="json")
    assert BakeSettings.model_validate(python) == settings
    assert BakeSettings.model_validate(as_json) == settings
    assert BakeSettings.model_validate(json.loads(json.dumps(as_json))) == settings  # through JSON text, as the service keeps it
    assert BakeSettings.model_validate(as_json).model_dump(mode="json") == as_json  # the preset is not applied again
    assert set(as_json) == set(BakeSettings.model_fields)


def test_build_puts_options_over_what_a_model_was_built_from():
    mixed = BakeSettings(texture="marble", quality="final", samples=4, max_octaves=3)
    resized = BakeSettings.build(mixed, size=8)
    assert (resized.size, resized.texture.name, resized.quality, resized.samples, resized.filtering, resized.max_octaves) == \
        (8, "marble", "final", 4, False, 3)
    assert BakeSettings.build(mixed) is mixed
    assert BakeSettings.build(BakeSettings(), quality="final").samples == 16  # a new preset brings its values
    assert BakeSettings.build(BakeSettings(quality="final"), quality="default") == BakeSettings()
    assert BakeSettings.build(BakeSettings(samples=4), quality="final").samples == 4  # an override stays one
    assert BakeSettings.build(BakeSettings(samples=4), samples=1).filtering is True  # the implied point sampling goes with it
    kept = BakeSettings.build(BakeSettings(samples=4, filtering=True), seed=3)
    assert (kept.samples, kept.filtering, kept.seed) == (4, True, 3)
    assert BakeSettings.build({"quality": "final"}, samples=2) == BakeSettings(quality="final", samples=2)


def test_the_reports_settings_are_the_resolved_settings_dump(meshes, tmp_path):
    result = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=16, quality="final", bump="noise", margin=1)
    assert result.settings.samples == 16 and result.report["rays"]["texel_samples"] == 16 * 16 * 16
    assert result.report["settings"] == result.settings.model_dump(mode="json")
    result.save(tmp_path)
    written = json.loads((tmp_path / "report.json").read_text())["settings"]
    assert written == result.settings.model_dump(mode="json") and BakeSettings.model_validate(written) == result.settings
    assert "parameters" not in result.report


@pytest.mark.parametrize("given, name", [
    ({"quality": "best"}, "quality"),
    ({"quality": 3}, "quality"),
    ({"samples": 0}, "samples"),
    ({"samples": "many"}, "samples"),
    ({"samples": 2000}, "samples"),
    ({"filtering": "yes"}, "filtering"),
    ({"precision": "float16"}, "precision"),
    ({"max_octaves": 0}, "max_octaves"),
    ({"size": 0}, "size"),
    ({"margin": -1}, "margin"),
    ({"light": [0, float("nan"), 1]}, "light"),
    ({"format": "exr", "bits": 8}, "bits"),
    ({"texture": "checker", "frames": [0, 1]}, "frames"),
    ({"texture": "plaid"}, "texture"),
    ({"sampels": 4}, "sampels"),
])
def test_a_bad_value_raises_a_parameter_error_naming_the_field(given, name):
    with pytest.raises(ParameterError) as caught:
        BakeSettings.build(given)
    assert caught.value.name.split(".")[0] == name, caught.value


def test_a_material_setting_holds_the_whole_material_and_round_trips():
    from texbake.materials import BUILTINS
    from texbake.settings import BakeSettings

    s = BakeSettings(material="lava", size=64)
    assert s.material.name == "lava" and s.material.nodes == BUILTINS["lava"]["nodes"] and s.normal_map
    assert [t.name for t in s.packing] == ["orm"]  # a material's default packing, resolved
    dumped = s.model_dump(mode="json")
    assert dumped["material"]["emissive"] == BUILTINS["lava"]["emissive"] and dumped["normal_convention"] == "opengl"
    assert BakeSettings.model_validate(dumped) == s
    assert BakeSettings.build(s, material=None).packing is None  # the default packing goes with the material
    assert BakeSettings.build(s, size=32).material == s.material
    assert not BakeSettings(material={"base_color": 0.5}).normal_map and BakeSettings(bump="noise").normal_map


def test_settings_of_a_mesh_maps_bake_import_no_texture_nor_material_model():
    import subprocess
    import sys

    code = ("import sys\nfrom texbake.settings import BakeSettings\n"
            "BakeSettings(texture='none', maps=['source_normal'], size=64)\n"
            "print(sorted(m for m in ('texbake.textures.spec', 'texbake.materials.model') if m in sys.modules))\n"
            "BakeSettings(texture='marble')\n"
            "print(sorted(m for m in ('texbake.textures.spec', 'texbake.materials.model') if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]", "['texbake.textures.spec']"]


def test_the_schema_names_what_the_texture_material_and_packing_fields_take():
    from texbake.materials.builtins import BUILTINS
    from texbake.textures.spec import TEXTURES

    schema = BakeSettings.model_json_schema()
    texture = schema["properties"]["texture"]["anyOf"]
    assert texture[0]["enum"] == list(TEXTURES) and texture[1] == {"const": "none", "type": "string"}
    assert set(texture[2]["discriminator"]["mapping"]) == set(TEXTURES) and "Marble" in schema["$defs"]
    material = schema["properties"]["material"]["anyOf"]
    assert material[0]["enum"] == list(BUILTINS) and material[1] == {"$ref": "#/$defs/Material"}
    packing = schema["properties"]["packing"]["anyOf"][0]["items"]["anyOf"]
    assert packing == [{"enum": ["orm", "hdrp-mask"], "type": "string"}, {"$ref": "#/$defs/PackTemplate"}]
