// zoomwarp's own web viewer (web/, served at /) in headless Chromium against a real server:
// it draws, a wheel notch zooms, its WebGL picture of a view matches the server's own rendering
// of that view (/viewport), a curator edit made with the mouse publishes a new version, and the
// curator tools are there only for a key the server takes as a curator's.
//
// Run: cd tests/browser && npm ci && node --test viewer.test.mjs
// Needs: a built zoomwarp (ZOOMWARP_BINARY), /usr/bin/chromium, Node >= 18.

import assert from 'node:assert/strict';
import crypto from 'node:crypto';
import fs from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, test } from 'node:test';

import { PNG } from 'pngjs';

import { Cleanups, SAMPLES, compareRgb, ingest, launchChromium, startZoomwarp, tempDir } from './support.mjs';

const __dirname = path.dirname(fileURLToPath(import.meta.url));
const OUT_DIR = path.join(__dirname, 'out', 'viewer');
const SAMPLE = path.join(SAMPLES, 'boats_lake_sunset.jpg');  // 2560×1600
const IMAGE_ID = 'boats_lake_sunset';
// The same picture under other ids for the edit tests, so that the other tests see the image
// as ingested whatever order they run in.
const EDITED_ID = 'boats-edited';
const LINES_ID = 'boats-lines';
const SUGGEST_ID = 'boats-suggest';
const VIEWPORT = { width: 480, height: 360 };

// The viewer draws the server's mesh with the GPU's bilinear filtering from JPEG tiles of one
// pyramid level; the server renders every triangle from the level that fits it, straight from
// the pyramid. A correct drawing measures 38.8 dB at zoom 0.4 and 36.8 dB at zoom 0, the same on
// every run; the same pictures one pixel off measure 26.7 and 25.6 dB.
const MIN_PSNR_DB = 30;
// The same, for a view squeezed almost three times along one axis (fit=warp on a phone).
const MIN_SQUEEZED_PSNR_DB = 25;

const VIEWS = [
  { name: 'zoom-0.4', zoom: 0.4, cx: 1200, cy: 700 },
  { name: 'zoom-0', zoom: 0, cx: 1280, cy: 800 },
];

// The server's key file (`--keys`, `KEY_ID ROLE KEY` a line) holds one key of each role the
// viewer meets; writes are not opened to everyone (no --open-writes).
const CURATOR_KEY = crypto.randomBytes(24).toString('base64url');
const READER_KEY = crypto.randomBytes(24).toString('base64url');
// Where the viewer keeps the key (web/curator.js).
const KEY_ITEM = 'zoomwarp.curatorKey';

const cleanups = new Cleanups();
let browser;
let base;

before(async () => {
  const dir = await tempDir(cleanups);
  const store = path.join(dir, 'store');
  const keys = path.join(dir, 'keys');
  await fs.writeFile(keys, `curator-1 curator ${CURATOR_KEY}\nreader-1 reader ${READER_KEY}\n`, { mode: 0o600 });
  await ingest(store, SAMPLE, IMAGE_ID);
  await ingest(store, SAMPLE, EDITED_ID);
  await ingest(store, SAMPLE, LINES_ID);
  await ingest(store, SAMPLE, SUGGEST_ID);
  base = `http://127.0.0.1:${await startZoomwarp(store, cleanups, ['--keys', keys])}`;
  browser = await launchChromium(cleanups);
  await fs.mkdir(OUT_DIR, { recursive: true });
}, { timeout: 90_000 });

after(() => cleanups.run());

test('the viewer draws the first image and zooms with the wheel', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, '/');
  const { images } = await getJson('/v1/images');
  assert.equal(await page.evaluate(() => window.zoomwarp.imageId), images[0].id, 'the first listed image by default');
  const picture = await canvasPixels(page);
  assert.ok(spread(picture) > 20, `the canvas looks blank (spread ${spread(picture).toFixed(1)})`);

  const before = await counters(page);
  await page.mouse.move(VIEWPORT.width / 2, VIEWPORT.height / 2);
  await page.mouse.wheel(0, -100);  // one notch up: zoom in
  await page.waitForFunction((zoom) => window.zoomwarp.getView().zoom > zoom, before.view.zoom);
  await page.evaluate(() => window.zoomwarp.setView({}));  // the same view: resolves once drawn
  const afterWheel = await counters(page);

  assert.ok(afterWheel.meshRequests > before.meshRequests, 'the wheel fetched a mesh');
  assert.ok(afterWheel.frames > before.frames, 'the wheel drew frames');
  assert.ok(Math.abs(afterWheel.view.zoom - (before.view.zoom + 0.05)) < 1e-9,
            `zoom ${before.view.zoom} → ${afterWheel.view.zoom}, expected one step of 0.05`);
});

