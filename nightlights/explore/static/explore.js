// @ts-check
/**
 * nightlights explore: the page.
 *
 * Plain modern JavaScript (an ES module, no libraries), checked with
 * `tsc --noEmit --allowJs --checkJs`. It talks only to the page's own server (`api/...`).
 *
 * Parts: the map (emission raster in its own CRS, pan/zoom, overlays, observer, brush), the
 * sky (equirectangular and fisheye panoramas coloured by sky brightness), the inverse tools
 * (Q/S maps, Dobashi et al. 2023 Eq. 12 sliders, least-flux dimming), edits with undo/redo and
 * exports. Requests that follow the pointer (panorama, dimming) go through a Coalescer: at most
 * one in flight, the latest request replaces any waiting one, and replies made stale by a
 * later change of scene are dropped.
 */

// --- constants ------------------------------------------------------------------------------

/** Luminance of a surface of 0 mag arcsec-2 [cd m-2] (nightlights.sky.brightness, Cinzano 2005). */
const ZERO_POINT_LUMINANCE = 1.08e5;
/** Darker edges of Bortle classes 1-9 [mag arcsec-2] (nightlights.sky.brightness). */
const BORTLE_LOWER_EDGES = [21.99, 21.89, 21.69, 20.49, 19.5, 18.94, 18.38, 18.0];
/** Colour range of the panoramas [mag arcsec-2], as nightlights.sky.render.MAGNITUDE_RANGE. */
const MAGNITUDE_RANGE = /** @type {const} */ ([14.0, 23.0]);
/** matplotlib "magma" at 17 even steps; the sky uses it reversed (bright sky light). */
const MAGMA = [
  "#000004",
  "#0a0822",
  "#1d1147",
  "#36106b",
  "#51127c",
  "#6a1c81",
  "#832681",
  "#9c2e7f",
  "#b73779",
  "#d0416f",
  "#e75263",
  "#f56b5c",
  "#fc8961",
  "#fea772",
  "#fec488",
  "#fde2a3",
  "#fcfdbf",
];
/** Colour of panorama pixels below the terrain (luminance null). */
const GROUND_RGB = Uint8ClampedArray.of(40, 46, 38);
/** Pointer travel [CSS px] below which a press and release is a click, not a drag. */
const CLICK_SLOP = 4;
/** Distance [CSS px] within which the pointer grabs the observer marker or a polygon vertex. */
const GRAB_RADIUS = 10;
/** Slider positions of the Q_a / Q_b range inputs. */
const SLIDER_STEPS = 1000;

const numberFormat = new Intl.NumberFormat("en", { maximumSignificantDigits: 3 });

// --- types ----------------------------------------------------------------------------------

/**
 * @typedef {object} Legend
 * @property {number} vmin
 * @property {number} vmax
 * @property {string} scale "log" or "linear"
 * @property {string} [cmap]
 * @property {string[]} colors CSS colour stops, low to high
 */

/**
 * @typedef {object} Info
 * @property {string} crs
 * @property {[number, number, number, number]} bounds left, bottom, right, top [m]
 * @property {[number, number]} shape rows, cols
 * @property {number} cell_size [m]
 * @property {number} n_lit
 * @property {number} total_flux_lm
 * @property {number} observer_height [m]
 * @property {number[]} elevation [deg]
 * @property {number[]} azimuth [deg]
 * @property {boolean} has_lights
 * @property {boolean} has_dem
 * @property {string | null} tiles
 * @property {number} edit_version
 * @property {boolean} can_undo
 * @property {boolean} can_redo
 * @property {string} export_dir
 * @property {Legend} emission_legend
 */

/**
 * @typedef {object} Panorama PanoramaView.to_dict()
 * @property {number[]} azimuth [deg]
 * @property {number[]} elevation [deg]
 * @property {(number | null)[][]} luminance (n_el, n_az) [cd m-2], null below the terrain
 * @property {number} zenith_luminance [cd m-2]
 * @property {number} zenith_magnitude [mag arcsec-2]
 * @property {number} bortle
 * @property {number} seconds
 * @property {number} x
 * @property {number} y
 * @property {number} observer_altitude [m]
 */

/**
 * @typedef {object} Influence
 * @property {string} kind
 * @property {string} metric
 * @property {number} total
 * @property {number | null} panorama_value
 * @property {string} unit
 * @property {number} seconds
 * @property {number} n_cells
 * @property {string} image data URL
 * @property {Legend} legend
 * @property {number | null} vmin
 * @property {number | null} vmax
 */

/**
 * @typedef {object} Dimming
 * @property {Panorama} panorama dimmed
 * @property {{zenith_magnitude: number} & Partial<Panorama>} before
 * @property {number} flux_removed_lm
 * @property {number} flux_removed_percent
 * @property {number} seconds
 * @property {string} [image] data URL of the dimming fraction map
 * @property {Legend} [legend]
 * @property {string} [method]
 */

/**
 * @typedef {object} EditResult EditView as JSON
 * @property {number} edit_version
 * @property {number} changed_cells
 * @property {number} n_lit
 * @property {number} total_flux
 * @property {boolean} can_undo
 * @property {boolean} can_redo
 */

/** @typedef {[number, number]} Pair */

/**
 * @typedef {object} Timing
 * @property {string} kind "panorama" or "dim"
 * @property {number} ms from the event to the canvas drawn
 * @property {number} queue_ms from the event to the request sent (waiting for one in flight)
 * @property {number} request_ms from the request sent to the reply read
 * @property {number} draw_ms from the reply read to the canvas drawn
 * @property {number} server_ms the engine's own time (seconds field)
 */

/**
 * @typedef {object} Stamp performance.now() times of one update
 * @property {number} start the event
 * @property {number} sent the request sent
 * @property {number} received the reply read
 */

// --- small helpers --------------------------------------------------------------------------

/**
 * The element with this id, checked against its expected class.
 * @template {HTMLElement} T
 * @param {string} id
 * @param {{new (): T}} type
 * @returns {T}
 */
function byId(id, type) {
  const element = document.getElementById(id);
  if (!(element instanceof type)) throw new Error(`page element #${id} is missing`);
  return element;
}

/** @param {number} value */
function fmt(value) {
  if (value === null || value === undefined || !Number.isFinite(value)) return "–";
  const magnitude = Math.abs(value);
  if (magnitude !== 0 && (magnitude < 1e-3 || magnitude >= 1e9)) return value.toExponential(2);
  return numberFormat.format(value);
}

/** Sky brightness [mag arcsec-2] from luminance [cd m-2] (nightlights.sky.brightness). */
export function luminanceToMagnitude(/** @type {number} */ luminance) {
  return -2.5 * Math.log10(luminance / ZERO_POINT_LUMINANCE);
}

/** Bortle class 1-9 of a zenith brightness [mag arcsec-2] (nightlights.sky.brightness). */
export function bortleClass(/** @type {number} */ zenithMagnitude) {
  return 1 + BORTLE_LOWER_EDGES.filter((edge) => zenithMagnitude < edge).length;
}

/** @param {string} hex "#rrggbb" @returns {number[]} */
function hexToRgb(hex) {
  const value = parseInt(hex.slice(1), 16);
  return [(value >> 16) & 255, (value >> 8) & 255, value & 255];
}

/**
 * A 256-entry RGB lookup table interpolated through colour stops.
 * @param {string[]} stops
 * @returns {Uint8ClampedArray}
 */
function colourTable(stops) {
  const rgb = stops.map(hexToRgb);
  const table = new Uint8ClampedArray(256 * 3);
  for (let i = 0; i < 256; i++) {
    const position = (i / 255) * (rgb.length - 1);
    const lower = Math.min(Math.floor(position), rgb.length - 2);
    const weight = position - lower;
    for (let c = 0; c < 3; c++) {
      table[i * 3 + c] = rgb[lower][c] * (1 - weight) + rgb[lower + 1][c] * weight;
    }
  }
  return table;
}

const SKY_TABLE = colourTable(MAGMA);

/**
 * Index into SKY_TABLE of a sky brightness: the bright end (small m) is light.
 * @param {number} magnitude [mag arcsec-2]
 */
function skyColourIndex(magnitude) {
  const [bright, dark] = MAGNITUDE_RANGE;
  const t = (dark - magnitude) / (dark - bright);
  return Math.round(Math.min(1, Math.max(0, t)) * 255);
}

/**
 * Size a canvas's backing store to its CSS box and the device pixel ratio.
 * @param {HTMLCanvasElement} canvas
 * @returns {{width: number, height: number, ratio: number}} CSS size and ratio
 */
function fitCanvas(canvas) {
  const ratio = window.devicePixelRatio || 1;
  const width = Math.max(1, canvas.clientWidth);
  const height = Math.max(1, canvas.clientHeight);
  const pixelWidth = Math.round(width * ratio);
  const pixelHeight = Math.round(height * ratio);
  if (canvas.width !== pixelWidth || canvas.height !== pixelHeight) {
    canvas.width = pixelWidth;
    canvas.height = pixelHeight;
  }
  return { width, height, ratio };
}

/** @param {HTMLCanvasElement} canvas */
function context2d(canvas) {
  const ctx = canvas.getContext("2d");
  if (!ctx) throw new Error("no 2D canvas context");
  return ctx;
}

