// The curator's description of an image: what IIIF Presentation 3.0 calls its descriptive and
// rights properties (§3.1, §3.3.3 of https://iiif.io/api/presentation/3.0/): label, summary,
// metadata pairs, rights and requiredStatement. It is the user's data, as lines and significance
// edits are: kept in the image version (description.json), set with the upload or by
// `PUT /v1/images/{id}/metadata`, carried into every later version — edits, and re-ingests that do
// not give a new one (tiles::IngestOptions::carry) — and served in the image's manifest
// (api/presentation.h).
//
// Text is held as IIIF language maps ({"en": ["Boats"], "none": ["…"]}); a body may give a plain
// string instead, which is the map {"none": [string]}. Plain data; no thread concerns.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "tiles/store.h"

namespace zoomwarp::api {

inline constexpr const char* kDescriptionFile = "description.json";
// A description's JSON is at most this long (413 description_too_large), and has at most this
// many metadata pairs (413 too_many_metadata): it travels inside every manifest.
inline constexpr std::size_t kMaxDescriptionBytes = 64 * 1024;
inline constexpr std::size_t kMaxMetadataPairs = 256;

// Language (a BCP 47 tag, or "none") → its values in the order given; languages sorted.
using LanguageMap = std::vector<std::pair<std::string, std::vector<std::string>>>;

struct LabelledValue {
  LanguageMap label;
  LanguageMap value;
};

struct Description {
  LanguageMap label;    // empty: none given (a manifest then shows the image's id)
  LanguageMap summary;  // empty: none
  std::vector<LabelledValue> metadata;
  // A Creative Commons licence or RightsStatements.org statement URI, as those specifications
  // spell them (http://…); empty: none.
  std::string rights;
  std::optional<LabelledValue> required_statement;  // e.g. {"Attribution": "Photo: …"}

  bool empty() const {
    return label.empty() && summary.empty() && metadata.empty() && rights.empty() && !required_statement;
  }
};

// {"label", "summary", "metadata": [{"label", "value"}, …], "rights", "requiredStatement":
// {"label", "value"}}, every member optional, no other member. Throws ApiError 400 invalid_body
// saying what is wrong (not JSON, an unknown member, a language tag that is not one, an empty
// value list, rights from neither vocabulary), 413 description_too_large (the body, or the
// description as stored, over kMaxDescriptionBytes) / too_many_metadata.
Description parse_description(std::string_view body);

// The canonical JSON of a description (every member present that is set; language maps as maps).
// parse_description(description_json(d)) == d for every d parse_description made (its languages
// sorted, as a JSON object's members are read).
std::string description_json(const Description& d);

// The fields an upload may set in its query string: label=, summary= (plain strings),
// rights= (a URI) and attribution= (the requiredStatement's value, labelled "Attribution"),
// laid over `base` (the description the image had, so that a re-upload giving only a label keeps
// the rest). Throws ApiError 400 for a rights URI from neither vocabulary, an empty value or one
// that is not UTF-8, 413 description_too_large when the result would be over kMaxDescriptionBytes.
Description description_with_upload_fields(Description base, const std::map<std::string, std::string>& fields);

// IngestOptions::carry (tiles/ingest.h) for an upload: the published version's description,
// with `fields` laid over it as description_with_upload_fields does (its errors are thrown when
// the ingest publishes: check the fields on an empty description before). No fields: the
// description's bytes as they are.
std::function<void(const tiles::ImageEntry* published, const tiles::VersionFiles& staged)> carry_description(
    std::map<std::string, std::string> fields = {});

// The description the version holds, or an empty one when it holds none. Throws
// std::runtime_error when description.json cannot be read or is damaged.
Description read_description(const tiles::ImageEntry& image);

// Publishes a new version of `current`'s image holding `d` (all else as in `current`), if the
// image is still at `current`'s version; throws tiles::VersionConflict if not, and
// std::runtime_error when the store fails. Nothing is published when it throws.
std::shared_ptr<const tiles::ImageEntry> publish_description(tiles::Store& store, const tiles::ImageEntry& current,
                                                             const Description& d);

bool operator==(const LabelledValue& a, const LabelledValue& b);
bool operator==(const Description& a, const Description& b);

}  // namespace zoomwarp::api
