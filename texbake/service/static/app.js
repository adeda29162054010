// texbake's page: one module, no framework. The forms are made from the API's JSON Schemas
// (GET /v1/textures for the texture spec, GET /v1/config for BakeSettings and the server's
// limits); the API validates, and its errors are shown beside the field they name.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

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
const NOT_SETTINGS = ["texture", "cage"]; // the texture has its own section; the service takes no source mesh

let config, catalogue, textureSchema; // GET /v1/config, GET /v1/textures
let meshFile = null;
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
    const names = path[0] === "settings" || path[0] === "body" ? path.slice(1) : path;
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
const resolve = (root, node) => { while (node?.$ref) node = root.$defs[node.$ref.split("/").pop()]; return node || {}; };
const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
const hex = (rgb) => "#" + rgb.map((c) => Math.round(255 * Math.min(1, Math.max(0, toSrgb(c)))).toString(16).padStart(2, "0")).join("");
const linear = (text) => [1, 3, 5].map((i) => Math.round(toLinear(parseInt(text.slice(i, i + 2), 16) / 255) * 1e4) / 1e4);
const numbers = (text) => text.split(/[\s,;]+/).filter(Boolean).map((t) => (Number.isFinite(Number(t)) ? Number(t) : t));
const titled = (prop, key) => prop.title || key[0].toUpperCase() + key.slice(1).replaceAll("_", " ");
const plain = (text) => text.replaceAll("``", "").replaceAll("`", ""); // the schema's descriptions are reST
let ids = 0;

// The range a number may take, and in words ("0 < x ≤ 1000"); `limit`: this server's, if lower
function range(node, limit) {
  const lo = node.minimum ?? node.exclusiveMinimum;
  let hi = node.maximum ?? node.exclusiveMaximum, below = node.maximum == null && hi != null ? "<" : "≤";
  const server = limit != null && !(hi <= limit);
  if (server) [hi, below] = [limit, "≤"];
  const text = [lo != null && `${lo} ${node.minimum != null ? "≤" : "<"}`, "x", hi != null && `${below} ${hi}`].filter(Boolean).join(" ");
  return { lo, hi, text: lo == null && hi == null ? "" : text + (server ? ": this server's limit" : "") };
}

