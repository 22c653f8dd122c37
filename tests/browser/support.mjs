// What the browser tests share: a real zoomwarp server on a free loopback port over a temporary
// store, the system Chromium driven by playwright-core, teardown in reverse order, and the PSNR
// of two pictures.

import assert from 'node:assert/strict';
import { execFile, spawn } from 'node:child_process';
import { once } from 'node:events';
import fs from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { promisify } from 'node:util';

import { chromium } from 'playwright-core';

const __dirname = path.dirname(fileURLToPath(import.meta.url));
export const ZOOMWARP = process.env.ZOOMWARP_BINARY || path.resolve(__dirname, '../../build/bin/zoomwarp');
export const SAMPLES = path.resolve(__dirname, '../../samples');
const CHROMIUM = '/usr/bin/chromium';

export const execFileP = promisify(execFile);

// Children get no ZOOMWARP_* variables: each is also a zoomwarp option (ZOOMWARP_PUBLIC_URL,
// ZOOMWARP_STORE, ...), and one left in a developer's shell must not change what is tested.
const childEnv = Object.fromEntries(Object.entries(process.env).filter(([k]) => !k.startsWith('ZOOMWARP_')));

// Teardown steps, run last-registered first, each even when an earlier one failed.
export class Cleanups {
  constructor() {
    this.steps = [];
  }

  push(step) {
    this.steps.push(step);
  }

  async run() {
    const errors = [];
    while (this.steps.length > 0) {
      try {
        await this.steps.pop()();
      } catch (err) {
        errors.push(err);
      }
    }
    if (errors.length > 0) throw new AggregateError(errors, 'cleanup failed');
  }
}

// A fresh temporary directory, removed at cleanup.
export async function tempDir(cleanups) {
  const dir = await fs.mkdtemp(path.join(os.tmpdir(), 'zoomwarp-browser-'));
  cleanups.push(() => fs.rm(dir, { recursive: true, force: true }));
  return dir;
}

export async function ingest(store, file, id) {
  await execFileP(ZOOMWARP, ['ingest', file, '--store', store, '--id', id, '--quiet'], { env: childEnv });
}

// Starts `zoomwarp serve` on a free loopback port and returns that port, read from the
// server's JSON 'listening' log line. Cleanup stops it with SIGTERM and expects a clean exit.
// `extraArgs` default to --open-writes, for tests not about access; the viewer test passes
// ['--keys', file] instead, so that its edits need a key as in production.
export async function startZoomwarp(store, cleanups, extraArgs = ['--open-writes']) {
  const server = spawn(ZOOMWARP, ['serve', '--host', '127.0.0.1', '--port', '0', '--store', store,
                                  '--log-requests', '0', ...extraArgs],
                       { env: childEnv, stdio: ['ignore', 'ignore', 'pipe'] });
  // The log is read to the end (not just up to 'listening') so that the server never blocks
  // on a full pipe, and is kept for error messages.
  let log = '';
  server.stderr.setEncoding('utf8');
  server.stderr.on('data', (chunk) => { log += chunk; });
  const exited = new Promise((resolve) => server.on('exit', (code, signal) => resolve(code ?? signal)));

  const port = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`zoomwarp serve did not start listening:\n${log}`)), 20_000);
    const onData = () => {
      const line = log.split('\n').find((l) => l.includes('"msg":"listening"'));
      if (line === undefined) return;
      server.stderr.off('data', onData);
      clearTimeout(timer);
      resolve(JSON.parse(line).port);
    };
    server.stderr.on('data', onData);
    server.on('error', (err) => {
      clearTimeout(timer);
      reject(err);
    });
    exited.then((status) => {
      clearTimeout(timer);
      reject(new Error(`zoomwarp serve exited with ${status} at start:\n${log}`));
    });
  }).catch((err) => {
    server.kill('SIGKILL');
    throw err;
  });

  cleanups.push(async () => {
    server.kill('SIGTERM');
    const timer = setTimeout(() => server.kill('SIGKILL'), 10_000);
    const status = await exited;
    clearTimeout(timer);
    assert.equal(status, 0, `zoomwarp serve exited with ${status} on SIGTERM:\n${log}`);
  });
  return port;
}

// Starts `server` (an http.Server) on a free loopback port and returns its origin; cleanup closes
// it and its connections.
export async function listenOnLoopback(server, cleanups) {
  server.listen(0, '127.0.0.1');
  await once(server, 'listening');
  cleanups.push(() => {
    server.closeAllConnections();
    return new Promise((resolve) => server.close(resolve));
  });
  return `http://127.0.0.1:${server.address().port}`;
}

// Headless Chromium (the system one; Playwright never downloads a browser), closed at cleanup.
export async function launchChromium(cleanups) {
  const browser = await chromium.launch({
    executablePath: CHROMIUM,
    // Playwright gives each launch a fresh temporary profile and deletes it on close.
    args: [
      '--headless=new', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
    ],
  });
  cleanups.push(() => browser.close());
  return browser;
}

// PSNR (dB) and mean absolute difference over the R, G and B samples of two same-sized
// RGBA images (pngjs always decodes to RGBA); alpha is ignored.
export function compareRgb(a, b) {
  assert.deepEqual([a.width, a.height], [b.width, b.height], 'the pictures differ in size');
  let sumSq = 0;
  let sumAbs = 0;
  for (let i = 0; i < a.data.length; i += 4) {
    for (let c = 0; c < 3; c++) {
      const d = a.data[i + c] - b.data[i + c];
      sumSq += d * d;
      sumAbs += Math.abs(d);
    }
  }
  const n = a.width * a.height * 3;
  const mse = sumSq / n;
  return { psnr: mse === 0 ? Infinity : 10 * Math.log10((255 * 255) / mse), mad: sumAbs / n };
}
