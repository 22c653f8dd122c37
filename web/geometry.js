// Pure geometry of the viewer, no DOM and no WebGL: the mesh JSON of /v1/images/{id}/mesh as
// typed arrays, the Deep Zoom layout its tiles follow, and point location in the mesh (screen →
// source for the curator tools, source → screen for the line overlay).

// Deep Zoom layout of zoomwarp (api/deepzoom.h): level 0 is 1 px, each level doubles rounding up.
const TILE_SIZE = 254;
const TILE_OVERLAP = 1;

// The mesh as the renderer and the tools use it. `from` (the previous view's screen positions,
// for the geomorph) falls back to `screen` when the request had no from_* parameters; `morphs`
// says which it is.
export function parseMesh(json) {
  const n = json.vertices.length;
  const source = new Float64Array(2 * n);
  const screen = new Float64Array(2 * n);
  const from = new Float64Array(2 * n);
  json.vertices.forEach(([u, v, x, y], i) => {
    source.set([u, v], 2 * i);
    screen.set([x, y], 2 * i);
    from.set(json.from ? json.from[i] : [x, y], 2 * i);
  });
  return {
    image: json.image,
    view: json.view,
    tiles: json.tiles,
    source,
    screen,
    from,
    morphs: Boolean(json.from),
    triangles: Uint32Array.from(json.triangles.flat()),
  };
}

// A w × h picture (a /viewport image) as a mesh the renderer draws: two triangles covering the
// pane, not moving (`morphs` false), with no source positions (`source` null: it maps no point
// to the image). Its texture coordinates are SCREEN_QUAD_TEXCOORDS, so each screen pixel centre
// samples its texel's centre: the picture is drawn exactly as the server sent it.
export function screenQuad(w, h) {
  const screen = Float64Array.of(0, 0, w, 0, w, h, 0, h);
  return { view: null, tiles: [], source: null, screen, from: screen, morphs: false, triangles: Uint32Array.of(0, 1, 2, 0, 2, 3) };
}

export const SCREEN_QUAD_TEXCOORDS = Float32Array.of(0, 0, 1, 0, 1, 1, 0, 1);

// Screen positions part way (t in 0…1) from `from` to `screen`.
export function interpolatePositions(mesh, t) {
  const out = new Float64Array(mesh.screen.length);
  for (let i = 0; i < out.length; i++) out[i] = mesh.from[i] + (mesh.screen[i] - mesh.from[i]) * t;
  return out;
}

function maxLevel(image) {
  return Math.ceil(Math.log2(Math.max(image.width, image.height)));
}

// Width and height of a level, in its own pixels.
function levelSize(image, level) {
  const divisor = 2 ** (maxLevel(image) - level);
  return { width: Math.ceil(image.width / divisor), height: Math.ceil(image.height / divisor) };
}

// Level pixels per full-resolution pixel. The server uses the width ratio for both axes (its
// renderer and its tile lists), so the viewer does too: the pictures then agree to the pixel.
function levelScale(image, level) {
  return levelSize(image, level).width / image.width;
}

// The level pixels [x0, x1) × [y0, y1) of tile (col, row): TILE_SIZE plus the overlap shared with
// each neighbour that exists.
export function tileRect(image, { level, col, row }) {
  const size = levelSize(image, level);
  const span = (index, extent) => [
    Math.max(0, index * TILE_SIZE - TILE_OVERLAP),
    Math.min(extent, (index + 1) * TILE_SIZE + TILE_OVERLAP),
  ];
  const [x0, x1] = span(col, size.width);
  const [y0, y1] = span(row, size.height);
  return { x0, y0, x1, y1 };
}

// The tiles of `level` covering the full-resolution rectangle `box` ({u0, v0, u1, v1}), as the
// server lists them (api/deepzoom.cc, dzi_tiles_covering); `extension` is the tiles' format.
function tilesCovering(image, level, box, extension) {
  const scale = levelScale(image, level);
  const size = levelSize(image, level);
  const index = (p, fullExtent, levelExtent) => {
    const clamped = Math.min(Math.max(p, 0), fullExtent);
    return Math.min(Math.floor((levelExtent - 1) / TILE_SIZE), Math.floor((clamped * scale) / TILE_SIZE));
  };
  const tiles = [];
  for (let row = index(box.v0, image.height, size.height); row <= index(box.v1, image.height, size.height); row++) {
    for (let col = index(box.u0, image.width, size.width); col <= index(box.u1, image.width, size.width); col++) {
      tiles.push({ level, col, row, url: `/dzi/${image.id}_files/${level}/${col}_${row}.${extension}` });
    }
  }
  return tiles;
}

