// The page around the wasm module (docs/SPEC.md §10): gathers a scene and its OBJ files
// (dropped, picked, an example, or the test hook's URL), renders, shows and saves.
import init, { render, objFileNames, Flags } from "./raycaster_web.js";

const $ = (id) => document.getElementById(id);
// { path, text, files: Map(path as the scene names it → text) }
let scene = null;
let rendered = null;

// A scene file fetched from `url`, with the obj_files it names fetched relative to it. One
// that cannot be fetched is left out: the parser then reports it where the scene names it,
// as the command line does for a file that is not there.
async function fetchScene(url) {
  const sceneUrl = new URL(url, location.href);
  const path = decodeURIComponent(sceneUrl.pathname.split("/").pop());
  const response = await fetch(sceneUrl);
  if (!response.ok) {
    throw `raycaster: ${path}: cannot read file: ${response.status} ${response.statusText}`;
  }
  const text = await response.text();
  const files = new Map();
  await Promise.all(objFileNames(text).map(async (name) => {
    const mesh = await fetch(new URL(name, sceneUrl)).catch(() => null);
    if (mesh && mesh.ok) files.set(name, await mesh.text());
  }));
  return { path, text, files };
}

// Dropped or picked files: the first that is not an .obj is the scene; the others are
// found by their names, as if they lay in the scene's folder.
async function readFiles(list) {
  const all = [...list];
  const sceneFile = all.find((f) => !f.name.toLowerCase().endsWith(".obj"));
  if (!sceneFile) throw "raycaster: no scene file among the files (only .obj files)";
  const files = new Map();
  for (const f of all) if (f !== sceneFile) files.set(f.name, await f.text());
  return { path: sceneFile.name, text: await sceneFile.text(), files };
}

function flags() {
  const f = new Flags();
  f.shade_back = $("shade_back").checked;
  f.shadows = $("shadows").checked;
  f.bounces = Number($("bounces").value) || 0;
  if ($("depth_min").value !== "" && $("depth_max").value !== "") {
    f.depth_min = Number($("depth_min").value);
    f.depth_max = Number($("depth_max").value);
  }
  return f;
}

function selectedOutput() {
  return document.querySelector("input[name=output]:checked").value;
}

// Renders the current scene; its times and notes are kept on window.raycasterTimes and
// window.raycasterNotes for automation.
async function renderScene() {
  const [width, height] = [Number($("width").value), Number($("height").value)];
  $("status").textContent = `rendering ${scene.path} at ${width} × ${height} …`;
  $("messages").textContent = "";
  $("download").disabled = true;
  const started = performance.now();
  const asked = flags();
  // The module's objects live in its memory until freed (a frame of floats: 32 bytes a pixel).
  const previous = rendered;
  rendered = null;
  previous?.free();
  try {
    rendered = await render(scene.path, scene.text, [...scene.files.keys()], [...scene.files.values()],
      width, height, asked);
  } finally {
    asked.free();
  }
  const wallMs = performance.now() - started;
  show();
  const kernel = rendered.kernelMs === undefined ? "" : `, kernel ${rendered.kernelMs.toFixed(1)} ms`;
  $("status").textContent = `${scene.path}, ${width} × ${height}: rendered in ${rendered.renderMs.toFixed(1)} ms`
    + `${kernel} (parsing ${rendered.parseMs.toFixed(1)} ms; ${wallMs.toFixed(1)} ms in all) on ${rendered.backend}`;
  $("messages").className = "notes";
  $("messages").textContent = rendered.notes.join("\n");
  $("download").disabled = false;
  window.raycasterTimes = { wallMs, parseMs: rendered.parseMs, renderMs: rendered.renderMs,
    kernelMs: rendered.kernelMs ?? null, backend: rendered.backend };
  window.raycasterNotes = rendered.notes;
}

function show() {
  if (!rendered) return;
  const canvas = $("image");
  canvas.width = rendered.width;
  canvas.height = rendered.height;
  const rgba = rendered.rgba(selectedOutput());
  const pixels = new Uint8ClampedArray(rgba.buffer, rgba.byteOffset, rgba.length);
  canvas.getContext("2d").putImageData(new ImageData(pixels, rendered.width, rendered.height), 0, 0);
}

function fail(error) {
  const text = typeof error === "string" ? error : String(error?.message ?? error);
  $("status").textContent = "";
  $("messages").className = "";
  $("messages").textContent = text;
  return text;
}

// The scene the page now shows, named on the page; Render renders it again.
function hold(loaded) {
  scene = loaded;
  $("scene").textContent = `Scene: ${scene.path}` + (scene.files.size ? ` with ${[...scene.files.keys()].join(", ")}` : "");
  $("render").disabled = false;
}

async function use(load) {
  try {
    hold(await load());
    await renderScene();
  } catch (error) {
    fail(error);
  }
}

function download() {
  const stem = scene.path.replace(/\.[^.]*$/, "");
  $("image").toBlob((blob) => {
    const link = document.createElement("a");
    link.href = URL.createObjectURL(blob);
    link.download = `${stem}_${selectedOutput()}.png`;
    link.click();
    URL.revokeObjectURL(link.href);
  }, "image/png");
}

async function listExamples() {
  const response = await fetch("scenes/index.json").catch(() => null);
  if (!response || !response.ok) return;
  for (const name of await response.json()) {
    $("example").add(new Option(name, name));
  }
}

function wire() {
  $("example").addEventListener("change", (e) => e.target.value && use(() => fetchScene(`scenes/${e.target.value}`)));
  $("files").addEventListener("change", (e) => use(() => readFiles(e.target.files)));
  $("render").addEventListener("click", () => use(async () => scene));
  $("download").addEventListener("click", download);
  for (const radio of document.querySelectorAll("input[name=output]")) radio.addEventListener("change", show);
  document.body.addEventListener("dragover", (e) => { e.preventDefault(); document.body.classList.add("dragging"); });
  document.body.addEventListener("dragleave", () => document.body.classList.remove("dragging"));
  document.body.addEventListener("drop", (e) => {
    e.preventDefault();
    document.body.classList.remove("dragging");
    use(() => readFiles(e.dataTransfer.files));
  });
}

// The test hook: ?scene=URL&size=W,H[&output=color|normals|depth][&shade_back=1][&shadows=1]
// [&bounces=N][&depth=MIN,MAX] renders that scene into the canvas and sets the title to `done`, or to the
// error text.
async function hook(params) {
  const size = (params.get("size") ?? "256,256").split(",");
  $("width").value = size[0];
  $("height").value = size[1] ?? size[0];
  const output = params.get("output") ?? "color";
  const radio = document.querySelector(`input[name=output][value="${output}"]`);
  if (!radio) throw `raycaster: output=${output}: one of color, normals, depth`;
  radio.checked = true;
  $("shade_back").checked = params.get("shade_back") === "1";
  $("shadows").checked = params.get("shadows") === "1";
  $("bounces").value = params.get("bounces") ?? "0";
  [$("depth_min").value, $("depth_max").value] = (params.get("depth") ?? ",").split(",");
  hold(await fetchScene(params.get("scene")));
  await renderScene();
}

async function main() {
  const params = new URLSearchParams(location.search);
  try {
    await init();
    wire();
    if (params.has("scene")) {
      await hook(params);
      document.title = "done";
    } else {
      document.title = "raycaster";
      await listExamples();
    }
  } catch (error) {
    document.title = fail(error);
  }
}

main();
