// One warp method's picture of the current view in a rectangle of the canvas. A method with a
// mesh is drawn from its /mesh (texture-mapped tiles, geomorphed from the view drawn before); one
// without (`mesh: false` in /v1/methods: seam carving) from its /viewport image, drawn 1:1. A
// pane keeps at most one request (with its tiles) in flight: view changes arriving meanwhile only
// replace the wanted view, and when the request is done the pane asks for the latest one, so a
// fast drag costs as many requests as the server can answer, not one per mouse event.

import { loadAtlas } from './atlas.js';
import { authorizedFetch } from './curator.js';
import {
  SCREEN_QUAD_TEXCOORDS, interpolatePositions, locate, magnificationAt, parseMesh, planAtlas, positionAt, screenQuad,
  textureCoordinates,
} from './geometry.js';

const ANIMATION_MS = 250;

// Decimals of the view sent to the server: zoom 1e-4 (well under a pixel), centre 1/100 pixel.
export const VIEW_DIGITS = { zoom: 4, cx: 2, cy: 2 };

// Texels per side of a mesh's texture at most: 64 MB, and room for a screen of 2048 pixels
// drawn from a level up to twice as fine.
const MAX_ATLAS = 4096;

// The server accepts screens of 16…4096 pixels (api/view_query.h).
const MIN_SCREEN = 16;
const MAX_SCREEN = 4096;

export class Pane {
  // method: its /v1/methods entry {name, mesh, …}; saliency: a `saliency=` value; fit: a `fit=`
  // value (auto, the server's default: crop what matters least, warp within a budget); image: {id,
  // width, height}; tiles: the viewer's TileCache; counters: {meshRequests, viewportRequests},
  // shared by the viewer's panes; onChange: called when a load ended, with something new to draw
  // or not.
  constructor({ method, saliency, fit = 'auto', image, renderer, tiles, counters, onChange }) {
    Object.assign(this, { method: method.name, hasMesh: method.mesh, saliency, fit, image, renderer, tiles, counters, onChange });
    this.rect = { x: 0, y: 0, width: MIN_SCREEN, height: MIN_SCREEN };  // CSS pixels in the canvas
    this.wanted = null;  // {zoom, cx, cy}
    this.shown = null;   // what is drawn: {request, mesh, plan, texture, drawable, start}
    this.busy = false;
    this.stale = false;  // the image has a new version: fetch again even for the same view
    this.failure = null; // {request, error} of the last failed load, not retried as such
    this.disposed = false;
  }

  // What the side-by-side mode writes under the pane.
  get label() {
    return `${this.method} · ${this.saliency}`;
  }

  show(view) {
    this.wanted = view;
    this.pump();
  }

  // The image changed on the server (an edit): the drawn view is fetched again.
  invalidate() {
    this.stale = true;
    this.pump();
  }

  // Nothing in flight, nothing left to fetch, no animation running: what is drawn is the view.
  idle(now) {
    if (this.busy) return false;
    if (this.failure && sameRequest(this.failure.request, this.currentRequest())) return true;
    return !this.stale && this.shows(this.currentRequest()) && this.progress(now) === 1;
  }

  currentRequest() {
    return this.wanted && {
      ...this.wanted,
      w: clamp(this.rect.width, MIN_SCREEN, MAX_SCREEN),
      h: clamp(this.rect.height, MIN_SCREEN, MAX_SCREEN),
    };
  }

  shows(request) {
    return this.shown !== null && sameRequest(this.shown.request, request);
  }

  pump() {
    const request = this.currentRequest();
    if (this.busy || !request) return;
    if (!this.stale && (this.shows(request) || (this.failure && sameRequest(this.failure.request, request)))) return;
    this.busy = true;
    this.stale = false;
    this.failure = null;
    this.load(request)
      .then((next) => this.install(next), (error) => { this.failure = { request, error }; })
      .finally(() => {
        this.busy = false;
        this.pump();
        this.onChange();
      });
  }

