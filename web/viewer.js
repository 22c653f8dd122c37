// The zoomwarp web viewer (served at /): one image full-window, warped by one of the server's
// methods (GET /v1/methods; ICAZ by default) and drawn with WebGL from its Deep Zoom tiles. The
// view is {zoom 0…1, cx, cy in full-resolution pixels}; every change asks the server for the mesh
// of the new view as a geomorph from the drawn one and animates between the two (a method without
// mesh: for its /viewport image). Side by side shows two methods on the same view path: one
// pan/zoom drives both panes. The URL's hash keeps the methods and the view (state.js), so a
// comparison can be shared as a link. Curator tools mark regions important and draw line
// constraints, shown only while the tab holds a curator key (curator.js).
//
// For tests and scripts, window.zoomwarp = {ready, setView, getView, imageId, panes, meshRequests,
// viewportRequests, frames, fit, whenIdle} (web/README.md).

import { TileCache } from './atlas.js';
import {
  authorizedFetch, curatorKey, fetchLines, fetchLineSet, insideImage, markImportant, outlineInSource, putLines,
  refusalMessage,
} from './curator.js';
import { MethodMenu, describeMethod, fetchMethods, secondChoice, validChoices } from './methods.js';
import { SuggestionPanel } from './suggestions.js';
import { Overlay } from './overlay.js';
import { Pane, VIEW_DIGITS } from './pane.js';
import { Renderer } from './renderer.js';
import { onRetryWait } from './retry.js';
import { formatState, parseState, withoutView } from './state.js';

// Zoom per wheel notch; a notch is 100 pixels or 3 lines of deltaY, so a touchpad's many small
// events zoom smoothly by the same amount per distance.
const ZOOM_STEP = 0.05;
const PIXELS_PER_NOTCH = 100;
const LINES_PER_NOTCH = 3;
// A pointer that moved less than this (CSS pixels) made a click, not a rectangle or a segment.
const MIN_SKETCH = 3;
// The hash is written this long after the last change: browsers throttle history updates made at
// the rate of pointer events.
const STATE_DELAY_MS = 300;

class Viewer {
  // catalogue: /v1/methods; choices: the panes' [{method, saliency}] (validChoices); view: the
  // first view's fields, the rest from the whole image.
  constructor({ canvas, overlayCanvas, status, image, catalogue, choices, view }) {
    this.canvas = canvas;
    this.status = status;
    this.image = image;
    this.catalogue = catalogue;
    this.renderer = new Renderer(canvas);
    this.overlay = new Overlay(overlayCanvas);
    this.tiles = new TileCache();
    this.counters = { meshRequests: 0, viewportRequests: 0, frames: 0 };
    this.view = { zoom: 0, cx: image.width / 2, cy: image.height / 2 };
    this.panes = [];
    this.choices = [];
    this.fit = 'auto';           // fit= of every pane's views (the fit menu)
    this.stateTimer = null;
    this.lines = [];
    this.suggested = [];         // automatically detected lines, shown in the line editor
    this.highlight = null;       // the suggestion under the pointer in the panel
    this.suggestions = new SuggestionPanel({
      element: document.getElementById('suggestions'),
      imageId: image.id,
      onEdited: (edited) => this.edited(edited),
      onHighlight: (index) => { this.highlight = index; this.requestFrame(); },
      say: (message) => this.say(message),
    });
    this.tool = 'pan';
    this.pointers = new Map();  // pointerId → [x, y], canvas CSS pixels
    this.gesture = null;        // the pan/pinch or the sketch under way
    this.waiters = [];          // setView() promises waiting for the viewer to be idle
    this.frameRequested = false;
    this.waitNotice = null;      // the status line while a read waits to be repeated
    onRetryWait((wait) => this.waiting(wait));
    let firstFrame;
    this.ready = new Promise((resolve) => { firstFrame = resolve; });
    this.firstFrame = firstFrame;
    this.changeView(view);
    this.setPanes(choices);
    this.listen();
    new ResizeObserver(() => this.layout()).observe(canvas);
    this.reloadLines();
  }

  // --- view -------------------------------------------------------------------------------

  getView() {
    return { ...this.view };
  }

  // The API's setView: the change, and a promise of it drawn.
  setView(view) {
    this.changeView(view);
    return this.whenIdle();
  }

