// Recognises the image formats ingest accepts from their first bytes, before any decoder sees
// them: an upload that is none of these is refused as unsupported (415) rather than handed to
// every reader OpenImageIO happens to have.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace zoomwarp::tiles {

// Bytes sniff_image_format() wants to see (fewer is fine; it then recognises less): a HEIF
// 'ftyp' box's first compatible brands lie past byte 16.
inline constexpr std::size_t kSniffBytes = 32;

// "jpeg", "png", "tiff" (classic and BigTIFF), "webp", "jp2" (a JPEG 2000 file), "j2k" (a bare
// JPEG 2000 codestream), "heif" (HEIC and other HEIF), "avif", or "" when the bytes are none of
// them.
std::string sniff_image_format(const std::uint8_t* head, std::size_t n);

// The same for a file's first bytes; "" if it cannot be read.
std::string sniff_image_file(const std::string& path);

}  // namespace zoomwarp::tiles
