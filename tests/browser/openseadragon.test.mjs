// OpenSeadragon in headless Chromium opens an image served by a real zoomwarp server, once
// through the Deep Zoom descriptor and once through the IIIF Image API info.json, and the
// screenshot must match a downscaled copy of the source image made by oiiotool, i.e.
// independently of zoomwarp's own resampling and encoding.
//
// Run: cd tests/browser && npm ci && node --test
// Needs: a built zoomwarp (ZOOMWARP_BINARY), /usr/bin/chromium, oiiotool, Node >= 18.

import assert from 'node:assert/strict';
import fs from 'node:fs/promises';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, test } from 'node:test';

import { PNG } from 'pngjs';

import {
  Cleanups, SAMPLES, compareRgb, execFileP, ingest, launchChromium, listenOnLoopback, startZoomwarp, tempDir,
} from './support.mjs';

const __dirname = path.dirname(fileURLToPath(import.meta.url));
const SAMPLE = path.join(SAMPLES, 'boats_lake_sunset.jpg');
const OSD_SCRIPT = path.join(__dirname, 'node_modules/openseadragon/build/openseadragon/openseadragon.min.js');
const OUT_DIR = path.join(__dirname, 'out');
const IMAGE_ID = 'boats';

// Same aspect ratio as the 2560x1600 sample, so OpenSeadragon's home view fills the viewport
// exactly and every screenshot pixel can be compared with the reference.
const VIEWPORT = { width: 800, height: 500 };

// A correct render measures 33.3 dB / MAD 3.4 here (Chromium's bilinear downscale of the
// right JPEG pyramid level against oiiotool's filtered resize of the original), the same on
// every run. These limits reject the picture one pixel off (23.5 dB / 9.2), one pyramid level
// too coarse (29.4 dB / 4.8), with margins (12.7 dB) or mirrored (12.4 dB).
const MIN_PSNR_DB = 31;
const MAX_MAD = 4.5;

// How OpenSeadragon is pointed at the server, and which requests are its image tiles
// (so the test can prove the picture was really fetched through that protocol).
const MODES = [
  {
    name: 'dzi',
    tileSource: (base) => `${base}/dzi/${IMAGE_ID}.dzi`,
    isTile: (url) => new RegExp(`/dzi/${IMAGE_ID}_files/\\d+/\\d+_\\d+\\.jpg$`).test(url),
  },
  {
    name: 'iiif',
    tileSource: (base) => `${base}/iiif/3/${IMAGE_ID}/info.json`,
    isTile: (url) => new RegExp(`/iiif/3/${IMAGE_ID}/[^/]+/[^/]+/0/default\\.jpg$`).test(url),
  },
];

// The page lives on a different origin (port) than zoomwarp, so the descriptor requests and,
// with crossOriginPolicy 'Anonymous', the tile requests only succeed if zoomwarp's CORS
// headers are right.
const PAGE_HTML = `<!doctype html>
<html>
<head>
<meta charset="utf-8">
<title>zoomwarp browser test</title>
<style>
  html, body { margin: 0; height: 100%; overflow: hidden; background: #000; }
  #viewer { width: 100vw; height: 100vh; }
</style>
<script src="/openseadragon.min.js"></script>
</head>
<body>
<div id="viewer"></div>
<script>
  // Resolves once every tile the home view needs is loaded and drawn; rejects on the first
  // descriptor or tile failure so that the test fails with OpenSeadragon's own reason, and
  // after a while (well within the test's timeout) if the view never completes.
  window.openImage = (tileSource) => new Promise((resolve, reject) => {
    setTimeout(() => reject(new Error('the home view was not fully loaded within 30 s')), 30_000);
    const viewer = OpenSeadragon({
      id: 'viewer',
      tileSources: tileSource,
      crossOriginPolicy: 'Anonymous',
      // WebGL only: OpenSeadragon's fallback, the canvas drawer, draws each tile of a source
      // without overlap (IIIF) 1px too large to hide seams, which smears the picture by up to
      // a pixel (about 23 dB here). Without WebGL the viewer fails instead of quietly falling
      // back and measuring something else.
      drawer: 'webgl',
      showNavigationControl: false,
      showNavigator: false,
      animationTime: 0,
      blendTime: 0,
      immediateRender: true,
      visibilityRatio: 1,
      constrainDuringPan: true,
      homeFillsViewer: false,
    });
    viewer.addHandler('open-failed', (e) => reject(new Error('open-failed: ' + e.message)));
    viewer.addHandler('tile-load-failed', (e) =>
      reject(new Error('tile-load-failed: ' + e.message + ' ' + e.tile.getUrl())));
    viewer.addHandler('drawer-error', (e) => reject(new Error('drawer-error: ' + e.error)));
    viewer.addHandler('open', () => {
      viewer.world.getItemAt(0).whenFullyLoaded(() => {
        // 'fully-loaded-change' is raised in the update step, before that frame's draw: wait
        // until nothing is left to draw, then one more frame so the canvas is composited.
        const settle = () => {
          if (viewer.world.needsDraw()) {
            requestAnimationFrame(settle);
          } else {
            requestAnimationFrame(() => resolve());
          }
        };
        settle();
      });
    });
  });
</script>
</body>
</html>
`;