/**
 * Load an image (URL or data URL), resolved once decoded.
 * @param {string} src
 * @returns {Promise<HTMLImageElement>}
 */
function loadImage(src) {
  return new Promise((resolve, reject) => {
    const image = new Image();
    image.onload = () => resolve(image);
    image.onerror = () => reject(new ApiError(`could not load the image ${src.slice(0, 60)}`, 0));
    image.src = src;
  });
}

/**
 * Fill a legend bar and its end labels.
 * @param {HTMLCanvasElement} bar
 * @param {Legend} legend
 * @param {HTMLElement} low
 * @param {HTMLElement} high
 */
function drawLegend(bar, legend, low, high) {
  const ctx = context2d(bar);
  const gradient = ctx.createLinearGradient(0, 0, bar.width, 0);
  const colours = legend.colors && legend.colors.length ? legend.colors : MAGMA;
  colours.forEach((colour, i) =>
    gradient.addColorStop(i / Math.max(1, colours.length - 1), colour),
  );
  ctx.fillStyle = gradient;
  ctx.fillRect(0, 0, bar.width, bar.height);
  low.textContent = fmt(legend.vmin);
  high.textContent = fmt(legend.vmax);
}

// --- talking to the server ------------------------------------------------------------------

class ApiError extends Error {
  /** @param {string} message @param {number} status */
  constructor(message, status) {
    super(message);
    this.status = status;
  }
}

/**
 * Call the API: GET without a body, POST with a JSON body. Errors become ApiError with the
 * server's one-line message.
 * @param {string} path e.g. "api/info"
 * @param {object} [body]
 * @returns {Promise<any>}
 */
async function api(path, body) {
  /** @type {RequestInit} */
  const init =
    body === undefined
      ? {}
      : {
          method: "POST",
          headers: { "Content-Type": "application/json" },
          body: JSON.stringify(body),
        };
  let response;
  try {
    response = await fetch(path, init);
  } catch (error) {
    throw new ApiError(`the server did not answer (${String(error)})`, 0);
  }
  const text = await response.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = null;
  }
  if (!response.ok) {
    const message = data && typeof data.error === "string" ? data.error : `HTTP ${response.status}`;
    throw new ApiError(message, response.status);
  }
  return data;
}

/**
 * At most one request in flight; a new request replaces the waiting one (coalescing); a
 * reply is applied only if no invalidate() happened since its request was made.
 * @template Req, Res
 */
class Coalescer {
  /**
   * @param {(request: Req) => Promise<Res>} send
   * @param {(request: Req, reply: Res, stamp: Stamp) => void} apply
   * @param {(error: unknown) => void} fail
   */
  constructor(send, apply, fail) {
    this.send = send;
    this.apply = apply;
    this.fail = fail;
    this.generation = 0;
    this.busy = false;
    /** @type {{request: Req, start: number, generation: number} | null} */
    this.waiting = null;
  }

  /** Queue a request; `start` is the performance.now() of the event that caused it. */
  submit(/** @type {Req} */ request, start = performance.now()) {
    this.waiting = { request, start, generation: this.generation };
    void this.pump();
  }

  /** Drop the waiting request and make the replies of requests in flight stale. */
  invalidate() {
    this.generation += 1;
    this.waiting = null;
  }

  async pump() {
    if (this.busy || this.waiting === null) return;
    const job = this.waiting;
    this.waiting = null;
    this.busy = true;
    try {
      const sent = performance.now();
      const reply = await this.send(job.request);
      const stamp = { start: job.start, sent, received: performance.now() };
      if (job.generation === this.generation) this.apply(job.request, reply, stamp);
    } catch (error) {
      if (job.generation === this.generation) this.fail(error);
    } finally {
      this.busy = false;
      void this.pump();
    }
  }
}

// --- page elements --------------------------------------------------------------------------

const ui = {
  sceneInfo: byId("scene-info", HTMLElement),
  status: byId("status", HTMLOutputElement),
  map: byId("map", HTMLCanvasElement),
  cursorCoords: byId("cursor-coords", HTMLElement),
  mapLegendBar: byId("map-legend-bar", HTMLCanvasElement),
  mapLegendMin: byId("map-legend-min", HTMLElement),
  mapLegendMax: byId("map-legend-max", HTMLElement),
  overlayLegend: byId("overlay-legend", HTMLElement),
  overlayLegendTitle: byId("overlay-legend-title", HTMLElement),
  overlayLegendBar: byId("overlay-legend-bar", HTMLCanvasElement),
  overlayLegendMin: byId("overlay-legend-min", HTMLElement),
  overlayLegendMax: byId("overlay-legend-max", HTMLElement),
  zenithMag: byId("zenith-mag", HTMLOutputElement),
  bortle: byId("bortle", HTMLOutputElement),
  latency: byId("latency-ms", HTMLOutputElement),
  skyLabel: byId("sky-label", HTMLElement),
  skyCursor: byId("sky-cursor", HTMLElement),
  panoEq: byId("pano-eq", HTMLCanvasElement),
  panoFish: byId("pano-fish", HTMLCanvasElement),
  colourbar: byId("pano-colorbar", HTMLCanvasElement),
  regionClear: byId("region-clear", HTMLButtonElement),
  obsX: byId("obs-x", HTMLInputElement),
  obsY: byId("obs-y", HTMLInputElement),
  obsHeight: byId("obs-height", HTMLInputElement),
  obsSet: byId("obs-set", HTMLButtonElement),
  showOriginal: byId("show-original", HTMLInputElement),
  showLights: byId("show-lights", HTMLInputElement),
  showTiles: byId("show-tiles", HTMLInputElement),
  overlay: byId("overlay", HTMLSelectElement),
  metric: byId("metric", HTMLSelectElement),
  overlayOpacity: byId("overlay-opacity", HTMLInputElement),
  dimByS: byId("dim-by-s", HTMLInputElement),
  qa: byId("qa", HTMLInputElement),
  qb: byId("qb", HTMLInputElement),
  gamma: byId("gamma", HTMLInputElement),
  qaValue: byId("qa-value", HTMLOutputElement),
  qbValue: byId("qb-value", HTMLOutputElement),
  gammaValue: byId("gamma-value", HTMLOutputElement),
  fluxRemoved: byId("flux-removed", HTMLOutputElement),
  showDimmed: byId("show-dimmed", HTMLInputElement),
  target: byId("target", HTMLSelectElement),
  targetMag: byId("target-mag", HTMLInputElement),
  maxDimming: byId("max-dimming", HTMLInputElement),
  solve: byId("solve", HTMLButtonElement),
  brushRadius: byId("brush-radius", HTMLInputElement),
  paintValue: byId("paint-value", HTMLInputElement),
  scaleFactor: byId("scale-factor", HTMLInputElement),
  undo: byId("undo", HTMLButtonElement),
  redo: byId("redo", HTMLButtonElement),
  exportName: byId("export-name", HTMLInputElement),
  exportOverwrite: byId("export-overwrite", HTMLInputElement),
  exportFiles: byId("export-files", HTMLUListElement),
};

/** @param {string} message @param {"info" | "error" | "busy"} [kind] */
function setStatus(message, kind = "info") {
  ui.status.textContent = message;
  ui.status.className = `status ${kind}`;
}

/** Status line while a panorama is on its way. */
const PANORAMA_BUSY = "computing the panorama…";

/** Clear the status line if it still shows `message`. */
function clearStatus(/** @type {string} */ message) {
  if (ui.status.textContent === message) setStatus("");
}

/** Show an error from a request on the status line. */
function showError(/** @type {unknown} */ error) {
  const message = error instanceof Error ? error.message : String(error);
  setStatus(message, "error");
}

// --- state ----------------------------------------------------------------------------------

/** @type {Timing[]} */
const timings = [];
/** @type {any} */ (window).__exploreTimings = timings;

const state = {
  /** @type {Info | null} */
  info: null,
  /** Map view: centre [m] and metres per CSS pixel. */
  view: { cx: 0, cy: 0, scale: 1, width: 1, height: 1, ratio: 1 },
  /** @type {{x: number, y: number} | null} */
  observer: null,
  /** @type {"current" | "original"} */
  which: "current",
  /** @type {"observer" | "paint" | "erase" | "scale"} */
  tool: "observer",
  /** @type {HTMLImageElement | null} */
  emissionImage: null,
  /** @type {Float64Array | null} x0, y0, x1, y1, ... of the light points */
  lights: null,
  /** Panorama from /api/panorama for the observer. @type {Panorama | null} */
  sky: null,
  /** @type {Dimming | null} */
  dimming: null,
  /** Body of the request that made `dimming` (for the export). @type {object | null} */
  dimmingRequest: null,
  /** Latest influence replies for the observer, by kind. */
  influence: /** @type {{q: Influence | null, s: Influence | null}} */ ({ q: null, s: null }),
  /** Map overlays by kind, with their legends. */
  overlays:
    /** @type {Record<string, {image: HTMLImageElement, legend: Legend, title: string} | null>} */ ({
      q: null,
      s: null,
      dimming: null,
    }),
  /** Closed sky region, first vertex repeated at the end. @type {Pair[] | null} */
  region: null,
  /** Vertices of the region being drawn. @type {Pair[]} */
  drawing: [],
  /** Cursor on the panorama while drawing. @type {Pair | null} */
  drawingCursor: null,
  /** Stroke of the brush being painted [m]. @type {Pair[]} */
  stroke: [],
  /** Brush cursor on the map [CSS px]. @type {Pair | null} */
  brushCursor: null,
  /** Background tiles by URL. @type {Map<string, HTMLImageElement | null>} */
  tiles: new Map(),
};

