// The srg web client: plays a publication's edge animations back to back.
//
// Timing: one game clock. A clip of k frames starts exactly k frame periods after the
// previous one (clipStart += k * period, never "now"), so clips join without a gap and
// without drift; each requestAnimationFrame draws the frame the clock is on, from the
// clip's frames, all already decoded to ImageBitmaps. The next
// edge is chosen at the clip boundary from the control held at that moment. While an
// edge plays, the strips of every edge leaving its destination (and theirs) are
// fetched and decoded, so the choice at the boundary finds its strip ready. An edge
// without an animation, or whose strip is still loading, is drawn as a placeholder at
// the same rate: the clock never waits.
//
// Clips: by the media type served, a VP9 clip in an IVF file (parsed here, decoded by
// WebCodecs' VideoDecoder, every frame to an ImageBitmap before the clip is due) or, for
// publications made before, a WebP image strip (k frames side by side, one ImageBitmap).
// A browser that cannot decode them plays placeholders and says so.
//
// Size: a phone's screen (PHONE_SCREEN) plays the phone's clips (every
// frame at half size, cut by the server from the stored clip), others the stored ones.
//
// Tilt: the device's tilt towards the screen's right, whichever way the screen is turned
// (screen.orientation.angle): gamma in portrait, beta in landscape, signs to match.
//
// Traces: rows of [vertex, control], uploaded (POST /api/traces, token in the
// Authorization header, fetch keepalive so it survives the page going away) when the
// page is hidden, on "New game", and every MAX_TRACE_STEPS steps. An upload is kept in
// localStorage until the server answers, and re-sent on the next visit under the same
// idempotency key: the server stores it once.

const CONTROLS = { LEVEL: 0, LEFT: 1, RIGHT: 2 };
const TILT_DEGREES = 12;
const MAX_TRACE_STEPS = 1800; // 10 minutes at 3 clips a second; keeps a body ~20 KB
const KEEPALIVE_MAX_BYTES = 60000; // browsers cap keepalive bodies at 64 KiB
const STRIP_CACHE_SIZE = 256;
const PENDING_MAX = 20;
const FRAME_LOG_MAX = 200000;
const START_WAIT_MS = 3000; // wait this long at most for the first strips before playing
// a phone held either way: narrow in portrait, low in landscape
const PHONE_SCREEN = "(max-width: 600px), (max-height: 500px)";
const SIZE = matchMedia(PHONE_SCREEN).matches ? "phone" : "desktop";
const POINTS_PER_SCORE = 1000; // a clip scores at most ~0.033: shown as up to ~33 points
const VP9_CODEC = "vp09.00.10.08"; // profile 0, 8 bits: what the server encodes

const stats = {
  frames: [], // rAF timestamps (ms) at which a new frame was drawn
  ticks: [], // every rAF timestamp while playing: tells browser stalls from client gaps
  clips: 0,
  placeholders: 0, // clips drawn as placeholders because the edge has no animation
  late: 0, // clips whose strip was not decoded in time (also drawn as placeholders)
  uploads: [], // {status, trace_id, n_steps} per answered upload
  score: 0,
  steps: 0,
  publicationId: null,
  size: SIZE, // which strips this screen plays
  stripWidth: null, // pixel width of a frame of the strips played
  undecodable: 0, // strips fetched that the browser could not decode
  tilt: null, // the last tilt read: degrees towards the screen's right
};
window.srgStats = stats;

const $ = (id) => document.getElementById(id);
const canvas = $("screen");
const ctx = canvas.getContext("2d");

// ---- HTTP -----------------------------------------------------------------------
async function api(path, options = {}) {
  const response = await fetch(path, options);
  const body = await response.json().catch(() => ({}));
  if (!response.ok) throw Object.assign(new Error(body.error || response.statusText), { response, body });
  return body;
}

async function registerPlayer() {
  const player = await api("/api/players", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ kind: "person" }), // bots register as "bot"; analytics tell them apart
  });
  localStorage.setItem("srg.token", player.token);
  return player.token;
}

let token = localStorage.getItem("srg.token");

function newKey() {
  if (crypto.randomUUID) return crypto.randomUUID();
  return Array.from(crypto.getRandomValues(new Uint8Array(16)), (b) => b.toString(16).padStart(2, "0")).join("");
}