// One control for one schema node: {element, get()}; get() gives the value it was made
// with until the person changes it (a colour round trip through hex is not exact).
function control(root, prop, key, path, value, changed, limit) {
  const branches = (resolve(root, prop).anyOf || [prop]).map((b) => resolve(root, b));
  const nullable = branches.some((b) => b.type === "null");
  const node = branches.find((b) => b.type !== "null") || {};
  const id = `f${++ids}`, title = titled(prop, key);
  let about = plain(prop.description || node.description || "");
  const field = el("div", { className: "field" });
  const error = el("p", { className: "error", id: `${id}-error`, role: "alert" });
  let input, read, touched = false;
  const hint = (text) => el("p", { className: "hint", id: `${id}-hint`, textContent: text });
  const labelled = (inp) => { inp.id = id; inp.setAttribute("aria-describedby", `${id}-hint ${id}-error`); };
  const touch = () => { touched = true; changed(); };

  if (node.properties) { // a group of parameters
    if (node.properties.knots && node.properties.colours) return colourMap(prop, key, path, value, changed);
    const children = Object.entries(node.properties).map(([k, p]) => [k, control(root, p, k, [...path, k], (value || {})[k] ?? p.default, changed)]);
    const group = el("details", {}, el("summary", { textContent: title }), el("div", { className: "form" }, children.map(([, c]) => c.element)));
    fields.set(path.join("."), { input: null, error });
    group.append(error);
    return { element: group, get: () => Object.fromEntries(children.map(([k, c]) => [k, c.get()])) };
  }
  if (node.enum) {
    input = el("select", {}, [...(nullable ? [null] : []), ...node.enum].map((v) => el("option", { value: JSON.stringify(v), textContent: v ?? "none" })));
    input.value = JSON.stringify(value ?? null);
    read = () => JSON.parse(input.value);
  } else if (node.type === "boolean") {
    input = el("input", { type: "checkbox", checked: !!value });
    read = () => input.checked;
  } else if (node.type === "number" || node.type === "integer") {
    const { lo, hi: top, text } = range(node, limit);
    input = el("input", { type: "number", step: node.type === "integer" ? "1" : "any", value: value ?? "", placeholder: nullable ? "auto" : "" });
    if (lo != null) input.min = lo;
    if (top != null) input.max = top;
    read = () => (input.value.trim() === "" ? (nullable ? null : input.value) : Number.isFinite(input.valueAsNumber) ? input.valueAsNumber : input.value);
    const row = el("div", { className: "number" }, input);
    if (lo != null && top != null && top - lo <= 1000) { // a slider beside the box where the range is small
      const slider = el("input", { type: "range", min: lo, max: top, step: node.type === "integer" ? 1 : (top - lo) / 200, value: value ?? lo, tabIndex: -1 });
      slider.setAttribute("aria-hidden", "true");
      slider.addEventListener("input", () => { input.value = slider.value; touch(); });
      input.addEventListener("input", () => { slider.value = input.value; });
      row.append(slider);
    }
    labelled(input);
    field.append(el("label", { htmlFor: id, textContent: title }), row, hint([about, text && `(${text})`].filter(Boolean).join(" ")), error);
  } else if (node.type === "array" && node.prefixItems?.length === 3 && node.description === "linear RGB") {
    input = el("input", { type: "color", value: hex(value || [0, 0, 0]) });
    read = () => linear(input.value);
  } else if (node.type === "array" && node.prefixItems) { // x, y, z
    const boxes = node.prefixItems.map((_, i) => el("input", { type: "number", step: "any", value: (value || [])[i] ?? "" }));
    boxes.forEach((b, i) => { b.setAttribute("aria-label", `${title} ${"xyz"[i]}`); b.addEventListener("input", touch); });
    labelled(boxes[0]);
    input = boxes[0];
    read = () => boxes.map((b) => (Number.isFinite(b.valueAsNumber) ? b.valueAsNumber : b.value));
    field.append(el("label", { htmlFor: id, textContent: title }), el("div", { className: "triple" }, boxes), hint(about), error);
  } else if (node.type === "array") { // a list of numbers
    input = el("input", { type: "text", value: (value || []).join(", "), placeholder: nullable ? "none" : "" });
    read = () => (input.value.trim() === "" && nullable ? null : numbers(input.value));
    about ||= "numbers, separated by commas";
  } else { // anything else: JSON
    input = el("input", { type: "text", value: JSON.stringify(value ?? null) });
    read = () => { try { return JSON.parse(input.value); } catch { return input.value; } };
  }
  if (!field.childElementCount) {
    labelled(input);
    field.append(el("label", { htmlFor: id, textContent: title }), input, hint(about), error);
  }
  if (input.type !== "range") input.addEventListener(input.type === "checkbox" || input.tagName === "SELECT" ? "change" : "input", touch);
  fields.set(path.join("."), { input, error });
  return { element: field, get: () => (touched ? read() : value), field };
}

// A colour map: its gradient, and each knot's place and colour (knots can be added and removed)
function colourMap(prop, key, path, value, changed) {
  const map = { knots: [...(value?.knots || [0, 1])], colours: (value?.colours || [[0, 0, 0], [1, 1, 1]]).map((c) => [...c]) };
  const error = el("p", { className: "error", role: "alert" });
  const bar = el("div", { className: "gradient", role: "img" });
  const list = el("div", { className: "knots" });
  const title = titled(prop, key);
  let touched = false;
  const draw = () => {
    const [k0, k1] = [map.knots[0], map.knots[map.knots.length - 1]];
    const at = (k) => (k1 > k0 ? (100 * (k - k0)) / (k1 - k0) : 0);
    bar.style.backgroundImage = `linear-gradient(to right, ${map.knots.map((k, i) => `${hex(map.colours[i])} ${at(k).toFixed(1)}%`).join(", ")})`;
    bar.setAttribute("aria-label", `${title}: ${map.knots.map((k, i) => `${hex(map.colours[i])} at ${k}`).join(", ")}`);
  };
  const edit = () => { touched = true; draw(); changed(); };
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
  const element = el("details", { open: true }, el("summary", { textContent: `${title} (colour map)` }), bar, list, add, error);
  return { element, get: () => (touched ? { knots: [...map.knots], colours: map.colours.map((c) => [...c]) } : value) };
}

