// Deep Zoom tiles, fetched once and kept decoded, composited into the one texture a mesh is drawn
// with (geometry.js planAtlas says which tiles and where).

import { authorizedFetch } from './curator.js';
import { tileRect } from './geometry.js';

// Decoded tiles by URL, the least recently used dropped first. A tile's pixels never change for a
// given image (edits publish new significance and lines, not new pixels), so entries stay valid
// across versions.
export class TileCache {
  constructor(limit = 256) {  // 256 × 256² × 4 bytes: 64 MB of decoded tiles at most
    this.limit = limit;
    this.entries = new Map();  // url → Promise<ImageBitmap>, in order of use
  }

  get(url) {
    let entry = this.entries.get(url);
    if (entry) {
      this.entries.delete(url);
    } else {
      entry = fetchBitmap(url);
      // A failed fetch is not kept: the next view asks again.
      entry.catch(() => this.entries.get(url) === entry && this.entries.delete(url));
    }
    this.entries.set(url, entry);
    if (this.entries.size > this.limit) this.entries.delete(this.entries.keys().next().value);
    return entry;
  }
}

async function fetchBitmap(url) {
  const response = await authorizedFetch(url);
  if (!response.ok) throw new Error(`tile ${url}: HTTP ${response.status}`);
  // Colours exactly as encoded, as the server's own renderer reads them; premultiplied, as the
  // renderer blends.
  return createImageBitmap(await response.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'premultiply' });
}

// One texture with the plan's tiles at their level positions. Neighbouring tiles share their
// overlap pixels, which hold the same values, so writing one over the other changes nothing; the
// tiles are copied unscaled, so every texel is a pixel as decoded.
export async function loadAtlas(renderer, image, plan, tiles) {
  const bitmaps = await Promise.all(plan.tiles.map((tile) => tiles.get(tile.url)));
  const texture = renderer.createTexture(plan.x1 - plan.x0, plan.y1 - plan.y0);
  plan.tiles.forEach((tile, k) => {
    const r = tileRect(image, tile);
    renderer.uploadTile(texture, bitmaps[k], r.x0 - plan.x0, r.y0 - plan.y0);
  });
  return texture;
}