  // Fields left out (or not numbers) stay as they are. Clamped to what the server accepts and
  // rounded as it is sent, so getView() is what is shown.
  changeView(view) {
    const value = (key, hi) => {
      const wanted = Number.isFinite(view[key]) ? view[key] : this.view[key];
      return Number(Math.min(hi, Math.max(0, wanted)).toFixed(VIEW_DIGITS[key]));
    };
    this.view = { zoom: value('zoom', 1), cx: value('cx', this.image.width), cy: value('cy', this.image.height) };
    for (const pane of this.panes) pane.show(this.view);
    this.rememberState();
  }

  // The URL's hash follows the panes and the view, so the address bar always holds a link to
  // what is shown.
  rememberState() {
    clearTimeout(this.stateTimer);
    this.stateTimer = setTimeout(() => {
      const hash = formatState({ panes: this.choices, view: this.view });
      if (location.hash !== hash) history.replaceState(history.state, '', hash);
    }, STATE_DELAY_MS);
  }

  // Resolves with the view once it is fetched and fully drawn (tiles loaded, animation over);
  // rejects if a pane could not load it.
  whenIdle() {
    const idle = new Promise((resolve, reject) => this.waiters.push({ resolve, reject }));
    this.requestFrame();
    return idle;
  }

  settle(now) {
    if (this.waiters.length === 0 || !this.panes.every((pane) => pane.idle(now))) return;
    const failed = this.panes.find((pane) => pane.failure);
    for (const { resolve, reject } of this.waiters.splice(0)) {
      if (failed) reject(failed.failure.error);
      else resolve(this.getView());
    }
  }

  // One pane per choice {method, saliency} (methods.js validChoices): one, or two side by side.
  // A pane whose choice did not change is kept as it is drawn.
  setPanes(choices) {
    const previous = this.panes;
    const kept = new Set();
    this.panes = choices.map((choice, k) => {
      const pane = previous[k];
      if (pane && pane.method === choice.method && pane.saliency === choice.saliency) {
        kept.add(pane);
        return pane;
      }
      return new Pane({
        method: describeMethod(this.catalogue, choice.method),
        saliency: choice.saliency,
        fit: this.fit,
        image: this.image,
        renderer: this.renderer,
        tiles: this.tiles,
        counters: this.counters,
        onChange: () => this.paneChanged(),
      });
    });
    for (const pane of previous) if (!kept.has(pane)) pane.dispose();
    this.choices = choices.map(({ method, saliency }) => ({ method, saliency }));
    this.layout();
    this.rememberState();
  }

  // Equal shares of the width, so that every pane asks for the same screen size (an odd pixel
  // left over stays black) and the panes show the same view path.
  layout() {
    const width = Math.round(this.canvas.clientWidth);
    const height = Math.round(this.canvas.clientHeight);
    const share = Math.floor(width / this.panes.length);
    this.panes.forEach((pane, k) => {
      pane.rect = { x: k * share, y: 0, width: share, height };
      pane.show(this.view);
    });
    this.requestFrame();
  }

  paneChanged() {
    const failed = this.panes.find((pane) => pane.failure);
    if (failed) this.say(failed.failure.error.message);
    else if (this.status.textContent === this.waitNotice) this.say('');
    this.requestFrame();
  }

  // A read the server asked to repeat (retry.js): said until a pane has loaded.
  waiting({ code, seconds }) {
    const why = code === 'analysis_pending' ? "the server is preparing this image's analysis"
              : code ? `the server answered ${code}` : 'the server is busy';
    this.waitNotice = `${why}; trying again in ${seconds} s…`;
    this.say(this.waitNotice);
  }

  // --- drawing ----------------------------------------------------------------------------

  requestFrame() {
    if (this.frameRequested) return;
    this.frameRequested = true;
    requestAnimationFrame((now) => this.frame(now));
  }

  frame(now) {
    this.frameRequested = false;
    const width = this.canvas.clientWidth;
    const height = this.canvas.clientHeight;
    const pixelRatio = window.devicePixelRatio || 1;
    this.renderer.beginFrame(width, height, pixelRatio);
    for (const pane of this.panes) pane.draw(now);
    const suggested = this.tool === 'line' ? this.suggested : [];
    this.overlay.draw({
      width, height, pixelRatio, panes: this.panes, lines: this.lines, suggested, highlight: this.highlight,
      sketch: this.sketch(), now,
    });
    this.counters.frames++;
    if (this.panes.some((pane) => pane.shown)) this.firstFrame();
    if (this.panes.some((pane) => pane.progress(now) < 1)) this.requestFrame();
    this.settle(now);
  }

