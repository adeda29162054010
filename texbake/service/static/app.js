// texbake's page: one module, no framework. The forms are made from the API's JSON Schemas
// (GET /v1/textures for the texture spec, GET /v1/config for BakeSettings and the server's
// limits); the API validates, and its errors are shown beside the field they name.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { RoomEnvironment } from "three/addons/environments/RoomEnvironment.js";
import { MATERIAL_WORDS, MTLX_WORDS, SETTING_WORDS, TEXTURE_NAMES, TEXTURE_WORDS, wordsFor } from "./words.js";

const $ = (id) => document.getElementById(id);
function el(tag, props = {}, ...children) { // an element with properties and children (false and null left out)
  const element = Object.assign(document.createElement(tag), props);
  element.append(...children.flat(2).filter((c) => c != null && c !== false));
  return element;
}
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const KEY = "texbake.key"; // the API key: this tab's session storage only
const FINISHED = ["done", "failed", "cancelled"];
const MAIN_SETTINGS = ["size", "quality", "shading", "bump", "bump_strength", "frames", "format"];
// the texture has its own section, the materials their list under the mesh; the service takes no source mesh;
// packing stays at its default (ORM); the material has its editor
const NOT_SETTINGS = ["texture", "cage", "materials", "packing", "material"];
const MATERIAL_FORMATS = [".obj", ".gltf", ".glb"]; // the formats whose meshes may have several materials (the others have one)

let config, catalogue, textureSchema; // GET /v1/config, GET /v1/textures
let meshFile = null, companionFiles = []; // the mesh, and the files it refers to (sent as `files` beside it)
let materialChoices = {}; // material name -> its texture select (POST /v1/inspect named them)
let inspecting = 0; // the mesh whose materials are being read (a newer choice drops an older answer)
let textureControls = {}, settingsControls = {};
let following = 0, currentJob = null; // the job whose progress is shown (a new follow() stops the old one)

// ---- talking to the API --------------------------------------------------------------
class ApiError extends Error {
  constructor(status, body, retryAfter = 0) { super(body.detail || `HTTP ${status}`); Object.assign(this, { status, body, retryAfter }); }
}

function headers(extra = {}) {
  const key = sessionStorage.getItem(KEY);
  return key ? { ...extra, Authorization: `Bearer ${key}` } : extra;
}

async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: headers(options.headers) });
  if (response.ok) return response;
  const body = await response.json().catch(() => ({ detail: `${response.status} ${response.statusText}` }));
  throw new ApiError(response.status, body, Number(response.headers.get("Retry-After")) || 0);
}
const json = async (path, options) => (await api(path, options)).json();

// XMLHttpRequest, as fetch reports no upload progress: progress(fraction) while sending
function upload(path, body, progress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open("POST", path);
    for (const [name, value] of Object.entries(headers())) xhr.setRequestHeader(name, value);
    xhr.upload.onprogress = (e) => e.lengthComputable && progress(e.loaded / e.total);
    xhr.onload = () => {
      let answer;
      try { answer = JSON.parse(xhr.responseText); } catch { answer = { detail: `${xhr.status} ${xhr.statusText}` }; }
      if (xhr.status < 400) resolve(answer);
      else reject(new ApiError(xhr.status, answer, Number(xhr.getResponseHeader("Retry-After")) || 0));
    };
    xhr.onerror = () => reject(new ApiError(0, { detail: "the server could not be reached" }));
    xhr.send(body);
  });
}

// A file of a job: its own URL, or (with an API key, which <img> and <a> cannot send) a
// blob's, kept in `blobs` until the next result is shown
const blobs = [];
async function fileUrl(path) {
  if (!sessionStorage.getItem(KEY)) return path;
  blobs.push(URL.createObjectURL(await (await api(path)).blob()));
  return blobs[blobs.length - 1];
}