for (const view of VIEWS) {
  test(`the WebGL picture matches the server's viewport at ${view.name}`, { timeout: 60_000 }, async (t) => {
    const page = await openViewer(t, `/?image=${IMAGE_ID}`);
    const { zoom, cx, cy } = view;
    assert.deepEqual(await page.evaluate((v) => window.zoomwarp.setView(v), { zoom, cx, cy }), { zoom, cx, cy });
    const drawn = await canvasPixels(page);
    const query = new URLSearchParams({ zoom, cx, cy, w: VIEWPORT.width, h: VIEWPORT.height, format: 'png' });
    const response = await fetch(`${base}/v1/images/${IMAGE_ID}/viewport?${query}`);
    assert.equal(response.status, 200);
    const rendered = PNG.sync.read(Buffer.from(await response.arrayBuffer()));

    const drawnPath = path.join(OUT_DIR, `${view.name}-webgl.png`);
    const renderedPath = path.join(OUT_DIR, `${view.name}-server.png`);
    await fs.writeFile(drawnPath, PNG.sync.write(drawn));
    await fs.writeFile(renderedPath, PNG.sync.write(rendered));
    const { psnr, mad } = compareRgb(drawn, rendered);
    console.log(`viewer ${view.name}: PSNR ${psnr.toFixed(2)} dB, MAD ${mad.toFixed(2)} (${drawnPath})`);
    assert.ok(psnr >= MIN_PSNR_DB, `${drawnPath} differs from ${renderedPath}: PSNR ${psnr.toFixed(2)} dB ` +
                                   `(min ${MIN_PSNR_DB})`);
  });
}

// fit= (issue 41). On a phone-shaped window the viewer asks for fit=auto, the server's default:
// the boats cropped where they matter least and warped within the budget, not all of them
// squeezed in. The fit menu changes what every view asks for, and each picture is the server's
// /viewport of that fit.
test('the fit menu asks for each fit and the picture is the server\'s view of it', { timeout: 90_000 }, async (t) => {
  const phone = { width: 300, height: 540 };
  const page = await openViewer(t, `/?image=${IMAGE_ID}`, async () => {}, phone);
  const asked = [];
  page.on('request', (r) => {
    if (r.url().includes('/mesh?')) asked.push(new URL(r.url()).searchParams.get('fit'));
  });
  assert.equal(await page.evaluate(() => window.zoomwarp.fit), 'auto');
  assert.equal(await page.inputValue('#fit'), 'auto');
  const pictures = {};
  for (const fit of ['auto', 'warp', 'pad']) {
    if (fit !== 'auto') {
      await page.selectOption('#fit', fit);
      await page.evaluate(() => window.zoomwarp.whenIdle());
      assert.equal(asked.at(-1), fit, `the mesh asked for after choosing ${fit}`);
    }
    const drawn = await canvasPixels(page);
    const { zoom, cx, cy } = await page.evaluate(() => window.zoomwarp.getView());
    const query = new URLSearchParams({ zoom, cx, cy, w: phone.width, h: phone.height, fit, format: 'png' });
    const response = await fetch(`${base}/v1/images/${IMAGE_ID}/viewport?${query}`);
    assert.equal(response.status, 200);
    const rendered = PNG.sync.read(Buffer.from(await response.arrayBuffer()));
    const drawnPath = path.join(OUT_DIR, `fit-${fit}-webgl.png`);
    await fs.writeFile(drawnPath, PNG.sync.write(drawn));
    const { psnr } = compareRgb(drawn, rendered);
    console.log(`viewer fit=${fit}: PSNR ${psnr.toFixed(2)} dB (${drawnPath})`);
    // fit=warp squeezes the boats 2.84 times along x: there the GPU's texture filtering (one
    // mipmap level for the whole triangle) and the server's resampling differ in the fine detail
    // the squeeze folds together, so the bound is that of a picture, not of pixels.
    const bound = fit === 'warp' ? MIN_SQUEEZED_PSNR_DB : MIN_PSNR_DB;
    assert.ok(psnr >= bound, `fit=${fit}: ${drawnPath} differs from the server's viewport: PSNR ${psnr.toFixed(2)} dB`);
    pictures[fit] = drawn;
  }
  // Three different pictures: auto is not warp (the crop), pad is not warp (its bands).
  for (const [a, b] of [['auto', 'warp'], ['warp', 'pad'], ['auto', 'pad']])
    assert.ok(compareRgb(pictures[a], pictures[b]).psnr < MIN_PSNR_DB, `fit=${a} and fit=${b} draw the same picture`);
});