  // --- input ------------------------------------------------------------------------------

  listen() {
    const c = this.canvas;
    c.addEventListener('wheel', (e) => this.wheel(e), { passive: false });
    c.addEventListener('pointerdown', (e) => this.pointerDown(e));
    c.addEventListener('pointermove', (e) => this.pointerMove(e));
    c.addEventListener('pointerup', (e) => this.pointerUp(e));
    c.addEventListener('pointercancel', (e) => this.pointerUp(e));
  }

  wheel(e) {
    e.preventDefault();
    const perNotch = e.deltaMode === WheelEvent.DOM_DELTA_LINE ? LINES_PER_NOTCH
                   : e.deltaMode === WheelEvent.DOM_DELTA_PAGE ? 1 : PIXELS_PER_NOTCH;
    this.changeView({ zoom: this.view.zoom - (e.deltaY / perNotch) * ZOOM_STEP });
  }

  pointerDown(e) {
    if (e.pointerType === 'mouse' && e.button !== 0) return;
    this.canvas.setPointerCapture(e.pointerId);
    this.pointers.set(e.pointerId, [e.offsetX, e.offsetY]);
    this.gesture = this.tool === 'pan' ? this.startPan() : this.startSketch();
  }

  pointerMove(e) {
    if (!this.pointers.has(e.pointerId)) return;
    this.pointers.set(e.pointerId, [e.offsetX, e.offsetY]);
    if (this.gesture?.kind === 'pan') this.movePan(this.gesture);
    if (this.gesture?.kind === 'sketch') {
      this.gesture.end = [e.offsetX, e.offsetY];
      this.requestFrame();
    }
  }

  pointerUp(e) {
    if (!this.pointers.delete(e.pointerId)) return;
    const gesture = this.gesture;
    // A pinch that loses a finger goes on as a pan of the other one, from where it is now.
    this.gesture = gesture?.kind === 'pan' && this.pointers.size > 0 ? this.startPan() : null;
    if (gesture?.kind === 'sketch') this.finishSketch(gesture);
  }

  // Pan and pinch from the view and pointers at the gesture's start. Moving the centre by the
  // pointer distance over the local magnification keeps the content under the pointer.
  startPan() {
    const points = [...this.pointers.values()];
    const centre = centroid(points);
    const pane = this.paneAt(centre) ?? this.panes[0];
    return { kind: 'pan', view: this.getView(), centre, spread: spread(points), pane,
             magnification: pane.magnificationAt(centre) };
  }

  movePan(g) {
    const points = [...this.pointers.values()];
    const centre = centroid(points);
    const pinch = points.length >= 2 && g.spread > 0 ? g.pane.zoomChange(spread(points) / g.spread) : 0;
    this.changeView({
      zoom: g.view.zoom + pinch,
      cx: g.view.cx - (centre[0] - g.centre[0]) / g.magnification,
      cy: g.view.cy - (centre[1] - g.centre[1]) / g.magnification,
    });
  }

  startSketch() {
    if (this.pointers.size !== 1) return null;
    const [start] = this.pointers.values();
    const pane = this.paneAt(start);
    if (pane?.shown && !pane.mapsSource()) {
      this.say(`${pane.method} shows pictures, not a mesh: edit in a pane with a mesh`);
      return null;
    }
    return pane?.shown ? { kind: 'sketch', tool: this.tool, pane, start, end: start } : null;
  }

  sketch() {
    return this.gesture?.kind === 'sketch' ? this.gesture : null;
  }

  async finishSketch({ tool, pane, start, end }) {
    this.requestFrame();  // clears the sketch
    if (Math.hypot(end[0] - start[0], end[1] - start[1]) < MIN_SKETCH) return;
    const toSource = (p) => pane.toSource(p, performance.now());
    try {
      if (tool === 'important') await this.markRegion(start, end, toSource);
      else await this.addLine(start, end, toSource);
    } catch (error) {
      this.say(error.message);
    }
  }

  async markRegion(start, end, toSource) {
    const polygon = outlineInSource(start, end, toSource, this.image);
    if (!polygon) return this.say('mark a region on the picture');
    this.say('marking the region important…');
    this.edited(await markImportant(this.image.id, polygon));
  }

