// The 2D canvas over the WebGL one: the image's line constraints where the warp puts them, the
// suggested lines of the line editor (dashed, numbered), the rectangle or segment being drawn with
// a curator tool, and the panes' divider and labels in the side-by-side mode. A pane showing a
// /viewport image (a method without mesh) gets no lines: its picture maps no source point to the
// screen.

import { locate, positionAt } from './geometry.js';

// Points per line: the warp bends a straight source segment only where it crosses triangles of
// different shape, and the server keeps constrained lines straight, so a few suffice.
const SAMPLES_PER_LINE = 16;

// The curator's lines solid yellow; suggestions dashed magenta, so neither is taken for the other.
const LINE_STYLE = { color: 'rgba(255, 200, 0, 0.9)', dash: [] };
const SUGGESTION_STYLE = { color: 'rgba(255, 70, 200, 0.95)', dash: [8, 5], numbered: true };

export class Overlay {
  constructor(canvas) {
    this.canvas = canvas;
    this.context = canvas.getContext('2d');
    this.anchors = new WeakMap();  // pane.shown → Map(lines → anchors): line points located in that mesh
  }

  // panes: the viewer's panes; lines, suggested: [[x0, y0, x1, y1], …] in source pixels;
  // highlight: the index of a suggestion to draw thicker, or null; sketch: null or
  // {tool: 'important' | 'line', start: [x, y], end: [x, y]} in canvas CSS pixels.
  draw({ width, height, pixelRatio, panes, lines, suggested = [], highlight = null, sketch, now }) {
    const c = this.context;
    const [deviceWidth, deviceHeight] = [Math.round(width * pixelRatio), Math.round(height * pixelRatio)];
    if (this.canvas.width !== deviceWidth) this.canvas.width = deviceWidth;  // resizing clears: only on change
    if (this.canvas.height !== deviceHeight) this.canvas.height = deviceHeight;
    c.setTransform(pixelRatio, 0, 0, pixelRatio, 0, 0);
    c.clearRect(0, 0, width, height);
    for (const pane of panes) {
      this.drawLines(pane, lines, now, LINE_STYLE);
      this.drawLines(pane, suggested, now, { ...SUGGESTION_STYLE, highlight });
    }
    if (panes.length > 1) this.drawComparison(panes, height);
    if (sketch) this.drawSketch(sketch);
  }

  drawLines(pane, lines, now, style) {
    if (!pane.mapsSource() || lines.length === 0) return;
    const positions = pane.positions(now);
    const c = this.context;
    c.save();
    c.beginPath();
    c.rect(pane.rect.x, pane.rect.y, pane.rect.width, pane.rect.height);
    c.clip();
    c.translate(pane.rect.x, pane.rect.y);
    c.strokeStyle = c.fillStyle = style.color;
    c.setLineDash(style.dash);
    c.font = 'bold 13px system-ui, sans-serif';
    this.lineAnchors(pane.shown, lines).forEach((anchors, index) => {
      c.lineWidth = index === style.highlight ? 5 : 2;
      c.beginPath();
      // A line leaving the drawn mesh (off screen) is broken there rather than cut across.
      let drawing = false;
      for (const anchor of anchors) {
        if (!anchor) {
          drawing = false;
          continue;
        }
        const [x, y] = positionAt(anchor, positions);
        if (drawing) c.lineTo(x, y);
        else c.moveTo(x, y);
        drawing = true;
      }
      c.stroke();
      // Numbered as the line editor lists them, at the middle sample when it is on screen.
      const middle = anchors[SAMPLES_PER_LINE / 2];
      if (style.numbered && middle) c.fillText(String(index + 1), ...positionAt(middle, positions).map((v) => v + 4));
    });
    c.restore();
  }

  // Each line's sample points located in the mesh's source positions, once per mesh and lines:
  // every frame of an animation then only mixes the current vertex positions.
  lineAnchors(shown, lines) {
    if (!this.anchors.has(shown)) this.anchors.set(shown, new Map());
    const cache = this.anchors.get(shown);
    if (cache.has(lines)) return cache.get(lines);
    const { triangles, source } = shown.mesh;
    const anchors = lines.map(([x0, y0, x1, y1]) => Array.from({ length: SAMPLES_PER_LINE + 1 }, (_, k) => {
      const s = k / SAMPLES_PER_LINE;
      return locate(triangles, source, [x0 + (x1 - x0) * s, y0 + (y1 - y0) * s]);
    }));
    cache.set(lines, anchors);
    return anchors;
  }

  // A divider between the panes and each one's method and saliency in its bottom-left corner.
  drawComparison(panes, height) {
    const c = this.context;
    c.fillStyle = '#fff';
    for (const pane of panes.slice(1)) c.fillRect(pane.rect.x - 1, 0, 2, height);
    c.font = '13px system-ui, sans-serif';
    c.textBaseline = 'bottom';
    for (const pane of panes) {
      const x = pane.rect.x + 8;
      const y = pane.rect.y + pane.rect.height - 8;
      c.fillStyle = 'rgba(20, 20, 20, 0.8)';
      c.fillRect(x - 4, y - 18, c.measureText(pane.label).width + 8, 20);
      c.fillStyle = '#eee';
      c.fillText(pane.label, x, y);
    }
  }

  drawSketch({ tool, start, end }) {
    const c = this.context;
    c.lineWidth = 2;
    c.setLineDash([6, 4]);
    c.strokeStyle = tool === 'line' ? 'rgba(255, 200, 0, 1)' : 'rgba(80, 220, 255, 1)';
    c.beginPath();
    if (tool === 'line') {
      c.moveTo(...start);
      c.lineTo(...end);
    } else {
      c.rect(start[0], start[1], end[0] - start[0], end[1] - start[1]);
    }
    c.stroke();
    c.setLineDash([]);
  }
}
