// @ts-check
/**
 * nightlights explore: edits of the emission.
 *
 * Brush strokes (paint, erase, scale) sent to the server, undo and redo; after each, the
 * scene's picture, panorama and influence maps are asked for anew and the dimming of the
 * old scene goes.
 */

import { api } from "./api.js";
import { dimRequests, refreshInfluence, showFluxRemoved, showOverlayLegend } from "./inverse.js";
import { brushRadius, loadEmission, scheduleMap } from "./map.js";
import { fmt, setStatus, showError, showSceneInfo, state, ui } from "./page.js";
import { panoramaRequests, requestPanorama } from "./sky.js";

/** @typedef {import("./api.js").EditResult} EditResult */
/** @typedef {import("./page.js").Pair} Pair */

/** Send the brush stroke just drawn (paint, erase or scale) as one edit. */
export async function applyStroke() {
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
export async function undoRedo(action) {
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
export function afterEdit(result, message) {
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
  window.dispatchEvent(new Event("nightlights:edited"));
}

/** Listen to the edit tools: the tool radios, Undo and Redo. */
export function bindEdits() {
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
  ui.undo.addEventListener("click", () => void undoRedo("undo"));
  ui.redo.addEventListener("click", () => void undoRedo("redo"));
}
