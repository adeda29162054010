// What a person reads on texbake's page. The forms are made from the API's JSON Schemas
// (app.js); the schemas' titles are field names ("Uv", "Obj"), so this table gives each field
// its label, a hint in place of the schema's description where that is written for
// programmers, and words for its options. A field missing here still gets a control, titled
// from its name: a new setting works before it is worded.
//
// Each entry: label; hint; options {value: words}; none (the words of a null option);
// noneIs (a null value means this option: the null option is not listed); placeholder (of an
// empty box); join (how a list is written in one box, as "2048x1024") and shape (what that
// box takes, for its error).
// A key is a field's name, or "group.field" where the name means something else in a group.

// The textures' names as a person says them (the select's option text; the value stays the name)
export const TEXTURE_NAMES = {
  position: "Position (RGB = XYZ)", checker: "Checker", noise: "Noise", turbulence: "Turbulence",
  fbm: "fBm (fractal noise)", marble: "Marble", wood: "Wood", flame: "Flame (animated)",
};

export const SETTING_WORDS = {
  size: { label: "Image size", join: "x", shape: "one number for a square, or width and height as 2048x1024",
    hint: "Texels: one number for a square image (1024), or width and height (2048x1024)." },
  quality: { label: "Quality preset", noneIs: "default",
    options: { default: "Default (1 sample a texel)", final: "Final (16 samples a texel, slower)" },
    hint: "Sets samples, filtering, precision and the octave cap; those set below override it." },
  samples: { label: "Samples per texel", hint: "Stratified samples averaged into each texel (the preset's unless changed)." },
  filtering: { label: "Filter by the texel's footprint", hint: "Antialiasing: the texture is averaged over the area a texel covers." },
  precision: { label: "Texture-space precision", options: { float64: "64-bit floats", float32: "32-bit floats (rounded)" },
    hint: "The points the texture is evaluated at (the preset's unless changed)." },
  max_octaves: { label: "Octave cap (noise textures)", placeholder: "all",
    hint: "Fewer octaves of noise: less fine detail. Empty: every octave the texture has." },
  adaptive: { label: "Extra samples where needed (share of texels)",
    hint: "With one filtered sample: this share of the texels, those that differ most from their neighbours, get four more (0: off)." },
  margin: { label: "Margin", hint: "Texels filled around each chart, so filtering and mipmaps do not show the seams." },
  uv: { label: "UV layout", options: { auto: "Automatic", unwrap: "Always unwrap", keep: "Keep the mesh's UVs" },
    hint: "Automatic keeps the mesh's own UVs when they are usable, else unwraps; Keep fails on a mesh without UVs." },
  charting: { label: "Unwrap method", options: { auto: "Automatic", planar: "Planar charts (by face normal)", xatlas: "xatlas (fewer seams, slower)" },
    hint: "Automatic: planar for CAD-like meshes and meshes of over 6,000 faces, xatlas otherwise." },
  texture_space: { label: "Texture space", options: { unit: "Unit box", object: "Object coordinates" },
    hint: "Unit box: the mesh's bounding box moved to start at 0 and scaled to a longest side of 1." },
  shading: { label: "Shading", hint: "The lit maps show the texture under the light below (More settings).",
    options: { decal: "Decal: albedo only", "ambient-diffuse": "Ambient + diffuse: a lit map too", full: "Full, with highlights: a lit map too" } },
  light: { label: "Light direction (x, y, z)", hint: "For the lit map." },
  bump: { label: "Bump texture", none: "No bump", options: TEXTURE_NAMES, hint: "Its brightness is baked into a normal map." },
  bump_strength: { label: "Bump strength", hint: "" },
  frames: { label: "Animation frames (times)", placeholder: "one frame", hint: "Times to bake the flame at, separated by commas (0, 0.5, 1)." },
  seed: { label: "Sample seed", hint: "Seed of the sample jitter and of the error estimate." },
  max_faces: { label: "Largest mesh (faces)", hint: "Meshes with more faces are refused." },
  unwrap_deadline: { label: "Unwrap time limit (seconds)", hint: "After this, a simpler atlas is used." },
  format: { label: "Image format", hint: "", options: { png: "PNG", exr: "OpenEXR", tif: "TIFF" } },
  bits: { label: "Bit depth", none: "Format default", options: { 8: "8 bits", 16: "16 bits", 32: "32 bits" },
    hint: "PNG takes 8 or 16, EXR 16 (half float) or 32, TIFF 8, 16 or 32. Default: PNG 8, EXR 16, TIFF 16." },
  obj: { label: "Also write OBJ + MTL", hint: "Beside the GLB, for tools that do not read glTF." },
  texture_set: { label: "Texture sets", options: { "per-material": "One per material (its own maps)", single: "One for the whole mesh" },
    hint: "One per material: each material its own atlas and maps, and its own texture if given one under Materials." },
  names: { label: "File names", hint: "A template of {mesh}, {set} (the material), {map}, {tile} (UDIM) and {ext}; a field without a value is left out." },
  material: { label: "PBR material", none: "No material (the texture)",
    options: { polished_marble: "Polished marble", oak_planks: "Oak planks", lava: "Lava", rusted_iron: "Rusted iron",
      glazed_ceramic_checker: "Glazed ceramic checker" },
    hint: "A built-in material: base colour, roughness, metallic, normal and more maps (and an ORM map) instead of the texture." },
  maps: { label: "Mesh maps", placeholder: "none", join: ",", shape: "map names separated by commas, as ao,curvature",
    hint: "Maps of the geometry beside the texture's: ao, bent_normal, thickness, curvature, position_object, position_world, "
      + "normal_object, normal_world, id_material, id_part, id_chart; with a source mesh also source_normal, source_height, source_missed." },
  map_rays: { label: "Rays per texel (mesh maps)", hint: "Rays each texel of the ambient occlusion, bent normal and thickness maps casts." },
  map_distance: { label: "Ray length (mesh maps)", placeholder: "the mesh's diagonal",
    hint: "How far the ambient occlusion, bent normal and thickness rays look." },
  curvature_scale: { label: "Curvature scale", placeholder: "2% of the diagonal",
    hint: "A length: a sphere of this radius is the brightest (or darkest, hollow) curvature." },
  front_distance: { label: "Ray start above the surface (high to low)", placeholder: "5% of the diagonal",
    hint: "How far out along the normal the rays onto the source mesh start." },
  back_distance: { label: "Ray reach below the surface (high to low)", placeholder: "as above",
    hint: "How far past the surface the rays onto the source mesh reach." },
  occluders: { label: "What occludes", options: { all: "The whole mesh", set: "The texture set's own faces" },
    hint: "What the ambient occlusion rays can hit." },
  normal_convention: { label: "Normal map convention", options: { opengl: "OpenGL (+Y, glTF)", directx: "DirectX (-Y)" },
    hint: "The normal map's green channel; the GLB always gets OpenGL's." },
};