// --- the map --------------------------------------------------------------------------------

/** Screen position [CSS px] of a point in the raster CRS. @returns {Pair} */
function toScreen(/** @type {number} */ x, /** @type {number} */ y) {
  const v = state.view;
  return [(x - v.cx) / v.scale + v.width / 2, v.height / 2 - (y - v.cy) / v.scale];
}

/** Point in the raster CRS of a screen position [CSS px]. @returns {Pair} */
function toWorld(/** @type {number} */ sx, /** @type {number} */ sy) {
  const v = state.view;
  return [v.cx + (sx - v.width / 2) * v.scale, v.cy - (sy - v.height / 2) * v.scale];
}

let mapFrame = 0;
/** Redraw the map at the next animation frame. */
function scheduleMap() {
  if (!mapFrame) mapFrame = requestAnimationFrame(drawMap);
}

function fitView() {
  if (!state.info) return;
  const [left, bottom, right, top] = state.info.bounds;
  const v = state.view;
  const size = fitCanvas(ui.map);
  v.width = size.width;
  v.height = size.height;
  v.cx = (left + right) / 2;
  v.cy = (bottom + top) / 2;
  v.scale = Math.max((right - left) / v.width, (top - bottom) / v.height) * 1.05;
}

function drawMap() {
  mapFrame = 0;
  const size = fitCanvas(ui.map);
  const v = state.view;
  v.width = size.width;
  v.height = size.height;
  v.ratio = size.ratio;
  const ctx = context2d(ui.map);
  ctx.setTransform(size.ratio, 0, 0, size.ratio, 0, 0);
  ctx.clearRect(0, 0, v.width, v.height);
  ctx.fillStyle = "#07080b";
  ctx.fillRect(0, 0, v.width, v.height);
  const info = state.info;
  if (!info) return;
  if (ui.showTiles.checked) drawTiles(ctx);
  const [left, bottom, right, top] = info.bounds;
  const [x0, y0] = toScreen(left, top);
  const [x1, y1] = toScreen(right, bottom);
  ctx.imageSmoothingEnabled = false;
  const overlay = state.overlays[ui.overlay.value];
  if (state.emissionImage) {
    // under an overlay the emission turns grey, so that the overlay's colours read alone
    if (overlay) ctx.filter = "grayscale(1) brightness(0.55)";
    ctx.drawImage(state.emissionImage, x0, y0, x1 - x0, y1 - y0);
    ctx.filter = "none";
  }
  if (overlay) {
    ctx.globalAlpha = Number(ui.overlayOpacity.value);
    ctx.drawImage(overlay.image, x0, y0, x1 - x0, y1 - y0);
    ctx.globalAlpha = 1;
  }
  ctx.strokeStyle = "#39414f";
  ctx.lineWidth = 1;
  ctx.strokeRect(x0, y0, x1 - x0, y1 - y0);
  if (ui.showLights.checked && state.lights) drawLights(ctx);
  drawStroke(ctx);
  drawObserver(ctx);
  drawScaleBar(ctx);
}

/** @param {CanvasRenderingContext2D} ctx */
function drawLights(ctx) {
  const points = state.lights;
  if (!points) return;
  const v = state.view;
  ctx.fillStyle = "rgb(140 220 255 / 70%)";
  const size = v.scale < (state.info?.cell_size ?? 1) / 8 ? 3 : 2;
  for (let i = 0; i < points.length; i += 2) {
    const sx = (points[i] - v.cx) / v.scale + v.width / 2;
    const sy = v.height / 2 - (points[i + 1] - v.cy) / v.scale;
    if (sx < -4 || sy < -4 || sx > v.width + 4 || sy > v.height + 4) continue;
    ctx.fillRect(sx - size / 2, sy - size / 2, size, size);
  }
}

/** @param {CanvasRenderingContext2D} ctx */
function drawStroke(ctx) {
  if (state.tool === "observer") return;
  const radius = brushRadius() / state.view.scale;
  ctx.fillStyle = "rgb(94 200 242 / 25%)";
  for (const [x, y] of state.stroke) {
    const [sx, sy] = toScreen(x, y);
    ctx.beginPath();
    ctx.arc(sx, sy, radius, 0, 2 * Math.PI);
    ctx.fill();
  }
  if (state.brushCursor) {
    ctx.strokeStyle = "#5ec8f2";
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.arc(state.brushCursor[0], state.brushCursor[1], radius, 0, 2 * Math.PI);
    ctx.stroke();
  }
}

/** @param {CanvasRenderingContext2D} ctx */
function drawObserver(ctx) {
  if (!state.observer) return;
  const [sx, sy] = toScreen(state.observer.x, state.observer.y);
  ctx.lineWidth = 2;
  ctx.strokeStyle = "#0e1117";
  ctx.fillStyle = "#5ec8f2";
  ctx.beginPath();
  ctx.arc(sx, sy, 7, 0, 2 * Math.PI);
  ctx.fill();
  ctx.stroke();
  ctx.strokeStyle = "#ffffff";
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.arc(sx, sy, 9.5, 0, 2 * Math.PI);
  ctx.stroke();
}

/** @param {CanvasRenderingContext2D} ctx */
function drawScaleBar(ctx) {
  const v = state.view;
  const target = 120 * v.scale; // metres in about 120 px
  const power = 10 ** Math.floor(Math.log10(target));
  const nice = [5, 2, 1].map((f) => f * power).find((length) => length <= target) ?? power;
  const pixels = nice / v.scale;
  const x = 12;
  const y = v.height - 16;
  ctx.fillStyle = "rgb(14 17 23 / 78%)";
  ctx.fillRect(x - 6, y - 20, pixels + 12, 30);
  ctx.strokeStyle = "#e3e6ec";
  ctx.lineWidth = 2;
  ctx.beginPath();
  ctx.moveTo(x, y - 5);
  ctx.lineTo(x, y);
  ctx.lineTo(x + pixels, y);
  ctx.lineTo(x + pixels, y - 5);
  ctx.stroke();
  ctx.fillStyle = "#e3e6ec";
  ctx.font = "12px system-ui, sans-serif";
  ctx.fillText(nice >= 1000 ? `${nice / 1000} km` : `${nice} m`, x + 2, y - 8);
}

/**
 * XYZ tiles behind the raster. They are drawn only when the raster is in Web Mercator
 * (EPSG:3857), the tiles' own CRS: the page does not reproject.
 * @param {CanvasRenderingContext2D} ctx
 */
function drawTiles(ctx) {
  const template = state.info?.tiles;
  if (!template) return;
  const v = state.view;
  const half = Math.PI * 6378137; // half the Web Mercator world [m]
  const zoom = Math.max(0, Math.min(19, Math.round(Math.log2((2 * half) / (256 * v.scale)))));
  const count = 2 ** zoom;
  const tileSize = (2 * half) / count;
  const [wx0, wy0] = toWorld(0, 0);
  const [wx1, wy1] = toWorld(v.width, v.height);
  const tx0 = Math.max(0, Math.floor((wx0 + half) / tileSize));
  const tx1 = Math.min(count - 1, Math.floor((wx1 + half) / tileSize));
  const ty0 = Math.max(0, Math.floor((half - wy0) / tileSize));
  const ty1 = Math.min(count - 1, Math.floor((half - wy1) / tileSize));
  if ((tx1 - tx0 + 1) * (ty1 - ty0 + 1) > 64) return;
  ctx.imageSmoothingEnabled = true;
  for (let tx = tx0; tx <= tx1; tx++) {
    for (let ty = ty0; ty <= ty1; ty++) {
      const url = template
        .replace("{z}", String(zoom))
        .replace("{x}", String(tx))
        .replace("{y}", String(ty))
        .replace("{s}", "abc"[(tx + ty) % 3]);
      const image = state.tiles.get(url);
      if (image === undefined) {
        state.tiles.set(url, null);
        if (state.tiles.size > 512) state.tiles.delete(state.tiles.keys().next().value ?? "");
        loadImage(url).then(
          (loaded) => {
            state.tiles.set(url, loaded);
            scheduleMap();
          },
          () => undefined,
        );
        continue;
      }
      if (!image) continue;
      const [sx, sy] = toScreen(tx * tileSize - half, half - ty * tileSize);
      ctx.drawImage(image, sx, sy, tileSize / v.scale, tileSize / v.scale);
    }
  }
}

/** The emission picture asked for last. */
let emissionUrl = "";

async function loadEmission() {
  if (!state.info) return;
  const url = `api/emission.png?which=${state.which}&v=${state.info.edit_version}`;
  emissionUrl = url;
  try {
    const image = await loadImage(url);
    if (url !== emissionUrl) return; // a later edit or toggle asked for another
    state.emissionImage = image;
    scheduleMap();
  } catch (error) {
    showError(error);
  }
}

