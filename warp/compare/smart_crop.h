// What a user picks instead of a warp (issue 41): a smart crop as imgproxy, thumbor and libvips'
// `smartcrop --interesting attention` make it — the image scaled to cover the screen and cut to
// it around where attention is. The attention map after libvips' (conversion/smartcrop.c, by
// J. Cupitt after sharp's): in CIELAB, |Sobel_x L| + |Sobel_y L|, plus 255 on skin tones
// (3 ≤ a ≤ 22, 4 ≤ b ≤ 31, L ≥ 15), plus 255 on saturated colour (chroma > 60); averaged down to
// 32 × 32, blurred with σ = |crop in those cells| / 6, and the crop centred on its maximum,
// clipped to the image. `zoomwarp compare` shows it as a row of its sheet; tests/bench/squash.py
// runs libvips' own for the figures of docs/compare.md.
//
// Plain function; thread-safe.
#pragma once

#include "tiles/raster.h"
#include "warp/core/mesh.h"

namespace zoomwarp::warp {

// The crop's centre (image px) for a screen of sw × sh on a W × H image, from `image`, the whole
// image at any reduced resolution (RGB or RGBA; grey has no skin or colour: edges only). The crop
// itself is the screen's shape covering the image's short side: sw/s × sh/s, s = max(sw/W, sh/H).
Point attention_crop_centre(const tiles::Raster& image, double W, double H, int sw, int sh);

}  // namespace zoomwarp::warp