// ---- uploads ----------------------------------------------------------------------
const pending = {
  load: () => JSON.parse(localStorage.getItem("srg.pending") || "[]"),
  save: (list) => localStorage.setItem("srg.pending", JSON.stringify(list.slice(-PENDING_MAX))),
  add(body) { this.save([...this.load().filter((b) => b.idempotency_key !== body.idempotency_key), body]); },
  remove(key) { this.save(this.load().filter((b) => b.idempotency_key !== key)); },
};

async function send(body, retried = false) {
  const text = JSON.stringify(body);
  let response;
  try {
    response = await fetch("/api/traces", {
      method: "POST",
      keepalive: text.length < KEEPALIVE_MAX_BYTES,
      headers: { "Content-Type": "application/json", Authorization: `Bearer ${token}` },
      body: text,
    });
  } catch {
    return; // offline or the page went away: it stays pending for the next visit
  }
  if (response.status === 403 && !retried) {
    token = await registerPlayer(); // our token is gone (e.g. a reset server): a new player
    return send(body, true);
  }
  const answer = await response.json().catch(() => ({}));
  stats.uploads.push({ status: response.status, trace_id: answer.trace_id, n_steps: body.steps.length });
  // Keep only what a later retry could fix: rate limits and server errors.
  if (response.status !== 429 && response.status < 500) pending.remove(body.idempotency_key);
}

async function flushPending() {
  for (const body of pending.load()) await send(body);
}

// ---- clips ------------------------------------------------------------------------
const strips = new Map(); // url -> {image: Clip | null}, Clip: {width, height, frame(f), close()}

function stripUrl(edge) {
  if (!edge.animation) return null;
  return SIZE === "phone" ? `${edge.animation}/phone?frames=${game.k}` : edge.animation;
}

function undecodable(blob) {
  stats.undecodable += 1;
  $("status").textContent = `this browser cannot decode the animations (${blob.type}): showing placeholders`;
}

// The frames of an IVF file: a 32-byte header (its length at byte 6), then per frame a
// 12-byte header (size, 64-bit timestamp) and the frame's bytes.
function ivfFrames(buffer) {
  const view = new DataView(buffer);
  const frames = [];
  for (let at = view.getUint16(6, true); at + 12 <= buffer.byteLength;) {
    const size = view.getUint32(at, true);
    frames.push(new Uint8Array(buffer, at + 12, size));
    at += 12 + size;
  }
  return { width: view.getUint16(12, true), height: view.getUint16(14, true), frames };
}

async function decodeVideo(blob) {
  if (typeof VideoDecoder === "undefined") throw new Error("no WebCodecs");
  const { width, height, frames } = ivfFrames(await blob.arrayBuffer());
  const bitmaps = [];
  let failed = null;
  const decoder = new VideoDecoder({
    output: (frame) => { bitmaps.push(createImageBitmap(frame).finally(() => frame.close())); },
    error: (error) => { failed = error; },
  });
  decoder.configure({ codec: VP9_CODEC, codedWidth: width, codedHeight: height });
  frames.forEach((data, i) => {
    const type = i === 0 ? "key" : "delta";
    decoder.decode(new EncodedVideoChunk({ type, timestamp: Math.round((i * 1e6) / 30), data }));
  });
  await decoder.flush();
  decoder.close();
  if (failed) throw failed;
  const images = await Promise.all(bitmaps);
  return { width, height, frame: (f) => [images[f], 0], close: () => images.forEach((b) => b.close()) };
}

async function decodeImageStrip(blob) {
  const image = await createImageBitmap(blob);
  const width = image.width / game.k;
  return { width, height: image.height, frame: (f) => [image, f * width], close: () => image.close() };
}

function decodeClip(blob) {
  const decode = blob.type.startsWith("image/") ? decodeImageStrip : decodeVideo;
  return decode(blob).catch((error) => { undecodable(blob); throw error; });
}

function requestStrip(url) {
  if (!url) return Promise.resolve();
  if (strips.has(url)) return strips.get(url).ready;
  const entry = { image: null };
  strips.set(url, entry);
  entry.ready = fetch(url)
    .then((r) => (r.ok ? r.blob() : Promise.reject(new Error(r.statusText))))
    .then(decodeClip)
    .then((clip) => { entry.image = clip; })
    .catch(() => strips.delete(url)); // try again next time it is needed
  if (strips.size > STRIP_CACHE_SIZE) {
    const [oldest, old] = strips.entries().next().value;
    strips.delete(oldest);
    old.image?.close();
  }
  return entry.ready;
}

function preloadFrom(vertex, depth = 2) {
  const loads = [];
  for (const edge of game.pub.vertices[vertex]) {
    loads.push(requestStrip(stripUrl(edge)));
    if (depth > 1) loads.push(...preloadFrom(edge.dst, depth - 1));
  }
  return loads;
}