// The controls of a schema's top-level properties into `into`; {key: control}
function form(root, node, into, { prefix, only, skip = [], limits = {}, changed }) {
  const out = {};
  for (const [key, prop] of Object.entries(node.properties)) {
    if (key === "name" || skip.includes(key) || (only && !only(key))) continue;
    const start = limits[key] != null ? Math.min(prop.default ?? limits[key], limits[key]) : prop.default;
    out[key] = control(root, prop, key, [...prefix, key], start, changed, limits[key]);
    out[key].default = prop.default;
    into.append(out[key].element);
  }
  return out;
}

// What differs from the defaults (a group is sent whole: its defaults are the parent's)
const changedValues = (controls) => Object.fromEntries(Object.entries(controls)
  .filter(([, c]) => !c.element.hidden).map(([k, c]) => [k, c.get()]).filter(([k, v]) => JSON.stringify(v) !== JSON.stringify(controls[k].default)));

// ---- the texture and its swatch ------------------------------------------------------
const textureDef = (name) => resolve(textureSchema, textureSchema.discriminator ? { $ref: textureSchema.discriminator.mapping[name] } : {});
const textureSpec = () => ({ name: $("texture").value, ...changedValues(textureControls) });

function buildTexture(name) {
  $("texture").value = name;
  for (const path of [...fields.keys()]) if (path.startsWith("texture.")) fields.delete(path);
  const box = $("texture-form");
  box.replaceChildren();
  const def = textureDef(name);
  textureControls = form(textureSchema, def, box, { prefix: ["texture"], changed: swatchSoon });
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

// ---- the mesh --------------------------------------------------------------------------
const megabytes = (n) => `${(n / 1e6).toFixed(n < 1e7 ? 2 : 0)} MB`;

function chooseMesh(file) {
  clearErrors("mesh");
  meshFile = null;
  $("mesh-info").textContent = "";
  if (!file) return;
  const dot = file.name.lastIndexOf("."), suffix = dot >= 0 ? file.name.slice(dot).toLowerCase() : "";
  const problem = !config.formats.includes(suffix) ? `${file.name} is not a mesh file this server takes (${config.formats.join(" ")})`
    : file.size > config.limits.max_upload_bytes ? `${file.name} is ${megabytes(file.size)}: larger than this server's limit of ${megabytes(config.limits.max_upload_bytes)}`
    : "";
  if (problem) return showError({ body: { detail: `mesh: ${problem}` } }, "mesh");
  meshFile = file;
  $("mesh-info").textContent = `${file.name}, ${megabytes(file.size)}`;
}

// ---- the bake and its progress -------------------------------------------------------
function mapsSummary() {
  if (!settingsControls.shading) return;
  const s = Object.fromEntries(Object.entries(settingsControls).map(([k, c]) => [k, c.get()]));
  const animated = !settingsControls.frames.element.hidden && s.frames?.length;
  const maps = [animated ? "an albedo map per frame and a flipbook" : "albedo", s.shading !== "decal" && "lit", s.bump && "normal", "coverage"];
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
}

function bakeSettings() {
  return { texture: textureSpec(), ...changedValues(settingsControls) };
}

async function bake(event) {
  event.preventDefault();
  clearErrors("mesh", "settings", ...Object.keys(settingsControls), "texture");
  if (!meshFile) {
    showError({ body: { detail: $("mesh").files.length ? "mesh: choose a mesh file this server takes" : "mesh: choose a mesh file first" } }, "mesh");
    return $("mesh").focus();
  }
  const form = new FormData();
  form.append("mesh", meshFile);
  form.append("settings", JSON.stringify(bakeSettings()));
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
  if (viewer.model) {
    viewer.scene.remove(viewer.model);
    viewer.model.traverse((o) => { o.geometry?.dispose(); for (const m of [o.userData.lit, o.userData.unlit]) { m?.map?.dispose(); m?.dispose(); } });
  }
  viewer.model = gltf.scene;
  viewer.model.position.sub(new THREE.Box3().setFromObject(viewer.model).getCenter(new THREE.Vector3())); // centred on the origin
  viewer.scene.add(viewer.model);
  frame();
  applyLit();
  $("viewer").dataset.ready = "1";
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
    ["Maps", `${(size.length === 1 ? [size[0], size[0]] : size).join(" × ")} texels, texture ${report.settings?.texture?.name}`],
    ["UV atlas", `${report.atlas.method}, ${report.atlas.charts} charts, ${Math.round(100 * report.atlas.utilisation)} % of the texture used — ${report.atlas.reason}`],
    ["Texels covered", `${report.texels.covered.toLocaleString()} of ${report.texels.total.toLocaleString()}`],
    report.error_estimate && ["Error estimate", `RMSE ${report.error_estimate.rmse.toExponential(2)} (${report.error_estimate.method})`],
    ["Seconds", seconds.map(([k, v]) => `${k} ${v.toFixed(2)}`).join(", ")],
  ].filter(Boolean);
  return el("dl", {}, rows.map(([k, v]) => [el("dt", { textContent: k }), el("dd", { textContent: v })]));
}