const cleanups = new Cleanups();
let browser;
let zoomwarpBase;
let pageUrl;
let reference;

before(async () => {
  const tmp = await tempDir(cleanups);
  // Not emptied first: node --test runs the test files at the same time, and out/ is shared.
  await fs.mkdir(OUT_DIR, { recursive: true });

  const store = path.join(tmp, 'store');
  const referencePath = path.join(OUT_DIR, 'reference.png');
  await Promise.all([
    ingest(store, SAMPLE, IMAGE_ID),
    execFileP('oiiotool', [SAMPLE, '--resize', `${VIEWPORT.width}x${VIEWPORT.height}`, '-o', referencePath]),
  ]);
  reference = PNG.sync.read(await fs.readFile(referencePath));

  const port = await startZoomwarp(store, cleanups);
  zoomwarpBase = `http://127.0.0.1:${port}`;
  pageUrl = await startPageServer();
  browser = await launchChromium(cleanups);
}, { timeout: 60_000 });

after(() => cleanups.run());

for (const mode of MODES) {
  test(`OpenSeadragon shows the image via ${mode.name}`, { timeout: 60_000 }, async () => {
    const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
    try {
      const page = await context.newPage();
      const pageErrors = [];
      page.on('pageerror', (err) => pageErrors.push(err.message));
      const tileStatuses = [];
      page.on('response', (res) => {
        if (res.url().startsWith(zoomwarpBase) && mode.isTile(res.url())) tileStatuses.push(res.status());
      });

      await page.goto(pageUrl);
      await page.evaluate((src) => window.openImage(src), mode.tileSource(zoomwarpBase));
      const screenshotPath = path.join(OUT_DIR, `${mode.name}.png`);
      const shot = PNG.sync.read(await page.screenshot({ path: screenshotPath }));

      const { psnr, mad } = compareRgb(shot, reference);
      console.log(`${mode.name}: PSNR ${psnr.toFixed(2)} dB, MAD ${mad.toFixed(2)} ` +
                  `(${tileStatuses.length} tiles, ${screenshotPath})`);

      assert.deepEqual(pageErrors, []);
      assert.ok(tileStatuses.length > 0, `no ${mode.name} tile was requested from zoomwarp`);
      assert.ok(tileStatuses.every((s) => s === 200), `tile statuses: ${tileStatuses.join(',')}`);
      assert.ok(psnr >= MIN_PSNR_DB && mad <= MAX_MAD,
                `${screenshotPath} differs from ${path.join(OUT_DIR, 'reference.png')}: ` +
                `PSNR ${psnr.toFixed(2)} dB (min ${MIN_PSNR_DB}), MAD ${mad.toFixed(2)} (max ${MAX_MAD})`);
    } finally {
      await context.close();
    }
  });
}

// Serves the test page and OpenSeadragon from node_modules on a free loopback port; returns
// the page's URL.
async function startPageServer() {
  const osd = await fs.readFile(OSD_SCRIPT);
  const server = http.createServer((req, res) => {
    if (req.url === '/') {
      res.writeHead(200, { 'Content-Type': 'text/html; charset=utf-8' }).end(PAGE_HTML);
    } else if (req.url === '/openseadragon.min.js') {
      res.writeHead(200, { 'Content-Type': 'text/javascript' }).end(osd);
    } else {
      res.writeHead(404).end();
    }
  });
  return `${await listenOnLoopback(server, cleanups)}/`;
}