// The material editor's words: its channels, and the choice of a new material
export const MATERIAL_WORDS = {
  new: "A new material",
  channels: { base_color: "Base colour", roughness: "Roughness", metallic: "Metallic", normal: "Normal map (tangent space)",
    height: "Height", occlusion: "Ambient occlusion", emissive: "Emission", opacity: "Opacity" },
};

// A MaterialX document loaded into the material editor (POST /v1/materials/mtlx)
export const MTLX_WORDS = {
  label: "Or load a MaterialX document (.mtlx)",
  hint: (limit) => `A .mtlx whose surface shader is a standard_surface, gltf_pbr, open_pbr_surface or UsdPreviewSurface, up to ${limit}: `
    + "its procedural graphs (noise, fractal, cell and Worley noise, math) are baked onto the mesh, at each point of its surface.",
  reading: (name) => `Reading ${name}…`,
  read: (answer) => `${answer.file}: the material ${answer.name}, its ${answer.shader.category} ${answer.shader.name}.`,
  option: (answer) => `${answer.name} (from ${answer.file})`,
  tooLarge: (name, size, limit) => `${name} is ${size}: larger than this server's limit of ${limit} for a MaterialX document`,
  kind: "The document's graph",
  channel: (inputs, graph) => `From the document: its shader's ${inputs.join(" × ")}, ${graph ? "a graph evaluated at each point of the mesh" : "a value"}.`,
};

const OCTAVES = {
  basis: { label: "Noise basis", options: { value: "Value noise", perlin: "Perlin (gradient) noise" } },
  interpolation: { label: "Interpolation", options: { linear: "Linear", cubic: "Cubic", "catmull-rom": "Catmull-Rom" }, hint: "Value noise only." },
  seed: { label: "Noise seed" },
  scale: { label: "Noise scale", hint: "Features a unit of texture space: larger is finer." },
  offset: { label: "Noise offset" },
  octaves: { label: "Octaves" },
  lacunarity: { label: "Lacunarity", hint: "Frequency step from one octave to the next." },
  gain: { label: "Gain", hint: "Amplitude step from one octave to the next." },
};

const SCALE = { join: ", ", shape: "one number, or x, y and z separated by commas" }; // uniform or per axis

export const TEXTURE_WORDS = {
  ...OCTAVES,
  "transform.scale": { ...SCALE, label: "Scale", hint: "One number, or x, y, z: larger makes the pattern larger." },
  "transform.rotate": { label: "Rotation (degrees, x y z)" },
  "transform.translate": { label: "Translation (x y z)" },
  "model.scale": { ...SCALE, label: "Object scale", hint: "One number, or x, y, z." },
  "model.rotate": { label: "Object rotation (degrees, x y z)" },
  "model.translate": { label: "Object translation (x y z)" },
  transform: { label: "Placement of the pattern" },
  space: { label: "The pattern moves with", hint: "", options: { object: "The object", world: "The world (the object moves through it)" } },
  model: { label: "Placement of the object in the world", hint: "Used when the pattern moves with the world." },
  colormap: { label: "Colour map" },
  box: { label: "Box size (x y z)" },
  color_even: { label: "Colour of even boxes", hint: "" },
  color_odd: { label: "Colour of odd boxes", hint: "" },
  filtered: { label: "Filter the squares by the texel's footprint", hint: "Each texel gets the mean over the area it covers." },
  axis: { label: "Stripe axis" },
  frequency: { label: "Stripe frequency" },
  amplitude: { label: "Turbulence amplitude", hint: "How far the stripes are pushed about." },
  turbulence: { label: "Turbulence" },
  ring_width: { label: "Ring width" },
  wobble: { label: "Wobble" },
  wobbles: { label: "Wobbles per ring" },
  twist: { label: "Twist" },
  tilt: { label: "Axis tilt (degrees, x y z)" },
  half_width: { label: "Half width", placeholder: "auto", hint: "Of the flame at its base; empty: half the object's width." },
  height: { label: "Height", placeholder: "auto", hint: "Of the flame; empty: the object's height." },
  time: { label: "Time" },
  rise: { label: "Rise speed" },
  turbulence_amount: { label: "Turbulence amount" },
  red: { label: "Red curve" },
  green: { label: "Green curve" },
  blue: { label: "Blue curve" },
  knots: { label: "Knots", hint: "Places along the curve, increasing, separated by commas." },
  values: { label: "Values", hint: "One value a knot, separated by commas." },
};

// A field's words: "group.field" first, then "field"
export function wordsFor(table, path) {
  return table[path.slice(-2).join(".")] ?? table[path[path.length - 1]] ?? {};
}