  // What install() takes: the request, a mesh (from the server, or the screen quad of a /viewport
  // image), the atlas plan if any, the texture and the mesh's texture coordinates.
  load(request) {
    return this.hasMesh ? this.loadMesh(request) : this.loadViewport(request);
  }

  async loadMesh(request) {
    this.counters.meshRequests++;
    const response = await authorizedFetch(this.meshUrl(request), { cache: 'no-cache' });  // versions change under the same URL
    if (!response.ok) throw new Error(`mesh: HTTP ${response.status} ${await response.text()}`);
    const mesh = parseMesh(await response.json());
    if (mesh.triangles.length === 0) return { request, mesh, plan: null, texture: null, texcoords: null };
    const plan = planAtlas(mesh, Math.min(MAX_ATLAS, this.renderer.maxTextureSize));
    // Panning within the same tiles reuses the texture drawn now.
    const reuse = sameAtlas(plan, this.shown?.plan);
    const texture = reuse ? this.shown.texture : await loadAtlas(this.renderer, mesh.image, plan, this.tiles);
    return { request, mesh, plan, texture, texcoords: textureCoordinates(mesh, plan) };
  }

  // The server's rendering of the view, exactly w × h, as a texture drawn texel for pixel.
  async loadViewport(request) {
    this.counters.viewportRequests++;
    const response = await authorizedFetch(this.viewUrl('viewport', request), { cache: 'no-cache' });
    if (!response.ok) throw new Error(`viewport: HTTP ${response.status} ${await response.text()}`);
    // As the tiles are decoded (atlas.js): colours as encoded, premultiplied as the renderer blends.
    const bitmap = await createImageBitmap(await response.blob(),
                                           { colorSpaceConversion: 'none', premultiplyAlpha: 'premultiply' });
    const texture = this.renderer.createTexture(bitmap.width, bitmap.height);
    this.renderer.uploadTile(texture, bitmap, 0, 0);
    bitmap.close();
    return { request, mesh: screenQuad(request.w, request.h), plan: null, texture, texcoords: SCREEN_QUAD_TEXCOORDS };
  }

  // /viewport or /mesh of `request` with this pane's method, saliency and fit.
  viewUrl(route, request, extra = {}) {
    const params = new URLSearchParams({
      ...viewParams(request), w: request.w, h: request.h, method: this.method, saliency: this.saliency, fit: this.fit,
      ...extra,
    });
    return `/v1/images/${encodeURIComponent(this.image.id)}/${route}?${params}`;
  }

  // The mesh of `request`, as a geomorph from the drawn view when there is one of the same size
  // and fit (the server frames both ends of a geomorph with the fit asked for, so a view drawn
  // with another fit is no start for it).
  meshUrl(request) {
    const from = this.shown?.request;
    const sameFit = (this.shown?.mesh.view?.fit ?? this.fit) === this.fit;
    if (!from || from.w !== request.w || from.h !== request.h || !sameFit) return this.viewUrl('mesh', request);
    const previous = viewParams(from);
    return this.viewUrl('mesh', request, { from_zoom: previous.zoom, from_cx: previous.cx, from_cy: previous.cy });
  }

  install({ request, mesh, plan, texture, texcoords }) {
    if (this.disposed) {
      if (texture) this.renderer.deleteTexture(texture);  // deleting a deleted texture does nothing
      return;
    }
    const old = this.shown;
    if (old) {
      if (old.drawable) this.renderer.deleteMesh(old.drawable);
      if (old.texture && old.texture !== texture) this.renderer.deleteTexture(old.texture);
    }
    const drawable = texcoords && this.renderer.createMesh(mesh, texcoords);
    this.shown = { request, mesh, plan, texture, drawable, start: null };
  }

  // 0…1 of the geomorph towards the drawn view; the clock starts at its first frame, so a busy
  // main thread does not eat the animation.
  progress(now) {
    if (!this.shown) return 1;
    if (this.shown.start === null) return 0;
    if (!this.shown.mesh.morphs) return 1;
    return Math.min(1, (now - this.shown.start) / ANIMATION_MS);
  }