async function loadLights() {
  if (!state.info?.has_lights || state.lights) return;
  try {
    const collection = await api("api/lights");
    /** @type {number[]} */
    const coordinates = [];
    for (const feature of collection.features ?? []) {
      const geometry = feature.geometry;
      if (geometry && geometry.type === "Point")
        coordinates.push(geometry.coordinates[0], geometry.coordinates[1]);
    }
    state.lights = Float64Array.from(coordinates);
    scheduleMap();
  } catch (error) {
    showError(error);
  }
}

function brushRadius() {
  const value = Number(ui.brushRadius.value);
  return Number.isFinite(value) && value > 0 ? value : (state.info?.cell_size ?? 1);
}

// --- map interaction ------------------------------------------------------------------------

/**
 * @typedef {object} Gesture
 * @property {"pan" | "observer" | "brush"} kind
 * @property {number} pointerId
 * @property {number} startX
 * @property {number} startY
 * @property {number} lastX
 * @property {number} lastY
 * @property {boolean} moved
 * @property {boolean} click a left press in the observer tool: a click places the observer
 */

/** @type {Gesture | null} */
let gesture = null;

/** @param {PointerEvent} event @returns {Pair} */
function mapPoint(event) {
  const box = ui.map.getBoundingClientRect();
  return [event.clientX - box.left, event.clientY - box.top];
}

/** @param {number} sx @param {number} sy */
function onMarker(sx, sy) {
  if (!state.observer) return false;
  const [mx, my] = toScreen(state.observer.x, state.observer.y);
  return Math.hypot(sx - mx, sy - my) <= GRAB_RADIUS;
}

ui.map.addEventListener("pointerdown", (event) => {
  if (!state.info) return;
  const [sx, sy] = mapPoint(event);
  const left = event.button === 0 && !event.shiftKey;
  /** @type {Gesture["kind"]} */
  let kind = "pan";
  if (left && state.tool === "observer" && onMarker(sx, sy)) kind = "observer";
  else if (left && state.tool !== "observer") kind = "brush";
  gesture = {
    kind,
    pointerId: event.pointerId,
    startX: sx,
    startY: sy,
    lastX: sx,
    lastY: sy,
    moved: false,
    click: left && state.tool === "observer" && kind === "pan",
  };
  ui.map.setPointerCapture(event.pointerId);
  // Ctrl+Z and Ctrl+Y after a stroke are the page's, not a text field's
  if (document.activeElement instanceof HTMLElement) document.activeElement.blur();
  if (kind === "brush") {
    state.stroke = [toWorld(sx, sy)];
    scheduleMap();
  }
  event.preventDefault();
});

ui.map.addEventListener("pointermove", (event) => {
  const [sx, sy] = mapPoint(event);
  const [wx, wy] = toWorld(sx, sy);
  ui.cursorCoords.textContent = `x ${wx.toFixed(1)}  y ${wy.toFixed(1)} m  (${state.info?.crs ?? ""})`;
  if (state.tool !== "observer") {
    state.brushCursor = [sx, sy];
    scheduleMap();
  }
  if (!gesture || gesture.pointerId !== event.pointerId) {
    ui.map.classList.toggle("on-marker", state.tool === "observer" && onMarker(sx, sy));
    return;
  }
  if (Math.hypot(sx - gesture.startX, sy - gesture.startY) > CLICK_SLOP) gesture.moved = true;
  if (gesture.kind === "pan" && gesture.moved) {
    ui.map.classList.add("panning");
    state.view.cx -= (sx - gesture.lastX) * state.view.scale;
    state.view.cy += (sy - gesture.lastY) * state.view.scale;
    scheduleMap();
  } else if (gesture.kind === "observer" && gesture.moved) {
    moveObserver(wx, wy, performance.now(), false);
  } else if (gesture.kind === "brush") {
    const last = state.stroke[state.stroke.length - 1];
    if (!last || Math.hypot(wx - last[0], wy - last[1]) >= brushRadius() / 3) {
      state.stroke.push([wx, wy]);
      scheduleMap();
    }
  }
  gesture.lastX = sx;
  gesture.lastY = sy;
});

/** @param {PointerEvent} event */
function endGesture(event) {
  if (!gesture || gesture.pointerId !== event.pointerId) return;
  const finished = gesture;
  gesture = null;
  ui.map.classList.remove("panning");
  if (ui.map.hasPointerCapture(event.pointerId)) ui.map.releasePointerCapture(event.pointerId);
  if (event.type === "pointercancel") {
    state.stroke = [];
    scheduleMap();
    return;
  }
  const [sx, sy] = mapPoint(event);
  if (finished.kind === "pan" && finished.click && !finished.moved) {
    const [wx, wy] = toWorld(sx, sy);
    moveObserver(wx, wy, performance.now(), true);
  } else if (finished.kind === "observer") {
    if (finished.moved) {
      const [wx, wy] = toWorld(sx, sy);
      moveObserver(wx, wy, performance.now(), true);
    }
  } else if (finished.kind === "brush") {
    void applyStroke();
  }
}

ui.map.addEventListener("pointerup", endGesture);
ui.map.addEventListener("pointercancel", endGesture);
ui.map.addEventListener("pointerleave", () => {
  state.brushCursor = null;
  scheduleMap();
});
ui.map.addEventListener("contextmenu", (event) => event.preventDefault());
byId("map-fit", HTMLButtonElement).addEventListener("click", () => {
  fitView();
  scheduleMap();
});

ui.map.addEventListener(
  "wheel",
  (event) => {
    event.preventDefault();
    const [sx, sy] = mapPoint(/** @type {any} */ (event));
    const [wx, wy] = toWorld(sx, sy);
    const unit = event.deltaMode === 1 ? 16 : event.deltaMode === 2 ? 400 : 1;
    const factor = Math.exp(event.deltaY * unit * 0.0015);
    const info = state.info;
    const extent = info
      ? Math.max(info.bounds[2] - info.bounds[0], info.bounds[3] - info.bounds[1])
      : 1;
    const cell = info?.cell_size ?? 1;
    const v = state.view;
    v.scale = Math.min(Math.max(v.scale * factor, cell / 64), (extent * 8) / Math.max(1, v.width));
    // keep the point under the cursor fixed
    v.cx = wx - (sx - v.width / 2) * v.scale;
    v.cy = wy + (sy - v.height / 2) * v.scale;
    scheduleMap();
  },
  { passive: false },
);

new ResizeObserver(() => {
  const firstFit = state.view.width <= 1;
  const size = fitCanvas(ui.map);
  state.view.width = size.width;
  state.view.height = size.height;
  if (firstFit) fitView();
  scheduleMap();
  drawSky();
}).observe(ui.map);

// --- the observer and the panorama ----------------------------------------------------------

function observerHeight() {
  const value = Number(ui.obsHeight.value);
  return Number.isFinite(value) && ui.obsHeight.value !== "" ? value : state.info?.observer_height;
}

/**
 * @typedef {object} PanoramaRequest
 * @property {number} x
 * @property {number} y
 * @property {number | undefined} height
 * @property {"current" | "original"} which
 */

/** @type {Coalescer<PanoramaRequest, Panorama>} */
const panoramaRequests = new Coalescer(
  (request) => {
    const query = new URLSearchParams({
      x: String(request.x),
      y: String(request.y),
      which: request.which,
    });
    if (request.height !== undefined) query.set("height", String(request.height));
    return api(`api/panorama?${query}`);
  },
  (_request, panorama, stamp) => {
    state.sky = panorama;
    drawSky();
    recordTiming("panorama", stamp, panorama.seconds);
    if (panoramaRequests.waiting === null) clearStatus(PANORAMA_BUSY);
  },
  showError,
);

/** @param {string} kind @param {Stamp} stamp @param {number} seconds */
function recordTiming(kind, stamp, seconds) {
  const now = performance.now();
  const ms = now - stamp.start;
  timings.push({
    kind,
    ms,
    queue_ms: stamp.sent - stamp.start,
    request_ms: stamp.received - stamp.sent,
    draw_ms: now - stamp.received,
    server_ms: (seconds ?? NaN) * 1000,
  });
  ui.latency.textContent = ms.toFixed(0);
}

/**
 * Place the observer and ask for its panorama (coalesced).
 * @param {number} x @param {number} y [m, raster CRS]
 * @param {number} start performance.now() of the event
 * @param {boolean} settled the pointer was released: also refresh the inverse maps
 */
function moveObserver(x, y, start, settled) {
  state.observer = { x, y };
  // full precision for scripts and tests (the inputs show decimetres)
  ui.map.dataset.observerX = String(x);
  ui.map.dataset.observerY = String(y);
  ui.obsX.value = x.toFixed(1);
  ui.obsY.value = y.toFixed(1);
  // Dimming and influence belong to the old position.
  dimRequests.invalidate();
  state.dimming = null;
  state.dimmingRequest = null;
  state.influence = { q: null, s: null };
  state.overlays = { q: null, s: null, dimming: null };
  showFluxRemoved(null);
  scheduleMap();
  requestPanorama(start);
  if (settled) void refreshInfluence();
}

