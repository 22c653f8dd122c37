// sniff_image_header(): the size of an upload's image from its first bytes, per format — a valid
// header, the same header cut short, and headers whose bytes lie.
#include <gtest/gtest.h>

#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/encode.h"
#include "tiles/header_sniff.h"

namespace zoomwarp {
namespace {

using Status = tiles::SniffedHeader::Status;

tiles::SniffedHeader sniff(const std::string& bytes, std::size_t n = std::string::npos) {
  n = std::min(n, bytes.size());
  return tiles::sniff_image_header(reinterpret_cast<const std::uint8_t*>(bytes.data()), n);
}

// The file OpenImageIO writes for a w×h test pattern in the format of `ext`.
std::string written(const std::string& ext, int w, int h) {
  testing::TempDir dir;
  const std::string path = dir.path() + "/image." + ext;
  testing::write_image(path, testing::test_pattern(w, h, 3), 8);
  return testing::read_file(path);
}

void expect_size(const tiles::SniffedHeader& h, const std::string& format, std::uint64_t w, std::uint64_t hgt) {
  EXPECT_EQ(h.status, Status::kOk) << h.problem;
  EXPECT_EQ(h.format, format);
  EXPECT_EQ(h.width, w);
  EXPECT_EQ(h.height, hgt);
}

void put_be(std::string& s, std::size_t at, std::uint64_t v, int len) {
  for (int i = 0; i < len; ++i) s[at + i] = char((v >> (8 * (len - 1 - i))) & 0xFF);
}

void put_le(std::string& s, std::size_t at, std::uint64_t v, int len) {
  for (int i = 0; i < len; ++i) s[at + i] = char((v >> (8 * i)) & 0xFF);
}

// Every prefix shorter than the header is kIncomplete, never a wrong size or a crash.
void expect_prefixes_incomplete(const std::string& bytes, std::size_t header_end, std::size_t magic) {
  for (std::size_t n = magic; n < header_end; ++n) EXPECT_EQ(sniff(bytes, n).status, Status::kIncomplete) << n;
}

TEST(HeaderSniff, Jpeg) {
  const std::string jpeg = written("jpg", 123, 45);
  expect_size(sniff(jpeg), "jpeg", 123, 45);
  expect_size(sniff(testing::read_file(testing::samples_dir() + "/boats_lake_sunset.jpg")), "jpeg", 2560, 1600);
  const std::size_t sof = jpeg.find("\xFF\xC0");
  ASSERT_NE(sof, std::string::npos);
  expect_prefixes_incomplete(jpeg, sof + 9, 3);

  std::string huge = jpeg;  // a frame header that claims 60000 × 50000
  put_be(huge, sof + 5, 50000, 2);
  put_be(huge, sof + 7, 60000, 2);
  expect_size(sniff(huge), "jpeg", 60000, 50000);
  std::string empty = jpeg;
  put_be(empty, sof + 5, 0, 2);
  EXPECT_EQ(sniff(empty).status, Status::kCorrupt);

  EXPECT_EQ(sniff("\xFF\xD8\xFF" + std::string(100000, '\0')).status, Status::kCorrupt) << "junk after the magic";
  EXPECT_EQ(sniff(std::string("\xFF\xD8\xFF\xE0\x00\x01", 6) + std::string(100, 'x')).status, Status::kCorrupt) << "length < 2";
  EXPECT_EQ(sniff(std::string("\xFF\xD8\xFF\xDA\x00\x08", 6) + std::string(100, 'x')).status, Status::kCorrupt)
      << "scan before frame";
  std::string app = std::string("\xFF\xD8\xFF\xE1\xFF\xFF", 6) + std::string(0xFFFF, 'x');  // SOF beyond
  EXPECT_EQ(sniff(app, tiles::kHeaderSniffBytes).status, Status::kIncomplete);
}

TEST(HeaderSniff, Png) {
  const std::string png = written("png", 7, 300);
  expect_size(sniff(png), "png", 7, 300);
  expect_prefixes_incomplete(png, 33, 8);
  std::string lying = png;  // the width edited without fixing the CRC
  put_be(lying, 16, 100000, 4);
  EXPECT_EQ(sniff(lying).status, Status::kCorrupt);
  std::string wrong_chunk = png;
  wrong_chunk.replace(12, 4, "IDAT");
  EXPECT_EQ(sniff(wrong_chunk).status, Status::kCorrupt);
}

TEST(HeaderSniff, PngWithConsistentHugeSize) {
  // A well-formed IHDR (right CRC) for 100000 × 100000: the size is reported for the caller's limit.
  std::string png("\x89PNG\r\n\x1A\n\0\0\0\x0DIHDR", 16);
  png += std::string(13 + 4, '\0');
  put_be(png, 16, 100000, 4);
  put_be(png, 20, 100000, 4);
  png[24] = 8;
  png[25] = 2;
  // CRC-32 of "IHDR" + the 13 bytes above, computed independently (Python zlib.crc32).
  put_be(png, 29, 0x27309C9Fu, 4);
  expect_size(sniff(png), "png", 100000, 100000);
}

TEST(HeaderSniff, Tiff) {
  const std::string tiff = written("tif", 640, 3);
  expect_size(sniff(tiff), "tiff", 640, 3);
  // Classic big-endian TIFF with SHORT sizes, built by hand: header, IFD at 8 with two entries.
  std::string mm("MM\0*\0\0\0\x08", 8);
  mm += std::string(2 + 2 * 12, '\0');
  put_be(mm, 8, 2, 2);
  put_be(mm, 10, 256, 2); put_be(mm, 12, 3, 2); put_be(mm, 14, 1, 4); put_be(mm, 18, 1000, 2);
  put_be(mm, 22, 257, 2); put_be(mm, 24, 4, 2); put_be(mm, 26, 1, 4); put_be(mm, 30, 70000, 4);
  expect_size(sniff(mm), "tiff", 1000, 70000);
  expect_prefixes_incomplete(mm, mm.size(), 4);
  std::string bad_type = mm;
  put_be(bad_type, 12, 2, 2);  // ASCII
  EXPECT_EQ(sniff(bad_type).status, Status::kCorrupt);
  std::string bad_offset = mm;
  put_be(bad_offset, 4, 3, 4);  // inside the header
  EXPECT_EQ(sniff(bad_offset).status, Status::kCorrupt);
  std::string no_size = mm;
  put_be(no_size, 10, 258, 2);
  put_be(no_size, 22, 259, 2);
  EXPECT_EQ(sniff(no_size).status, Status::kCorrupt);
  std::string far = mm;  // the IFD after the pixels, beyond the bytes given
  put_be(far, 4, 1 << 20, 4);
  EXPECT_EQ(sniff(far).status, Status::kIncomplete);

  // BigTIFF, little-endian, LONG8 sizes.
  std::string big("II+\0\x08\0\0\0", 8);
  big += std::string(8 + 8 + 2 * 20, '\0');
  put_le(big, 8, 16, 8);
  put_le(big, 16, 2, 8);
  put_le(big, 24, 256, 2); put_le(big, 26, 16, 2); put_le(big, 28, 1, 8); put_le(big, 36, 5000000000ull, 8);
  put_le(big, 44, 257, 2); put_le(big, 46, 3, 2); put_le(big, 48, 1, 8); put_le(big, 56, 2, 2);
  expect_size(sniff(big), "tiff", 5000000000ull, 2);
  expect_prefixes_incomplete(big, big.size(), 4);
}

TEST(HeaderSniff, Webp) {
  const std::string lossy = tiles::encode_image(testing::test_pattern(333, 77, 3), tiles::ImageFormat::kWebp, {});
  expect_size(sniff(lossy), "webp", 333, 77);
  expect_prefixes_incomplete(lossy, 30, 12);
  std::string not_key = lossy;
  not_key[23] = 0;  // start code
  EXPECT_EQ(sniff(not_key).status, Status::kCorrupt);

  std::string lossless("RIFF\0\0\0\0WEBPVP8L\0\0\0\0", 20);
  lossless += std::string(5, '\0');
  lossless[20] = 0x2F;
  put_le(lossless, 21, (16383u) | (9u << 14), 4);  // 16384 × 10
  expect_size(sniff(lossless), "webp", 16384, 10);
  expect_prefixes_incomplete(lossless, 25, 12);
  std::string bad_signature = lossless;
  bad_signature[20] = 0x2E;
  EXPECT_EQ(sniff(bad_signature).status, Status::kCorrupt);

  std::string extended("RIFF\0\0\0\0WEBPVP8X\0\0\0\0", 20);
  extended += std::string(10, '\0');
  put_le(extended, 24, 99999, 3);
  put_le(extended, 27, 0, 3);
  expect_size(sniff(extended), "webp", 100000, 1);
  expect_prefixes_incomplete(extended, 30, 12);

  std::string unknown = extended;
  unknown.replace(12, 4, "ALPH");
  EXPECT_EQ(sniff(unknown).status, Status::kCorrupt);
}

TEST(HeaderSniff, UnknownFormats) {
  EXPECT_EQ(sniff("GIF89a" + std::string(100, '\0')).status, Status::kUnknownFormat);
  EXPECT_EQ(sniff("just some text").status, Status::kUnknownFormat);
  EXPECT_EQ(sniff("").status, Status::kUnknownFormat);
  EXPECT_EQ(sniff("\xFF\xD8").status, Status::kUnknownFormat);  // too short to tell
}

}  // namespace
}  // namespace zoomwarp
