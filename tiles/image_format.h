// The encoded formats the server answers in, by file extension and MIME type.
#pragma once

#include <optional>
#include <string_view>

namespace zoomwarp::tiles {

enum class ImageFormat { kJpeg, kPng, kWebp, kAvif, kJxl };

// "jpg"/"jpeg", "png", "webp", "avif", "jxl" -> format; anything else -> nullopt.
std::optional<ImageFormat> format_from_extension(std::string_view ext);
std::string_view mime_type(ImageFormat f);
std::string_view extension(ImageFormat f);

}  // namespace zoomwarp::tiles