// A first view that outlasts --request-timeout while the image's analysis is made is answered
// 503 analysis_pending with Retry-After (api/warp_engines.h); on a busy machine that is the
// viewer's first mesh. The viewer waits as asked, says why, and asks again. The answer is the
// server's own, replayed by routing the page's first mesh and lines reads, so that the test
// does not depend on how loaded the machine is.
test('a view the server asks to retry (503 analysis_pending, Retry-After) is retried and drawn', { timeout: 60_000 }, async (t) => {
  const refused = [];
  let statusSeen;
  const page = await openViewer(t, `/?image=${IMAGE_ID}`, async (page) => {
    const pending = async (route) => {
      if (refused.some((url) => url === route.request().url())) return route.continue();
      refused.push(route.request().url());
      await route.fulfill({
        status: 503,
        headers: { 'Retry-After': '1', 'Content-Type': 'application/json' },
        body: JSON.stringify({ error: { code: 'analysis_pending', message: "this image's analysis is being computed" } }),
      });
    };
    await page.route(/\/mesh\?/, pending);
    await page.route(/\/lines$/, pending);
    page.on('load', () => {
      statusSeen = page.waitForFunction(() => document.getElementById('status').textContent, null, { polling: 50 })
        .then((handle) => handle.jsonValue());
    });
  });
  assert.equal(refused.filter((url) => url.includes('/mesh?')).length, 1, 'the first mesh read was answered 503');
  assert.equal(refused.filter((url) => url.endsWith('/lines')).length, 1, 'the first lines read was answered 503');
  assert.match(await statusSeen, /preparing this image's analysis; trying again in 1 s/);
  assert.ok(spread(await canvasPixels(page)) > 20, 'the retried view is drawn');
  assert.equal(await page.textContent('#status'), '', 'the notice is gone once the view is drawn');
  const { suggested } = await getJson(`/v1/images/${IMAGE_ID}/lines`);
  assert.ok(suggested.length > 0);
  await page.waitForFunction((n) => document.querySelectorAll('#suggestions li').length === n, suggested.length);
});

test('marking a region important with the mouse publishes a new version', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, `/?image=${EDITED_ID}`);
  const { version, width, height } = await getJson(`/v1/images/${EDITED_ID}`);

  await enterKey(page, CURATOR_KEY);
  await page.check('#tool-important');
  const patch = page.waitForResponse((r) => r.request().method() === 'PATCH' &&
                                            r.url().endsWith(`/v1/images/${EDITED_ID}/significance`));
  await page.mouse.move(160, 140);
  await page.mouse.down();
  await page.mouse.move(240, 200, { steps: 5 });
  await page.mouse.move(320, 260, { steps: 5 });
  await page.mouse.up();
  const response = await patch;

  assert.equal(response.status(), 200, await response.text());
  const [region] = response.request().postDataJSON().regions;
  assert.equal(region.weight, 1);
  assert.ok(region.polygon.length >= 3, 'a polygon');
  for (const [x, y] of region.polygon) assert.ok(x >= 0 && x <= width && y >= 0 && y <= height, `${x},${y} in the image`);
  const edited = await getJson(`/v1/images/${EDITED_ID}`);
  assert.notEqual(edited.version, version, 'a new image version');
  assert.equal((await response.json()).version, edited.version);
});

test('without a key the curator tools are hidden and a drag writes nothing', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, `/?image=${LINES_ID}`);
  const { lines } = await getJson(`/v1/images/${LINES_ID}/lines`);
  const requests = recordRequests(page);

  assert.equal(await page.isVisible('#key-button'), true, 'the key control is offered');
  for (const tool of ['#tool-important', '#tool-line']) assert.equal(await page.isVisible(tool), false, `${tool} hidden`);
  await drag(page);
  await page.evaluate(() => window.zoomwarp.setView({}));  // the drag's view, drawn

  assert.deepEqual(requests.filter((r) => r.method() !== 'GET').map((r) => `${r.method()} ${r.url()}`), []);
  for (const request of requests) assert.equal((await request.allHeaders()).authorization, undefined, request.url());
  assert.deepEqual((await getJson(`/v1/images/${LINES_ID}/lines`)).lines, lines, 'the lines as they were');
});

