// @ts-check
/**
 * nightlights explore: talking to the page's own server (`api/...`).
 *
 * The shapes of its replies, its one-line errors (ApiError), images (the server's
 * pictures and background tiles) and the Coalescer that requests following the pointer
 * (panorama, dimming) go through: at most one in flight, the latest request replaces any
 * waiting one, and replies made stale by a later change of scene are dropped.
 */

// --- the server's replies -------------------------------------------------------------------

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
 * @property {boolean} has_streets
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
 * @property {number | null} zenith_luminance [cd m-2], null for a sky that is not finite
 * @property {number | null} zenith_magnitude [mag arcsec-2], null for zero or no luminance
 * @property {number | null} bortle null for a sky that is not finite (see bortle_reason)
 * @property {string | null} [bortle_reason] why bortle is null
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

/**
 * @typedef {object} Stamp performance.now() times of one update
 * @property {number} start the event
 * @property {number} sent the request sent
 * @property {number} received the reply read
 */

// --- requests -------------------------------------------------------------------------------

export class ApiError extends Error {
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
export async function api(path, body) {
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
export class Coalescer {
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

/**
 * Load an image (URL or data URL), resolved once decoded.
 * @param {string} src
 * @returns {Promise<HTMLImageElement>}
 */
export function loadImage(src) {
  return new Promise((resolve, reject) => {
    const image = new Image();
    image.onload = () => resolve(image);
    image.onerror = () => reject(new ApiError(`could not load the image ${src.slice(0, 60)}`, 0));
    image.src = src;
  });
}
