#!/usr/bin/python3
"""Issue 41's squash measures of a running server's views, under a saliency model no method
optimises: spectral residual [Hou07] on a 128-px thumbnail, its top fifth of pixels the salient
part. Per view (GET /mesh at zoom 0, centred, for each method x fit x screen):

  anisotropy p90 / p99   sigma1/sigma2 of the affine map (source -> screen) of the triangle holding
                         each salient thumbnail pixel whose centre lands on the screen (equal
                         weights: source area);
  coverage               the share of the salient part's saliency mass that lands on the screen.

Beside them, per image and screen: a uniform stretch of the whole image (its anisotropy), and
libvips' attention smart crop (`vips smartcrop --interesting attention` after scaling to cover the
screen; anisotropy 1) with its coverage, and the coverage of the best undistorted window as wide
as fit=auto's budget allows, placed by this map itself (an oracle: no placement of a window that
wide beats it). Needs python3-numpy, python3-pil and libvips-tools.

  tests/bench/squash.py --url http://127.0.0.1:8080 ID=FILE ... [--sizes 360x640,640x360]
      [--methods icaz,retarget-zoom,patch,mp,polyfem] [--fits auto,warp] [--budget 1.4] [--json out.json]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import urllib.request

import numpy as np
from PIL import Image


def spectral_residual(path, side=128):
    """Hou & Zhang 2007 on a thumbnail whose long side is `side`: returns (map, thumb_w, thumb_h)."""
    img = Image.open(path).convert("L")
    w, h = img.size
    f = min(1.0, side / max(w, h))  # never enlarged
    tw, th = max(1, round(w * f)), max(1, round(h * f))
    g = np.asarray(img.resize((tw, th), Image.BOX), dtype=np.float64)  # cell means, as OpenCV's INTER_AREA
    spectrum = np.fft.fft2(g)
    log_amp = np.log(np.abs(spectrum) + 1e-9)
    phase = np.angle(spectrum)
    pad = np.pad(log_amp, 1, mode="edge")
    mean3 = sum(pad[dy:dy + th, dx:dx + tw] for dy in range(3) for dx in range(3)) / 9.0
    sal = np.abs(np.fft.ifft2(np.exp(log_amp - mean3 + 1j * phase))) ** 2
    # Gaussian blur, sigma 3 thumbnail px (separable, edge-padded)
    r = 9
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / 3.0) ** 2)
    k /= k.sum()
    sal = np.apply_along_axis(lambda v: np.convolve(np.pad(v, r, mode="edge"), k, "valid"), 1, sal)
    sal = np.apply_along_axis(lambda v: np.convolve(np.pad(v, r, mode="edge"), k, "valid"), 0, sal)
    return sal / sal.max(), tw, th


def salient_points(sal, tw, th, W, H):
    """Centres (image px) and values of the top fifth of the map's pixels."""
    flat = sal.ravel()
    k = max(1, int(np.ceil(flat.size * 0.2)))
    idx = np.argpartition(-flat, k - 1)[:k]
    ys, xs = np.divmod(idx, tw)
    pts = np.stack([(xs + 0.5) * W / tw, (ys + 0.5) * H / th], axis=1)
    return pts, flat[idx]


def get_json(url):
    with urllib.request.urlopen(url, timeout=600) as r:
        return json.loads(r.read())


def mesh_measures(mesh, pts, mass, sw, sh):
    verts = np.asarray(mesh["vertices"], dtype=np.float64)
    tris = np.asarray(mesh["triangles"], dtype=np.int64)
    aniso_of = np.full(len(pts), np.nan)
    screen = np.full((len(pts), 2), np.nan)
    if len(tris):
        src, scr = verts[:, :2], verts[:, 2:]
        for t in tris:
            a, b, c = src[t]
            lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
            sel = np.where((pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0]) & (pts[:, 1] >= lo[1]) & (pts[:, 1] <= hi[1])
                           & np.isnan(aniso_of))[0]
            if not len(sel):
                continue
            E = np.array([b - a, c - a]).T
            det = np.linalg.det(E)
            if det == 0:
                continue
            lam = np.linalg.solve(E, (pts[sel] - a).T).T
            inside = (lam[:, 0] >= -1e-9) & (lam[:, 1] >= -1e-9) & (lam.sum(axis=1) <= 1 + 1e-9)
            sel, lam = sel[inside], lam[inside]
            if not len(sel):
                continue
            a2, b2, c2 = scr[t]
            F = np.array([b2 - a2, c2 - a2]).T
            M = F @ np.linalg.inv(E)
            s = np.linalg.svd(M, compute_uv=False)
            aniso_of[sel] = s[0] / s[1] if s[1] > 0 else np.inf
            screen[sel] = a2 + lam @ F.T
    on = (~np.isnan(screen[:, 0])) & (screen[:, 0] >= 0) & (screen[:, 0] <= sw) & (screen[:, 1] >= 0) & (screen[:, 1] <= sh)
    coverage = mass[on].sum() / mass.sum()
    shown = aniso_of[on]
    if not len(shown):
        return None, None, coverage
    return float(np.percentile(shown, 90)), float(np.percentile(shown, 99)), float(coverage)