test('a reader key is refused at its first edit, forgotten, and the tools hidden', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, `/?image=${LINES_ID}`);
  const { lines } = await getJson(`/v1/images/${LINES_ID}/lines`);

  await enterKey(page, READER_KEY);
  await page.check('#tool-line');
  const put = page.waitForResponse((r) => r.request().method() === 'PUT');
  await drag(page);
  const response = await put;

  assert.equal(response.status(), 403, await response.text());
  await page.waitForSelector('#curator-tools', { state: 'hidden' });
  assert.match(await page.textContent('#status'), /refused the curator key \(HTTP 403.*forgotten/);
  assert.equal(await page.isChecked('#tool-pan'), true, 'back to pan & zoom');
  assert.equal(await page.isVisible('#key-button'), true, 'a key can be entered again');
  assert.equal(await storedKey(page), null);
  assert.deepEqual((await getJson(`/v1/images/${LINES_ID}/lines`)).lines, lines, 'the lines as they were');
});

test('a curator key shows the tools, goes with every request, and can be forgotten', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, `/?image=${LINES_ID}`);
  const { lines } = await getJson(`/v1/images/${LINES_ID}/lines`);

  await enterKey(page, CURATOR_KEY);
  const requests = recordRequests(page);
  assert.equal(await page.isVisible('#tool-line'), true, 'the tools appear');
  assert.equal(await storedKey(page), CURATOR_KEY, 'the key in sessionStorage');
  assert.equal(await page.evaluate(() => localStorage.length), 0, 'nothing in localStorage');
  assert.ok(!page.url().includes(CURATOR_KEY), 'the key is not in the URL');

  await page.check('#tool-line');
  const put = page.waitForResponse((r) => r.request().method() === 'PUT');
  await drag(page);
  const response = await put;
  assert.equal(response.status(), 200, await response.text());
  await page.waitForFunction(() => document.getElementById('status').textContent.startsWith('saved: version'));
  const edited = (await getJson(`/v1/images/${LINES_ID}/lines`)).lines;
  assert.equal(edited.length, lines.length + 1, 'one more line on the server');
  assert.deepEqual(edited.slice(0, lines.length), lines);
  await page.evaluate(() => window.zoomwarp.setView({}));  // the new version's mesh, drawn

  const sent = requests.splice(0);
  for (const kind of [/PUT .*\/lines$/, /GET .*\/lines$/, /GET .*\/mesh\?/]) {
    assert.ok(sent.some((r) => kind.test(`${r.method()} ${r.url()}`)), `a request ${kind} was sent`);
  }
  for (const request of sent) {
    assert.equal((await request.allHeaders()).authorization, `Bearer ${CURATOR_KEY}`, `${request.method()} ${request.url()}`);
  }

  await page.click('#forget-key');
  assert.equal(await page.isVisible('#tool-line'), false, 'the tools hidden again');
  assert.equal(await page.isChecked('#tool-pan'), true, 'back to pan & zoom');
  assert.equal(await storedKey(page), null, 'the key gone from sessionStorage');
  await page.evaluate(() => window.zoomwarp.setView({ zoom: 0.2 }));
  assert.ok(requests.some((r) => r.url().includes('/mesh?')), 'a mesh fetched after forgetting');
  for (const request of requests) assert.equal((await request.allHeaders()).authorization, undefined, request.url());
});