function requestPanorama(start = performance.now()) {
  if (!state.observer) return;
  setStatus(PANORAMA_BUSY, "busy");
  panoramaRequests.submit(
    { x: state.observer.x, y: state.observer.y, height: observerHeight(), which: state.which },
    start,
  );
}

/**
 * The angular grid of a panorama: nearest-pixel tables from angles to its pixels.
 * @typedef {object} SkyGrid
 * @property {string} key the grid's shape and extremes (panoramas of a session share it)
 * @property {number} nAz
 * @property {Int32Array} azimuthIndex nearest azimuth index per 0.1 deg of [0, 360)
 * @property {Int32Array} elevationIndex nearest elevation index per 0.1 deg of [0, 90]
 */

/**
 * A panorama ready to draw: its brightness and colour per pixel of its grid.
 * @typedef {object} SkyImage
 * @property {SkyGrid} grid
 * @property {Float32Array} magnitude (n_el * n_az) [mag arcsec-2], NaN below the terrain
 * @property {Uint32Array} colours (n_el * n_az) RGBA packed as the canvas stores it
 */

/** @type {WeakMap<Panorama, SkyImage>} */
const skyImages = new WeakMap();
/** @type {Map<string, SkyGrid>} */
const skyGrids = new Map();
/** Canvas pixel to panorama pixel maps (-1: outside the sky), by canvas, size and grid. */
const pixelMaps = /** @type {Map<string, Int32Array>} */ (new Map());

/**
 * Nearest-index lookup table over [0, span] at 0.1 deg.
 * @param {number[]} angles pixel centres [deg]
 * @param {number} span 360 (azimuth, wraps) or 90 (elevation)
 */
function nearestTable(angles, span) {
  const wrap = span === 360;
  const size = wrap ? 3600 : 901;
  const table = new Int32Array(size);
  const order = angles.map((angle, index) => [angle, index]).sort((a, b) => a[0] - b[0]);
  let k = 0;
  for (let i = 0; i < size; i++) {
    const angle = i / 10;
    while (k + 1 < order.length && order[k + 1][0] <= angle) k++;
    /** @type {number[][]} */
    const candidates = [order[k]];
    if (k + 1 < order.length) candidates.push(order[k + 1]);
    if (wrap) candidates.push(order[0], order[order.length - 1]);
    let best = candidates[0][1];
    let bestDistance = Infinity;
    for (const [value, index] of candidates) {
      let distance = Math.abs(value - angle);
      if (wrap) distance = Math.min(distance, 360 - (distance % 360));
      if (distance < bestDistance) {
        bestDistance = distance;
        best = index;
      }
    }
    table[i] = best;
  }
  return table;
}

/** @param {Panorama} panorama @returns {SkyGrid} */
function skyGrid(panorama) {
  const { azimuth, elevation } = panorama;
  const key = [azimuth.length, azimuth[0], azimuth.at(-1), elevation.length, elevation[0],
    elevation.at(-1)].join(":"); // prettier-ignore
  let grid = skyGrids.get(key);
  if (!grid) {
    grid = {
      key,
      nAz: azimuth.length,
      azimuthIndex: nearestTable(
        azimuth.map((a) => ((a % 360) + 360) % 360),
        360,
      ),
      elevationIndex: nearestTable(elevation, 90),
    };
    skyGrids.set(key, grid);
  }
  return grid;
}

/** @param {Panorama} panorama @returns {SkyImage} */
function skyImage(panorama) {
  const cached = skyImages.get(panorama);
  if (cached) return cached;
  const nEl = panorama.elevation.length;
  const nAz = panorama.azimuth.length;
  const magnitude = new Float32Array(nEl * nAz);
  const rgba = new Uint8ClampedArray(nEl * nAz * 4);
  for (let i = 0; i < nEl; i++) {
    const row = panorama.luminance[i];
    for (let j = 0; j < nAz; j++) {
      const value = row[j];
      const cell = i * nAz + j;
      // null: below the terrain; 0: no artificial light (+inf, drawn darkest)
      const m = value === null || value < 0 ? NaN : luminanceToMagnitude(value);
      magnitude[cell] = m;
      const colour = Number.isNaN(m) ? GROUND_RGB : SKY_TABLE.subarray(skyColourIndex(m) * 3);
      rgba.set([colour[0], colour[1], colour[2], 255], cell * 4);
    }
  }
  const image = {
    grid: skyGrid(panorama),
    magnitude,
    colours: new Uint32Array(rgba.buffer),
  };
  skyImages.set(panorama, image);
  return image;
}

/** Index into a panorama of (azimuth, elevation) [deg] by nearest pixel. */
function skyIndex(
  /** @type {SkyGrid} */ grid,
  /** @type {number} */ azimuth,
  /** @type {number} */ elevation,
) {
  const turn = (((azimuth % 360) + 360) % 360) * 10;
  const a = grid.azimuthIndex[Math.min(3599, Math.max(0, Math.floor(turn)))];
  const e = grid.elevationIndex[Math.min(900, Math.max(0, Math.round(elevation * 10)))];
  return e * grid.nAz + a;
}

/** Brightness [mag arcsec-2] at (azimuth, elevation) [deg] by nearest pixel. */
function skyAt(
  /** @type {SkyImage} */ sky,
  /** @type {number} */ azimuth,
  /** @type {number} */ elevation,
) {
  return sky.magnitude[skyIndex(sky.grid, azimuth, elevation)];
}

/**
 * The panorama pixel each canvas pixel shows (-1 outside the sky), cached.
 * @param {"eq" | "fish"} kind equirectangular or fisheye
 * @param {number} width @param {number} height canvas pixels
 * @param {number} radius fisheye horizon radius [canvas pixels]
 * @param {SkyGrid} grid
 */
function pixelMap(kind, width, height, radius, grid) {
  const key = `${kind}:${width}:${height}:${radius}:${grid.key}`;
  let map = pixelMaps.get(key);
  if (map) return map;
  map = new Int32Array(width * height).fill(-1);
  for (let j = 0; j < height; j++) {
    for (let i = 0; i < width; i++) {
      if (kind === "eq") {
        map[j * width + i] = skyIndex(
          grid,
          ((i + 0.5) / width) * 360,
          90 - ((j + 0.5) / height) * 90,
        );
        continue;
      }
      const dx = i + 0.5 - width / 2;
      const dy = height / 2 - (j + 0.5);
      const r = Math.hypot(dx, dy) / radius;
      if (r > 1) continue;
      const azimuth = (Math.atan2(dx, dy) * 180) / Math.PI; // north up, clockwise
      map[j * width + i] = skyIndex(grid, azimuth, 90 - r * 90);
    }
  }
  if (pixelMaps.size > 8) pixelMaps.delete(pixelMaps.keys().next().value ?? "");
  pixelMaps.set(key, map);
  return map;
}

/**
 * Paint a panorama into a canvas through a pixel map.
 * @param {CanvasRenderingContext2D} ctx @param {SkyImage} sky @param {Int32Array} map
 * @param {number} width @param {number} height
 */
function paintSky(ctx, sky, map, width, height) {
  const data = ctx.createImageData(width, height);
  const out = new Uint32Array(data.data.buffer);
  const colours = sky.colours;
  for (let p = 0; p < map.length; p++) {
    const cell = map[p];
    if (cell >= 0) out[p] = colours[cell];
  }
  ctx.putImageData(data, 0, 0);
}

/** The panorama on show: the dimmed one when a dimming is shown, else the observer's. */
function shownPanorama() {
  if (state.dimming && ui.showDimmed.checked) return state.dimming.panorama;
  return state.sky;
}

/** Equirectangular canvas position [CSS px] of (azimuth, elevation) [deg]. @returns {Pair} */
function eqPoint(/** @type {number} */ azimuth, /** @type {number} */ elevation) {
  const width = ui.panoEq.clientWidth;
  const height = ui.panoEq.clientHeight;
  return [(azimuth / 360) * width, ((90 - elevation) / 90) * height];
}

/** Fisheye position [CSS px] of (azimuth, elevation): north up, azimuth clockwise. @returns {Pair} */
function fishPoint(/** @type {number} */ azimuth, /** @type {number} */ elevation) {
  const size = ui.panoFish.clientWidth;
  const radius = size / 2 - 14;
  const r = ((90 - elevation) / 90) * radius;
  const a = (azimuth * Math.PI) / 180;
  return [size / 2 + r * Math.sin(a), size / 2 - r * Math.cos(a)];
}

function drawSky() {
  const panorama = shownPanorama();
  drawEquirectangular(panorama);
  drawFisheye(panorama);
  if (!panorama) return;
  const zenith = panorama.zenith_magnitude ?? luminanceToMagnitude(panorama.zenith_luminance);
  ui.zenithMag.textContent = Number.isFinite(zenith) ? zenith.toFixed(2) : "–";
  ui.zenithMag.dataset.value = String(zenith);
  ui.bortle.textContent = String(panorama.bortle ?? bortleClass(zenith));
  let label = state.which === "original" ? "original emission (before edits)" : "current emission";
  if (panorama === state.dimming?.panorama) {
    const before = state.dimming.before.zenith_magnitude;
    label = `dimmed: zenith ${before.toFixed(2)} → ${zenith.toFixed(2)} mag arcsec-2`;
    if (state.dimming.method) label += ` (${state.dimming.method})`;
  }
  ui.skyLabel.textContent =
    `${label}; observer at ${panorama.x.toFixed(0)}, ${panorama.y.toFixed(0)} m, ` +
    `eye ${panorama.observer_altitude.toFixed(1)} m a.s.l.`;
}