// ---- input ------------------------------------------------------------------------
const input = { keys: new Set(), tilt: null, pointer: null };
const KEYS = { ArrowLeft: CONTROLS.LEFT, ArrowRight: CONTROLS.RIGHT, ArrowUp: CONTROLS.LEVEL, ArrowDown: CONTROLS.LEVEL };

function currentControl() {
  if (input.keys.size) {
    const held = new Set([...input.keys].map((k) => KEYS[k]));
    return held.size === 1 ? [...held][0] : CONTROLS.LEVEL;
  }
  return input.pointer ?? input.tilt ?? CONTROLS.LEVEL;
}

addEventListener("keydown", (e) => {
  if (e.key in KEYS) { input.keys.add(e.key); e.preventDefault(); }
});
addEventListener("keyup", (e) => input.keys.delete(e.key));
addEventListener("blur", () => input.keys.clear());
function screenAngle() {
  const angle = screen.orientation?.angle ?? window.orientation ?? 0;
  return ((angle % 360) + 360) % 360;
}

// Degrees the device leans towards the screen's right edge. Turned 90 degrees (its top
// to the left), the screen's right is the device's bottom: leaning it that way raises
// the top, beta grows; turned 270 the other way round; upside down, gamma flips.
function tiltToScreenRight(e) {
  switch (screenAngle()) {
    case 90: return e.beta;
    case 180: return e.gamma === null ? null : -e.gamma;
    case 270: return e.beta === null ? null : -e.beta;
    default: return e.gamma;
  }
}

addEventListener("deviceorientation", (e) => {
  const tilt = tiltToScreenRight(e);
  if (tilt === null) return;
  stats.tilt = tilt;
  input.tilt = tilt < -TILT_DEGREES ? CONTROLS.LEFT : tilt > TILT_DEGREES ? CONTROLS.RIGHT : CONTROLS.LEVEL;
});
canvas.addEventListener("pointerdown", (e) => {
  const rect = canvas.getBoundingClientRect();
  input.pointer = e.clientX - rect.left < rect.width / 2 ? CONTROLS.LEFT : CONTROLS.RIGHT;
});
for (const type of ["pointerup", "pointercancel", "pointerleave"]) {
  canvas.addEventListener(type, () => { input.pointer = null; });
}
const needsTiltPermission = typeof DeviceOrientationEvent !== "undefined"
  && typeof DeviceOrientationEvent.requestPermission === "function";
if (needsTiltPermission && "ontouchstart" in window) {
  $("tilt").hidden = false; // iOS asks for permission on a tap
  $("tilt").addEventListener("click", () => DeviceOrientationEvent.requestPermission().catch(() => {}));
}

// ---- playback ---------------------------------------------------------------------
const game = {
  pub: null, period: 1000 / 30, k: 10,
  vertex: 0, // where the next edge starts
  edge: null, image: null,
  clipStart: null, lastFrame: -1, running: false,
  trace: null,
};

function newTrace() { return { key: newKey(), steps: [] }; }

function endTrace() {
  const { trace } = game;
  game.trace = newTrace();
  if (!trace || trace.steps.length === 0) return;
  const body = { publication_id: game.pub.publication_id, idempotency_key: trace.key, steps: trace.steps };
  pending.add(body);
  send(body);
}

function startEdge() {
  const control = currentControl();
  const edge = game.pub.vertices[game.vertex][control];
  game.trace.steps.push([game.vertex, control]);
  game.edge = edge;
  const url = stripUrl(edge);
  game.image = url ? strips.get(url)?.image ?? null : null;
  if (!url) stats.placeholders += 1;
  else if (!game.image) { stats.late += 1; requestStrip(url); }
  if (game.image) stats.stripWidth = game.image.width;
  if (game.image && canvas.width !== stats.stripWidth) {
    canvas.width = stats.stripWidth;
    canvas.height = game.image.height;
  }
  loading(url !== null && !game.image);
  game.vertex = edge.dst;
  preloadFrom(edge.dst);
  stats.clips += 1;
  stats.steps += 1;
  stats.score += edge.score;
  showScore();
  for (const el of document.querySelectorAll(".controls span")) {
    el.classList.toggle("on", Number(el.dataset.control) === control);
  }
  if (game.trace.steps.length >= MAX_TRACE_STEPS) endTrace(); // play on, in a new trace
}

