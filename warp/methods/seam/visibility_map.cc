#include "warp/methods/seam/visibility_map.h"

#include <lqr.h>

#include <algorithm>
#include <memory>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

using CarverPtr = std::unique_ptr<LqrCarver, decltype(&lqr_carver_destroy)>;

// liblqr's bias buffer: the saliency at every image pixel (nearest map pixel).
std::vector<gdouble> bias_of(const SignificanceMap& saliency, int width, int height) {
  std::vector<gdouble> out(std::size_t(width) * height, 0.0);
  if (saliency.width < 1 || saliency.height < 1) return out;
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(saliency.height - 1, int((y + 0.5) * saliency.height / height));
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(saliency.width - 1, int((x + 0.5) * saliency.width / width));
      out[std::size_t(y) * width + x] = saliency.at(sx, sy);
    }
  }
  return out;
}

// One axis's map: a carver resized by D seams along it with the visibility map dumped. Every
// liblqr call is checked; whatever fails leaves the axis not carvable (depth 0), which the
// request side handles by scaling instead.
VisibilityMap carve_axis(const tiles::Raster& image, const std::vector<gdouble>& bias, int bias_factor, bool vertical) {
  const int w = image.width, h = image.height;
  VisibilityMap out;
  out.length = vertical ? h : w;
  out.lines = vertical ? w : h;
  out.order.assign(std::size_t(w) * h, 0);
  const int depth = out.length * kRecordedSeamsPercent / 100;
  // A side of 1 px has nothing to remove, and liblqr 0.4.2 crashes (reads past its buffers)
  // carving an image of a single line — 2×1 … 1024×1 px, seen here: such an axis is not carved.
  if (depth < 1 || out.lines < 2 || image.channels < 1) return out;

  std::vector<guchar> pixels(image.pixels.begin(), image.pixels.end());
  CarverPtr carver(lqr_carver_new(pixels.data(), w, h, image.channels), &lqr_carver_destroy);
  if (!carver) return out;
  // The buffer stays ours (a std::vector, not g_malloc'd): liblqr must not free or alter it.
  lqr_carver_set_preserve_input_image(carver.get());
  if (lqr_carver_init(carver.get(), 1, 0) != LQR_OK) return out;
  if (lqr_carver_set_energy_function_builtin(carver.get(), LQR_EF_GRAD_NORM) != LQR_OK) return out;
  // liblqr adds the buffer into its own bias map and only reads it (its parameter is not const).
  if (bias_factor != 0 && lqr_carver_bias_add(carver.get(), const_cast<gdouble*>(bias.data()), bias_factor) != LQR_OK)
    return out;
  lqr_carver_set_dump_vmaps(carver.get());
  if (lqr_carver_resize(carver.get(), vertical ? w : w - depth, vertical ? h - depth : h) != LQR_OK) return out;

  LqrVMapList* list = lqr_vmap_list_start(carver.get());
  LqrVMap* vmap = list ? lqr_vmap_list_current(list) : nullptr;
  if (!vmap || lqr_vmap_get_width(vmap) != w || lqr_vmap_get_height(vmap) != h ||
      lqr_vmap_get_orientation(vmap) != (vertical ? 1 : 0) || lqr_vmap_get_depth(vmap) != depth)
    return out;
  const gint* data = lqr_vmap_get_data(vmap);
  if (!data) return out;
  VisibilityMap map = out;
  map.depth = depth;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const gint v = data[std::size_t(y) * w + x];
      if (v < 0) return out;
      // Carved down to one pixel, liblqr numbers the last one depth + 1 rather than 0: it is
      // not removed within the recorded depth either way.
      const std::size_t at = vertical ? std::size_t(x) * h + y : std::size_t(y) * w + x;
      map.order[at] = std::uint16_t(v > depth ? 0 : v);
    }
  return check_visibility_map(map).empty() ? map : out;
}

}  // namespace

VisibilityMaps compute_visibility_maps(const tiles::Raster& image, const SignificanceMap& saliency, int bias_factor) {
  if (image.width < 1 || image.height < 1) throw std::invalid_argument("visibility maps of an empty image");
  const std::vector<gdouble> bias = bias_of(saliency, image.width, image.height);
  // The axes are independent carvers, carved one after the other: in parallel they halved this
  // file's wall time on two cores but held two carvers (~20 MB each at 1024×576) at once, which
  // took a 100 MP ingest past its memory bound (tests/http/http_large_image_test.cc).
  VisibilityMap horizontal = carve_axis(image, bias, bias_factor, false);
  return {std::move(horizontal), carve_axis(image, bias, bias_factor, true)};
}

std::string check_visibility_map(const VisibilityMap& map) {
  if (map.length < 1 || map.lines < 1 || map.length > 65535 || map.lines > 65535) return "bad size";
  if (map.depth < 0 || map.depth >= map.length) return "bad depth";
  if (map.order.size() != std::size_t(map.length) * map.lines) return "size does not match its values";
  std::vector<int> seen(std::size_t(map.depth) + 1);
  for (int l = 0; l < map.lines; ++l) {
    std::fill(seen.begin(), seen.end(), 0);
    for (int p = 0; p < map.length; ++p) {
      const int v = map.at(l, p);
      if (v > map.depth) return "a value above the depth";
      if (v > 0 && seen[v]++) return "a seam crosses a line twice";
    }
    if (std::count(seen.begin() + 1, seen.end(), 1) != map.depth) return "a seam misses a line";
  }
  return "";
}

CarveTable carve(const VisibilityMap& map, int k) {
  if (k < 0 || k > map.depth) throw std::invalid_argument("more seams than the visibility map records");
  CarveTable out;
  out.kept = map.length - k;
  out.lines = map.lines;
  out.positions.resize(std::size_t(out.kept) * out.lines);
  for (int l = 0; l < map.lines; ++l) {
    std::uint16_t* kept = out.positions.data() + std::size_t(l) * out.kept;
    int j = 0;
    for (int p = 0; p < map.length; ++p) {
      const int v = map.at(l, p);
      if (v != 0 && v <= k) continue;
      // A checked map keeps exactly length − k per line; never write past the line regardless.
      if (j == out.kept) throw std::logic_error("a line keeps more positions than its carving allows");
      kept[j++] = std::uint16_t(p);
    }
    if (j != out.kept) throw std::logic_error("a line keeps fewer positions than its carving allows");
  }
  return out;
}

}  // namespace zoomwarp::warp