/** @param {Panorama | null} panorama */
function drawEquirectangular(panorama) {
  const size = fitCanvas(ui.panoEq);
  const ctx = context2d(ui.panoEq);
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = "#000";
  ctx.fillRect(0, 0, ui.panoEq.width, ui.panoEq.height);
  if (panorama) {
    const sky = skyImage(panorama);
    const width = ui.panoEq.width;
    const height = ui.panoEq.height;
    paintSky(ctx, sky, pixelMap("eq", width, height, 0, sky.grid), width, height);
  }
  ctx.setTransform(size.ratio, 0, 0, size.ratio, 0, 0);
  // grid: every 45 deg of azimuth, 30 deg of elevation
  ctx.strokeStyle = "rgb(255 255 255 / 22%)";
  ctx.fillStyle = "rgb(255 255 255 / 70%)";
  ctx.font = "10px system-ui, sans-serif";
  ctx.lineWidth = 1;
  const names = ["N", "NE", "E", "SE", "S", "SW", "W", "NW", "N"];
  for (let k = 0; k <= 8; k++) {
    const [x] = eqPoint(k * 45, 0);
    ctx.beginPath();
    ctx.moveTo(x, 0);
    ctx.lineTo(x, size.height);
    ctx.stroke();
    ctx.textAlign = k === 0 ? "left" : k === 8 ? "right" : "center";
    ctx.fillText(names[k], x + (k === 0 ? 2 : k === 8 ? -2 : 0), size.height - 3);
  }
  ctx.textAlign = "left";
  for (const elevation of [30, 60]) {
    const [, y] = eqPoint(0, elevation);
    ctx.beginPath();
    ctx.moveTo(0, y);
    ctx.lineTo(size.width, y);
    ctx.stroke();
    ctx.fillText(`${elevation}°`, 2, y - 2);
  }
  drawRegion(ctx, eqPoint, false);
}

/** @param {Panorama | null} panorama */
function drawFisheye(panorama) {
  const size = fitCanvas(ui.panoFish);
  const ctx = context2d(ui.panoFish);
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.clearRect(0, 0, ui.panoFish.width, ui.panoFish.height);
  const pixels = ui.panoFish.width;
  const radius = (size.width / 2 - 14) * size.ratio;
  if (panorama) {
    const sky = skyImage(panorama);
    paintSky(ctx, sky, pixelMap("fish", pixels, pixels, radius, sky.grid), pixels, pixels);
  }
  ctx.setTransform(size.ratio, 0, 0, size.ratio, 0, 0);
  const c = size.width / 2;
  const r = size.width / 2 - 14;
  ctx.strokeStyle = "rgb(255 255 255 / 22%)";
  ctx.lineWidth = 1;
  for (const elevation of [0, 30, 60]) {
    ctx.beginPath();
    ctx.arc(c, c, ((90 - elevation) / 90) * r, 0, 2 * Math.PI);
    ctx.stroke();
  }
  ctx.fillStyle = "rgb(255 255 255 / 75%)";
  ctx.font = "11px system-ui, sans-serif";
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillText("N", c, 6);
  ctx.fillText("S", c, size.width - 6);
  ctx.fillText("E", size.width - 6, c);
  ctx.fillText("W", 6, c);
  ctx.textBaseline = "alphabetic";
  ctx.textAlign = "left";
  drawRegion(ctx, fishPoint, true);
}

/**
 * The region (closed) and the polygon being drawn, in a panorama's own projection.
 * @param {CanvasRenderingContext2D} ctx
 * @param {(azimuth: number, elevation: number) => Pair} project
 * @param {boolean} curved edges follow straight lines in (azimuth, elevation)
 */
function drawRegion(ctx, project, curved) {
  /** @param {Pair[]} vertices @param {boolean} close */
  const path = (vertices, close) => {
    ctx.beginPath();
    vertices.forEach(([azimuth, elevation], i) => {
      if (i === 0) {
        ctx.moveTo(...project(azimuth, elevation));
        return;
      }
      const [a0, e0] = vertices[i - 1];
      const steps = curved ? 16 : 1;
      for (let s = 1; s <= steps; s++) {
        const t = s / steps;
        ctx.lineTo(...project(a0 + (azimuth - a0) * t, e0 + (elevation - e0) * t));
      }
    });
    if (close) ctx.closePath();
  };
  if (state.region) {
    path(state.region, true);
    ctx.fillStyle = "rgb(94 200 242 / 18%)";
    ctx.fill();
    ctx.strokeStyle = "#5ec8f2";
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }
  if (state.drawing.length) {
    const vertices =
      state.drawingCursor && !curved ? [...state.drawing, state.drawingCursor] : state.drawing;
    path(vertices, false);
    ctx.strokeStyle = "#ffb454";
    ctx.lineWidth = 1.5;
    ctx.setLineDash([4, 3]);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = "#ffb454";
    state.drawing.forEach(([azimuth, elevation], i) => {
      const [x, y] = project(azimuth, elevation);
      const half = i === 0 && state.drawing.length >= 3 ? 5 : 3;
      ctx.fillRect(x - half, y - half, 2 * half, 2 * half);
    });
  }
}

function drawColourbar() {
  const canvas = ui.colourbar;
  const ratio = window.devicePixelRatio || 1;
  canvas.width = Math.round(44 * ratio);
  canvas.height = Math.round(220 * ratio);
  const ctx = context2d(canvas);
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  const [bright, dark] = MAGNITUDE_RANGE;
  const top = 6;
  const bottom = 214;
  for (let y = top; y < bottom; y++) {
    const magnitude = bright + ((y - top) / (bottom - top)) * (dark - bright);
    const c = skyColourIndex(magnitude) * 3;
    ctx.fillStyle = `rgb(${SKY_TABLE[c]} ${SKY_TABLE[c + 1]} ${SKY_TABLE[c + 2]})`;
    ctx.fillRect(0, y, 14, 1);
  }
  ctx.fillStyle = "#e3e6ec";
  ctx.font = "10px system-ui, sans-serif";
  ctx.textBaseline = "middle";
  for (let magnitude = bright; magnitude <= dark; magnitude += 1) {
    const y = top + ((magnitude - bright) / (dark - bright)) * (bottom - top);
    ctx.fillRect(14, y, 4, 1);
    ctx.fillText(String(magnitude), 20, y);
  }
}

// --- the sky region -------------------------------------------------------------------------

/** @param {MouseEvent} event @returns {Pair} azimuth, elevation [deg] */
function eqAngles(event) {
  const box = ui.panoEq.getBoundingClientRect();
  const azimuth = ((event.clientX - box.left) / box.width) * 360;
  const elevation = 90 - ((event.clientY - box.top) / box.height) * 90;
  return [Math.min(360, Math.max(0, azimuth)), Math.min(90, Math.max(0, elevation))];
}

ui.panoEq.addEventListener("click", (event) => {
  const [azimuth, elevation] = eqAngles(event);
  if (event.detail >= 2) {
    // the second click of a double-click closes (its first click added the vertex)
    if (state.drawing.length >= 3) closeRegion();
    return;
  }
  if (state.drawing.length >= 3) {
    const [fx, fy] = eqPoint(...state.drawing[0]);
    const [x, y] = eqPoint(azimuth, elevation);
    if (Math.hypot(x - fx, y - fy) <= GRAB_RADIUS) {
      closeRegion();
      return;
    }
  }
  state.drawing.push([Number(azimuth.toFixed(2)), Number(elevation.toFixed(2))]);
  drawSky();
});

ui.panoEq.addEventListener("mousemove", (event) => {
  const [azimuth, elevation] = eqAngles(event);
  const panorama = shownPanorama();
  const magnitude = panorama ? skyAt(skyImage(panorama), azimuth, elevation) : NaN;
  ui.skyCursor.textContent =
    `azimuth ${azimuth.toFixed(1)}°, elevation ${elevation.toFixed(1)}°` +
    (panorama
      ? Number.isNaN(magnitude)
        ? ", terrain"
        : `, ${magnitude.toFixed(2)} mag arcsec-2`
      : "");
  if (state.drawing.length) {
    state.drawingCursor = [azimuth, elevation];
    drawEquirectangular(shownPanorama());
  }
});

ui.panoEq.addEventListener("mouseleave", () => {
  state.drawingCursor = null;
  ui.skyCursor.innerHTML = "&nbsp;";
  drawEquirectangular(shownPanorama());
});

function closeRegion() {
  const vertices = state.drawing;
  state.drawing = [];
  state.drawingCursor = null;
  state.region = [...vertices, vertices[0]];
  ui.dimByS.disabled = false;
  ui.dimByS.checked = true;
  ui.target.value = "region";
  drawSky();
  void refreshInfluence("s", true);
}

function cancelDrawing() {
  state.drawing = [];
  state.drawingCursor = null;
  drawSky();
}