function draw(frame) {
  const { k } = game;
  if (game.image) {
    const { width, height } = game.image;
    const [source, x] = game.image.frame(frame);
    ctx.drawImage(source, x, 0, width, height, 0, 0, canvas.width, canvas.height);
    return;
  }
  ctx.fillStyle = game.edge.kind === "sim" ? "#3a6ea5" : "#b8733a";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = "rgba(255,255,255,.7)";
  ctx.fillRect(0, canvas.height * 0.9, (canvas.width * (frame + 1)) / k, canvas.height * 0.1);
}

function tick(now) {
  if (!game.running) return;
  if (stats.ticks.length < FRAME_LOG_MAX) stats.ticks.push(now);
  const clip = game.k * game.period;
  if (game.clipStart === null || now - game.clipStart >= 2 * clip) {
    game.clipStart = now; // first frame, or the tab was throttled: restart the clock here
    startEdge();
  }
  while (now - game.clipStart >= clip) {
    game.clipStart += clip;
    startEdge();
  }
  const frame = Math.min(game.k - 1, Math.floor((now - game.clipStart) / game.period));
  if (frame !== game.lastFrame || stats.frames.length === 0) {
    draw(frame);
    if (stats.frames.length < FRAME_LOG_MAX) stats.frames.push(now);
  }
  game.lastFrame = frame;
  requestAnimationFrame(tick);
}

function play() {
  if (game.running || document.hidden) return;
  game.running = true;
  game.clipStart = null;
  game.lastFrame = -1;
  requestAnimationFrame(tick);
}

function pause() {
  game.running = false;
  endTrace();
}

function restart() {
  endTrace();
  game.vertex = game.pub.start;
  stats.score = 0;
  showScore();
}

function showScore() {
  $("score").textContent = Math.round(stats.score * POINTS_PER_SCORE).toLocaleString("en");
}

// The loading state: shown until the first strips are decoded, and while a clip's strip
// is still on its way (its placeholder plays meanwhile).
function loading(on) {
  $("loading").hidden = !on;
  canvas.setAttribute("aria-busy", String(on));
}

function describe(pub) {
  const parts = [`publication ${pub.number}`, `${pub.n_vertices.toLocaleString("en")} vertices`];
  if (pub.size_frames !== undefined) parts.push(`${pub.size_frames.toLocaleString("en")} frames`);
  if (pub.blend_share !== undefined) parts.push(`${Math.round(pub.blend_share * 100)} % blends`);
  if (pub.mean_blend_error !== undefined) parts.push(`mean blend error ${pub.mean_blend_error.toFixed(3)}`);
  return parts.join(" · ");
}

// ---- start ------------------------------------------------------------------------
async function main() {
  const status = $("status");
  try {
    token = token || (await registerPlayer());
    flushPending();
    const graphs = await api("/api/graphs");
    const wanted = new URLSearchParams(location.search).get("graph");
    const playable = graphs.filter((g) => g.latest_publication !== null);
    const name = wanted || playable[0]?.name;
    if (!name) throw new Error("no published graph yet");
    const select = $("graph");
    for (const g of graphs) select.add(new Option(g.name, g.name, false, g.name === name));
    select.addEventListener("change", () => { location.search = `?graph=${encodeURIComponent(select.value)}`; });
    game.pub = await api(`/api/graphs/${encodeURIComponent(name)}/publication`);
    game.period = 1000 / game.pub.fps;
    game.k = game.pub.frames_per_clip;
    game.vertex = game.pub.start;
    game.trace = newTrace();
    stats.publicationId = game.pub.publication_id;
    $("publication").textContent = describe(game.pub);
    paintPoster(game.pub.vertices[game.vertex][CONTROLS.LEVEL].poster);
    const firstStrips = Promise.all(preloadFrom(game.vertex));
    await Promise.race([firstStrips, new Promise((resolve) => setTimeout(resolve, START_WAIT_MS))]);
    loading(false);
    document.addEventListener("visibilitychange", () => (document.hidden ? pause() : play()));
    addEventListener("pagehide", pause);
    $("restart").addEventListener("click", restart);
    play();
  } catch (error) {
    loading(false);
    status.textContent = `cannot play: ${error.message}`;
  }
}

// A still of the start state while the first strips load (replaced by the first clip).
function paintPoster(url) {
  if (!url) return;
  const image = new Image();
  image.onload = () => { if (stats.clips === 0) ctx.drawImage(image, 0, 0, canvas.width, canvas.height); };
  image.src = url;
}

window.srg = { endTrace, restart, stats };
main();