  async addLine(start, end, toSource) {
    const [a, b] = [toSource(start), toSource(end)];
    if (!a || !b) return this.say('draw lines on the picture');
    this.say('adding the line…');
    const lines = await fetchLines(this.image.id);
    lines.push([...insideImage(a, this.image), ...insideImage(b, this.image)]);
    this.edited(await putLines(this.image.id, lines));
  }

  // What zoom 0 does where the image's aspect is not the screen's (fit=: auto, warp, crop, pad):
  // every pane fetches its view again; resolves when they are drawn.
  setFit(fit) {
    this.fit = fit;
    for (const pane of this.panes) {
      pane.fit = fit;
      pane.invalidate();
    }
    this.say(`fit: ${fit}`);
    return this.whenIdle();
  }

  // A new image version: every pane fetches its view again, and the overlay the lines.
  edited(image) {
    this.image = { ...this.image, version: image.version };
    this.say(`saved: version ${image.version}`);
    for (const pane of this.panes) pane.invalidate();
    this.reloadLines();
  }

  async reloadLines() {
    try {
      ({ lines: this.lines, suggested: this.suggested } = await fetchLineSet(this.image.id));
      this.suggestions.update(this.suggested);
      this.requestFrame();
    } catch (error) {
      this.say(error.message);
    }
  }

  paneAt(point) {
    return this.panes.find((pane) => pane.contains(point));
  }

  setTool(tool) {
    this.tool = tool;
    this.canvas.dataset.tool = tool;
    this.suggestions.show(tool === 'line');
    this.requestFrame();
  }

  say(message) {
    this.status.textContent = message;
  }
}

function centroid(points) {
  const sum = points.reduce(([x, y], [px, py]) => [x + px, y + py], [0, 0]);
  return [sum[0] / points.length, sum[1] / points.length];
}

// Mean distance of the points from their centroid: its ratio between two moments is the pinch.
function spread(points) {
  const [cx, cy] = centroid(points);
  return points.reduce((sum, [x, y]) => sum + Math.hypot(x - cx, y - cy), 0) / points.length;
}

// --- page ---------------------------------------------------------------------------------

async function listImages() {
  const response = await authorizedFetch('/v1/images', { cache: 'no-cache' });
  if (!response.ok) throw new Error(`image list: HTTP ${response.status}`);
  return (await response.json()).images;
}

// The picker reloads the page for another image: each image starts from a clean viewer, with
// the methods chosen but not the view, which belongs to the image.
function fillPicker(picker, images, selected) {
  for (const image of images) picker.add(new Option(`${image.id} (${image.width}×${image.height})`, image.id));
  picker.value = selected.id;
  picker.addEventListener('change', () => {
    const url = new URL(location.href);
    url.searchParams.set('image', picker.value);
    url.hash = withoutView(location.hash);
    location.assign(url);
  });
}

function wireControls(viewer) {
  for (const input of document.querySelectorAll('input[name="tool"]')) {
    input.addEventListener('change', () => input.checked && viewer.setTool(input.value));
  }
  wireMethodMenus(viewer);
  const fitMenu = document.getElementById('fit');
  fitMenu.value = viewer.fit;
  fitMenu.addEventListener('change', () => viewer.setFit(fitMenu.value));
}

// The method and saliency menus of the two panes and the side-by-side switch. They show the
// viewer's panes and set them when changed; a link pasted into the address bar (a new hash) sets
// both.
function wireMethodMenus(viewer) {
  const { catalogue } = viewer;
  const menus = [
    new MethodMenu(catalogue, document.getElementById('method'), document.getElementById('saliency')),
    new MethodMenu(catalogue, document.getElementById('method2'), document.getElementById('saliency2')),
  ];
  const sideBySide = document.getElementById('side-by-side');
  const second = document.getElementById('second-pane');
  const show = (choices) => {
    menus[0].value = choices[0];
    menus[1].value = choices[1] ?? secondChoice(catalogue, choices[0]);
    sideBySide.checked = choices.length > 1;
    second.hidden = choices.length < 2;
  };
  const chosen = () => (sideBySide.checked ? [menus[0].value, menus[1].value] : [menus[0].value]);
  for (const menu of menus) menu.onChange(() => viewer.setPanes(chosen()));
  sideBySide.addEventListener('change', () => {
    second.hidden = !sideBySide.checked;
    viewer.setPanes(chosen());
  });
  show(viewer.choices);
  window.addEventListener('hashchange', () => {
    const { panes, view } = parseState(location.hash);
    if (panes.length > 0) {
      const { choices, problems } = validChoices(catalogue, panes);
      if (problems.length > 0) viewer.say(problems.join('; '));
      viewer.setPanes(choices);
      show(choices);
    }
    viewer.changeView(view);
  });
}