ui.regionClear.addEventListener("click", () => {
  state.drawing = [];
  state.region = null;
  state.influence.s = null;
  state.overlays.s = null;
  ui.dimByS.disabled = true;
  /** @type {HTMLInputElement} */ (
    document.querySelector('input[name="dim-by"][value="q"]')
  ).checked = true;
  if (ui.overlay.value === "s") ui.overlay.value = "none";
  setSliderRanges();
  drawSky();
  showOverlayLegend();
  scheduleMap();
});

// --- influence maps and dimming -------------------------------------------------------------

/** @returns {"q" | "s"} */
function dimBy() {
  const checked = /** @type {HTMLInputElement | null} */ (
    document.querySelector('input[name="dim-by"]:checked')
  );
  return checked && checked.value === "s" && state.region ? "s" : "q";
}

/** Request base of the inverse calls: the observer and its height. */
function observerBody() {
  if (!state.observer) throw new ApiError("place an observer on the map first", 0);
  /** @type {{x: number, y: number, height?: number}} */
  const body = { x: state.observer.x, y: state.observer.y };
  const height = observerHeight();
  if (height !== undefined) body.height = height;
  return body;
}

/**
 * Fetch the Q or S map for the observer, make it an overlay and set the slider ranges.
 * @param {"q" | "s" | undefined} [only] fetch this kind only (default: those the page needs)
 * @param {boolean} [show] show it as the overlay
 */
async function refreshInfluence(only, show = false) {
  if (!state.observer) return;
  const kinds = only
    ? [only]
    : /** @type {("q" | "s")[]} */ (["q", "s"]).filter((kind) => needsInfluence(kind));
  for (const kind of kinds) {
    if (kind === "s" && !state.region) continue;
    /** @type {typeof state.observer} */
    const observer = state.observer;
    const { region } = state;
    const metric = ui.metric.value;
    const version = state.info?.edit_version;
    const body = {
      ...observerBody(),
      kind,
      ...(kind === "s" ? { region: state.region } : { metric: ui.metric.value }),
    };
    setStatus(kind === "q" ? "computing the Q map…" : "computing the S map…", "busy");
    try {
      /** @type {Influence} */
      const influence = await api("api/influence", body);
      // out of date (a newer call follows): the observer moved, the scene was edited, the
      // region was redrawn or the metric changed meanwhile
      if (state.observer !== observer || state.info?.edit_version !== version) return;
      if (kind === "s" ? state.region !== region : ui.metric.value !== metric) continue;
      state.influence[kind] = influence;
      const image = await loadImage(influence.image);
      const title =
        kind === "q"
          ? `Q (${influence.metric}) [${influence.unit}]`
          : `S (region) [${influence.unit}]`;
      state.overlays[kind] = { image, legend: influence.legend, title };
      if (show) ui.overlay.value = kind;
      const total = `${fmt(influence.total)} ${influence.unit}`;
      setStatus(`${kind.toUpperCase()} map: ${fmt(influence.n_cells)} lit cells, total ${total}`);
      setSliderRanges();
      showOverlayLegend();
      scheduleMap();
    } catch (error) {
      showError(error);
    }
  }
}

/** @param {"q" | "s"} kind */
function needsInfluence(kind) {
  return ui.overlay.value === kind || dimBy() === kind;
}

function showOverlayLegend() {
  const overlay = state.overlays[ui.overlay.value];
  ui.overlayLegend.hidden = !overlay;
  if (!overlay) return;
  ui.overlayLegendTitle.textContent = overlay.title;
  drawLegend(ui.overlayLegendBar, overlay.legend, ui.overlayLegendMin, ui.overlayLegendMax);
}

/** Slider mapping for Q_a and Q_b over the influence values (log when they span > 100x). */
const sliderRange = { vmin: 0, vmax: 1, log: false };

/** Value of a Q slider position. */
function sliderValue(/** @type {HTMLInputElement} */ input) {
  const t = Number(input.value) / SLIDER_STEPS;
  const { vmin, vmax, log } = sliderRange;
  return log ? vmin * (vmax / vmin) ** t : vmin + (vmax - vmin) * t;
}

function setSliderRanges() {
  const influence = state.influence[dimBy()];
  const ready =
    !!influence &&
    influence.vmin !== null &&
    influence.vmax !== null &&
    influence.vmax > influence.vmin;
  for (const input of [ui.qa, ui.qb, ui.gamma]) input.disabled = !ready;
  if (!influence || !ready) {
    ui.qaValue.textContent = "–";
    ui.qbValue.textContent = "–";
    return;
  }
  const vmin = /** @type {number} */ (influence.vmin);
  const vmax = /** @type {number} */ (influence.vmax);
  sliderRange.vmin = vmin;
  sliderRange.vmax = vmax;
  sliderRange.log = vmin > 0 && vmax / vmin > 100;
  showSliderValues();
}

function showSliderValues() {
  ui.qaValue.textContent = fmt(sliderValue(ui.qa));
  ui.qbValue.textContent = fmt(sliderValue(ui.qb));
  ui.gammaValue.textContent = Number(ui.gamma.value).toFixed(2);
}

/** Body of /api/dim for the sliders as they stand. */
function dimBody(/** @type {boolean} */ withImage) {
  const by = dimBy();
  return {
    ...observerBody(),
    by,
    ...(by === "s" ? { region: state.region } : { metric: ui.metric.value }),
    qa: sliderValue(ui.qa),
    qb: sliderValue(ui.qb),
    gamma: Number(ui.gamma.value),
    image: withImage,
  };
}

/** @type {Coalescer<ReturnType<typeof dimBody>, Dimming>} */
const dimRequests = new Coalescer(
  (body) => api("api/dim", body),
  (body, dimming, stamp) => {
    const { image, ...request } = body;
    showDimming(dimming, request, stamp, "dim");
  },
  showError,
);

/**
 * Show a dimming: the dimmed sky, the flux removed and, when it came with one, its map.
 * @param {Dimming} dimming
 * @param {object} request the body that made it (kept for the export)
 * @param {Stamp} stamp when it was asked for and came
 * @param {string} kind timing kind
 */
function showDimming(dimming, request, stamp, kind) {
  state.dimming = dimming;
  state.dimmingRequest = request;
  showFluxRemoved(dimming);
  drawSky();
  recordTiming(kind, stamp, dimming.seconds);
  if (dimming.image && dimming.legend) {
    const legend = dimming.legend;
    loadImage(dimming.image).then((image) => {
      if (state.dimming !== dimming) return;
      state.overlays.dimming = { image, legend, title: "dimming fraction [1]" };
      ui.overlay.value = "dimming";
      showOverlayLegend();
      scheduleMap();
    }, showError);
  }
}

/** @param {Dimming | null} dimming */
function showFluxRemoved(dimming) {
  ui.fluxRemoved.textContent = dimming
    ? `${fmt(dimming.flux_removed_lm)} lm (${dimming.flux_removed_percent.toFixed(2)} %)`
    : "–";
  ui.fluxRemoved.dataset.value = dimming ? String(dimming.flux_removed_lm) : "";
}

/** Keep Q_a below Q_b: the slider that moved pushes the other one. */
function orderSliders(/** @type {HTMLInputElement} */ moved) {
  const qa = Number(ui.qa.value);
  const qb = Number(ui.qb.value);
  if (qa < qb) return;
  if (moved === ui.qa) {
    if (qa >= SLIDER_STEPS) ui.qa.value = String(SLIDER_STEPS - 1);
    ui.qb.value = String(Number(ui.qa.value) + 1);
  } else {
    if (qb <= 0) ui.qb.value = "1";
    ui.qa.value = String(Number(ui.qb.value) - 1);
  }
}

for (const input of [ui.qa, ui.qb, ui.gamma]) {
  input.addEventListener("input", () => {
    const start = performance.now();
    orderSliders(input);
    showSliderValues();
    try {
      dimRequests.submit(dimBody(false), start);
    } catch (error) {
      showError(error);
    }
  });
  input.addEventListener("change", () => {
    const start = performance.now();
    try {
      dimRequests.submit(dimBody(true), start);
    } catch (error) {
      showError(error);
    }
  });
}

document.querySelectorAll('input[name="dim-by"]').forEach((radio) =>
  radio.addEventListener("change", () => {
    setSliderRanges();
    if (!state.influence[dimBy()]) void refreshInfluence(dimBy());
  }),
);

ui.solve.addEventListener("click", async () => {
  const start = performance.now();
  try {
    const target = ui.target.value;
    if (target === "region" && !state.region)
      throw new ApiError("draw a region on the panorama first", 0);
    const body = {
      ...observerBody(),
      target,
      brightness: Number(ui.targetMag.value),
      max_dimming: Number(ui.maxDimming.value),
      ...(target === "region" ? { region: state.region } : {}),
    };
    dimRequests.invalidate();
    setStatus("solving the least-flux dimming…", "busy");
    ui.solve.disabled = true;
    const observer = state.observer;
    const sent = performance.now();
    /** @type {Dimming} */
    const dimming = await api("api/least-dimming", body);
    if (state.observer !== observer) return;
    ui.showDimmed.checked = true;
    showDimming(dimming, body, { start, sent, received: performance.now() }, "least-dimming");
    setStatus(
      `least-flux dimming (${dimming.method ?? "solved"}): ${fmt(dimming.flux_removed_lm)} lm removed`,
    );
  } catch (error) {
    showError(error);
  } finally {
    ui.solve.disabled = false;
  }
});

