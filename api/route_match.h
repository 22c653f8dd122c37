// A request path matched against the route table's OpenAPI path templates (Router::routes()):
// "/dzi/{id}_files/{level}/{tile}" against the path's percent-decoded segments. A template
// segment may hold parameters between literals ("{id}.dzi", "{quality}.{format}"). Plain
// functions of plain data, thread-safe.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace zoomwarp::api {

// A matched route's parameters by template name, in template order; the names point into the
// (static) route table.
using PathParams = std::vector<std::pair<std::string_view, std::string>>;

// The decoded segments routes match against (a trailing slash ignored: "/v1/images/"); nullopt
// for a malformed path.
std::optional<std::vector<std::string>> route_segments(std::string_view path);

// Whether `segments` match the template `tmpl` (which starts with '/'); its parameters into
// `params` (cleared first). A parameter takes at least one character and runs to the next literal
// (the last occurrence for the template's last literal, so "a.b.png" against "{x}.{format}" gives
// x = "a.b").
bool match_path(std::string_view tmpl, const std::vector<std::string>& segments, PathParams& params);

// The parameter `name` of a matched route; the route's handler asks only for its template's
// own (std::logic_error otherwise: a bug in the table).
const std::string& param(const PathParams& params, std::string_view name);

}  // namespace zoomwarp::api