test('the line editor lists the suggested lines; drop, accept and accept all edit them', { timeout: 60_000 }, async (t) => {
  const page = await openViewer(t, `/?image=${SUGGEST_ID}`);
  const { suggested } = await getJson(`/v1/images/${SUGGEST_ID}/lines`);
  assert.ok(suggested.length >= 3, `the sample has straight edges (${suggested.length} suggested)`);
  await enterKey(page, CURATOR_KEY);
  assert.equal(await page.isVisible('#suggestions'), false, 'not listed while panning');
  await page.check('#tool-line');
  await page.waitForSelector('#suggestions', { state: 'visible' });
  assert.equal(await page.locator('#suggestions li').count(), suggested.length);

  // Each button publishes a new version; the list is read again from the server.
  const click = async (selector) => {
    const put = page.waitForResponse((r) => r.request().method() === 'PUT' && r.url().endsWith(`/${SUGGEST_ID}/lines`));
    await page.click(selector);
    const response = await put;
    assert.equal(response.status(), 200, await response.text());
    await page.waitForFunction(() => document.getElementById('status').textContent.startsWith('saved: version'));
    return response.request().postDataJSON();
  };
  const dropped = await click('#suggestions li:nth-child(1) button.drop');
  assert.deepEqual(dropped, { lines: [], dismissed: [suggested[0]] });
  await page.waitForFunction((n) => document.querySelectorAll('#suggestions li').length === n, suggested.length - 1);

  const accepted = await click('#suggestions li:nth-child(1) button.accept');
  assert.deepEqual(accepted, { lines: [suggested[1]] });
  await page.waitForFunction((n) => document.querySelectorAll('#suggestions li').length === n, suggested.length - 2);
  let server = await getJson(`/v1/images/${SUGGEST_ID}/lines`);
  assert.deepEqual(server.lines, [suggested[1]]);
  assert.deepEqual(server.dismissed, [suggested[0]]);
  assert.deepEqual(server.suggested, suggested.slice(2));

  await click('#suggestions button.accept-all');
  server = await getJson(`/v1/images/${SUGGEST_ID}/lines`);
  assert.deepEqual(server.lines, suggested.slice(1), 'every suggestion not dropped is a curator line');
  assert.deepEqual(server.suggested, []);
  await page.waitForSelector('#suggestions', { state: 'hidden' });
});

// Enters a key with the viewer's key control, as a person would, and waits for it to be taken.
async function enterKey(page, key) {
  await page.click('#key-button');
  await page.fill('#key-input', key);
  await page.press('#key-input', 'Enter');
  await page.waitForSelector('#forget-key', { state: 'visible' });
}

async function storedKey(page) {
  return page.evaluate((item) => sessionStorage.getItem(item), KEY_ITEM);
}

// The requests the page makes from now on (kept live in the returned array).
function recordRequests(page) {
  const requests = [];
  page.on('request', (request) => requests.push(request));
  return requests;
}

// A mouse drag across the middle of the picture: a pan, a marked rectangle or a line by the tool.
async function drag(page) {
  await page.mouse.move(120, 120);
  await page.mouse.down();
  await page.mouse.move(240, 180, { steps: 5 });
  await page.mouse.move(360, 240, { steps: 5 });
  await page.mouse.up();
}

// A page of the viewer in its own context (480×360 CSS pixels by default, one device pixel each), ready:
// the first frame is drawn. Page errors fail the test; the context is closed after it.
// `prepare(page)` runs before the page loads (to route its requests).
async function openViewer(t, url, prepare = async () => {}, viewport = VIEWPORT) {
  const context = await browser.newContext({ viewport, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (err) => errors.push(err.message));
  t.after(async () => {
    await context.close();
    assert.deepEqual(errors, [], 'errors in the page');
  });
  await prepare(page);
  await page.goto(base + url);
  await page.evaluate(() => window.zoomwarp.ready);
  return page;
}

async function counters(page) {
  return page.evaluate(() => ({
    meshRequests: window.zoomwarp.meshRequests,
    frames: window.zoomwarp.frames,
    view: window.zoomwarp.getView(),
  }));
}

// The WebGL canvas as drawn (preserveDrawingBuffer), without the toolbar and overlay above it.
async function canvasPixels(page) {
  const dataUrl = await page.evaluate(() => document.getElementById('view').toDataURL('image/png'));
  return PNG.sync.read(Buffer.from(dataUrl.slice(dataUrl.indexOf(',') + 1), 'base64'));
}

// Standard deviation of the green samples: near 0 for a blank or uniform canvas.
function spread(png) {
  let sum = 0;
  let sumSq = 0;
  const n = png.width * png.height;
  for (let i = 1; i < png.data.length; i += 4) {
    sum += png.data[i];
    sumSq += png.data[i] * png.data[i];
  }
  return Math.sqrt(sumSq / n - (sum / n) ** 2);
}

async function getJson(route) {
  const response = await fetch(base + route);
  assert.equal(response.status, 200, `${route}: ${response.status}`);
  return response.json();
}
