#include "warp/methods/seam/seam_carving.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "warp/core/uniform_zoom.h"
#include "warp/methods/seam/seam_resolution.h"
#include "warp/render/level_patch.h"

namespace zoomwarp::warp {

namespace {

void put_int(std::string& out, std::int32_t v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }

void put_map(std::string& out, const VisibilityMap& m) {
  put_int(out, m.length), put_int(out, m.lines), put_int(out, m.depth);
  out.append(reinterpret_cast<const char*>(m.order.data()), m.order.size() * sizeof(std::uint16_t));
}

// Reads what put_map wrote from the front of `bytes`, checking every size before using it.
VisibilityMap take_map(std::string_view& bytes) {
  std::int32_t head[3];
  if (bytes.size() < sizeof head) throw std::runtime_error("truncated");
  std::memcpy(head, bytes.data(), sizeof head);
  bytes.remove_prefix(sizeof head);
  VisibilityMap m;
  m.length = head[0], m.lines = head[1], m.depth = head[2];
  if (m.length < 1 || m.lines < 1 || m.length > 65535 || m.lines > 65535) throw std::runtime_error("bad map size");
  const std::size_t n = std::size_t(m.length) * std::size_t(m.lines);
  if (bytes.size() < n * sizeof(std::uint16_t)) throw std::runtime_error("truncated");
  m.order.resize(n);
  std::memcpy(m.order.data(), bytes.data(), n * sizeof(std::uint16_t));
  bytes.remove_prefix(n * sizeof(std::uint16_t));
  if (const std::string problem = check_visibility_map(m); !problem.empty())
    throw std::runtime_error("visibility map: " + problem);
  return m;
}

std::unique_ptr<Retargeter> load(const ImageModel& model, const SignificanceMap&, std::string_view bytes) {
  VisibilityMaps maps = parse_visibility_maps(bytes);
  // The maps are the analysis image's reduced (seam_resolution.h); the significance map is made
  // from the analysis image pixel for pixel.
  const SignificanceMap& analysis = model.significance;
  if (!seam_maps_fit(maps, analysis.width, analysis.height))
    throw std::runtime_error("visibility maps made for another image size");
  return std::make_unique<SeamCarving>(model.width, model.height, std::move(maps));
}

}  // namespace

const RetargetingMethod& seam_carving_method() {
  static const RetargetingMethod kSeam{
      .name = "seam",
      .summary = "Seam carving [Avidan07] through liblqr: the least significant 8-connected seams of pixels are "
                 "removed until the image has the screen's aspect ratio (saliency protects what matters); no mesh.",
      .zoom = "zoom=0 shows the whole image carved to the screen's aspect ratio (pixels removed along one axis, never "
              "added); zoom=1 is 1:1 of the carved image; in between, traditional zoom into it, centred on the view "
              "centre's position in the carved image. Equal aspect ratios carve nothing.",
      .has_mesh = false,
      .magic = {'Z', 'W', 'S', 'E', 'A', 'M', '1', 0},
      .precompute =
          [](const MethodInput& in) {
            return visibility_map_bytes(compute_seam_maps(in.analysis_image, in.saliency));
          },
      .precompute_bytes_per_pixel = 48,  // liblqr's carver, one axis at a time, and the bias: 42-45 MB at 996×934
      .load = load,
  };
  return kSeam;
}

std::string visibility_map_bytes(const VisibilityMaps& maps) {
  std::string out;
  put_map(out, maps.horizontal);
  put_map(out, maps.vertical);
  return out;
}

VisibilityMaps parse_visibility_maps(std::string_view bytes) {
  VisibilityMaps maps;
  maps.horizontal = take_map(bytes);
  maps.vertical = take_map(bytes);
  if (!bytes.empty()) throw std::runtime_error("trailing bytes");
  if (maps.vertical.length != maps.horizontal.lines || maps.vertical.lines != maps.horizontal.length)
    throw std::runtime_error("the two visibility maps are of different images");
  return maps;
}

int CarvedImage::line_at(double across) const {
  const double across_length = vertical ? width : height;
  return std::clamp(int(std::floor(across * analysis_lines / across_length)), 0, analysis_lines - 1);
}

CarvedImage::Kept CarvedImage::kept_at(double along) const {
  // The kept positions fill the target evenly; the fraction within one is carried through.
  const int n = table->kept;
  const double u = std::clamp(along * n / (vertical ? height : width), 0.0, double(n));
  const int j = std::min(int(u), n - 1);
  return {j, u - j};
}

double CarvedImage::source_along(int line, const Kept& kept) const {
  return (table->line(line)[kept.index] + kept.fraction) * source_length / analysis_length;
}

Point CarvedImage::to_source(const Point& p) const {
  const double along = vertical ? p.y : p.x, across = vertical ? p.x : p.y;
  const double source = source_along(line_at(across), kept_at(along));
  return vertical ? Point{across, source} : Point{source, across};
}

CarvedImage::Box CarvedImage::source_box(double x0, double y0, double x1, double y1) const {
  const double along0 = vertical ? y0 : x0, along1 = vertical ? y1 : x1;
  const double across0 = vertical ? x0 : y0, across1 = vertical ? x1 : y1;
  const int j0 = kept_at(along0).index, j1 = kept_at(along1).index;
  const double unit = source_length / analysis_length;
  // Kept positions increase along a line: its first and last visible ones bound it.
  double source0 = source_length, source1 = 0;
  for (int l = line_at(across0), last = line_at(across1); l <= last; ++l) {
    source0 = std::min(source0, table->line(l)[j0] * unit);
    source1 = std::max(source1, (table->line(l)[j1] + 1) * unit);
  }
  return vertical ? Box{across0, source0, across1, source1} : Box{source0, across0, source1, across1};
}

Point CarvedImage::from_source(const Point& p) const {
  const double along = vertical ? p.y : p.x, across = vertical ? p.x : p.y;
  const double target = vertical ? height : width, across_length = vertical ? width : height;
  const int line = std::clamp(int(std::floor(across * analysis_lines / across_length)), 0, analysis_lines - 1);
  const int n = table->kept;
  const double a = std::clamp(along * analysis_length / source_length, 0.0, double(analysis_length));
  const int position = std::min(int(a), analysis_length - 1);
  const std::uint16_t* kept = table->line(line);
  const int j = int(std::lower_bound(kept, kept + n, position) - kept);
  const double u = j < n && kept[j] == position ? j + (a - position) : j;
  const double carved = u * target / n;
  return vertical ? Point{across, carved} : Point{carved, across};
}

SeamCarving::SeamCarving(double width, double height, VisibilityMaps maps)
    : width_(width), height_(height), maps_(std::move(maps)) {
  if (!(width_ >= 1 && height_ >= 1)) throw std::invalid_argument("seam carving of an empty image");
}

View SeamCarving::view(const ViewRequest&) {
  throw NoMesh("method=seam carves pixels away and has no mesh; use /viewport?method=seam");
}

std::shared_ptr<const CarveTable> SeamCarving::table(bool vertical, int seams) {
  std::lock_guard lock(mu_);
  if (const auto* cached = tables_.find({vertical, seams})) return *cached;
  return tables_.put({vertical, seams},
                     std::make_shared<const CarveTable>(carve(vertical ? maps_.vertical : maps_.horizontal, seams)));
}

CarvedImage SeamCarving::carved(double sw, double sh) {
  CarvedImage c;
  // Removal only [Avidan07 §4]: the side that is too long for the target's aspect shrinks.
  c.vertical = width_ * sh < height_ * sw;
  c.width = c.vertical ? width_ : std::min(width_, height_ * sw / sh);
  c.height = c.vertical ? std::min(height_, width_ * sh / sw) : height_;
  const VisibilityMap& map = c.vertical ? maps_.vertical : maps_.horizontal;
  c.source_length = c.vertical ? height_ : width_;
  c.analysis_length = map.length;
  c.analysis_lines = map.lines;
  const double target = c.vertical ? c.height : c.width;
  // Beyond the recorded seams (a tenth of the side, or none where liblqr could not carve), carve
  // to the floor and let the kept positions stretch over the target: scaling (ours).
  const long long wanted = map.length - std::llround(target * map.length / c.source_length);
  c.seams = int(std::clamp<long long>(wanted, 0, map.depth));
  c.table = table(c.vertical, c.seams);
  return c;
}

SeamCarving::ScreenLayout SeamCarving::layout(const ViewRequest& r) {
  check_view_request(r);
  const int sw = r.screen_width, sh = r.screen_height;
    // The target is the screen's shape, or the frame's aspect (fit=auto, warp/window/fit.h).
  const bool framed = frame_aspect(r.frame, sw, sh) != double(sw) / sh;
  ScreenLayout out{framed ? carved(r.frame.aspect, 1) : carved(sw, sh), {}, {}, {}, {}};
  const CarvedImage& c = out.carved;
  // Traditional zoom into the carved image [ICAZ §6.1]: its rectangle through core's geometry.
  const Mesh rect{{{0, 0}, {c.width, 0}, {c.width, c.height}, {0, c.height}}, {{0, 1, 2}, {0, 2, 3}}};
  out.zoom = uniform_zoom(rect, rect.vertices, c.width, c.height, r, c.from_source({r.cx, r.cy}));
  const View& v = out.zoom;
  const double scale = v.geometry.screen_scale;
  const double target = c.vertical ? c.height : c.width, across_length = c.vertical ? c.width : c.height;
  const auto carved_at = [&](int i, bool y_axis) { return (y_axis ? v.view_y : v.view_x) + (i + 0.5) / scale; };
  const int along_count = c.vertical ? sh : sw, across_count = c.vertical ? sw : sh;
  out.kept.resize(along_count);
  for (int i = 0; i < along_count; ++i) {
    const double t = carved_at(i, c.vertical);
    out.kept[i] = t < 0 || t > target ? CarvedImage::Kept{-1, 0} : c.kept_at(t);
  }
  out.line.assign(across_count, -1);
  out.across.resize(across_count);
  for (int i = 0; i < across_count; ++i) {
    out.across[i] = carved_at(i, !c.vertical);
    if (out.across[i] >= 0 && out.across[i] <= across_length) out.line[i] = c.line_at(out.across[i]);
  }
  return out;
}

bool SeamCarving::ScreenLayout::source_of(int x, int y, Point* p) const {
  const int a = carved.vertical ? y : x, b = carved.vertical ? x : y;
  if (kept[a].index < 0 || line[b] < 0) return false;
  const double source = carved.source_along(line[b], kept[a]);
  *p = carved.vertical ? Point{across[b], source} : Point{source, across[b]};
  return true;
}

tiles::Raster SeamCarving::render(const ViewRequest& r, const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const ScreenLayout s = layout(r);
  const CarvedImage& c = s.carved;
  const View& v = s.zoom;
  const int sw = r.screen_width, sh = r.screen_height;
  const double scale = v.geometry.screen_scale;

  // The carved rectangle on screen, and the source box its kept positions come from.
  const double x0 = std::max(0.0, v.view_x), x1 = std::min(c.width, v.view_x + sw / scale);
  const double y0 = std::max(0.0, v.view_y), y1 = std::min(c.height, v.view_y + sh / scale);
  const CarvedImage::Box box = c.source_box(x0, y0, x1, y1);
  const double target = c.vertical ? c.height : c.width;
  const double unit = c.source_length / c.analysis_length;  // image px per analysis position

  // One level for the screen: the finer of the two axes' magnifications decides, so neither
  // is minified by more than 2× (render/level_patch.h).
  const double along_magnification = scale * (target / c.table->kept) / unit;
  const tiles::Manifest& m = image.manifest;
  const int level = level_for(std::max(scale, along_magnification), m.levels);
  const LevelPatch patch = read_patch(image, reader, level, box.u0, box.v0, box.u1, box.v1);

  // Outside the carved image (letterbox: it is smaller than the screen) nothing is drawn.
  tiles::Raster out(sw, sh, m.channels);
  for (int y = 0; y < sh; ++y) {
    check_stop(r.stop);
    std::uint8_t* row = out.row(y);
    for (int x = 0; x < sw; ++x) {
      Point p;
      if (s.source_of(x, y, &p)) patch.sample(p.x, p.y, row + std::size_t(x) * m.channels);
    }
  }
  return out;
}

std::vector<Point> SeamCarving::screen_sources(const ViewRequest& r) {
  const ScreenLayout s = layout(r);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Point> out(std::size_t(r.screen_width) * r.screen_height, Point{nan, nan});
  for (int y = 0; y < r.screen_height; ++y)
    for (int x = 0; x < r.screen_width; ++x) s.source_of(x, y, &out[std::size_t(y) * r.screen_width + x]);
  return out;
}

std::size_t SeamCarving::memory_bytes() {
  std::size_t bytes = (maps_.horizontal.order.size() + maps_.vertical.order.size()) * sizeof(std::uint16_t);
  return bytes + tables_.bytes();
}

}  // namespace zoomwarp::warp
