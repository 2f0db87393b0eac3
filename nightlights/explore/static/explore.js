// @ts-check
/**
 * nightlights explore: the page.
 *
 * Plain modern JavaScript (ES modules, no libraries, no build step), checked with
 * `tsc --noEmit --allowJs --checkJs`. It talks only to the page's own server (`api/...`).
 *
 * This entry module wires the parts: the map (map.js), the sky (sky.js), the inverse tools
 * (inverse.js: Q/S maps, Dobashi et al. 2023 Eq. 12 sliders, least-flux dimming), edits
 * with undo/redo (edits.js), road compliance and the plan that keeps roads lit (roads.js)
 * and exports (export.js), over the server's API (api.js) and
 * the page's shared elements and state (page.js). Here: moving the observer, which
 * touches them all, the observer's inputs, the layers, the keyboard and the start.
 */

import { api } from "./api.js";
import { afterEdit, applyStroke, bindEdits, undoRedo } from "./edits.js";
import { bindExport } from "./export.js";
import {
  bindInverse,
  dimRequests,
  refreshInfluence,
  showFluxRemoved,
  useRegion,
} from "./inverse.js";
import { bindMap, fitView, loadEmission, loadLights, scheduleMap } from "./map.js";
import { drawLegend, setStatus, showError, showSceneInfo, state, ui } from "./page.js";
import { bindRoads, loadRoads } from "./roads.js";
import {
  bindSky,
  cancelDrawing,
  drawColourbar,
  drawSky,
  panoramaRequests,
  requestPanorama,
} from "./sky.js";

export { bortleClass, luminanceToMagnitude } from "./sky.js";

/** @typedef {import("./api.js").Info} Info */

// --- the observer ---------------------------------------------------------------------------

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

function setObserverFromInputs() {
  const x = Number(ui.obsX.value);
  const y = Number(ui.obsY.value);
  if (ui.obsX.value === "" || ui.obsY.value === "" || !Number.isFinite(x) || !Number.isFinite(y)) {
    setStatus("observer x and y must be numbers [m]", "error");
    return;
  }
  moveObserver(x, y, performance.now(), true);
}

// --- wiring ---------------------------------------------------------------------------------

/** Listen to the observer's inputs, the layers, the keyboard and the original toggle. */
function bindPage() {
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
}

// --- start ----------------------------------------------------------------------------------

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
    ui.showRoads.disabled = !info.has_streets;
    ui.showRoads.checked = info.has_streets;
    ui.roadPlan.disabled = !info.has_streets;
    ui.roadsPanel.hidden = !info.has_streets;
    fitView();
    scheduleMap();
    await Promise.all([
      loadEmission(),
      ui.showLights.checked ? loadLights() : Promise.resolve(),
      loadRoads(),
    ]);
    setStatus("ready: click the map to place an observer");
    document.body.dataset.ready = "true";
  } catch (error) {
    showError(error);
  }
}

bindMap({ moveObserver, applyStroke, onResize: drawSky });
bindSky({ regionClosed: useRegion });
bindInverse();
bindEdits();
bindPage();
bindExport();
bindRoads(afterEdit);
void start();
