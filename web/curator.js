// The curator's edits as the server takes them: significance regions and line constraints, in
// source pixels. Each publishes a new image version and answers with the image JSON.

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

export async function fetchLines(imageId) {
  // no-cache: the lines change under the same URL with every version.
  const response = await fetch(`/v1/images/${encodeURIComponent(imageId)}/lines`, { cache: 'no-cache' });
  if (!response.ok) throw new Error(`lines: HTTP ${response.status}`);
  return (await response.json()).lines;
}

export async function putLines(imageId, lines) {
  return send('PUT', `/v1/images/${encodeURIComponent(imageId)}/lines`, { lines });
}

async function send(method, url, body) {
  const response = await fetch(url, {
    method,
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  if (!response.ok) throw new Error(`${method} ${url}: HTTP ${response.status} ${await response.text()}`);
  return response.json();
}
