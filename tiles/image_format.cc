#include "tiles/image_format.h"

namespace zoomwarp::tiles {

std::optional<ImageFormat> format_from_extension(std::string_view ext) {
  if (ext == "jpg" || ext == "jpeg") return ImageFormat::kJpeg;
  if (ext == "png") return ImageFormat::kPng;
  if (ext == "webp") return ImageFormat::kWebp;
  if (ext == "avif") return ImageFormat::kAvif;
  if (ext == "jxl") return ImageFormat::kJxl;
  return std::nullopt;
}

std::string_view mime_type(ImageFormat f) {
  switch (f) {
    case ImageFormat::kJpeg: return "image/jpeg";
    case ImageFormat::kPng: return "image/png";
    case ImageFormat::kWebp: return "image/webp";
    case ImageFormat::kAvif: return "image/avif";
    case ImageFormat::kJxl: return "image/jxl";
  }
  return "application/octet-stream";
}

std::string_view extension(ImageFormat f) {
  switch (f) {
    case ImageFormat::kJpeg: return "jpg";
    case ImageFormat::kPng: return "png";
    case ImageFormat::kWebp: return "webp";
    case ImageFormat::kAvif: return "avif";
    case ImageFormat::kJxl: return "jxl";
  }
  return "";
}

}  // namespace zoomwarp::tiles
