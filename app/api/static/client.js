// The srg web client: plays a publication's edge animations back to back.
//
// Timing: one game clock. A clip of k frames starts exactly k frame periods after the
// previous one (clipStart += k * period, never "now"), so clips join without a gap and
// without drift; each requestAnimationFrame draws the frame the clock is on, from the
// clip's frames, all already decoded to ImageBitmaps. The next edge is chosen at the
// clip boundary from the control held at that moment.
//
// Never a flash: a clip that is not decoded when it is due is waited for, holding the
// last frame shown (a small sign in the corner says so), and the clock restarts when it
// is in; the edge is chosen again each animation frame meanwhile, so a control changed
// during the wait counts. What makes waits rare: while an edge plays, the clips of the
// next two steps are fetched, the next step's first, and the next step's decoded (the
// edge due at the boundary is one of them). Decoded frames are big (480 x 360 x 4 bytes
// each), so only the last DECODED_CLIPS clips keep theirs; fetched bytes are small.
//
// Clips: by the media type served, a VP9 clip in an IVF file (parsed here, decoded by
// WebCodecs' VideoDecoder, every frame to an ImageBitmap before the clip is due) or, for
// publications made before, a WebP image strip (k frames side by side, one ImageBitmap).
// A browser that cannot decode them says so.
//
// Publications: the one played is the graph's latest when the page loads, and again at
// each "New game" (a revalidation, 304 while it is still the latest): growth publishes
// new ones while people play, and a game never changes publication half-way. Graphs
// published without animations (for bots) are not offered.
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
const FETCHED_CLIPS = 256; // encoded clips kept (~15 KB each at 480 x 360)
const DECODED_CLIPS = 16; // clips kept decoded (~7 MB each at 480 x 360): a few steps' worth
const RETRY_MS = 1000; // a clip that failed to arrive is asked for again after this
const PENDING_MAX = 20;
const FRAME_LOG_MAX = 200000;
const START_WAIT_MS = 3000; // wait this long at most for the next step's clips before playing
// a phone held either way: narrow in portrait, low in landscape
const PHONE_SCREEN = "(max-width: 600px), (max-height: 500px)";
const SIZE = matchMedia(PHONE_SCREEN).matches ? "phone" : "desktop";
const POINTS_PER_SCORE = 1000; // a clip scores at most ~0.033: shown as up to ~33 points
const VP9_CODEC = "vp09.00.10.08"; // profile 0, 8 bits: what the server encodes

