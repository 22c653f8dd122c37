// IIIF Presentation API 3.0 (https://iiif.io/api/presentation/3.0/) documents of stored images,
// so that Mirador, the Universal Viewer or any IIIF client opens an image by one URL:
//
//   /iiif/presentation/3/{id}/manifest     one Canvas the size of the image, painted by the image
//                                          through its Image API 3 service (api/iiif.h), with a
//                                          thumbnail and the curator's description (api/description.h)
//   /iiif/presentation/3/collection        the public images, as pages of kCollectionPageSize
//   /iiif/presentation/3/collection/{n}    page n (1-based): references to their manifests
//
// Pure functions of the image manifests, descriptions and URLs given; the router chooses which
// images are listed and signs the service of a private image (api/url_signing.h).
#pragma once

#include <string>
#include <vector>

#include "api/description.h"
#include "api/iiif.h"
#include "tiles/manifest.h"

namespace zoomwarp::api {

inline constexpr int kCollectionPageSize = 100;

std::string manifest_path(const std::string& id);  // /iiif/presentation/3/{id}/manifest
std::string collection_path();                     // /iiif/presentation/3/collection
std::string collection_page_path(int page);        // /iiif/presentation/3/collection/{page}

struct ManifestLinks {
  std::string base;        // absolute origin of every URL, e.g. https://tiles.example.org
  std::string service_id;  // the Image API service: base + /iiif/3/{id} (or its service segment)
  bool in_collection = false;  // public: partOf the collection
};

// The manifest of image `m`. Its label is the description's, else the image id; the canvas body
// is the service's `full/max` (the largest size the limits allow), the thumbnail its whole-image
// size of the first pyramid level within 400 × 400; `seeAlso` is the image's /v1/images record.
std::string manifest_json(const tiles::Manifest& m, const Description& d, const ManifestLinks& links,
                          const IiifLimits& limits);

// The collection of `count` public images: its pages (each labelled with the range of images it
// holds), kCollectionPageSize images each.
std::string collection_json(const std::string& base, std::size_t count);

struct CollectionEntry {
  const tiles::Manifest* image;
  Description description;
};
// Page `page` (1-based) of `pages`: its images' manifests referenced with label and thumbnail.
std::string collection_page_json(const std::string& base, int page, int pages,
                                 const std::vector<CollectionEntry>& images);

}  // namespace zoomwarp::api