def smart_crop_coverage(path, W, H, sw, sh, pts, mass):
    s = max(sw / W, sh / H)
    cw, ch = min(W, sw / s), min(H, sh / s)
    with tempfile.TemporaryDirectory() as d:
        small = os.path.join(d, "small.v")
        f = min(1.0, 1024 / max(W, H))
        subprocess.run(["vips", "resize", path, small, str(f)], check=True)
        out = os.path.join(d, "crop.v")
        subprocess.run(["vips", "smartcrop", small, out, str(max(1, int(cw * f))), str(max(1, int(ch * f))),
                        "--interesting", "attention"], check=True)
        x = abs(int(subprocess.run(["vipsheader", "-f", "xoffset", out], capture_output=True, text=True).stdout)) / f
        y = abs(int(subprocess.run(["vipsheader", "-f", "yoffset", out], capture_output=True, text=True).stdout)) / f
    inside = (pts[:, 0] >= x) & (pts[:, 0] <= x + cw) & (pts[:, 1] >= y) & (pts[:, 1] <= y + ch)
    return float(mass[inside].sum() / mass.sum())


def best_window_coverage(W, H, sw, sh, pts, mass, budget):
    """The most salient mass any undistorted window that fit=auto's budget allows could show: a
    window (along the long axis) budget times the screen-shaped crop's length, placed by this map
    itself — an oracle, not a method: what no placement of a window that wide can beat."""
    wide = (W / H) > (sw / sh)
    change = max((W / H) / (sw / sh), (sw / sh) / (W / H))
    extent = W if wide else H
    length = extent * min(1.0, budget / change)
    along = pts[:, 0] if wide else pts[:, 1]
    order = np.argsort(along)
    x, m = along[order], np.concatenate([[0.0], np.cumsum(mass[order])])
    best = 0.0
    for start in np.linspace(0, extent - length, 257):
        lo, hi = np.searchsorted(x, start, "left"), np.searchsorted(x, start + length, "right")
        best = max(best, m[hi] - m[lo])
    return float(best / m[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("images", nargs="+", help="ID=FILE: an image the server has, and its source file")
    ap.add_argument("--url", default="http://127.0.0.1:8080")
    ap.add_argument("--sizes", default="360x640,640x360")
    ap.add_argument("--methods", default="icaz,retarget-zoom,patch,mp,polyfem")
    ap.add_argument("--fits", default="auto,warp", help="fit= values; auto@B also sets max_distortion=B")
    ap.add_argument("--json", help="also write every row to this file")
    ap.add_argument("--budget", type=float, default=1.4, help="fit=auto's budget for the best-window ceiling")
    a = ap.parse_args()
    rows = []
    print("| image | screen | stretch | smart crop cov | best window cov | method | fit | p90 | p99 | coverage | cov / crop |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for item in a.images:
        ident, path = item.split("=", 1)
        info = get_json(f"{a.url}/v1/images/{ident}")
        W, H = info["width"], info["height"]
        sal, tw, th = spectral_residual(path)
        pts, mass = salient_points(sal, tw, th, W, H)
        for size in a.sizes.split(","):
            sw, sh = map(int, size.split("x"))
            stretch = max((W / H) / (sw / sh), (sw / sh) / (W / H))
            crop = smart_crop_coverage(path, W, H, sw, sh, pts, mass)
            best = best_window_coverage(W, H, sw, sh, pts, mass, a.budget)
            for method in a.methods.split(","):
                for fit in a.fits.split(","):
                    name, _, budget = fit.partition("@")  # "auto@2" asks for max_distortion=2
                    query = f"zoom=0&w={sw}&h={sh}&method={method}&fit={name}" + (f"&max_distortion={budget}" if budget else "")
                    mesh = get_json(f"{a.url}/v1/images/{ident}/mesh?{query}")
                    p90, p99, cov = mesh_measures(mesh, pts, mass, sw, sh)
                    row = dict(image=ident, screen=size, stretch=stretch, smart_crop_coverage=crop,
                               best_window_coverage=best, method=method, fit=fit, p90=p90, p99=p99, coverage=cov)
                    rows.append(row)
                    fmt = lambda v: "—" if v is None else f"{v:.2f}"
                    print(f"| {ident} | {size} | {stretch:.2f} | {crop:.2f} | {best:.2f} | {method} | {fit} | {fmt(p90)} | {fmt(p99)} "
                          f"| {cov:.2f} | {cov / crop:.2f} |", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
