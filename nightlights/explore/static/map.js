// @ts-check
/**
 * nightlights explore: the map.
 *
 * The emission raster in its own CRS (metres), panned and zoomed; the Q, S or dimming
 * overlay over it; the street segments by compliance (with a popup), the light points, background tiles (Web Mercator rasters only), the
 * observer marker, the brush and a scale bar; and the pointer gestures on it.
 */

import { api, loadImage } from "./api.js";
import { GRAB_RADIUS, byId, context2d, fitCanvas, showError, state, ui } from "./page.js";

/** @typedef {import("./page.js").Pair} Pair */

/** Pointer travel [CSS px] below which a press and release is a click, not a drag. */
const CLICK_SLOP = 4;
/** Distance [CSS px] within which the pointer picks a street segment for its popup. */
const ROAD_PICK = 6;
/** Colours of the compliance statuses, as nightlights.io.styles.COMPLIANCE_COLOURS. */
const STATUS_COLOURS = /** @type {Record<string, string>} */ ({
  pass: "#1a9641",
  fail: "#d7191c",
  "not rated": "#bdbdbd",
});

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
export function scheduleMap() {
  if (!mapFrame) mapFrame = requestAnimationFrame(drawMap);
}

/** Fit the whole raster into the map. */
export function fitView() {
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
  if (ui.showRoads.checked && state.roads) drawRoads(ctx);
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
function drawRoads(ctx) {
  ctx.lineWidth = 3;
  ctx.lineCap = "round";
  for (const feature of state.roads.features ?? []) {
    const coordinates = feature.geometry?.coordinates ?? [];
    if (coordinates.length < 2) continue;
    ctx.strokeStyle = STATUS_COLOURS[feature.properties.status] ?? STATUS_COLOURS["not rated"];
    ctx.beginPath();
    coordinates.forEach((/** @type {number[]} */ point, /** @type {number} */ i) => {
      const [sx, sy] = toScreen(point[0], point[1]);
      if (i === 0) ctx.moveTo(sx, sy);
      else ctx.lineTo(sx, sy);
    });
    ctx.stroke();
  }
}

/**
 * The segment nearest a screen point within ROAD_PICK, or null.
 * @param {number} sx @param {number} sy [CSS px]
 */
function roadAt(sx, sy) {
  let best = null;
  let bestDistance = ROAD_PICK;
  for (const feature of state.roads?.features ?? []) {
    const points = (feature.geometry?.coordinates ?? []).map(
      (/** @type {number[]} */ p) => toScreen(p[0], p[1]),
    );
    for (let i = 1; i < points.length; i++) {
      const [ax, ay] = points[i - 1];
      const [bx, by] = points[i];
      const dx = bx - ax;
      const dy = by - ay;
      const length2 = dx * dx + dy * dy;
      const t = length2 ? Math.min(1, Math.max(0, ((sx - ax) * dx + (sy - ay) * dy) / length2)) : 0;
      const distance = Math.hypot(sx - (ax + t * dx), sy - (ay + t * dy));
      if (distance <= bestDistance) {
        bestDistance = distance;
        best = feature.properties;
      }
    }
  }
  return best;
}

/** Show the popup of the segment under the pointer (class, status, binding criterion, margin). */
function showRoadPopup(/** @type {number} */ sx, /** @type {number} */ sy) {
  const road = ui.showRoads.checked ? roadAt(sx, sy) : null;
  ui.roadPopup.hidden = !road;
  if (!road) return;
  const margin =
    road.binding_margin === null ? "" : ` (margin ${(100 * road.binding_margin).toFixed(1)} %)`;
  const binding = road.binding ? `binding: ${road.binding}${margin}` : road.reason || "";
  ui.roadPopup.textContent =
    `segment ${road.segment} · ${road.lighting_class ?? "no class"} · ${road.status}` +
    (binding ? ` · ${binding}` : "");
  // beside the pointer, on the side of the map with room for it
  const width = ui.roadPopup.offsetWidth;
  const left = sx + 12 + width > state.view.width ? Math.max(0, sx - 12 - width) : sx + 12;
  ui.roadPopup.style.left = `${left}px`;
  ui.roadPopup.style.top = `${sy + 12}px`;
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

/** Fetch the emission picture of the scene shown (current or original). */
export async function loadEmission() {
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

/** Fetch the light points, once, when the scene has them. */
export async function loadLights() {
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

/** Radius of the brush [m]: the box's, else one cell. */
export function brushRadius() {
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

/**
 * Listen to the map: pointer gestures (place or drag the observer, pan, brush), the
 * wheel, the Fit button and the map's size.
 * @param {object} handlers
 * @param {(x: number, y: number, start: number, settled: boolean) => void} handlers.moveObserver
 *   place the observer at (x, y) [m, raster CRS]; `settled` when the pointer was released
 * @param {() => Promise<void>} handlers.applyStroke send the brush stroke just drawn
 * @param {() => void} handlers.onResize after the map was refitted to a new size
 */
export function bindMap({ moveObserver, applyStroke, onResize }) {
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
    if (state.roads) showRoadPopup(sx, sy);
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
    ui.roadPopup.hidden = true;
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
      v.scale = Math.min(
        Math.max(v.scale * factor, cell / 64),
        (extent * 8) / Math.max(1, v.width),
      );
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
    onResize();
  }).observe(ui.map);
}
