// The curator's edits as the server takes them: significance regions, line constraints and the
// automatically suggested lines accepted or dropped, in source pixels. Each publishes a new image
// version and answers with the image JSON.
//
// And the curator's key, which the server asks of every edit (and of reads of private images):
// kept in sessionStorage, so it lives as long as the tab and no longer, and sent by
// authorizedFetch as `Authorization: Bearer …` with every request the viewer makes. Never in
// localStorage (it would outlive the session), in a URL (it would reach logs and history) or on
// the console.

import { retryingRead } from './retry.js';

// Points per side of a marked rectangle: under a warp a screen rectangle is a curved region of
// the source, so its outline is sent as a polygon, not as the bounding box of its corners.
const OUTLINE_POINTS_PER_SIDE = 8;

// The outline of the screen rectangle spanned by corners a and b, as source pixels inside the
// image, through `toSource` (screen → source or null off the picture); null if too little of the
// rectangle lies on the picture to make a region.
export function outlineInSource(a, b, toSource, image) {
  const [x0, x1] = [Math.min(a[0], b[0]), Math.max(a[0], b[0])];
  const [y0, y1] = [Math.min(a[1], b[1]), Math.max(a[1], b[1])];
  const corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
  const outline = [];
  corners.forEach((p, k) => {
    const q = corners[(k + 1) % 4];
    for (let i = 0; i < OUTLINE_POINTS_PER_SIDE; i++) {
      const s = i / OUTLINE_POINTS_PER_SIDE;
      const point = toSource([p[0] + (q[0] - p[0]) * s, p[1] + (q[1] - p[1]) * s]);
      if (point) outline.push(insideImage(point, image));
    }
  });
  return outline.length >= 3 && polygonArea(outline) > 1 ? outline : null;
}

export function insideImage([x, y], image) {
  return [Math.min(image.width, Math.max(0, x)), Math.min(image.height, Math.max(0, y))];
}

function polygonArea(points) {
  let twice = 0;
  points.forEach(([x, y], k) => {
    const [nx, ny] = points[(k + 1) % points.length];
    twice += x * ny - nx * y;
  });
  return Math.abs(twice) / 2;
}

export async function markImportant(imageId, polygon) {
  return send('PATCH', `/v1/images/${encodeURIComponent(imageId)}/significance`,
              { regions: [{ polygon, weight: 1 }] });
}

// The image's lines: {lines: the curator's, suggested: the automatically detected ones not yet
// accepted or dropped, dismissed: the dropped ones}, each [x0, y0, x1, y1] in source pixels.
export async function fetchLineSet(imageId) {
  // no-cache: the lines change under the same URL with every version.
  const response = await authorizedFetch(`/v1/images/${encodeURIComponent(imageId)}/lines`, { cache: 'no-cache' });
  if (!response.ok) throw new Error(`lines: HTTP ${response.status}`);
  return response.json();
}

export async function fetchLines(imageId) {
  return (await fetchLineSet(imageId)).lines;
}

export async function putLines(imageId, lines) {
  return send('PUT', `/v1/images/${encodeURIComponent(imageId)}/lines`, { lines });
}

// Accepting suggestions makes them curator lines; the server then no longer suggests them.
export async function acceptSuggestions(imageId, accepted) {
  const { lines } = await fetchLineSet(imageId);
  return putLines(imageId, [...lines, ...accepted]);
}

// Dropping a suggestion: the server keeps it among the image's dismissed lines (the curator's
// lines stay as they are) and suggests it no more.
export async function dismissSuggestion(imageId, suggestion) {
  const { lines, dismissed } = await fetchLineSet(imageId);
  return send('PUT', `/v1/images/${encodeURIComponent(imageId)}/lines`, { lines, dismissed: [...dismissed, suggestion] });
}

async function send(method, url, body) {
  const response = await authorizedFetch(url, {
    method,
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  if (response.status === 401 || response.status === 403) {
    throw new Error(refusalMessage({ status: response.status, message: await errorMessage(response) }));
  }
  if (!response.ok) throw new Error(`${method} ${url}: HTTP ${response.status} ${await response.text()}`);
  return response.json();
}

// What the viewer says when the server refuses the key: the same whether the edit that was
// refused or the key's listeners say it first.
export function refusalMessage({ status, message }) {
  return `the server refused the curator key (HTTP ${status}${message ? `: ${message}` : ''}); it is forgotten`;
}

const KEY_ITEM = 'zoomwarp.curatorKey';

// The key of this tab, and who wants to hear of it changing. One instance (curatorKey) serves
// every module, so a key refused by one request is gone for all of them.
class CuratorKey {
  constructor(storage) {
    this.storage = storage;
    this.listeners = [];
  }

  get() {
    return this.storage.getItem(KEY_ITEM);
  }

  set(key) {
    this.storage.setItem(KEY_ITEM, key);
    this.changed({ refused: null });
  }

  // refused: null when the user asked, else {status, message} of the answer that refused the key.
  forget(refused = null) {
    this.storage.removeItem(KEY_ITEM);
    this.changed({ refused });
  }

  // listener({key, refused}) after every change; key is null once forgotten.
  onChange(listener) {
    this.listeners.push(listener);
  }

  changed({ refused }) {
    for (const listener of this.listeners) listener({ key: this.get(), refused });
  }
}

export const curatorKey = new CuratorKey(sessionStorage);

// fetch(), with the tab's key as a bearer token when there is one and the URL is on the viewer's
// own server (tile URLs may name another host, e.g. a CDN, which must never see the key). A 401 or
// 403 to a request that carried the key means the server does not take it (unknown, rotated
// away, or without the role the request needs): the key is forgotten, and the listeners told why.
// Requests without a key change nothing, so a private image refused to a reader does not touch
// the key. A read the server asks to repeat later (503 or 429 with Retry-After: an analysis
// being made on first use) is sent again after the wait it asks for (retry.js).
export async function authorizedFetch(url, init = {}) {
  const method = (init.method ?? 'GET').toUpperCase();
  if (method === 'GET' || method === 'HEAD') return retryingRead(url, () => sendWithKey(url, init));
  return sendWithKey(url, init);
}

async function sendWithKey(url, init) {
  const key = curatorKey.get();
  if (key === null || new URL(url, location.href).origin !== location.origin) return fetch(url, init);
  const response = await fetch(url, { ...init, headers: { ...init.headers, Authorization: `Bearer ${key}` } });
  // Requests in flight together may all be refused; the first one forgets the key.
  if ((response.status === 401 || response.status === 403) && curatorKey.get() === key) {
    curatorKey.forget({ status: response.status, message: await errorMessage(response.clone()) });
  }
  return response;
}

// The message of the server's JSON error ({"error": {"code", "message"}}), or '' if there is none.
async function errorMessage(response) {
  try {
    return (await response.json()).error?.message ?? '';
  } catch {
    return '';
  }
}
