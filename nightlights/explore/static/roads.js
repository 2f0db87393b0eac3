// @ts-check
/**
 * nightlights explore: road lighting.
 *
 * The street segments of a session started with --streets, coloured by their compliance with
 * their lighting class at the current emission (as `nightlights streets audit` styles them),
 * the share of the rated length compliant, and the plan that keeps the roads lit: the least
 * energy (or flux) per-light dimming that meets the dimming panel's sky target at the observer
 * (`api/road-plan`), applied as one edit (Undo takes it back).
 */

import { api } from "./api.js";
import { scheduleMap } from "./map.js";
import { fmt, observerBody, setStatus, showError, state, ui } from "./page.js";

/** @typedef {import("./api.js").EditResult} EditResult */

/**
 * @typedef {object} RoadSummary AuditSummary.to_dict()
 * @property {number} segments
 * @property {number} rated
 * @property {number} passed
 * @property {number} rated_length_m
 * @property {number} passed_length_m
 * @property {number | null} share_compliant
 */

/** @param {RoadSummary | undefined} summary */
function share(summary) {
  if (!summary || summary.share_compliant === null) return "–";
  return `${(100 * summary.share_compliant).toFixed(1)} %`;
}

/** Fetch the segments with their status at the current emission (when the layer is shown). */
export async function loadRoads() {
  if (!state.info?.has_streets || !ui.showRoads.checked) return;
  try {
    const collection = await api("api/roads");
    state.roads = collection;
    ui.roadsShare.textContent = share(collection.summary);
    scheduleMap();
  } catch (error) {
    showError(error);
  }
}

/**
 * The plan's figures as lines of text.
 * @param {any} plan the reply of api/road-plan
 * @returns {string[]}
 */
function planLines(plan) {
  const unit = plan.unit;
  if (!plan.feasible) {
    const lines = ["No plan meets both the sky and the roads; binding segments:"];
    for (const row of plan.binding.slice(0, 8))
      lines.push(
        `  segment ${row.segment} (${row.lighting_class}): short by ${fmt(100 * row.slack)} % (${row.criteria})`,
      );
    return lines;
  }
  const lines = [
    `${plan.applied ? "Applied" : "Solved"}: ${plan.lights_dimmed} of ${plan.lights} lights dimmed`,
    `${plan.objective}: ${fmt(plan.cost)} of ${fmt(plan.cost_full)} ${unit} ` +
      `(saved ${fmt(plan.saved)} ${unit})`,
    ...(plan.energy_saved_kwh !== null
      ? [`energy saved: ${fmt(plan.energy_saved_kwh)} kWh a year over ${fmt(plan.hours)} h`]
      : []),
    `cost of safety: ${fmt(plan.cost_of_safety)} ${unit} over the sky-only plan`,
    `compliant: ${share(plan.compliance_before)} before, ${share(plan.compliance_after)} after`,
  ];
  const sky = plan.sky;
  if (sky.goal_cd_m2 !== null)
    lines.push(
      `sky (${plan.target}): ${fmt(sky.before_cd_m2)} → ${fmt(sky.after_cd_m2 ?? sky.predicted_cd_m2)} ` +
        `cd m⁻² (goal ${fmt(sky.goal_cd_m2)})`,
    );
  return lines;
}

/**
 * Listen to the roads layer toggle and the plan button.
 * @param {(result: EditResult, message: string) => void} afterEdit what an edit refreshes
 */
export function bindRoads(afterEdit) {
  ui.showRoads.addEventListener("change", () => {
    if (ui.showRoads.checked) void loadRoads();
    scheduleMap();
  });
  window.addEventListener("nightlights:edited", () => {
    state.roads = null;
    void loadRoads();
  });
  ui.roadPlan.addEventListener("click", async () => {
    try {
      /** @type {Record<string, unknown>} */
      let body = {
        objective: ui.roadObjective.value,
        min_dimming: Number(ui.roadMinDimming.value),
      };
      if (ui.roadHours.value !== "") body.hours = Number(ui.roadHours.value);
      if (ui.roadSky.checked) {
        const target = ui.target.value;
        if (target === "region" && !state.region) throw new Error("draw a region on the panorama first");
        body = {
          ...body,
          ...observerBody(),
          target,
          brightness: Number(ui.targetMag.value),
          ...(target === "region" ? { region: state.region } : {}),
        };
      }
      setStatus("solving the plan that keeps the roads lit…", "busy");
      ui.roadPlan.disabled = true;
      const plan = await api("api/road-plan", body);
      ui.roadPlanResult.textContent = planLines(plan).join("\n");
      if (plan.applied) {
        ui.showRoads.checked = true;
        afterEdit(plan.edit, "road plan applied (Undo takes it back)");
      } else {
        setStatus(plan.feasible ? "road plan solved" : "no plan meets both", "info");
        state.roads = plan.roads;
        ui.roadsShare.textContent = share(plan.roads.summary);
        scheduleMap();
      }
    } catch (error) {
      showError(error);
    } finally {
      ui.roadPlan.disabled = !state.info?.has_streets;
    }
  });
}