// ---- errors beside the field they name -----------------------------------------------
// "settings.size: ...", "mesh 'x.obj': ...", "texture 'marble': frequency: ...": each
// problem goes to the error line of the field it names, else to the fallback's.
const fields = new Map(); // "texture.frequency", "size", "mesh", ... -> {input, error}
const PREFIX = /^(?:(mesh|texture) (?:'[^']*'|"[^"]*")|([A-Za-z_][\w.]*)):\s*/;

function problems(body) {
  const items = body.errors?.length ? body.errors.map((e) => [e.loc.map(String), e.msg]) : [[[], String(body.detail ?? "")]];
  const out = [];
  for (const [loc, message] of items) {
    let context = loc;
    for (const part of message.split("; ")) {
      let rest = part, path = [...context];
      let named = ""; // "mesh 'x.obj': ..." keeps the file's name in the words
      for (let m; (m = PREFIX.exec(rest)); rest = rest.slice(m[0].length)) {
        path.push(...(m[1] || m[2]).split("."));
        if (m[1] === "mesh") named = m[0].slice(5).replace(/^['"]|['"]:\s*$/g, "") + ": ";
      }
      path = path.filter((name, i) => name !== path[i - 1]);
      out.push({ path, text: named + rest });
      context = path.slice(0, -1); // "a: x; b: y": b sits beside a
    }
  }
  return out;
}

function clearErrors(...prefixes) {
  for (const [path, field] of fields) {
    if (!prefixes.some((p) => path === p || path.startsWith(p + "."))) continue;
    field.error.textContent = "";
    field.input?.removeAttribute("aria-invalid");
  }
}

function showError(error, fallback) {
  if (error.name === "AbortError") return;
  if (error.status === 401) { $("key-form").hidden = false; fallback = "key"; }
  const body = error.body || { detail: String(error.message || error) };
  for (const { path, text } of problems(body)) {
    let names = path[0] === "settings" || path[0] === "body" ? path.slice(1) : path;
    const node = names[0] === "material" && /^node '([^']+)': /.exec(text); // a material's node: beside its channel
    if (node) names = ["material", fields.has(`material.${node[1].split(/[.#]/)[0]}`) ? node[1].split(/[.#]/)[0] : "nodes"];
    let n = names.length, field;
    for (; n > 0 && !(field = fields.get(names.slice(0, n).join("."))); n--);
    if (!field || error.status === 401) { field = fields.get(fallback); n = 0; }
    const said = n < names.length ? `${names.slice(n).join(".")}: ${text}` : text;
    const before = field.error.textContent;
    if (!before.split("; ").includes(said)) field.error.textContent = before ? `${before}; ${said}` : said;
    field.input?.setAttribute("aria-invalid", "true");
  }
}

// ---- forms from a JSON Schema --------------------------------------------------------
// Each control is made from its schema node; its label, hint and option words come from
// words.js (a field missing there is titled from its name, and the console says so).
const resolve = (root, node) => { while (node?.$ref) node = root.$defs[node.$ref.split("/").pop()]; return node || {}; };
const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
const hex = (rgb) => "#" + rgb.map((c) => Math.round(255 * Math.min(1, Math.max(0, toSrgb(c)))).toString(16).padStart(2, "0")).join("");
const linear = (text) => [1, 3, 5].map((i) => Math.round(toLinear(parseInt(text.slice(i, i + 2), 16) / 255) * 1e4) / 1e4);
const numbers = (text) => text.split(/[\s,;]+/).filter(Boolean).map((t) => (Number.isFinite(Number(t)) ? Number(t) : t));
const titled = (prop, key) => prop.title || key[0].toUpperCase() + key.slice(1).replaceAll("_", " ");
const plain = (text) => text.replaceAll("``", "").replaceAll("`", ""); // the schema's descriptions are reST
const isNumber = (node) => node.type === "number" || node.type === "integer";
let ids = 0;

// The range a number may take, in words ("0 < x ≤ 1000", `name` for x) and as a test;
// `limit`: this server's, if lower
function range(node, limit, name = "x") {
  const lo = node.minimum ?? node.exclusiveMinimum, loOpen = node.minimum == null;
  let hi = node.maximum ?? node.exclusiveMaximum, hiOpen = node.maximum == null;
  const server = limit != null && !(hi <= limit);
  if (server) [hi, hiOpen] = [limit, false];
  const text = [lo != null && `${lo} ${loOpen ? "<" : "≤"}`, name, hi != null && `${hiOpen ? "<" : "≤"} ${hi}`].filter(Boolean).join(" ");
  const inside = (x) => (lo == null || (loOpen ? x > lo : x >= lo)) && (hi == null || (hiOpen ? x < hi : x <= hi));
  return { lo, hi, inside, text: lo == null && hi == null ? "" : text + (server ? ": this server's limit" : "") };
}

// One control for one schema node: {element, get(), problems()}. get() gives the value it
// was made with until the person changes it (a colour round trip through hex is not exact);
// problems() lists "path: what is wrong" where the page can tell before the API does.
function control(ctx, prop, key, path, value, limit) {
  const branches = (resolve(ctx.root, prop).anyOf || [prop]).map((b) => resolve(ctx.root, b));
  const node = branches.find((b) => b.type !== "null") || {};
  const words = wordsFor(ctx.words, path);
  if (words.label == null) console.warn(`texbake page: no label for ${path.join(".")} in words.js`);
  const spec = { ctx, path, value, limit, branches, node, words, nullable: branches.some((b) => b.type === "null"),
    title: words.label ?? titled(prop, key), about: words.hint ?? plain(prop.description || node.description || "") };
  if (node.properties) return node.properties.knots && node.properties.colours ? colourMap(spec) : group(spec);
  const build = branches.some(isNumber) && branches.some((b) => b.type === "array" && b.prefixItems) ? numberOrList
    : node.enum ? choice : node.type === "boolean" ? checkbox : isNumber(node) ? numberBox
    : node.type === "array" && node.prefixItems?.length === 3 && node.description === "linear RGB" ? colour
    : node.type === "array" && node.prefixItems ? triple : node.type === "array" ? list : node.type === "string" ? textBox : jsonBox;
  return field(spec, build(spec));
}

// A labelled control: the label, what `made` built ({input, read, body, note, check,
// inputs}), a hint and an error line
function field({ ctx, path, value, title, about }, made) {
  const { input, read, body = input, note = "", check = () => "" } = made;
  const id = `f${++ids}`;
  let touched = false;
  input.id = id;
  input.setAttribute("aria-describedby", `${id}-hint ${id}-error`);
  for (const each of made.inputs || [input]) {
    each.addEventListener(each.type === "checkbox" || each.tagName === "SELECT" ? "change" : "input", () => { touched = true; ctx.changed(); });
  }
  const label = el("label", { htmlFor: id, textContent: title });
  const hint = el("p", { className: "hint", id: `${id}-hint`, textContent: [about, note].filter(Boolean).join(" ") });
  const error = el("p", { className: "error", id: `${id}-error`, role: "alert" });
  const box = input.type === "checkbox";
  const element = el("div", { className: box ? "field check" : "field" }, box ? [input, label] : [label, body], hint, error);
  fields.set(path.join("."), { input, error });
  const problems = () => { const problem = touched && check(); return problem ? [`${path.join(".")}: ${problem}`] : []; };
  return { element, get: () => (touched ? read() : value), problems };
}

// A group of parameters, folded
function group({ ctx, node, path, value, title }) {
  const children = Object.entries(node.properties).map(([k, p]) => [k, control(ctx, p, k, [...path, k], (value || {})[k] ?? p.default)]);
  const error = el("p", { className: "error", role: "alert" });
  fields.set(path.join("."), { input: null, error });
  const element = el("details", {}, el("summary", { textContent: title }), el("div", { className: "form" }, children.map(([, c]) => c.element)), error);
  return { element, get: () => Object.fromEntries(children.map(([k, c]) => [k, c.get()])), problems: () => children.flatMap(([, c]) => c.problems()) };
}

function choice({ node, nullable, value, words }) {
  const listed = [...(nullable && words.noneIs === undefined ? [null] : []), ...node.enum];
  const said = (v) => (v === null ? words.none ?? "none" : words.options?.[v] ?? String(v));
  const input = el("select", {}, listed.map((v) => el("option", { value: JSON.stringify(v), textContent: said(v) })));
  input.value = JSON.stringify(value ?? words.noneIs ?? null);
  return { input, read: () => JSON.parse(input.value) };
}

function checkbox({ value }) {
  const input = el("input", { type: "checkbox", checked: !!value });
  return { input, read: () => input.checked };
}

function numberBox({ node, nullable, value, limit, words }) {
  const { lo, hi, text } = range(node, limit);
  const integer = node.type === "integer";
  const input = el("input", { type: "number", step: integer ? "1" : "any", value: value ?? "", placeholder: nullable ? words.placeholder ?? "auto" : "" });
  if (lo != null) input.min = lo;
  if (hi != null) input.max = hi;
  const body = el("div", { className: "number" }, input);
  if (lo != null && hi != null && hi - lo <= 1000) { // a slider beside the box where the range is small
    const slider = el("input", { type: "range", min: lo, max: hi, step: integer ? 1 : (hi - lo) / 200, value: value ?? lo, tabIndex: -1 });
    slider.setAttribute("aria-hidden", "true");
    slider.addEventListener("input", () => { input.value = slider.value; input.dispatchEvent(new Event("input")); });
    input.addEventListener("input", () => { slider.value = input.value; });
    body.append(slider);
  }
  const read = () => (input.value.trim() === "" ? (nullable ? null : input.value) : Number.isFinite(input.valueAsNumber) ? input.valueAsNumber : input.value);
  return { input, read, body, note: text && `(${text})` };
}

// One number or a fixed-length list of them in one text box, written as a person would
// ("2048", "2048x1024", "2048, 1024"), sent as the number or the list the schema takes
function numberOrList({ branches, value, limit, words }) {
  const scalar = branches.find(isNumber), n = branches.find((b) => b.type === "array").prefixItems.length;
  const bounds = range(scalar, limit, "each");
  const input = el("input", { type: "text", value: [value ?? []].flat().join(words.join ?? ", "), spellcheck: false, autocomplete: "off" });
  const parse = () => {
    const parts = input.value.trim().split(/\s*[x×*,;]\s*|\s+/i), values = parts.map(Number); // "96x": ["96", ""]
    if (!(parts.length === 1 || parts.length === n) || parts.includes("") || !values.every(Number.isFinite)) return undefined;
    return parts.length === 1 ? values[0] : values;
  };
  const check = () => {
    const parsed = parse();
    if (parsed === undefined) return `${words.shape ?? `one number, or ${n} separated by commas`}, not "${input.value.trim()}"`;
    const bad = [parsed].flat().find((x) => !bounds.inside(x) || (scalar.type === "integer" && !Number.isInteger(x)));
    return bad === undefined ? "" : `${bad} is not allowed (${bounds.text}${scalar.type === "integer" ? ", whole numbers" : ""})`;
  };
  return { input, read: () => parse() ?? input.value, check, note: bounds.text && `(${bounds.text})` };
}

function colour({ value }) {
  const input = el("input", { type: "color", value: hex(value || [0, 0, 0]) });
  return { input, read: () => linear(input.value) };
}

function triple({ node, value, title }) { // x, y, z
  const boxes = node.prefixItems.map((_, i) => el("input", { type: "number", step: "any", value: (value || [])[i] ?? "" }));
  boxes.forEach((b, i) => b.setAttribute("aria-label", `${title} ${"xyz"[i]}`));
  const read = () => boxes.map((b) => (Number.isFinite(b.valueAsNumber) ? b.valueAsNumber : b.value));
  return { input: boxes[0], inputs: boxes, read, body: el("div", { className: "triple" }, boxes) };
}

function list({ ctx, node, nullable, value, words, about }) { // a list of numbers, or of names (the mesh maps)
  const item = node.items ? resolve(ctx.root, node.items) : {};
  const names = Boolean(item.enum) || item.type === "string";
  const input = el("input", { type: "text", value: (value || []).join(words.join ?? ", "), placeholder: words.placeholder ?? (nullable ? "none" : "") });
  const read = () => (input.value.trim() === "" && nullable ? null
    : names ? input.value.split(",").map((part) => part.trim()).filter(Boolean) : numbers(input.value));
  return { input, read, note: about ? "" : names ? "Names, separated by commas." : "Numbers, separated by commas." };
}

function textBox({ value }) { // a string that is not one of a list
  const input = el("input", { type: "text", value: value ?? "", spellcheck: false, autocomplete: "off" });
  return { input, read: () => input.value };
}

function jsonBox({ value }) { // anything else: JSON
  const input = el("input", { type: "text", value: JSON.stringify(value ?? null) });
  return { input, read: () => { try { return JSON.parse(input.value); } catch { return input.value; } } };
}

// A colour map: its gradient, and each knot's place and colour (knots can be added and removed)
function colourMap({ ctx, path, value, title }) {
  const map = { knots: [...(value?.knots || [0, 1])], colours: (value?.colours || [[0, 0, 0], [1, 1, 1]]).map((c) => [...c]) };
  const error = el("p", { className: "error", role: "alert" });
  const bar = el("div", { className: "gradient", role: "img" });
  const list = el("div", { className: "knots" });
  let touched = false;
  const draw = () => {
    const [k0, k1] = [map.knots[0], map.knots[map.knots.length - 1]];
    const at = (k) => (k1 > k0 ? (100 * (k - k0)) / (k1 - k0) : 0);
    bar.style.backgroundImage = `linear-gradient(to right, ${map.knots.map((k, i) => `${hex(map.colours[i])} ${at(k).toFixed(1)}%`).join(", ")})`;
    bar.setAttribute("aria-label", `${title}: ${map.knots.map((k, i) => `${hex(map.colours[i])} at ${k}`).join(", ")}`);
  };
  const edit = () => { touched = true; draw(); ctx.changed(); };
  const rows = () => {
    list.replaceChildren(...map.knots.map((k, i) => {
      const place = el("input", { type: "number", step: "any", value: k });
      const colour = el("input", { type: "color", value: hex(map.colours[i]) });
      place.setAttribute("aria-label", `${title}: place of knot ${i + 1}`);
      colour.setAttribute("aria-label", `${title}: colour of knot ${i + 1}`);
      place.addEventListener("input", () => { map.knots[i] = Number.isFinite(place.valueAsNumber) ? place.valueAsNumber : place.value; edit(); });
      colour.addEventListener("input", () => { map.colours[i] = linear(colour.value); edit(); });
      const remove = el("button", { type: "button", textContent: "−", disabled: map.knots.length < 2 });
      remove.setAttribute("aria-label", `${title}: remove knot ${i + 1}`);
      remove.addEventListener("click", () => { map.knots.splice(i, 1); map.colours.splice(i, 1); rows(); edit(); });
      return el("div", { className: "knot" }, place, colour, remove);
    }));
  };
  const add = el("button", { type: "button", textContent: "Add a knot" });
  add.addEventListener("click", () => {
    const last = map.knots.length - 1;
    map.knots.push(last >= 0 ? map.knots[last] + 0.1 : 0);
    map.colours.push(last >= 0 ? [...map.colours[last]] : [0.5, 0.5, 0.5]);
    rows(); edit();
  });
  rows(); draw();
  fields.set(path.join("."), { input: null, error });
  const element = el("details", { open: true }, el("summary", { textContent: title }), bar, list, add, error);
  return { element, get: () => (touched ? { knots: [...map.knots], colours: map.colours.map((c) => [...c]) } : value), problems: () => [] };
}

// The controls of a schema's top-level properties into `into`; {key: control}. `ctx`:
// {root: the schema, words: its table in words.js, changed: called on every edit}
// `values`: what the controls start at, where not their defaults
function form(ctx, node, into, { prefix, only, skip = [], limits = {}, values = {} }) {
  const out = {};
  for (const [key, prop] of Object.entries(node.properties)) {
    if (key === "name" || skip.includes(key) || (only && !only(key))) continue;
    const start = key in values ? values[key] : limits[key] != null ? Math.min(prop.default ?? limits[key], limits[key]) : prop.default;
    out[key] = control(ctx, prop, key, [...prefix, key], start, limits[key]);
    out[key].default = prop.default;
    into.append(out[key].element);
  }
  return out;
}

// What differs from the defaults (a group is sent whole: its defaults are the parent's)
const changedValues = (controls) => Object.fromEntries(Object.entries(controls)
  .filter(([, c]) => !c.element.hidden).map(([k, c]) => [k, c.get()]).filter(([k, v]) => JSON.stringify(v) !== JSON.stringify(controls[k].default)));
// What the page can tell is wrong with the shown controls: "path: problem; ..." ("" if nothing)
const typedWrong = (controls) => Object.values(controls).filter((c) => !c.element.hidden).flatMap((c) => c.problems()).join("; ");

// ---- the texture and its swatch ------------------------------------------------------
const textureDef = (name) => resolve(textureSchema, textureSchema.discriminator ? { $ref: textureSchema.discriminator.mapping[name] } : {});
const textureSpec = () => ({ name: $("texture").value, ...changedValues(textureControls) });

function buildTexture(name) {
  $("texture").value = name;
  for (const path of [...fields.keys()]) if (path.startsWith("texture.")) fields.delete(path);
  const box = $("texture-form");
  box.replaceChildren();
  const def = textureDef(name);
  textureControls = form({ root: textureSchema, words: TEXTURE_WORDS, changed: () => swatchSoon() }, def, box, { prefix: ["texture"] });
  // the placement last, closed: most people tune the pattern, not where it sits
  for (const key of ["transform", "space", "model"]) if (textureControls[key]) box.append(textureControls[key].element);
  $("texture-about").textContent = plain(catalogue.find((t) => t.name === name)?.description || "");
  if (settingsControls.frames) settingsControls.frames.element.hidden = !def.properties.time; // only an animated texture has frames
  clearErrors("texture");
  mapsSummary();
  swatchSoon(0);
}

let swatchTimer = 0, swatchAbort = null, swatchShown = "";
function swatchSoon(wait = 150) {
  clearTimeout(swatchTimer);
  swatchAbort?.abort(); // an answer for the parameters before is not wanted any more
  $("swatch").classList.add("stale");
  $("swatch").dataset.ready = "0";
  swatchTimer = setTimeout(updateSwatch, wait);
}

async function updateSwatch() {
  swatchAbort?.abort();
  const abort = (swatchAbort = new AbortController());
  const wrong = typedWrong(textureControls);
  if (wrong) { // said beside the field, without asking the server
    clearErrors("texture");
    showError({ body: { detail: wrong } }, "texture");
    $("swatch-state").textContent = "not updated: see the error";
    return;
  }
  const spec = textureSpec(), view = $("swatch-view").value;
  const query = new URLSearchParams({ texture: JSON.stringify(spec), view });
  $("swatch-state").textContent = "updating…";
  try {
    const blob = await (await api(`/v1/swatch?${query}`, { signal: abort.signal })).blob();
    clearErrors("texture");
    const img = $("swatch"), old = swatchShown;
    swatchShown = URL.createObjectURL(blob);
    img.onload = () => {
      URL.revokeObjectURL(old);
      if (abort !== swatchAbort || abort.signal.aborted) return; // the parameters changed meanwhile
      img.classList.remove("stale");
      img.dataset.ready = "1";
    };
    img.src = swatchShown;
    img.alt = `Preview: ${spec.name} ${view === "sphere" ? "on a sphere" : "as a slice"}, with the parameters below`;
    $("swatch-state").textContent = "";
  } catch (error) {
    if (error.name === "AbortError") return;
    clearErrors("texture");
    showError(error, "texture");
    $("swatch-state").textContent = "not updated: see the error";
  }
}

// ---- the material editor ---------------------------------------------------------------
// A material (GET /v1/materials: the built-ins, the channels and their defaults) is its
// channels, each not given, a constant, a texture, layers (a base with inputs mixed over it,
// each through a mask texture) or, where a built-in's graph is none of these, its
// expression as JSON; and the named nodes those refer to (JSON). The editor writes the
// material object the bake's `material` setting takes. After each edit every channel given
// is swatched (POST /v1/swatch: the channel on the texture swatch's sphere, unlit) and the
// swatches are the maps of a MeshStandardMaterial on a sphere lit by an environment light.
let materialCatalogue; // GET /v1/materials
let channelEditors = {}; // channel -> {element, get(), img}
let materialExtras = {}; // what the chosen material has beside its channels and nodes (description, alpha mode)
const isColourChannel = (channel) => materialCatalogue.channels[channel] === "colour";
const isPlain = (v) => v && typeof v === "object" && !Array.isArray(v);
const isConstant = (v) => typeof v === "number" || (Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number"));
const onlyKeys = (v, keys) => Object.keys(v).every((k) => keys.includes(k));
const isTexture = (v, colour) => isPlain(v) && (colour ? !("op" in v) && typeof v.name === "string"
  : v.op === "texture" && v.output === "value" && isPlain(v.texture) && onlyKeys(v, ["op", "output", "texture"]));
let editorNodes = {}; // the named nodes of the material chosen (a mask may be one of them)
const isNamed = (v) => typeof v === "string" && v in editorNodes;
const isMaskSource = (v) => isTexture(v, false) || isNamed(v);
const isMask = (v) => isMaskSource(v) || (isPlain(v) && v.op === "invert" && onlyKeys(v, ["op", "input"]) && isMask(v.input))
  || (isPlain(v) && v.op === "smoothstep" && onlyKeys(v, ["op", "input", "edge0", "edge1"]) && isMaskSource(v.input));
const isInput = (v, colour) => isConstant(v) || isTexture(v, colour);
const isLayers = (v, colour) => isPlain(v) && v.op === "mix" && onlyKeys(v, ["op", "a", "b", "mask"]) && isInput(v.b, colour) && isMask(v.mask)
  && (isInput(v.a, colour) || isLayers(v.a, colour));
const isMtlx = (v) => isPlain(v) && v.op === "mtlx"; // a channel of a MaterialX document (its graph, evaluated by the server)
function kindOf(value, colour) {
  if (value == null) return "none";
  if (isMtlx(value)) return "mtlx";
  return isConstant(value) ? "constant" : isTexture(value, colour) ? "texture" : isLayers(value, colour) ? "layers" : "json";
}

let materialTimer = 0, materialAbort = null;
function materialChanged(wait = 250) {
  clearTimeout(materialTimer);
  materialAbort?.abort();
  $("material-sphere").dataset.ready = "0";
  for (const { img } of Object.values(channelEditors)) { img.classList.add("stale"); img.dataset.ready = "0"; }
  mapsSummary();
  materialTimer = setTimeout(updateMaterial, wait);
}

// A select of kinds, and what the kind chosen shows below it; `make(kind, value)` -> {element, get()}
function kindSwitch(label, kinds, kind, value, make, className = "kind") {
  const id = `m${++ids}`;
  const select = el("select", { id }, Object.entries(kinds).map(([k, words]) => el("option", { value: k, textContent: words })));
  select.value = kind;
  const body = el("div", { className: "kind-body" });
  let editor;
  const build = (k, v) => { editor = make(k, v); body.replaceChildren(editor.element); };
  build(kind, value);
  select.addEventListener("change", () => { build(select.value, undefined); materialChanged(); });
  const element = el("div", { className }, el("label", { htmlFor: id, textContent: label }), select, body);
  return { element, select, get: () => editor.get(), kind: () => select.value };
}

function constantInput(label, value, colour, fallback) {
  const id = `m${++ids}`;
  const start = value ?? fallback;
  const input = colour ? el("input", { id, type: "color", value: hex([start].flat().length === 3 ? start : [start, start, start]) })
    // a number shown to a float32's digits (a MaterialX value's 0.1, not 0.10000000149), sent as given until edited
    : el("input", { id, type: "number", step: "any", value: typeof start === "number" ? Number(start.toPrecision(7)) : start });
  const read = colour ? () => linear(input.value) : () => (Number.isFinite(input.valueAsNumber) ? input.valueAsNumber : input.value);
  let touched = false;
  input.addEventListener("input", () => { touched = true; materialChanged(); });
  return { element: el("div", { className: "field" }, el("label", { htmlFor: id, textContent: label }), input), get: () => (touched || value == null ? read() : value) };
}

// A texture: which one (the valued ones only where a scalar is taken), its parameters folded below
function textureInput(label, path, value, colour) {
  const spec = value == null ? { name: "checker" } : colour ? value : value.texture;
  const id = `m${++ids}`;
  const names = catalogue.map((t) => t.name).filter((n) => colour || materialCatalogue.valued.includes(n));
  const select = el("select", { id }, names.map((n) => el("option", { value: n, textContent: TEXTURE_NAMES[n] ?? n })));
  const params = el("div", { className: "form" });
  let controls = {};
  const build = (name, given) => {
    for (const key of [...fields.keys()]) if (key.startsWith(path.join(".") + ".")) fields.delete(key);
    select.value = name;
    params.replaceChildren();
    controls = form({ root: textureSchema, words: TEXTURE_WORDS, changed: () => materialChanged() }, textureDef(name), params, { prefix: path, values: given });
  };
  build(names.includes(spec.name) ? spec.name : names[0], spec);
  select.addEventListener("change", () => { build(select.value, {}); materialChanged(); });
  const read = () => ({ name: select.value, ...changedValues(controls) });
  const element = el("div", { className: "field" }, el("label", { htmlFor: id, textContent: label }), select,
    el("details", {}, el("summary", { textContent: `${label}: its parameters` }), params));
  return { element, get: () => (colour ? read() : { op: "texture", output: "value", texture: read() }) };
}

const INPUT_KINDS = { constant: "A constant", texture: "A texture" };
function layerInput(label, path, value, colour, fallback) {
  return kindSwitch(label, INPUT_KINDS, value == null ? "constant" : kindOf(value, colour), value, (kind, v) => (kind === "constant"
    ? constantInput(`${label}: value`, v, colour, fallback) : textureInput(`${label}: texture`, [...path, "texture"], v, colour)));
}

// A named node of the material, by name
function nodeInput(label, value) {
  const id = `m${++ids}`;
  const select = el("select", { id }, Object.keys(editorNodes).map((n) => el("option", { value: n, textContent: n })));
  if (value) select.value = value;
  select.addEventListener("change", () => materialChanged());
  return { element: el("div", { className: "field" }, el("label", { htmlFor: id, textContent: label }), select), get: () => select.value };
}

// A mask: a texture's value (or a named node's), through smoothstep's edges (both empty: as it is), inverted or not
function maskInput(label, path, value) {
  let invert = false, edges = null, texture = value;
  if (texture?.op === "invert") { invert = true; texture = texture.input; }
  if (texture?.op === "smoothstep") { edges = [texture.edge0, texture.edge1]; texture = texture.input; }
  const checker = { op: "texture", output: "value", texture: { name: "checker", box: [0.25, 0.25, 0.25] } };
  const pickTexture = (v) => textureInput(`${label}: texture`, [...path, "texture"], v ?? checker, false);
  const pick = !Object.keys(editorNodes).length ? pickTexture(texture)
    : kindSwitch(label, { texture: "A texture", node: "A named node" }, isNamed(texture) ? "node" : "texture", texture,
      (kind, v) => (kind === "node" ? nodeInput(`${label}: node`, v) : pickTexture(v)));
  const boxes = [0, 1].map((i) => {
    const box = el("input", { type: "number", step: "any", value: edges?.[i] ?? "", placeholder: "none" });
    box.setAttribute("aria-label", `${label}: ${i ? "upper" : "lower"} edge`);
    box.addEventListener("input", () => materialChanged());
    return box;
  });
  const flip = el("input", { type: "checkbox", checked: invert });
  flip.setAttribute("aria-label", `${label}: inverted`);
  flip.addEventListener("change", () => materialChanged());
  const get = () => {
    let mask = pick.get();
    if (boxes.every((b) => Number.isFinite(b.valueAsNumber))) mask = { op: "smoothstep", input: mask, edge0: boxes[0].valueAsNumber, edge1: boxes[1].valueAsNumber };
    return flip.checked ? { op: "invert", input: mask } : mask;
  };
  const element = el("div", { className: "mask" }, pick.element,
    el("p", { className: "hint", textContent: "Its edges (a smooth step from the lower to the upper; empty: the value as it is):" }),
    el("div", { className: "triple" }, boxes), el("label", {}, flip, " Inverted"));
  return { element, get };
}

// Layers: a base, then each layer's input mixed over what is below it where its mask is 1
function layersInput(channel, value, colour) {
  const fallback = materialCatalogue.defaults[channel];
  const stack = [];
  let base = value ?? { op: "mix", a: fallback, b: colour ? [0.05, 0.1, 0.6] : 0.2, mask: undefined };
  while (isPlain(base) && base.op === "mix") { stack.unshift(base); base = base.a; }
  const list = el("div", { className: "layers" });
  const baseInput = layerInput("Base", ["material", channel, "base"], base, colour, fallback);
  const layers = [];
  const add = (layer) => {
    const n = ++ids;
    const input = layerInput(`Layer ${layers.length + 1}`, ["material", channel, `l${n}`], layer.b, colour, colour ? [0.5, 0.5, 0.5] : 0.5);
    const mask = maskInput(`Layer ${layers.length + 1} mask`, ["material", channel, `l${n}`, "mask"], layer.mask);
    const remove = el("button", { type: "button", textContent: "Remove this layer" });
    const entry = { input, mask, element: el("fieldset", { className: "layer" }, el("legend", { textContent: `Layer ${layers.length + 1}` }), input.element, mask.element, remove) };
    remove.addEventListener("click", () => { layers.splice(layers.indexOf(entry), 1); entry.element.remove(); materialChanged(); });
    layers.push(entry);
    list.append(entry.element);
  };
  stack.forEach(add);
  const more = el("button", { type: "button", textContent: "Add a layer" });
  more.addEventListener("click", () => { add({ b: undefined, mask: undefined }); materialChanged(); });
  const get = () => layers.reduce((below, l) => ({ op: "mix", a: below, b: l.input.get(), mask: l.mask.get() }), baseInput.get());
  return { element: el("div", {}, baseInput.element, list, more), get };
}

function jsonInput(label, value) {
  const id = `m${++ids}`;
  const input = el("textarea", { id, rows: 4, spellcheck: false, value: JSON.stringify(value ?? 0.5, null, 1) });
  input.addEventListener("input", () => materialChanged(600));
  const get = () => readJson(input.value, label);
  return { element: el("div", { className: "field" }, el("label", { htmlFor: id, textContent: label }), input), get };
}

// JSON text, or an error the page can tell without the server: `{body: {detail}}` as showError takes
function readJson(text, what) {
  try { return JSON.parse(text); } catch (error) { throw { body: { detail: `${what}: not JSON: ${error.message}` } }; }
}

const CHANNEL_KINDS = { none: "Not given (the default)", constant: "A constant", texture: "A texture", layers: "Layers through masks", json: "An expression (JSON)" };
function channelEditor(channel, value) {
  const colour = isColourChannel(channel), words = MATERIAL_WORDS.channels[channel];
  const all = isMtlx(value) ? { mtlx: MTLX_WORDS.kind, ...CHANNEL_KINDS } : CHANNEL_KINDS; // the document's graph, while chosen
  const kinds = channel === "base_color" ? Object.fromEntries(Object.entries(all).filter(([k]) => k !== "none")) : all;
  const img = el("img", { className: "channel-swatch", width: 128, height: 128, alt: `the ${words} on a sphere` });
  img.dataset.channel = channel;
  const error = el("p", { className: "error", role: "alert" });
  const editor = kindSwitch(words, kinds, kindOf(value, colour), value, (kind, v) => {
    if (kind === "none") return { element: el("p", { className: "hint", textContent: `The default: ${JSON.stringify(materialCatalogue.defaults[channel])}` }), get: () => undefined };
    if (kind === "constant") return constantInput(`${words}: value`, v, colour, materialCatalogue.defaults[channel]);
    if (kind === "texture") return textureInput(`${words}: texture`, ["material", channel, "texture"], v, colour);
    if (kind === "layers") return layersInput(channel, v, colour);
    if (kind === "mtlx") return mtlxInput(channel, value);
    return jsonInput(`${words}: expression`, v ?? materialCatalogue.defaults[channel]);
  });
  fields.set(`material.${channel}`, { input: editor.select, error });
  const element = el("fieldset", { className: "channel" }, el("legend", { textContent: words }),
    el("div", { className: "channel-row" }, img, el("div", { className: "channel-edit" }, editor.element, error)));
  element.dataset.channel = channel;
  return { element, get: editor.get, img };
}

// A channel of the MaterialX document loaded: what of its shader it is (nothing to edit: the graph is the document's)
function mtlxInput(channel, value) {
  const { inputs = [value.channel], graph = true } = mtlxLoaded?.channels[channel] ?? {};
  return { element: el("p", { className: "hint", textContent: MTLX_WORDS.channel(inputs, graph) }), get: () => value };
}

function chooseMaterial(choice) {
  for (const path of [...fields.keys()]) if (path.startsWith("material.")) fields.delete(path);
  clearErrors("material");
  channelEditors = {};
  $("material-channels").replaceChildren();
  const given = choice === "" ? null : choice === "new" ? { name: "my_material", base_color: [0.8, 0.8, 0.8] }
    : choice === "mtlx" ? mtlxLoaded.material : materialCatalogue.materials.find((m) => m.name === choice);
  $("material-editor").hidden = !given;
  $("material-about").textContent = given ? `${given.description || "A material of your own: give each channel a constant, a texture or layers."} The bake takes it in place of the texture (2. Texture).` : "Bake the texture (2. Texture) into an albedo map.";
  if (!given) { mapsSummary(); return; }
  const { nodes = {}, name, height_scale: scale, ...rest } = given;
  editorNodes = nodes;
  materialExtras = Object.fromEntries(Object.entries(rest).filter(([k]) => !(k in materialCatalogue.channels)));
  $("material-name").value = name || "";
  $("material-height-scale").value = scale ?? 0.01;
  $("material-nodes").value = JSON.stringify(nodes, null, 1);
  $("material-nodes-box").hidden = !Object.keys(nodes).length;
  for (const channel of Object.keys(materialCatalogue.channels)) {
    channelEditors[channel] = channelEditor(channel, given[channel]);
    $("material-channels").append(channelEditors[channel].element);
  }
  materialChanged(0);
}

// ---- a MaterialX document in the editor ------------------------------------------------
// POST /v1/materials/mtlx reads it (nothing kept): its material, as the bake's `material`
// takes it, is the editor's choice "Name (from file.mtlx)"; its graph-driven channels are
// `mtlx` nodes the server evaluates, for the swatches and the bake alike.
let mtlxLoaded = null; // the server's answer for the document last read
async function loadMtlx(file) {
  clearErrors("mtlx");
  $("mtlx-warnings").replaceChildren();
  if (!file) return;
  const limit = materialCatalogue.mtlx_max_bytes;
  if (file.size > limit) {
    $("mtlx-hint").textContent = "";
    return showError({ body: { detail: `mtlx: ${MTLX_WORDS.tooLarge(file.name, kilobytes(file.size), kilobytes(limit))}` } }, "mtlx");
  }
  $("mtlx-hint").textContent = MTLX_WORDS.reading(file.name);
  const body = new FormData();
  body.append("mtlx", file);
  try { mtlxLoaded = await json("/v1/materials/mtlx", { method: "POST", body }); } catch (error) {
    $("mtlx-hint").textContent = MTLX_WORDS.hint(kilobytes(limit));
    return showError(error, "mtlx");
  }
  $("mtlx-hint").textContent = MTLX_WORDS.read(mtlxLoaded);
  $("mtlx-warnings").replaceChildren(...mtlxLoaded.warnings.map((w) => el("li", { textContent: w })));
  const option = $("material").querySelector("option[value='mtlx']") ?? $("material").appendChild(el("option", { value: "mtlx" }));
  option.textContent = MTLX_WORDS.option(mtlxLoaded);
  $("material").value = "mtlx";
  chooseMaterial("mtlx");
}
const kilobytes = (n) => `${Math.ceil(n / 1024)} kB`;

// The material object the editor shows (null: none chosen). Throws {body: {detail}} (as
// showError takes) for JSON that does not read, naming the channel
function materialObject() {
  if ($("material").value === "") return null;
  const nodes = readJson($("material-nodes").value || "{}", "material.nodes");
  const scale = $("material-height-scale").valueAsNumber;
  const out = { ...materialExtras, name: $("material-name").value, ...(Object.keys(nodes).length ? { nodes } : {}), ...(Number.isFinite(scale) ? { height_scale: scale } : {}) };
  const wrong = [];
  for (const [channel, editor] of Object.entries(channelEditors)) {
    try {
      const value = editor.get();
      if (value !== undefined) out[channel] = value;
    } catch (error) { wrong.push(`material.${channel}: ${error.body?.detail.replace(/^[^:]*: /, "") ?? error}`); }
  }
  if (wrong.length) throw { body: { detail: wrong.join("; ") } };
  return out;
}

async function updateMaterial() {
  materialAbort?.abort();
  const abort = (materialAbort = new AbortController());
  let material, images;
  try { material = materialObject(); } catch (error) {
    clearErrors("material");
    showError(error, "material");
    $("material-state").textContent = "not updated: see the error";
    return;
  }
  if (!material) return;
  const given = Object.keys(channelEditors).filter((c) => material[c] !== undefined);
  $("material-state").textContent = "updating…";
  try {
    images = await Promise.all(given.map(async (channel) => [channel, await (await api("/v1/swatch", {
      method: "POST", headers: { "Content-Type": "application/json" }, signal: abort.signal,
      body: JSON.stringify({ material, channel, size: 128 }) })).blob()]));
  } catch (error) {
    if (error.name === "AbortError" || abort !== materialAbort) return;
    clearErrors("material");
    showError(error, "material");
    $("material-state").textContent = "not updated: see the error";
    return;
  }
  if (abort !== materialAbort) return;
  clearErrors("material");
  for (const [channel, editor] of Object.entries(channelEditors)) {
    const found = images.find(([c]) => c === channel), img = editor.img;
    if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
    img.classList.remove("stale");
    if (!found) { img.removeAttribute("src"); img.dataset.ready = "none"; continue; }
    img.onload = () => { if (abort === materialAbort) img.dataset.ready = "1"; };
    img.src = URL.createObjectURL(found[1]);
  }
  await litSphere(Object.fromEntries(images), abort);
  if (abort === materialAbort) $("material-state").textContent = "";
}

const sphere = {};
function setupSphere() {
  sphere.renderer = new THREE.WebGLRenderer({ antialias: true });
  sphere.renderer.setSize(256, 256);
  sphere.renderer.toneMapping = THREE.ACESFilmicToneMapping;
  $("material-sphere").append(sphere.renderer.domElement);
  sphere.scene = new THREE.Scene();
  sphere.scene.background = new THREE.Color(0x262b33);
  sphere.scene.environment = new THREE.PMREMGenerator(sphere.renderer).fromScene(new RoomEnvironment(), 0.02).texture;
  sphere.camera = new THREE.OrthographicCamera(-1.05, 1.05, 1.05, -1.05, 0.1, 10);
  sphere.camera.position.set(0, 0, 3);
  // each point of the sphere's front takes the swatches' pixel in front of it: its (x, y) is its uv
  const geometry = new THREE.SphereGeometry(1, 128, 96), p = geometry.attributes.position, uv = geometry.attributes.uv;
  for (let i = 0; i < p.count; i++) uv.setXY(i, 0.5 + 0.5 * p.getX(i), 0.5 + 0.5 * p.getY(i));
  sphere.mesh = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial());
  sphere.scene.add(sphere.mesh);
}

// The swatches ({channel: PNG blob}) as a MeshStandardMaterial's maps; a channel not given takes its default
async function litSphere(images, abort) {
  if (!sphere.renderer) setupSphere();
  const loader = new THREE.TextureLoader(), maps = {};
  for (const [channel, blob] of Object.entries(images)) {
    const url = URL.createObjectURL(blob);
    try { maps[channel] = await loader.loadAsync(url); } finally { URL.revokeObjectURL(url); }
    maps[channel].colorSpace = ["base_color", "emissive"].includes(channel) ? THREE.SRGBColorSpace : THREE.NoColorSpace;
  }
  if (abort !== materialAbort) { Object.values(maps).forEach((t) => t.dispose()); return; }
  const d = materialCatalogue.defaults, colour = (rgb) => new THREE.Color().setRGB(...rgb, THREE.LinearSRGBColorSpace);
  const old = sphere.mesh.material;
  sphere.mesh.material = new THREE.MeshStandardMaterial({
    color: maps.base_color ? 0xffffff : colour(d.base_color), map: maps.base_color ?? null,
    roughness: maps.roughness ? 1 : d.roughness, roughnessMap: maps.roughness ?? null,
    metalness: maps.metallic ? 1 : d.metallic, metalnessMap: maps.metallic ?? null,
    aoMap: maps.occlusion ?? null, normalMap: maps.normal ?? null, bumpMap: maps.normal ? null : maps.height ?? null, bumpScale: 4,
    emissive: maps.emissive ? 0xffffff : 0x000000, emissiveMap: maps.emissive ?? null,
    alphaMap: maps.opacity ?? null, transparent: !!maps.opacity,
  });
  for (const key of ["map", "roughnessMap", "metalnessMap", "aoMap", "normalMap", "bumpMap", "emissiveMap", "alphaMap"]) old[key]?.dispose();
  old.dispose();
  sphere.renderer.render(sphere.scene, sphere.camera);
  $("material-sphere").dataset.ready = "1";
}

// ---- the mesh --------------------------------------------------------------------------
const megabytes = (n) => `${(n / 1e6).toFixed(n < 1e7 ? 2 : 0)} MB`;

const suffixOf = (name) => { const dot = name.lastIndexOf("."); return dot > 0 ? name.slice(dot).toLowerCase() : ""; };

// What is wrong with the chosen files, said before anything is sent ("" when nothing): one
// mesh, the others files a mesh refers to (an OBJ's MTL and images, a glTF's .bin and
// images), all together within the server's upload limit.
function filesProblem(mesh, others, all) {
  const limit = config.limits.max_upload_bytes, total = all.reduce((n, f) => n + f.size, 0);
  const meshes = all.filter((f) => config.formats.includes(suffixOf(f.name)));
  const stranger = others.find((f) => !config.companions.includes(suffixOf(f.name)));
  if (!mesh) return all.length > 1 ? `no mesh among ${all.map((f) => f.name).join(", ")} (this server takes ${config.formats.join(" ")})`
    : `${all[0].name} is not a mesh file this server takes (${config.formats.join(" ")})`;
  if (meshes.length > 1) return `one mesh at a time: got ${meshes.map((f) => f.name).join(", ")}`;
  if (stranger) return `${stranger.name} is not a mesh file this server takes (${config.formats.join(" ")}), nor a file a mesh refers to (${config.companions.join(" ")})`;
  if (others.length > config.max_companions) return `${others.length} files beside the mesh: this server takes at most ${config.max_companions}`;
  if (total > limit) return `${all.length > 1 ? "together " : ""}${mesh.name}${all.length > 1 ? " and its files are" : " is"} ${megabytes(total)}: larger than this server's limit of ${megabytes(limit)}`;
  return "";
}

function chooseMesh(files) {
  clearErrors("mesh");
  clearMaterials();
  meshFile = null;
  companionFiles = [];
  $("mesh-info").textContent = "";
  const all = [...(files || [])];
  if (!all.length) return;
  const mesh = all.find((f) => config.formats.includes(suffixOf(f.name))), others = all.filter((f) => f !== mesh);
  const problem = filesProblem(mesh, others, all);
  if (problem) return showError({ body: { detail: `mesh: ${problem}` } }, "mesh");
  [meshFile, companionFiles] = [mesh, others];
  const total = all.reduce((n, f) => n + f.size, 0);
  $("mesh-info").textContent = others.length ? `${mesh.name} with ${others.map((f) => f.name).join(", ")}, ${megabytes(total)}` : `${mesh.name}, ${megabytes(total)}`;
  readMaterials(mesh, others);
}

// ---- the mesh's materials: a texture each ----------------------------------------------
// The server reads the mesh with the bake's own loader (POST /v1/inspect), so the names
// listed are those the bake's `materials` takes (an unnamed glTF material is material_0,
// ...), which the page could not promise reading the file itself with three.js's loaders.
function clearMaterials() {
  inspecting++;
  materialChoices = {};
  for (const path of [...fields.keys()]) if (path.startsWith("materials.")) fields.delete(path);
  $("materials-list").replaceChildren();
  $("materials-hint").textContent = "";
  clearErrors("materials");
  $("materials").hidden = true;
}

async function readMaterials(mesh, others) {
  clearMaterials();
  if (!MATERIAL_FORMATS.includes(suffixOf(mesh.name))) return; // one material: the bake's texture
  const token = inspecting, form = new FormData();
  form.append("mesh", mesh);
  for (const file of others) form.append("files", file);
  $("materials").hidden = false;
  $("materials-hint").textContent = `Reading the materials of ${mesh.name}…`;
  let info;
  try {
    info = await json("/v1/inspect", { method: "POST", body: form });
  } catch (error) {
    if (token !== inspecting) return;
    $("materials").hidden = true;
    return showError(error, "mesh");
  }
  if (token !== inspecting) return;
  showMaterials(info);
}

function showMaterials(info) {
  if (info.materials.length < 2) { // one texture set: the bake's texture is its texture
    $("materials-hint").textContent = `One material (${info.materials[0]?.name ?? "none"}): it takes the bake's texture (2. Texture).`;
    return;
  }
  const uvWords = { all: "its own UVs", some: "UVs on some parts", none: "no UVs" };
  const rows = info.materials.map((m) => {
    const id = `material-${++ids}`;
    const select = el("select", { id }, el("option", { value: "", textContent: "The bake's texture (2. Texture)" }),
      catalogue.map((t) => el("option", { value: t.name, textContent: TEXTURE_NAMES[t.name] ?? t.name })));
    select.setAttribute("aria-describedby", `${id}-hint ${id}-error`);
    select.addEventListener("change", () => clearErrors("materials"));
    materialChoices[m.name] = select;
    const tiles = m.tiles.length ? `, UDIM tiles ${m.tiles[0]}–${m.tiles[m.tiles.length - 1]}` : "";
    const error = el("p", { className: "error", id: `${id}-error`, role: "alert" });
    fields.set(`materials.${m.name}`, { input: select, error });
    return el("div", { className: "field" }, el("label", { htmlFor: id, textContent: m.name }),
      select, el("p", { className: "hint", id: `${id}-hint`, textContent: `${m.faces.toLocaleString()} faces, ${uvWords[m.uv] ?? m.uv}${tiles}` }), error);
  });
  $("materials-list").replaceChildren(...rows);
  materialsEnabled();
}

// One texture set for the whole mesh has no material of its own to give a texture
function materialsEnabled() {
  const single = settingsControls.texture_set?.get() === "single";
  for (const select of Object.values(materialChoices)) select.disabled = single;
  if (Object.keys(materialChoices).length) {
    $("materials-hint").textContent = single ? "One texture set for the whole mesh (More settings): every material takes the bake's texture (2. Texture)."
      : "Each material is a texture set of its own: give it a texture of its own, or it takes the bake's (2. Texture).";
  }
}

// {name: {texture}} of the materials given a texture of their own (null: none)
function materialSettings() {
  if (settingsControls.texture_set?.get() === "single") return null;
  const given = Object.entries(materialChoices).filter(([, select]) => select.value).map(([name, select]) => [name, { texture: select.value }]);
  return given.length ? Object.fromEntries(given) : null;
}

// ---- the bake and its progress -------------------------------------------------------
function mapsSummary() {
  if (!settingsControls.shading) return;
  const s = Object.fromEntries(Object.entries(settingsControls).map(([k, c]) => [k, c.get()]));
  const animated = !settingsControls.frames.element.hidden && s.frames?.length;
  const maps = $("material").value !== "" ? ["the material's base colour, roughness, metallic, normal...", "ORM", s.shading !== "decal" && "lit", "coverage"]
    : [animated ? "an albedo map per frame and a flipbook" : "albedo", s.shading !== "decal" && "lit", s.bump && "normal", "coverage"];
  $("maps").textContent = `This bake writes: ${maps.filter(Boolean).join(", ")} maps and a GLB.`;
}

function setProgress(text, fraction) {
  $("status").textContent = text;
  $("progress").value = fraction;
  $("percent").textContent = `${Math.round(100 * fraction)} %`;
}

function showJob(job) {
  const words = { queued: "Queued", running: "Baking", done: "Done", failed: "Failed", cancelled: "Cancelled" }[job.state] || job.state;
  setProgress(`${words}: ${job.mesh}${job.error ? ` — ${job.error}` : ""}`, job.state === "done" ? 1 : job.progress || 0);
  $("cancel").disabled = FINISHED.includes(job.state);
}

// Poll the job: soon at first, then less often while nothing changes (at most every 5 s;
// every 15 s in a hidden tab), as long as the server's Retry-After asks on a 503
async function follow(job) {
  const token = ++following;
  currentJob = job;
  if (resultOf !== job.id || job.state !== "done") clearResult(); // what is on screen is this job's result, or nothing
  let wait = 500, last = "";
  refreshJobs();
  while (token === following) {
    showJob(job);
    if (FINISHED.includes(job.state)) break;
    await sleep(document.hidden ? Math.max(wait, 15000) : wait);
    if (token !== following) return;
    try {
      job = await json(`/v1/jobs/${job.id}`);
    } catch (error) {
      if (error.status === 503) { await sleep(1000 * (error.retryAfter || 10)); continue; }
      showError(error, "settings");
      return;
    }
    const seen = `${job.state} ${job.progress}`;
    wait = seen === last ? Math.min(wait * 1.5, 5000) : 1000;
    last = seen;
  }
  if (token !== following) return;
  currentJob = job;
  refreshJobs();
  if (job.state === "done") await showResult(job);
  else if (job.state === "failed") showFailure(job);
}

// The first control marked invalid, its folded groups opened
function focusInvalid() {
  const invalid = document.querySelector("[aria-invalid='true']");
  for (let group = invalid?.closest("details"); group; group = group.parentElement.closest("details")) group.open = true;
  invalid?.focus();
}

function bakeSettings() {
  const materials = materialSettings();
  const material = materialObject();
  return { texture: textureSpec(), ...changedValues(settingsControls), ...(materials ? { materials } : {}), ...(material ? { material } : {}) };
}

async function bake(event) {
  event.preventDefault();
  clearErrors("mesh", "settings", "materials", ...Object.keys(settingsControls), "texture", "material");
  let settings, wrong = [typedWrong(settingsControls), typedWrong(textureControls)].filter(Boolean).join("; ");
  try { settings = bakeSettings(); } catch (error) { wrong = [wrong, error.body.detail].filter(Boolean).join("; "); }
  if (!meshFile || wrong) {
    if (!meshFile) showError({ body: { detail: $("mesh").files.length ? "mesh: choose a mesh file this server takes" : "mesh: choose a mesh file first" } }, "mesh");
    if (wrong) showError({ body: { detail: wrong } }, "settings");
    return focusInvalid();
  }
  const form = new FormData();
  form.append("mesh", meshFile);
  for (const file of companionFiles) form.append("files", file);
  form.append("settings", JSON.stringify(settings));
  $("bake").disabled = true;
  setProgress(`Uploading ${meshFile.name}`, 0);
  try {
    follow(await upload("/v1/jobs", form, (f) => setProgress(`Uploading ${meshFile.name}`, f)));
  } catch (error) {
    setProgress("Not sent: see the error above", 0);
    showError(error, "settings");
  } finally {
    $("bake").disabled = false;
  }
}

async function cancel(job) {
  try {
    const answer = await json(`/v1/jobs/${job.id}`, { method: "DELETE" });
    if (currentJob?.id === job.id) showJob(answer);
  } catch (error) { showError(error, currentJob?.id === job.id ? "settings" : "jobs"); }
  refreshJobs();
}

async function retry(job) {
  try { follow(await json(`/v1/jobs/${job.id}/retry`, { method: "POST" })); } catch (error) { showError(error, "jobs"); }
}

// ---- the result ------------------------------------------------------------------------
const viewer = {};

function setupViewer() {
  const box = $("viewer");
  viewer.renderer = new THREE.WebGLRenderer({ antialias: true });
  viewer.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
  viewer.renderer.domElement.tabIndex = 0;
  viewer.renderer.domElement.setAttribute("aria-label", "3D view: drag to turn, scroll to zoom, arrow keys to move");
  box.append(viewer.renderer.domElement);
  viewer.scene = new THREE.Scene();
  viewer.scene.background = new THREE.Color(0x262b33);
  viewer.camera = new THREE.PerspectiveCamera(35, 4 / 3, 0.01, 100);
  viewer.scene.add(new THREE.HemisphereLight(0xffffff, 0x50545c, 1.4), viewer.camera);
  const sun = new THREE.DirectionalLight(0xffffff, 1.8);
  sun.position.set(0.5, 1, 0.3);
  viewer.camera.add(sun); // a headlight: the side in view is lit
  viewer.controls = new OrbitControls(viewer.camera, viewer.renderer.domElement);
  viewer.controls.listenToKeyEvents(viewer.renderer.domElement);
  viewer.controls.addEventListener("change", render);
  new ResizeObserver(() => {
    const { clientWidth: w, clientHeight: h } = box;
    if (!w || !h) return;
    viewer.renderer.setSize(w, h, false);
    viewer.camera.aspect = w / h;
    viewer.camera.updateProjectionMatrix();
    render();
  }).observe(box);
}

const render = () => viewer.renderer.render(viewer.scene, viewer.camera);

function frame() {
  const box = new THREE.Box3().setFromObject(viewer.model);
  const radius = box.getSize(new THREE.Vector3()).length() / 2 || 1;
  const distance = (radius / Math.sin(THREE.MathUtils.degToRad(viewer.camera.fov / 2))) * 1.05;
  viewer.camera.near = radius / 100;
  viewer.camera.far = radius * 100;
  viewer.camera.updateProjectionMatrix();
  viewer.camera.position.set(0.35, 0.25, 1).normalize().multiplyScalar(distance);
  viewer.controls.target.set(0, 0, 0);
  viewer.controls.update();
}

function applyLit() {
  const lit = $("lit").checked;
  viewer.model?.traverse((o) => {
    if (!o.isMesh) return;
    o.userData.lit ||= o.material;
    o.userData.unlit ||= new THREE.MeshBasicMaterial({ map: o.material.map || o.material.emissiveMap });
    o.material = lit ? o.userData.lit : o.userData.unlit;
  });
  if (viewer.renderer) render();
}

async function showModel(url) {
  $("viewer").dataset.ready = "0";
  if (!viewer.renderer) setupViewer();
  const loader = new GLTFLoader().setRequestHeader(headers());
  const gltf = await loader.loadAsync(url);
  dropModel();
  viewer.model = gltf.scene;
  viewer.model.position.sub(new THREE.Box3().setFromObject(viewer.model).getCenter(new THREE.Vector3())); // centred on the origin
  viewer.scene.add(viewer.model);
  frame();
  applyLit();
  const materials = new Set(); // every material of the GLB, each with its own maps (a primitive each)
  viewer.model.traverse((o) => o.isMesh && materials.add(o.userData.lit.name));
  $("viewer").dataset.materials = [...materials].sort().join(",");
  $("viewer").dataset.ready = "1";
}

function dropModel() {
  if (!viewer.model) return;
  viewer.scene.remove(viewer.model);
  viewer.model.traverse((o) => { o.geometry?.dispose(); for (const m of [o.userData.lit, o.userData.unlit]) { m?.map?.dispose(); m?.dispose(); } });
  viewer.model = null;
  $("viewer").dataset.ready = "0";
}

function turn(angle) {
  const { camera, controls } = viewer;
  camera.position.sub(controls.target).applyAxisAngle(new THREE.Vector3(0, 1, 0), angle).add(controls.target);
  controls.update();
}

function zoom(factor) {
  const { camera, controls } = viewer;
  camera.position.sub(controls.target).multiplyScalar(factor).add(controls.target);
  controls.update();
}

function figures(report) {
  const seconds = Object.entries(report.seconds || {}).filter(([k]) => !["lookup", "surface", "texture", "accumulate"].includes(k));
  const size = [report.settings?.size].flat(); // one number: square
  const rows = [
    ["Mesh", `${report.mesh.name}: ${report.mesh.faces.toLocaleString()} faces, ${report.mesh.vertices.toLocaleString()} vertices`],
    ["Maps", `${(size.length === 1 ? [size[0], size[0]] : size).join(" × ")} texels, ${report.material ? `material ${report.material.name || "unnamed"}` : `texture ${report.settings?.texture?.name}`}`],
    report.atlas.charts == null ? ["UV atlas", "one per texture set (below)"] // several sets: each its own
      : ["UV atlas", `${report.atlas.method}, ${report.atlas.charts} charts, ${Math.round(100 * report.atlas.utilisation)} % of the texture used — ${report.atlas.reason}`],
    ["Texels covered", `${report.texels.covered.toLocaleString()} of ${report.texels.total.toLocaleString()}`],
    report.material && ["Material", `${report.material.name || "unnamed"}: ${report.material.maps.join(", ")} maps`],
    report.error_estimate && ["Error estimate", `RMSE ${report.error_estimate.rmse.toExponential(2)} (${report.error_estimate.method})`],
    ["Seconds", seconds.map(([k, v]) => `${k} ${v.toFixed(2)}`).join(", ")],
  ].filter(Boolean);
  return el("dl", {}, rows.map(([k, v]) => [el("dt", { textContent: k }), el("dd", { textContent: v })]));
}

// A line per texture set of a done job: its materials, size, texture, atlas and UDIM tiles
function textureSets(job) {
  const atlases = Object.fromEntries((job.report?.sets || []).map((s) => [s.name, s.atlas || {}]));
  return (job.sets || []).map((s) => {
    const atlas = atlases[s.name] || {};
    const materials = s.materials.length === 1 && s.materials[0] === s.name ? "" : ` (materials ${s.materials.join(", ")})`;
    const used = atlas.utilisation == null ? "" : `, ${Math.round(100 * atlas.utilisation)} % used`;
    const tiles = s.tiles.length ? `; UDIM tiles ${s.tiles.join(", ")}` : "";
    const item = el("li", { textContent: `${s.name}${materials}: ${TEXTURE_NAMES[s.texture] ?? s.texture}, ${s.size.join(" × ")} texels, atlas ${atlas.method ?? "?"}${used}${tiles}; ${s.files.length} files` });
    item.dataset.set = s.name;
    return item;
  });
}

// The name a Content-Disposition header gives the file (filename*, else filename)
function attachmentName(response) {
  const header = response.headers.get("Content-Disposition") || "";
  const utf8 = /filename\*=UTF-8''([^;\s]+)/i.exec(header), ascii = /filename="([^"]+)"/i.exec(header);
  return utf8 ? decodeURIComponent(utf8[1]) : ascii?.[1];
}

// A download link; `name` unset: the name the server gives it
function link(path, name, text) {
  const a = el("a", { href: path, download: name ?? "", textContent: text });
  a.addEventListener("click", async (event) => { // with a key, the file comes through fetch
    if (!sessionStorage.getItem(KEY)) return;
    event.preventDefault();
    try {
      const response = await api(path);
      blobs.push(URL.createObjectURL(await response.blob()));
      el("a", { href: blobs[blobs.length - 1], download: name ?? attachmentName(response) ?? path.split("/").pop() }).click();
    } catch (error) { showError(error, "jobs"); }
  });
  return a;
}

// The result card holds one job's: its files, or why it failed (resultOf: that job's id)
let resultOf = null;
function clearResult() {
  resultOf = null;
  blobs.splice(0).forEach((url) => URL.revokeObjectURL(url));
  for (const id of ["figures", "warnings", "sets", "downloads", "images"]) $(id).replaceChildren();
  $("result-error").textContent = "";
  $("result").hidden = true;
  dropModel();
}

function showFailure(job) {
  clearResult();
  resultOf = job.id;
  $("result-title").textContent = `4. Result: ${job.mesh} failed`;
  $("result-body").hidden = true;
  $("result-error").textContent = `The bake of ${job.mesh} failed: ${job.error || "the server gave no reason"}. Change the settings and bake again.`;
  $("result").hidden = false;
}

async function showResult(job) {
  const base = `/v1/jobs/${job.id}`;
  clearResult();
  resultOf = job.id;
  $("result-body").hidden = false;
  $("result").hidden = false;
  $("result-title").textContent = `4. Result: ${job.mesh}`;
  $("figures").replaceChildren(job.report ? figures(job.report) : "");
  $("warnings").replaceChildren(...job.warnings.map((w) => el("li", { textContent: w })));
  $("sets").replaceChildren(...textureSets(job));
  $("downloads").replaceChildren(el("li", {}, link(`${base}/result.zip`, undefined, "All files (result.zip)")),
    ...job.files.map((name) => el("li", {}, link(`${base}/files/${encodeURIComponent(name)}`, name, name))));
  const images = job.files.filter((name) => name.endsWith(".png"));
  $("images").replaceChildren(...await Promise.all(images.map(async (name) => el("figure", {},
    el("img", { src: await fileUrl(`${base}/files/${encodeURIComponent(name)}`), alt: `the ${name.replace(/\.png$/, "")} map`, loading: "lazy" }),
    el("figcaption", { textContent: name })))));
  const glb = job.files.find((name) => name.endsWith(".glb"));
  if (glb) {
    try { await showModel(`${base}/files/${encodeURIComponent(glb)}`); } catch (error) { showError({ body: { detail: `the model could not be shown: ${error.message || error}` } }, "jobs"); }
  }
}

// ---- recent jobs ---------------------------------------------------------------------
async function refreshJobs() {
  let page;
  try { page = await json("/v1/jobs?limit=10"); } catch (error) { clearErrors("jobs"); return showError(error, "jobs"); }
  clearErrors("jobs");
  const button = (text, label, action) => {
    const b = el("button", { type: "button", textContent: text });
    b.setAttribute("aria-label", label);
    b.addEventListener("click", action);
    return b;
  };
  $("jobs").tBodies[0].replaceChildren(...page.jobs.map((job) => {
    const texture = job.settings.texture?.name ?? job.settings.texture ?? "checker";
    const live = !FINISHED.includes(job.state);
    const state = `${job.state}${job.state === "running" ? ` ${Math.round(100 * (job.progress || 0))} %` : ""}`;
    // each cell says its column: on a phone the rows are stacked and the header hidden (page.css)
    const cell = (column, ...children) => { const td = el("td", {}, ...children); td.dataset.label = column; return td; };
    return el("tr", {},
      cell("Mesh", job.mesh), cell("Texture", TEXTURE_NAMES[texture] ?? texture),
      cell("State", el("div", {}, el("span", { className: `state-${job.state}`, textContent: state }), job.error && el("small", { className: "reason", textContent: job.error }))),
      cell("Created", new Date(job.created).toLocaleString()),
      cell("Actions", el("div", { className: "actions" },
        job.state === "done" && button("Show", `show the result of ${job.mesh}`, () => { currentJob = job; following++; showJob(job); showResult(job); }),
        live && button("Follow", `follow the bake of ${job.mesh}`, () => follow(job)),
        live && button("Cancel", `cancel the bake of ${job.mesh}`, () => cancel(job)),
        ["failed", "cancelled"].includes(job.state) && button("Retry", `bake ${job.mesh} again`, () => retry(job)))));
  }));
  if (!page.jobs.length) $("jobs").tBodies[0].append(el("tr", {}, el("td", { colSpan: 5, textContent: "No jobs yet." })));
}

// ---- start -----------------------------------------------------------------------------
async function start() {
  fields.set("key", { input: $("key"), error: $("key-error") });
  fields.set("mesh", { input: $("mesh"), error: $("mesh-error") });
  fields.set("files", { input: $("mesh"), error: $("mesh-error") }); // the files beside the mesh: one field on the page
  fields.set("texture", { input: $("texture"), error: $("texture-error") });
  fields.set("materials", { input: null, error: $("materials-error") });
  fields.set("settings", { input: null, error: $("settings-error") });
  fields.set("jobs", { input: null, error: $("jobs-error") });
  fields.set("material", { input: $("material"), error: $("material-error") });
  fields.set("material.nodes", { input: $("material-nodes"), error: $("material-nodes-error") });
  fields.set("mtlx", { input: $("mtlx"), error: $("mtlx-error") });
  let textures;
  [config, textures, materialCatalogue] = await Promise.all([json("/v1/config"), json("/v1/textures"), json("/v1/materials")]);
  catalogue = textures.textures;
  textureSchema = textures.schema;
  $("key-form").hidden = !config.auth;
  if (sessionStorage.getItem(KEY)) $("key").placeholder = "a key is set for this tab";

  const limit = config.limits;
  $("mesh-hint").textContent = `${config.formats.join(" ")}, up to ${megabytes(limit.max_upload_bytes)}; an OBJ with its MTL and images, a glTF with its .bin and images`;
  $("mesh").accept = [...config.formats, ...config.companions].join(",");
  $("mesh").addEventListener("change", () => chooseMesh($("mesh").files));
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    if (e.dataTransfer.files.length) { $("mesh").files = e.dataTransfer.files; chooseMesh(e.dataTransfer.files); }
  });

  const settings = config.settings_schema;
  const ctx = { root: settings, words: SETTING_WORDS, changed: () => { mapsSummary(); materialsEnabled(); } };
  const limits = { size: limit.max_size, samples: limit.max_samples, max_faces: limit.max_faces };
  settingsControls = {
    ...form(ctx, settings, $("settings-form"), { prefix: [], only: (k) => MAIN_SETTINGS.includes(k), limits }),
    ...form(ctx, settings, $("settings-more"), { prefix: [], only: (k) => !MAIN_SETTINGS.includes(k), skip: NOT_SETTINGS, limits }),
  };
  for (const t of catalogue) $("texture").append(el("option", { value: t.name, textContent: TEXTURE_NAMES[t.name] ?? t.name }));
  const first = resolve(settings, settings.properties.texture).default;
  buildTexture(typeof first === "string" ? first : catalogue[0].name);

  $("material").append(el("option", { value: "", textContent: SETTING_WORDS.material.none }),
    ...materialCatalogue.materials.map((m) => el("option", { value: m.name, textContent: SETTING_WORDS.material.options[m.name] ?? m.name })),
    el("option", { value: "new", textContent: MATERIAL_WORDS.new }));
  $("material").addEventListener("change", () => chooseMaterial($("material").value));
  $("mtlx-label").textContent = MTLX_WORDS.label;
  $("mtlx-hint").textContent = MTLX_WORDS.hint(kilobytes(materialCatalogue.mtlx_max_bytes));
  $("mtlx").addEventListener("change", () => loadMtlx($("mtlx").files[0]));
  for (const id of ["material-name", "material-height-scale", "material-nodes"]) $(id).addEventListener("input", () => materialChanged(400));
  chooseMaterial("");
  $("texture").addEventListener("change", () => buildTexture($("texture").value));
  $("texture-reset").addEventListener("click", () => buildTexture($("texture").value));
  $("swatch-view").addEventListener("change", () => swatchSoon(0));
  $("bake-form").addEventListener("submit", bake);
  $("cancel").addEventListener("click", () => currentJob && cancel(currentJob));
  $("jobs-refresh").addEventListener("click", refreshJobs);
  $("lit").addEventListener("change", applyLit);
  $("view-reset").addEventListener("click", () => viewer.model && frame());
  for (const [id, action] of [["turn-left", () => turn(-Math.PI / 8)], ["turn-right", () => turn(Math.PI / 8)], ["zoom-in", () => zoom(0.8)], ["zoom-out", () => zoom(1.25)]]) {
    $(id).addEventListener("click", () => viewer.model && action());
  }
  $("key-form").addEventListener("submit", (e) => {
    e.preventDefault();
    sessionStorage.setItem(KEY, $("key").value.trim());
    $("key").value = "";
    $("key").placeholder = "a key is set for this tab";
    clearErrors("key");
    refreshJobs();
    swatchSoon(0);
  });
  $("key-forget").addEventListener("click", () => { sessionStorage.removeItem(KEY); $("key").placeholder = ""; });
  refreshJobs();
}

start().catch((error) => {
  document.querySelector("header").append(el("p", { className: "error", role: "alert", textContent: `The page could not start: ${error.message || error}` }));
});