ui.showDimmed.addEventListener("change", drawSky);

ui.overlay.addEventListener("change", () => {
  const kind = ui.overlay.value;
  if ((kind === "q" || kind === "s") && !state.overlays[kind]) void refreshInfluence(kind);
  if (kind === "s" && !state.region) setStatus("draw a region on the panorama to get the S map");
  if (kind === "dimming" && !state.overlays.dimming)
    setStatus("release a slider or solve to get the dimming map");
  showOverlayLegend();
  scheduleMap();
});

ui.metric.addEventListener("change", () => {
  state.influence.q = null;
  state.overlays.q = null;
  if (ui.overlay.value === "q" || dimBy() === "q") void refreshInfluence("q");
});

ui.overlayOpacity.addEventListener("input", scheduleMap);

// --- edits ----------------------------------------------------------------------------------

document.querySelectorAll('input[name="tool"]').forEach((radio) =>
  radio.addEventListener("change", () => {
    const checked = /** @type {HTMLInputElement | null} */ (
      document.querySelector('input[name="tool"]:checked')
    );
    state.tool = /** @type {typeof state.tool} */ (checked ? checked.value : "observer");
    state.brushCursor = null;
    scheduleMap();
  }),
);

async function applyStroke() {
  const points = state.stroke;
  if (!points.length) return;
  /** @type {{op: string, points: Pair[], radius: number, value?: number}} */
  const body = { op: state.tool, points, radius: brushRadius() };
  if (state.tool === "paint") body.value = Number(ui.paintValue.value);
  if (state.tool === "scale") body.value = Number(ui.scaleFactor.value);
  setStatus(`${state.tool}…`, "busy");
  try {
    /** @type {EditResult} */
    const result = await api("api/edit", body);
    afterEdit(result, `${state.tool}: ${fmt(result.changed_cells)} cells changed`);
  } catch (error) {
    showError(error);
  } finally {
    state.stroke = [];
    scheduleMap();
  }
}

/** @param {"undo" | "redo"} action */
async function undoRedo(action) {
  try {
    /** @type {EditResult} */
    const result = await api(`api/${action}`, {});
    afterEdit(result, `${action}: ${fmt(result.changed_cells)} cells changed`);
  } catch (error) {
    showError(error);
  }
}

/**
 * The scene changed: new statistics, a new emission picture, a new panorama; the dimming and
 * the influence maps of the old scene go.
 * @param {EditResult} result
 * @param {string} message
 */
function afterEdit(result, message) {
  const info = state.info;
  if (!info) return;
  info.edit_version = result.edit_version;
  info.n_lit = result.n_lit;
  info.total_flux_lm = result.total_flux;
  info.can_undo = result.can_undo;
  info.can_redo = result.can_redo;
  showSceneInfo();
  setStatus(message);
  void loadEmission();
  dimRequests.invalidate();
  panoramaRequests.invalidate();
  state.dimming = null;
  state.dimmingRequest = null;
  state.influence = { q: null, s: null };
  state.overlays = { q: null, s: null, dimming: null };
  showFluxRemoved(null);
  showOverlayLegend();
  requestPanorama();
  void refreshInfluence();
}

ui.undo.addEventListener("click", () => void undoRedo("undo"));
ui.redo.addEventListener("click", () => void undoRedo("redo"));

document.addEventListener("keydown", (event) => {
  const target = event.target;
  const typing =
    target instanceof HTMLInputElement && (target.type === "text" || target.type === "number");
  if (event.key === "Escape" && state.drawing.length) {
    cancelDrawing();
    event.preventDefault();
    return;
  }
  if (typing || !(event.ctrlKey || event.metaKey)) return;
  const key = event.key.toLowerCase();
  if (key === "z" && !event.shiftKey) {
    event.preventDefault();
    void undoRedo("undo");
  } else if (key === "y" || (key === "z" && event.shiftKey)) {
    event.preventDefault();
    void undoRedo("redo");
  }
});

ui.showOriginal.addEventListener("change", () => {
  state.which = ui.showOriginal.checked ? "original" : "current";
  panoramaRequests.invalidate();
  state.dimming = null;
  ui.showDimmed.checked = !ui.showOriginal.checked;
  void loadEmission();
  requestPanorama();
});

// --- observer inputs and layers -------------------------------------------------------------

function setObserverFromInputs() {
  const x = Number(ui.obsX.value);
  const y = Number(ui.obsY.value);
  if (ui.obsX.value === "" || ui.obsY.value === "" || !Number.isFinite(x) || !Number.isFinite(y)) {
    setStatus("observer x and y must be numbers [m]", "error");
    return;
  }
  moveObserver(x, y, performance.now(), true);
}

ui.obsSet.addEventListener("click", setObserverFromInputs);
ui.obsHeight.addEventListener("change", () => {
  if (state.observer) moveObserver(state.observer.x, state.observer.y, performance.now(), true);
});
for (const input of [ui.obsX, ui.obsY, ui.obsHeight]) {
  input.addEventListener("keydown", (event) => {
    if (event.key === "Enter") setObserverFromInputs();
  });
}

ui.showLights.addEventListener("change", () => {
  if (ui.showLights.checked) void loadLights();
  scheduleMap();
});
ui.showTiles.addEventListener("change", scheduleMap);

// --- export ---------------------------------------------------------------------------------

/** Suffix each export needs; the name box holds a stem or a complete name. */
const EXPORT_SUFFIX = /** @type {Record<string, string>} */ ({
  emission: ".tif",
  dimming: ".tif",
  panorama: "",
  session: ".json",
});

/** @param {string} what */
function exportName(what) {
  const name = ui.exportName.value.trim() || "explore";
  const suffix = EXPORT_SUFFIX[what];
  if (suffix && name.toLowerCase().endsWith(suffix)) return name;
  const stem = name.replace(/\.(tif|tiff|json|png|nc)$/i, "");
  return `${stem}-${what}${suffix}`;
}

/** @param {string} what */
async function exportFile(what) {
  /** @type {Record<string, unknown>} */
  let body = { what, name: exportName(what), overwrite: ui.exportOverwrite.checked };
  try {
    if (what === "dimming") {
      if (!state.dimmingRequest)
        throw new ApiError("no dimming to export: move a slider or solve first", 0);
      body = { ...state.dimmingRequest, ...body };
    } else if (what === "panorama") {
      body = { ...observerBody(), which: state.which, ...body };
    } else if (what === "session" && state.observer) {
      body = { ...body, x: state.observer.x, y: state.observer.y };
    }
    setStatus(`writing the ${what}…`, "busy");
    const result = await api("api/export", body);
    ui.exportFiles.replaceChildren(
      ...result.files.map((/** @type {string} */ path) => {
        const item = document.createElement("li");
        item.textContent = path;
        return item;
      }),
    );
    setStatus(`wrote ${result.files.length} file(s)`);
  } catch (error) {
    showError(error);
  }
}

document
  .querySelectorAll("button[data-export]")
  .forEach((button) =>
    button.addEventListener(
      "click",
      () => void exportFile(/** @type {HTMLElement} */ (button).dataset.export ?? ""),
    ),
  );

// --- start ----------------------------------------------------------------------------------

function showSceneInfo() {
  const info = state.info;
  if (!info) return;
  ui.sceneInfo.textContent =
    `${info.crs} · ${info.shape[0]} × ${info.shape[1]} cells of ${fmt(info.cell_size)} m · ` +
    `${fmt(info.n_lit)} lit · ${fmt(info.total_flux_lm)} lm · edit ${info.edit_version}`;
  ui.undo.disabled = !info.can_undo;
  ui.redo.disabled = !info.can_redo;
}

async function start() {
  drawColourbar();
  drawSky();
  try {
    /** @type {Info} */
    const info = await api("api/info");
    state.info = info;
    showSceneInfo();
    drawLegend(ui.mapLegendBar, info.emission_legend, ui.mapLegendMin, ui.mapLegendMax);
    ui.obsHeight.value = String(info.observer_height);
    ui.brushRadius.value = String(Math.round(info.cell_size * 3 * 100) / 100);
    const mercator = /^EPSG:3857$/i.test(info.crs);
    ui.showTiles.disabled = !info.tiles || !mercator;
    ui.showTiles.checked = !!info.tiles && mercator;
    ui.showTiles.parentElement?.setAttribute(
      "title",
      !info.tiles
        ? "start with --tiles URL to show tiles"
        : mercator
          ? ""
          : "tiles are shown only for rasters in EPSG:3857",
    );
    ui.showLights.disabled = !info.has_lights;
    ui.showLights.checked = info.has_lights;
    fitView();
    scheduleMap();
    await Promise.all([loadEmission(), ui.showLights.checked ? loadLights() : Promise.resolve()]);
    setStatus("ready: click the map to place an observer");
    document.body.dataset.ready = "true";
  } catch (error) {
    showError(error);
  }
}

void start();
