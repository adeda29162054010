"""Validation errors written for a person (texbake.validation), as the settings and the
texture specs give them: the field, the value and what is allowed, no pydantic internals."""

import pytest

from texbake.errors import ParameterError, TextureError
from texbake.settings import BakeSettings
from texbake.textures.spec import parse_spec, with_overrides
from texbake.validation import allowed, describe, did_you_mean

KNOWN = "checker, fbm, flame, marble, noise, position, turbulence, wood"


@pytest.mark.parametrize("schema, words", [
    ({"type": "integer", "minimum": 1, "maximum": 30}, "a whole number from 1 to 30"),
    ({"type": "number", "exclusiveMinimum": 0, "maximum": 1e6}, "a number above 0 and at most 1000000"),
    ({"type": "number", "gt": 0}, "a number above 0"),  # pydantic's own name where JSON Schema has none
    ({"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1}, "a number above 0 and below 1"),
    ({"type": "integer", "minimum": 0}, "a whole number of at least 0"),
    ({"type": "boolean"}, "true or false"),
    ({"enum": ["auto", "keep"], "type": "string"}, "one of 'auto', 'keep'"),
    ({"anyOf": [{"enum": [8, 16], "type": "integer"}, {"type": "null"}]}, "one of 8, 16 (or none)"),
    ({"type": "array", "prefixItems": [{"type": "number"}] * 3}, "3 numbers"),
    ({"type": "array", "items": {"type": "number"}, "minItems": 1, "maxItems": 4}, "a list of 1 to 4 numbers"),
    ({"$ref": "#/$defs/T"}, "a group of parameters (a, b)"),
])
def test_what_a_schema_allows_in_words(schema, words):
    assert allowed(schema, {"T": {"type": "object", "properties": {"a": {}, "b": {}}}}) == words


def test_close_names_are_suggested_and_far_ones_not():
    assert did_you_mean("marbel", ["marble", "wood"]) == "did you mean 'marble'? "
    assert did_you_mean("plaid", ["marble", "wood"]) == ""


def test_a_query_parameter_without_a_schema_is_described_from_the_error():
    errors = [{"type": "less_than_equal", "loc": ("size",), "msg": "Input should be less than or equal to 512", "input": "4096",
               "ctx": {"le": 512}},
              {"type": "missing", "loc": ("texture",), "msg": "Field required", "input": None}]
    assert describe(errors, {}) == [("size", "expected at most 512, got 4096"), ("texture", "required")]


@pytest.mark.parametrize("given, message", [
    ({"size": "abc"}, "size: expected a whole number from 1 to 65536 (or width,height), got 'abc'"),
    ({"size": 0}, "size: expected a whole number from 1 to 65536 (or width,height), got 0"),
    ({"size": [1, 2, 3]}, "size: expected a whole number from 1 to 65536 (or width,height), got [1, 2, 3]"),
    ({"uv": "sideways"}, "uv: expected one of 'auto', 'unwrap', 'keep', got 'sideways'"),
    ({"sampels": 4}, "sampels: not a setting (did you mean 'samples'?)"),
    ({"margin": -1}, "margin: expected a whole number from 0 to 4096, got -1"),
    ({"light": [1, 2]}, "light: expected 3 finite numbers (x,y,z), got [1, 2]"),
    ({"light": [1, 2, "nan"]}, "light.2: expected a finite number, got nan"),
    ({"cage": 0}, "cage: expected a number above 0 (or none), got 0"),
    ({"format": "exr", "bits": 8}, "bits: exr takes 16 or 32 bits, got 8"),
    ({"texture": "marble", "frames": [0, 1]}, "frames: texture 'marble' has no time to animate"),
    ({"texture": "marbel"}, f"texture: unknown texture 'marbel' (did you mean 'marble'? known: {KNOWN})"),
    ({"bump": "plaid"}, f"bump: unknown texture 'plaid' (known: {KNOWN})"),
    ({"texture": '{"name": "marble", x}'}, "texture: not valid JSON at line 1 column 20: expecting property name enclosed in double quotes"),
    ({"texture": {"name": "marble", "octaves": 6}}, "texture: marble has no parameter 'octaves' (did you mean 'turbulence.octaves'? "
                                                    "it has: axis, frequency, amplitude, turbulence, colormap, transform, space, model)"),
    ({"texture": {"name": "marble", "turbulence": {"octaves": 99}}}, "texture: turbulence.octaves: expected a whole number from 1 to 30, got 99"),
    ({"texture": {"name": "checker", "transform": {"scale": -1}}}, "texture: transform.scale: expected a number above 0 or 3 numbers, got -1"),
    ({"size": 0, "uv": "x"}, "size: expected a whole number from 1 to 65536 (or width,height), got 0; uv: expected one of 'auto', "
                             "'unwrap', 'keep', got 'x'"),
])
def test_a_bad_setting_names_the_field_the_value_and_what_is_allowed(given, message):
    with pytest.raises(ParameterError) as error:
        BakeSettings.build(given)
    assert str(error.value) == message and error.value.name == message.partition(":")[0]


@pytest.mark.parametrize("spec, sets, message", [
    ("marble", ["octaves=6"], "set: marble has no parameter 'octaves' (did you mean 'turbulence.octaves'? it has: axis, frequency, "
                              "amplitude, turbulence, colormap, transform, space, model)"),
    ("marble", ["turbulence.octavs=6"], "set: marble's turbulence has no parameter 'octavs' (did you mean 'octaves'? it has: basis, "
                                        "interpolation, seed, scale, offset, octaves, lacunarity, gain)"),
    ("marble", ["axis=w"], "set: axis: expected one of 'x', 'y', 'z', got 'w'"),
    ("marble", ["colormap.knots=[0, 1, 2]"], "set: colormap: expected one knot for each of at least one value, got 3 knots for 5 values"),  # the marble's own 5 colours kept
    ("marble", ["x"], "set: expected key=value (e.g. turbulence.octaves=6), got 'x'"),
    ("marble", ["axis.x=1"], "set: 'axis.x=1': 'axis' is one value, not a group of parameters"),
    ("wod", [], f"texture: unknown texture 'wod' (did you mean 'wood'? known: {KNOWN})"),
    ('{"name": "marble"', [], "texture: not valid JSON at line 1 column 18: expecting ',' delimiter"),
    ("[1, 2]", [], "texture: expected a JSON object with a 'name', got a list"),
    ({"nam": "x"}, [], f"texture: a spec needs a 'name' (one of {KNOWN}), got the keys nam"),
])
def test_a_bad_spec_or_override_names_what_is_wrong(spec, sets, message):
    with pytest.raises(TextureError) as error:
        with_overrides(spec, sets)
    assert str(error.value) == message


def test_a_spec_error_alone_names_the_parameter_from_the_spec_top():
    with pytest.raises(TextureError) as error:
        parse_spec({"name": "checker", "box": [0, 1, 1]})
    assert str(error.value) == "box.0: expected a number above 0, got 0"