function link(path, name, text) {
  const a = el("a", { href: path, download: name, textContent: text });
  a.addEventListener("click", async (event) => { // with a key, the file comes through fetch
    if (!sessionStorage.getItem(KEY)) return;
    event.preventDefault();
    try {
      el("a", { href: await fileUrl(path), download: name }).click();
    } catch (error) { showError(error, "jobs"); }
  });
  return a;
}

async function showResult(job) {
  const base = `/v1/jobs/${job.id}`;
  blobs.splice(0).forEach((url) => URL.revokeObjectURL(url));
  $("result").hidden = false;
  $("result-title").textContent = `4. Result: ${job.mesh}`;
  $("figures").replaceChildren(job.report ? figures(job.report) : "");
  $("warnings").replaceChildren(...job.warnings.map((w) => el("li", { textContent: w })));
  $("downloads").replaceChildren(el("li", {}, link(`${base}/result.zip`, `${job.id}.zip`, "All files (result.zip)")),
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
    return el("tr", {},
      el("td", { textContent: job.mesh }), el("td", { textContent: texture }),
      el("td", { className: `state-${job.state}`, textContent: state, title: job.error || "" }),
      el("td", { textContent: new Date(job.created).toLocaleString() }),
      el("td", {}, el("div", { className: "actions" },
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
  fields.set("texture", { input: $("texture"), error: $("texture-error") });
  fields.set("settings", { input: null, error: $("settings-error") });
  fields.set("jobs", { input: null, error: $("jobs-error") });
  let textures;
  [config, textures] = await Promise.all([json("/v1/config"), json("/v1/textures")]);
  catalogue = textures.textures;
  textureSchema = textures.schema;
  $("key-form").hidden = !config.auth;
  if (sessionStorage.getItem(KEY)) $("key").placeholder = "a key is set for this tab";

  const limit = config.limits;
  $("mesh-hint").textContent = `${config.formats.join(" ")}, up to ${megabytes(limit.max_upload_bytes)}`;
  $("mesh").accept = config.formats.join(",");
  $("mesh").addEventListener("change", () => chooseMesh($("mesh").files[0]));
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    if (e.dataTransfer.files.length) { $("mesh").files = e.dataTransfer.files; chooseMesh(e.dataTransfer.files[0]); }
  });

  const settings = config.settings_schema;
  const changed = () => { mapsSummary(); };
  const limits = { size: limit.max_size, samples: limit.max_samples, max_faces: limit.max_faces };
  settingsControls = {
    ...form(settings, settings, $("settings-form"), { prefix: [], only: (k) => MAIN_SETTINGS.includes(k), limits, changed }),
    ...form(settings, settings, $("settings-more"), { prefix: [], only: (k) => !MAIN_SETTINGS.includes(k), skip: NOT_SETTINGS, limits, changed }),
  };
  for (const t of catalogue) $("texture").append(el("option", { value: t.name, textContent: t.name }));
  const first = resolve(settings, settings.properties.texture).default;
  buildTexture(typeof first === "string" ? first : catalogue[0].name);

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