const stats = {
  frames: [], // rAF timestamps (ms) at which a new frame was drawn
  ticks: [], // every rAF timestamp while playing: tells browser stalls from client gaps
  clips: 0,
  unanimated: 0, // clips of edges without an animation (the last frame held meanwhile)
  waits: [], // [from, to] (ms) of each hold for a late clip; to is null while it lasts
  // clips not decoded when due: the last frame was held until they were
  get late() { return this.waits.length; },
  // time spent holding a frame for late clips (the holds that ended)
  get waitedMs() { return this.waits.reduce((ms, [from, to]) => ms + (to === null ? 0 : to - from), 0); },
  lateUnasked: 0, // late clips whose decoding had not begun before they were due
  uploads: [], // {status, trace_id, n_steps} per answered upload
  score: 0,
  steps: 0,
  publicationId: null,
  size: SIZE, // which clips this screen plays
  stripWidth: null, // pixel width of a frame of the clips played
  undecodable: 0, // clips fetched that the browser could not decode
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
// url -> {bytes: Promise<Blob>, decoding: Promise | null, clip: Clip | null}, in least
// recently used order; Clip: {width, height, frame(f) -> [source, x], close()}
const clips = new Map();
const decoded = new Set(); // urls whose clip holds decoded frames, least recently used first

function clipUrl(edge) {
  if (!edge.animation) return null;
  return SIZE === "phone" ? `${edge.animation}/phone?frames=${game.k}` : edge.animation;
}

function undecodable(blob) {
  stats.undecodable += 1;
  $("status").textContent = `this browser cannot decode the animations (${blob.type})`;
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

function decodeBlob(blob) {
  const decode = blob.type.startsWith("image/") ? decodeImageStrip : decodeVideo;
  return decode(blob).catch((error) => { undecodable(blob); throw error; });
}

// The clip's entry, fetching it the first time. A failed fetch is forgotten after
// RETRY_MS, so a clip is asked for again at most that often.
function clipEntry(url) {
  let entry = clips.get(url);
  if (entry) {
    clips.delete(url); // to the most recently used end
  } else {
    entry = { decoding: null, askedAt: null, clip: null };
    entry.bytes = fetch(url).then((r) => (r.ok ? r.blob() : Promise.reject(new Error(r.statusText))));
    entry.bytes.catch(() => setTimeout(() => forget(url, entry), RETRY_MS));
  }
  clips.set(url, entry);
  if (clips.size > FETCHED_CLIPS) {
    const [oldest, old] = clips.entries().next().value;
    forget(oldest, old);
  }
  return entry;
}

function forget(url, entry) {
  if (clips.get(url) !== entry) return;
  clips.delete(url);
  decoded.delete(url);
  dropFrames(entry);
}

function dropFrames(entry) {
  if (entry.clip && entry.clip !== game.image) entry.clip.close(); // never the one playing
  entry.clip = null;
  entry.decoding = null;
  entry.askedAt = null;
}

// The clip ready to play, or null while it is on its way (asking for it if need be).
function readyClip(url) {
  const entry = clipEntry(url);
  if (entry.clip) keepDecoded(url);
  if (!entry.decoding) {
    entry.askedAt = performance.now();
    entry.decoding = entry.bytes.then(decodeBlob).then(
      (clip) => { entry.clip = clip; keepDecoded(url); },
      () => {}, // lost on the way (forgotten, then fetched again) or undecodable (said once)
    );
  }
  return entry.clip;
}

// Decoded frames for the DECODED_CLIPS clips used last; the one playing keeps its own.
function keepDecoded(url) {
  decoded.delete(url);
  decoded.add(url);
  for (const oldest of decoded) {
    if (decoded.size <= DECODED_CLIPS) break;
    const entry = clips.get(oldest);
    if (entry && entry.clip === game.image) continue; // playing
    decoded.delete(oldest);
    if (entry) dropFrames(entry);
  }
}

// The clips of the next two steps from ``vertex``: the next step's decoded, the one
// after fetched; the next step's first, so that they are the first to arrive.
function prefetchFrom(vertex) {
  const next = game.pub.vertices[vertex];
  const nextUrls = next.map(clipUrl).filter(Boolean);
  nextUrls.forEach(readyClip);
  for (const edge of next) {
    for (const after of game.pub.vertices[edge.dst]) {
      const url = clipUrl(after);
      if (url) clipEntry(url);
    }
  }
  return nextUrls;
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
  name: null, pub: null, period: 1000 / 30, k: 10,
  vertex: 0, // where the next edge starts
  edge: null, image: null,
  clipStart: null, lastFrame: -1, running: false,
  waitingSince: null, // when the clip now due was found not ready (null: none is late)
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

// The edge of the control held now, from the vertex the next edge starts at.
function edgeDue() { return game.pub.vertices[game.vertex][currentControl()]; }

// Start the edge of the control held now, if its clip is ready; false while it is not.
function startEdge() {
  const control = currentControl();
  const edge = edgeDue();
  const url = clipUrl(edge);
  const image = url ? readyClip(url) : null;
  if (url && !image) return false;
  game.trace.steps.push([game.vertex, control]);
  game.edge = edge;
  game.image = image;
  if (!url) stats.unanimated += 1; // the last frame stays while its clip's time passes
  if (image) stats.stripWidth = image.width;
  if (image && canvas.width !== image.width) {
    canvas.width = image.width; // clears the canvas: the frame is drawn in this same tick
    canvas.height = image.height;
  }
  game.vertex = edge.dst;
  prefetchFrom(edge.dst);
  stats.clips += 1;
  stats.steps += 1;
  stats.score += edge.score;
  showScore();
  for (const el of document.querySelectorAll(".controls span")) {
    el.classList.toggle("on", Number(el.dataset.control) === control);
  }
  if (game.trace.steps.length >= MAX_TRACE_STEPS) endTrace(); // play on, in a new trace
  return true;
}

// At a clip boundary: the next clip, on time (the clock goes on from the boundary), after
// a wait or a throttled tab (the clock restarts now), or still not ready: then the last
// frame stays on the canvas and this is asked again at the next animation frame.
function nextClip(now) {
  const clip = game.k * game.period;
  if (!startEdge()) {
    if (game.waitingSince === null) {
      game.waitingSince = now;
      if (stats.clips > 0) {
        // asked to decode before this frame began, or only just now by startEdge: a late
        // clip that was is the machine's decoding time, one that was not the client's gap
        if (!(clips.get(clipUrl(edgeDue())).askedAt < now)) stats.lateUnasked += 1;
        if (stats.waits.length < FRAME_LOG_MAX) stats.waits.push([now, null]);
      }
    }
    showWait(stats.clips > 0 ? "late" : "loading");
    return false;
  }
  const onTime = game.waitingSince === null && game.clipStart !== null && now - game.clipStart < 2 * clip;
  const wait = stats.waits.at(-1);
  if (wait && wait[1] === null) wait[1] = now;
  game.waitingSince = null;
  game.clipStart = onTime ? game.clipStart + clip : now;
  game.lastFrame = -1;
  showWait(null);
  return true;
}

function draw(frame) {
  if (!game.image) return; // an edge without animation: the last frame stays
  const { width, height } = game.image;
  const [source, x] = game.image.frame(frame);
  ctx.drawImage(source, x, 0, width, height, 0, 0, canvas.width, canvas.height);
}

function tick(now) {
  if (!game.running) return;
  if (stats.ticks.length < FRAME_LOG_MAX) stats.ticks.push(now);
  const due = game.edge === null || game.waitingSince !== null || now - game.clipStart >= game.k * game.period;
  if (!due || nextClip(now)) {
    const frame = Math.min(game.k - 1, Math.floor((now - game.clipStart) / game.period));
    if (frame !== game.lastFrame) {
      draw(frame);
      if (stats.frames.length < FRAME_LOG_MAX) stats.frames.push(now);
    }
    game.lastFrame = frame;
  }
  requestAnimationFrame(tick);
}

function play() {
  if (game.running || document.hidden) return;
  game.running = true;
  game.clipStart = null; // the next boundary restarts the clock
  game.edge = null;
  requestAnimationFrame(tick);
}

function pause() {
  game.running = false;
  endTrace();
}

// A new game from the start vertex, on the graph's latest publication: growth may have
// published one since (a revalidation of the one played costs a 304). Kept as it is when
// the server cannot be reached.
async function restart() {
  const latest = await api(publicationPath(game.name)).catch(() => game.pub);
  endTrace(); // the game played so far, on the publication it was played on
  if (latest.publication_id !== game.pub.publication_id) usePublication(latest);
  game.vertex = game.pub.start;
  prefetchFrom(game.vertex);
  stats.score = 0;
  showScore();
}

function showScore() {
  $("score").textContent = Math.round(stats.score * POINTS_PER_SCORE).toLocaleString("en");
}

// What the picture waits for: "loading", the first clip ("loading clips..." over the
// poster); "late", a clip due mid-game (the last frame stays, with a small sign in a
// corner: never a word or a colour over the picture); null, nothing.
function showWait(kind) {
  $("loading").hidden = kind !== "loading";
  $("waiting").hidden = kind !== "late";
  canvas.setAttribute("aria-busy", String(kind !== null));
}

function describe(pub) {
  const parts = [`publication ${pub.number}`, `${pub.n_vertices.toLocaleString("en")} vertices`];
  if (pub.size_frames !== undefined) parts.push(`${pub.size_frames.toLocaleString("en")} frames`);
  if (pub.blend_share !== undefined) parts.push(`${Math.round(pub.blend_share * 100)} % blends`);
  if (pub.mean_blend_error !== undefined) parts.push(`mean blend error ${pub.mean_blend_error.toFixed(3)}`);
  return parts.join(" · ");
}

function publicationPath(name) { return `/api/graphs/${encodeURIComponent(name)}/publication`; }

function usePublication(pub) {
  game.pub = pub;
  game.period = 1000 / pub.fps;
  game.k = pub.frames_per_clip;
  stats.publicationId = pub.publication_id;
  $("publication").textContent = describe(pub);
}

// Why a graph cannot be played here, or null: the menu offers only those that can.
function unplayable(graph) {
  if (graph.latest_publication === null) return "it has no publication yet";
  if (!graph.animated) return "it was published without animations, for bots (choose another graph)";
  return null;
}

// ---- start ------------------------------------------------------------------------
async function main() {
  const status = $("status");
  try {
    token = token || (await registerPlayer());
    flushPending();
    const graphs = await api("/api/graphs");
    const playable = graphs.filter((g) => unplayable(g) === null);
    const wanted = new URLSearchParams(location.search).get("graph");
    const name = wanted || playable[0]?.name;
    if (!name) throw new Error("no graph published with animations yet");
    const select = $("graph");
    for (const g of playable) select.add(new Option(g.name, g.name, false, g.name === name));
    select.value = name; // empty when the graph asked for is not offered
    select.addEventListener("change", () => { location.search = `?graph=${encodeURIComponent(select.value)}`; });
    const graph = graphs.find((g) => g.name === name);
    if (!graph) throw new Error(`no graph ${name}`);
    const why = unplayable(graph);
    if (why) throw new Error(`${name}: ${why}`);
    game.name = name;
    usePublication(await api(publicationPath(name)));
    game.vertex = game.pub.start;
    game.trace = newTrace();
    paintPoster(game.pub.vertices[game.vertex][CONTROLS.LEVEL].poster);
    const firstClips = prefetchFrom(game.vertex).map((url) => clips.get(url).decoding);
    await Promise.race([Promise.all(firstClips), new Promise((resolve) => setTimeout(resolve, START_WAIT_MS))]);
    document.addEventListener("visibilitychange", () => (document.hidden ? pause() : play()));
    addEventListener("pagehide", pause);
    $("restart").addEventListener("click", restart);
    play(); // "loading clips..." stays until the first clip plays
  } catch (error) {
    showWait(null);
    status.textContent = `cannot play: ${error.message}`;
  }
}

// A still of the start state while the first clips load (replaced by the first clip).
function paintPoster(url) {
  if (!url) return;
  const image = new Image();
  image.onload = () => { if (stats.clips === 0) ctx.drawImage(image, 0, 0, canvas.width, canvas.height); };
  image.src = url;
}

window.srg = { endTrace, restart, stats };
main();
