// Files compiled into the binary (api/CMakeLists.txt, cmake/embed_files.cmake): the OpenAPI
// document and the web viewer. Looked up by file name.
#pragma once

#include <optional>
#include <string_view>

namespace zoomwarp::api {

std::optional<std::string_view> asset(std::string_view file_name);

}  // namespace zoomwarp::api