  draw(now) {
    if (!this.shown?.drawable) return;
    this.shown.start ??= now;
    const { w, h } = this.shown.request;
    this.renderer.draw(this.shown.drawable, this.shown.texture, { x: this.rect.x, y: this.rect.y, width: w, height: h },
                       ease(this.progress(now)));
  }

  // Screen positions of the drawn mesh's vertices at this moment of the animation.
  positions(now) {
    return interpolatePositions(this.shown.mesh, ease(this.progress(now)));
  }

  // Whether the drawn picture maps screen points to source pixels and back: a mesh does, a
  // /viewport image does not (the curator tools and the line overlay need it).
  mapsSource() {
    return Boolean(this.shown?.mesh.source);
  }

  // The source pixel drawn at canvas point p now, or null where the pane shows no picture or
  // cannot say (a /viewport image).
  toSource(p, now) {
    if (!this.mapsSource()) return null;
    const location = locate(this.shown.mesh.triangles, this.positions(now), this.local(p));
    return location && positionAt(location, this.shown.mesh.source);
  }

  // Screen pixels per source pixel at canvas point p; where the picture gives none (no mesh
  // yet, letterbox, a /viewport image), the mean over the pane.
  magnificationAt(p) {
    const local = this.mapsSource() && magnificationAt(this.shown.mesh, this.local(p));
    if (local) return local;
    const view = this.shown?.mesh.view;
    return view ? (view.scale * view.target.width) / this.image.width : this.uniformMagnification();
  }

  // The zoom change that magnifies the picture by `ratio` on the server's geometric zoom curve
  // (warp/core/zoom_curve.cc): the viewing area shrinks geometrically from the whole image at zoom 0
  // to one screen of full-resolution pixels at zoom 1.
  zoomChange(ratio) {
    const range = this.zoomRange();
    return range > 0 ? Math.log(ratio) / range : 0;
  }

  // The magnification of that curve at the wanted zoom: the image's area on the screen at zoom 0
  // (a retargeted image keeps its area), 1:1 at zoom 1, never more.
  uniformMagnification() {
    return Math.min(1, Math.exp(-this.zoomRange() * (1 - this.currentRequest().zoom)));
  }

  // log of the magnification from zoom 0 to zoom 1.
  zoomRange() {
    const { w, h } = this.currentRequest();
    return Math.log(Math.sqrt((this.image.width * this.image.height * w) / h) / w);
  }

  local([x, y]) {
    return [x - this.rect.x, y - this.rect.y];
  }

  contains([x, y]) {
    return x >= this.rect.x && y >= this.rect.y && x < this.rect.x + this.rect.width && y < this.rect.y + this.rect.height;
  }

  dispose() {
    if (this.shown?.drawable) this.renderer.deleteMesh(this.shown.drawable);
    if (this.shown?.texture) this.renderer.deleteTexture(this.shown.texture);
    this.shown = null;
    this.wanted = null;
    this.disposed = true;  // a load still in flight installs nothing
  }
}

// Query values as the server parses them: plain decimals, never exponents.
function viewParams({ zoom, cx, cy }) {
  return { zoom: zoom.toFixed(VIEW_DIGITS.zoom), cx: cx.toFixed(VIEW_DIGITS.cx), cy: cy.toFixed(VIEW_DIGITS.cy) };
}

function sameRequest(a, b) {
  return a !== null && b !== null && a.zoom === b.zoom && a.cx === b.cx && a.cy === b.cy && a.w === b.w && a.h === b.h;
}

function sameAtlas(a, b) {
  return a && b && a.level === b.level && a.x0 === b.x0 && a.y0 === b.y0 && a.x1 === b.x1 && a.y1 === b.y1;
}

function clamp(value, lo, hi) {
  return Math.min(hi, Math.max(lo, Math.round(value)));
}

// Slow in, slow out: the picture starts and settles without a jolt.
function ease(t) {
  return t * t * (3 - 2 * t);
}
