// SHA-256 digests as 64 lower-case hex digits. A source file's, as recorded in the manifest of the version made from it
// (Manifest::source_sha256): what lets `zoomwarp ingest` skip a file whose bytes are already
// published under its id, so that an interrupted bulk ingest resumes where it stopped.
//
// Threads: any; each call reads the file on its own.
#pragma once

#include <string>
#include <string_view>

namespace zoomwarp::tiles {

class RandomAccessFile;

// 64 lower-case hex digits. Streams the file through OpenSSL's EVP digest 1 MiB at a time, so any
// size costs the same memory. Throws std::system_error (the errno of the open or read that failed)
// when the file cannot be read.
std::string file_sha256_hex(const std::string& path);
// The same for a file read by range (a bucket's: store copy checks what it wrote by it); its
// read errors are thrown as they come.
std::string file_sha256_hex(const RandomAccessFile& file);

// The same for bytes in memory (an S3 request's body, signed with it: tiles/s3_client.h).
std::string sha256_hex(std::string_view data);

}  // namespace zoomwarp::tiles
