// @ts-check
/**
 * nightlights explore: the sky.
 *
 * The observer's panorama, asked for through a Coalescer, drawn equirectangular and
 * fisheye, coloured by sky brightness (magnitudes, Bortle class); the region drawn on it
 * for the S map.
 */

import { Coalescer, api } from "./api.js";
import {
  GRAB_RADIUS,
  MAGMA,
  clearStatus,
  context2d,
  fitCanvas,
  observerHeight,
  recordTiming,
  setStatus,
  showError,
  state,
  ui,
} from "./page.js";

/** @typedef {import("./api.js").Panorama} Panorama */
/** @typedef {import("./page.js").Pair} Pair */

// --- constants ------------------------------------------------------------------------------

/** Luminance of a surface of 0 mag arcsec-2 [cd m-2] (nightlights.sky.brightness, Cinzano 2005). */
const ZERO_POINT_LUMINANCE = 1.08e5;
/** Darker edges of Bortle classes 1-9 [mag arcsec-2] (nightlights.sky.brightness). */
const BORTLE_LOWER_EDGES = [21.99, 21.89, 21.69, 20.49, 19.5, 18.94, 18.38, 18.0];
/** Colour range of the panoramas [mag arcsec-2], as nightlights.sky.render.MAGNITUDE_RANGE. */
const MAGNITUDE_RANGE = /** @type {const} */ ([14.0, 23.0]);
/** Colour of panorama pixels below the terrain (luminance null). */
const GROUND_RGB = Uint8ClampedArray.of(40, 46, 38);

/** Status line while a panorama is on its way. */
const PANORAMA_BUSY = "computing the panorama…";

// --- brightness and colour ------------------------------------------------------------------

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

// --- the panorama ---------------------------------------------------------------------------

/**
 * @typedef {object} PanoramaRequest
 * @property {number} x
 * @property {number} y
 * @property {number | undefined} height
 * @property {"current" | "original"} which
 */

/** @type {Coalescer<PanoramaRequest, Panorama>} */
export const panoramaRequests = new Coalescer(
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

export function requestPanorama(start = performance.now()) {
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

export function drawSky() {
  const panorama = shownPanorama();
  drawEquirectangular(panorama);
  drawFisheye(panorama);
  if (!panorama) return;
  // A null zenith luminance is a sky that is not finite: no magnitude and no class (the
  // server says why in bortle_reason); a zero luminance (null magnitude) is +inf, class 1.
  const zenith =
    panorama.zenith_magnitude ??
    (panorama.zenith_luminance === null ? NaN : luminanceToMagnitude(panorama.zenith_luminance));
  ui.zenithMag.textContent = Number.isFinite(zenith) ? zenith.toFixed(2) : "–";
  ui.zenithMag.dataset.value = String(zenith);
  const noClass = panorama.bortle === null || Number.isNaN(zenith);
  ui.bortle.textContent = noClass ? "–" : String(panorama.bortle ?? bortleClass(zenith));
  const reason = panorama.bortle_reason ?? "the sky is not finite: no Bortle class";
  ui.bortle.title = noClass ? reason : "";
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

export function drawColourbar() {
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

/**
 * Listen to the equirectangular panorama: vertices of a sky region, the cursor's
 * direction and brightness.
 * @param {object} handlers
 * @param {() => void} handlers.regionClosed after a region was closed (`state.region`)
 */
export function bindSky({ regionClosed }) {
  ui.panoEq.addEventListener("click", (event) => {
    const [azimuth, elevation] = eqAngles(event);
    if (event.detail >= 2) {
      // the second click of a double-click closes (its first click added the vertex)
      if (state.drawing.length >= 3) closeRegion(regionClosed);
      return;
    }
    if (state.drawing.length >= 3) {
      const [fx, fy] = eqPoint(...state.drawing[0]);
      const [x, y] = eqPoint(azimuth, elevation);
      if (Math.hypot(x - fx, y - fy) <= GRAB_RADIUS) {
        closeRegion(regionClosed);
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
}

/** Close the region being drawn. @param {() => void} regionClosed */
function closeRegion(regionClosed) {
  const vertices = state.drawing;
  state.drawing = [];
  state.drawingCursor = null;
  state.region = [...vertices, vertices[0]];
  regionClosed();
}

/** Drop the region being drawn (Escape). */
export function cancelDrawing() {
  state.drawing = [];
  state.drawingCursor = null;
  drawSky();
}