// A key is printable ASCII without spaces, as a header value must be: fetch() refuses anything else.
const KEY_SYNTAX = /^[\x21-\x7e]+$/;

// The curator key control. The tools show while the tab holds a key; the server alone knows what
// a key may do, so a key without the curator role shows them too, until its first edit is
// refused and the key forgotten (curator.js authorizedFetch).
function wireCuratorKey(status) {
  const button = document.getElementById('key-button');
  const form = document.getElementById('key-form');
  const input = document.getElementById('key-input');
  const forget = document.getElementById('forget-key');
  const showForm = (shown) => {
    form.hidden = !shown;
    button.setAttribute('aria-expanded', String(shown));
    if (shown) input.focus();
  };
  const showKeyHeld = (held) => {
    showCuratorTools(held);
    button.hidden = held;
    forget.hidden = !held;
    if (held) showForm(false);
  };
  button.addEventListener('click', () => showForm(form.hidden));
  form.addEventListener('submit', (e) => {
    e.preventDefault();  // a plain form submission would navigate
    const key = input.value.trim();
    input.value = '';
    if (!KEY_SYNTAX.test(key)) {
      status.textContent = 'a key is printable ASCII without spaces';
      return;
    }
    curatorKey.set(key);
    status.textContent = 'curator key kept for this tab and sent with every request';
  });
  forget.addEventListener('click', () => {
    curatorKey.forget();
    status.textContent = 'curator key forgotten';
  });
  curatorKey.onChange(({ key, refused }) => {
    showKeyHeld(key !== null);
    if (refused) status.textContent = refusalMessage(refused);
  });
  showKeyHeld(curatorKey.get() !== null);
}

// Hiding the tools goes back to pan & zoom, so no gesture can start an edit without a key.
function showCuratorTools(shown) {
  document.getElementById('curator-tools').hidden = !shown;
  const pan = document.getElementById('tool-pan');
  if (!shown && !pan.checked) {
    pan.checked = true;
    pan.dispatchEvent(new Event('change'));
  }
}

async function start() {
  const status = document.getElementById('status');
  // First, so that a key refused by the very first request is reported.
  wireCuratorKey(status);
  const [images, catalogue] = await Promise.all([listImages(), fetchMethods()]);
  if (images.length === 0) throw new Error('no images yet: add one with POST /v1/images');
  const wanted = new URLSearchParams(location.search).get('image');
  const image = images.find((i) => i.id === wanted) ?? images[0];
  const state = parseState(location.hash);
  const { choices, problems } = validChoices(catalogue, state.panes);
  if (wanted && image.id !== wanted) problems.unshift(`no image '${wanted}'; showing ${image.id}`);
  if (problems.length > 0) status.textContent = problems.join('; ');
  fillPicker(document.getElementById('image-picker'), images, image);
  const viewer = new Viewer({
    canvas: document.getElementById('view'),
    overlayCanvas: document.getElementById('overlay'),
    status,
    image,
    catalogue,
    choices,
    view: state.view,
  });
  wireControls(viewer);
  return viewer;
}

// The test API exists from the first moment; ready settles when the first frame is drawn (or
// the viewer could not start).
let viewerNow = null;
const booting = start();
window.zoomwarp = {
  ready: booting.then((viewer) => viewer.ready),
  setView: async (view) => (await booting).setView(view),
  getView: () => viewerNow?.getView(),
  get imageId() { return viewerNow?.image.id; },
  get panes() { return viewerNow?.choices.map((choice) => ({ ...choice })); },
  get meshRequests() { return viewerNow?.counters.meshRequests ?? 0; },
  get viewportRequests() { return viewerNow?.counters.viewportRequests ?? 0; },
  get frames() { return viewerNow?.counters.frames ?? 0; },
  get fit() { return viewerNow?.fit; },
  whenIdle: async () => (await booting).whenIdle(),
};
booting.then((viewer) => { viewerNow = viewer; },
             (error) => { document.getElementById('status').textContent = error.message; });
