// The XML S3 and STS answer with, read with expat (issue 29; STS for credentials, issue 42).
// Thread-safe: no state.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace zoomwarp::tiles {

// Calls on_end(path, text) at the end of every element, path the element names from the root
// joined by '/' ("ListBucketResult/Contents/Key"), text the character data directly inside it.
// S3's documents are small and flat, so this is all the structure they need. Namespaces are not
// processed (S3's default namespace is only an attribute here), and a document type declaration
// stops the parse: S3 never sends one, and entities are the usual way to abuse an XML parser.
// Returns false for a malformed document.
bool parse_xml(std::string_view xml, const std::function<void(const std::string& path, std::string& text)>& on_end);

}  // namespace zoomwarp::tiles