// The texture a mesh is drawn with: its tiles composited into one rectangle of level pixels
// [x0, x1) × [y0, y1). The listed tiles are used as long as that rectangle fits `maxSize`; a
// geomorph between distant views can list far more than that (the source region of both views at
// the finer view's level), and then the viewer takes coarser levels until it fits, so the picture
// is blurred during that one animation instead of failing.
export function planAtlas(mesh, maxSize) {
  let tiles = mesh.tiles;
  const extension = tiles[0].url.split('.').pop();
  for (;;) {
    const atlas = boundingRect(mesh.image, tiles);
    const level = tiles[0].level;
    if ((atlas.x1 - atlas.x0 <= maxSize && atlas.y1 - atlas.y0 <= maxSize) || level === 0) {
      return { ...atlas, level, tiles, scale: levelScale(mesh.image, level) };
    }
    tiles = tilesCovering(mesh.image, level - 1, sourceBounds(mesh), extension);
  }
}

function boundingRect(image, tiles) {
  const box = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
  for (const tile of tiles) {
    const r = tileRect(image, tile);
    box.x0 = Math.min(box.x0, r.x0);
    box.y0 = Math.min(box.y0, r.y0);
    box.x1 = Math.max(box.x1, r.x1);
    box.y1 = Math.max(box.y1, r.y1);
  }
  return box;
}

// Per vertex, its source position as atlas texture coordinates (0…1, texel centres at +0.5 like
// the server's bilinear sampling).
export function textureCoordinates(mesh, atlas) {
  const out = new Float32Array(mesh.source.length);
  const width = atlas.x1 - atlas.x0;
  const height = atlas.y1 - atlas.y0;
  for (let i = 0; i < out.length; i += 2) {
    out[i] = (mesh.source[i] * atlas.scale - atlas.x0) / width;
    out[i + 1] = (mesh.source[i + 1] * atlas.scale - atlas.y0) / height;
  }
  return out;
}

// Bounding box of the mesh's source positions, full-resolution pixels.
function sourceBounds(mesh) {
  const box = { u0: Infinity, v0: Infinity, u1: -Infinity, v1: -Infinity };
  for (let i = 0; i < mesh.source.length; i += 2) {
    box.u0 = Math.min(box.u0, mesh.source[i]);
    box.u1 = Math.max(box.u1, mesh.source[i]);
    box.v0 = Math.min(box.v0, mesh.source[i + 1]);
    box.v1 = Math.max(box.v1, mesh.source[i + 1]);
  }
  return box;
}

// Where point p lies in the mesh whose vertex positions are `positions` (interleaved x, y): the
// triangle and the barycentric weights of its three vertices, or null outside every triangle.
// A linear scan: it runs once per pointer gesture or per mesh, not per frame.
export function locate(triangles, positions, [px, py]) {
  for (let t = 0; t < triangles.length; t += 3) {
    const [a, b, c] = [triangles[t], triangles[t + 1], triangles[t + 2]];
    const weights = barycentric(positions, a, b, c, px, py);
    if (weights) return { vertices: [a, b, c], weights };
  }
  return null;
}

// Tolerance on the barycentric weights so a point on a shared edge is found in either triangle.
const EDGE_TOLERANCE = 1e-9;

function barycentric(p, a, b, c, px, py) {
  const [ax, ay, bx, by, cx, cy] = [p[2 * a], p[2 * a + 1], p[2 * b], p[2 * b + 1], p[2 * c], p[2 * c + 1]];
  const area = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
  if (area === 0) return null;
  const wa = ((bx - px) * (cy - py) - (cx - px) * (by - py)) / area;
  const wb = ((cx - px) * (ay - py) - (ax - px) * (cy - py)) / area;
  const wc = 1 - wa - wb;
  if (wa < -EDGE_TOLERANCE || wb < -EDGE_TOLERANCE || wc < -EDGE_TOLERANCE) return null;
  return [wa, wb, wc];
}

// The position a location (from locate()) has in another set of vertex positions.
export function positionAt(location, positions) {
  let x = 0;
  let y = 0;
  location.vertices.forEach((v, k) => {
    x += location.weights[k] * positions[2 * v];
    y += location.weights[k] * positions[2 * v + 1];
  });
  return [x, y];
}

// Screen pixels per source pixel of the triangle under screen point p (null outside the mesh):
// how far the picture moves there when the view centre moves by one source pixel.
export function magnificationAt(mesh, p) {
  const location = locate(mesh.triangles, mesh.screen, p);
  if (!location) return null;
  const [a, b, c] = location.vertices;
  const area = (positions) => Math.abs(
    (positions[2 * b] - positions[2 * a]) * (positions[2 * c + 1] - positions[2 * a + 1]) -
    (positions[2 * c] - positions[2 * a]) * (positions[2 * b + 1] - positions[2 * a + 1]));
  const sourceArea = area(mesh.source);
  return sourceArea > 0 ? Math.sqrt(area(mesh.screen) / sourceArea) : null;
}
