// @ts-check
/**
 * nightlights explore: exports.
 *
 * The emission (COG), the dimming fraction (COG), the panorama (PNG and NetCDF) and the
 * session, written by the server into its export folder under the name in the box.
 */

import { ApiError, api } from "./api.js";
import { observerBody, setStatus, showError, state, ui } from "./page.js";

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

/** Listen to the export buttons. */
export function bindExport() {
  document
    .querySelectorAll("button[data-export]")
    .forEach((button) =>
      button.addEventListener(
        "click",
        () => void exportFile(/** @type {HTMLElement} */ (button).dataset.export ?? ""),
      ),
    );
}
