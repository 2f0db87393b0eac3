// @ts-check
/**
 * nightlights explore: what the page's parts share.
 *
 * The page's elements, the status line, the state of the page (scene, map view, observer,
 * panoramas, overlays, sky region, brush), the latencies it records, the observer as the
 * inverse calls send it, number formatting, canvas sizing and colour legends.
 */

import { ApiError } from "./api.js";

/** @typedef {import("./api.js").Dimming} Dimming */
/** @typedef {import("./api.js").Info} Info */
/** @typedef {import("./api.js").Influence} Influence */
/** @typedef {import("./api.js").Legend} Legend */
/** @typedef {import("./api.js").Panorama} Panorama */
/** @typedef {import("./api.js").Stamp} Stamp */

// --- constants ------------------------------------------------------------------------------

/** matplotlib "magma" at 17 even steps; the sky uses it reversed (bright sky light). */
export const MAGMA = [
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
/** Distance [CSS px] within which the pointer grabs the observer marker or a polygon vertex. */
export const GRAB_RADIUS = 10;

const numberFormat = new Intl.NumberFormat("en", { maximumSignificantDigits: 3 });

// --- types ----------------------------------------------------------------------------------

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

// --- small helpers --------------------------------------------------------------------------

/**
 * The element with this id, checked against its expected class.
 * @template {HTMLElement} T
 * @param {string} id
 * @param {{new (): T}} type
 * @returns {T}
 */
export function byId(id, type) {
  const element = document.getElementById(id);
  if (!(element instanceof type)) throw new Error(`page element #${id} is missing`);
  return element;
}

/** @param {number} value */
export function fmt(value) {
  if (value === null || value === undefined || !Number.isFinite(value)) return "–";
  const magnitude = Math.abs(value);
  if (magnitude !== 0 && (magnitude < 1e-3 || magnitude >= 1e9)) return value.toExponential(2);
  return numberFormat.format(value);
}

/**
 * Size a canvas's backing store to its CSS box and the device pixel ratio.
 * @param {HTMLCanvasElement} canvas
 * @returns {{width: number, height: number, ratio: number}} CSS size and ratio
 */
export function fitCanvas(canvas) {
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
export function context2d(canvas) {
  const ctx = canvas.getContext("2d");
  if (!ctx) throw new Error("no 2D canvas context");
  return ctx;
}

/**
 * Fill a legend bar and its end labels.
 * @param {HTMLCanvasElement} bar
 * @param {Legend} legend
 * @param {HTMLElement} low
 * @param {HTMLElement} high
 */
export function drawLegend(bar, legend, low, high) {
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

// --- page elements --------------------------------------------------------------------------

export const ui = {
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
  showRoads: byId("show-roads", HTMLInputElement),
  roadPopup: byId("road-popup", HTMLElement),
  roadsPanel: byId("roads-panel", HTMLDetailsElement),
  roadsShare: byId("roads-share", HTMLOutputElement),
  roadObjective: byId("road-objective", HTMLSelectElement),
  roadMinDimming: byId("road-min-dimming", HTMLInputElement),
  roadHours: byId("road-hours", HTMLInputElement),
  roadSky: byId("road-sky", HTMLInputElement),
  roadPlan: byId("road-plan", HTMLButtonElement),
  roadPlanResult: byId("road-plan-result", HTMLElement),
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
export function setStatus(message, kind = "info") {
  ui.status.textContent = message;
  ui.status.className = `status ${kind}`;
}

/** Clear the status line if it still shows `message`. */
export function clearStatus(/** @type {string} */ message) {
  if (ui.status.textContent === message) setStatus("");
}

/** Show an error from a request on the status line. */
export function showError(/** @type {unknown} */ error) {
  const message = error instanceof Error ? error.message : String(error);
  setStatus(message, "error");
}

// --- state ----------------------------------------------------------------------------------

/** @type {Timing[]} */
const timings = [];
/** @type {any} */ (window).__exploreTimings = timings;

export const state = {
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
  /** Street segments with their compliance (GeoJSON from api/roads). @type {any} */
  roads: null,
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

/** @param {string} kind @param {Stamp} stamp @param {number} seconds */
export function recordTiming(kind, stamp, seconds) {
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

/** The observer's height [m]: the box's, else the scene's default. */
export function observerHeight() {
  const value = Number(ui.obsHeight.value);
  return Number.isFinite(value) && ui.obsHeight.value !== "" ? value : state.info?.observer_height;
}

/** Request base of the inverse calls: the observer and its height. */
export function observerBody() {
  if (!state.observer) throw new ApiError("place an observer on the map first", 0);
  /** @type {{x: number, y: number, height?: number}} */
  const body = { x: state.observer.x, y: state.observer.y };
  const height = observerHeight();
  if (height !== undefined) body.height = height;
  return body;
}

/** The scene's numbers in the top bar; Undo and Redo as the server allows them. */
export function showSceneInfo() {
  const info = state.info;
  if (!info) return;
  ui.sceneInfo.textContent =
    `${info.crs} · ${info.shape[0]} × ${info.shape[1]} cells of ${fmt(info.cell_size)} m · ` +
    `${fmt(info.n_lit)} lit · ${fmt(info.total_flux_lm)} lm · edit ${info.edit_version}`;
  ui.undo.disabled = !info.can_undo;
  ui.redo.disabled = !info.can_redo;
}
