// @ts-check
/**
 * nightlights explore: the inverse tools (Dobashi et al. 2023, Sec. 4).
 *
 * The Q map (light-pollution level caused by each cell) and the S map (each cell's share
 * of the glow in the sky region) as overlays; dimming by Q or S with the Q_a / Q_b / gamma
 * sliders of Eq. 12, coalesced while a slider moves; the least-flux dimming that meets a
 * brightness target.
 */

import { ApiError, Coalescer, api, loadImage } from "./api.js";
import { scheduleMap } from "./map.js";
import {
  drawLegend,
  fmt,
  observerBody,
  recordTiming,
  setStatus,
  showError,
  state,
  ui,
} from "./page.js";
import { drawSky } from "./sky.js";

/** @typedef {import("./api.js").Dimming} Dimming */
/** @typedef {import("./api.js").Influence} Influence */
/** @typedef {import("./api.js").Stamp} Stamp */

/** Slider positions of the Q_a / Q_b range inputs. */
const SLIDER_STEPS = 1000;

// --- influence maps -------------------------------------------------------------------------

/** @returns {"q" | "s"} */
function dimBy() {
  const checked = /** @type {HTMLInputElement | null} */ (
    document.querySelector('input[name="dim-by"]:checked')
  );
  return checked && checked.value === "s" && state.region ? "s" : "q";
}

/**
 * Fetch the Q or S map for the observer, make it an overlay and set the slider ranges.
 * @param {"q" | "s" | undefined} [only] fetch this kind only (default: those the page needs)
 * @param {boolean} [show] show it as the overlay
 */
export async function refreshInfluence(only, show = false) {
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

/** The legend of the overlay on show; hidden without one. */
export function showOverlayLegend() {
  const overlay = state.overlays[ui.overlay.value];
  ui.overlayLegend.hidden = !overlay;
  if (!overlay) return;
  ui.overlayLegendTitle.textContent = overlay.title;
  drawLegend(ui.overlayLegendBar, overlay.legend, ui.overlayLegendMin, ui.overlayLegendMax);
}

/** A region was closed on the panorama: dim by its S map, aim the solver at it. */
export function useRegion() {
  ui.dimByS.disabled = false;
  ui.dimByS.checked = true;
  ui.target.value = "region";
  drawSky();
  void refreshInfluence("s", true);
}

// --- dimming --------------------------------------------------------------------------------

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
export const dimRequests = new Coalescer(
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
export function showFluxRemoved(dimming) {
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

/**
 * Listen to the inverse tools: the Q_a, Q_b and gamma sliders, dim by Q or S, the
 * solver, the overlay, the Q metric, the overlay's opacity and the Clear region button.
 */
export function bindInverse() {
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
}
