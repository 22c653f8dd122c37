// Image ids name folders in the store, so they are validated before they touch a path:
// 1–128 characters from [A-Za-z0-9._-], starting with a letter or digit, never "..".
#pragma once

#include <string>
#include <string_view>

namespace zoomwarp::tiles {

inline constexpr std::size_t kMaxImageIdLength = 128;

bool is_valid_image_id(std::string_view id);

// A valid id made from a file name's stem ("My photo (1).JPG" -> "My_photo_1"); empty if nothing
// usable is left.
std::string image_id_from_filename(std::string_view filename);

}  // namespace zoomwarp::tiles
