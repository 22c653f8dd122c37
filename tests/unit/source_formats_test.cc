// The formats digital libraries keep their masters in (issue 31): JPEG 2000 (JP2 and bare
// codestreams, lossless and lossy, 8 and 16 bits), HEIF, AVIF, BigTIFF, tiled TIFF and a
// pyramidal TIFF whose overview comes first. Each is made at test time with Debian's own tools
// (opj_compress, heif-enc, tiffcp; scripts/setup.sh installs them) from a crop of a bundled
// photograph, ingested, and its stored level 0 compared with the source as an independent
// decoder gives it (opj_decompress, heif-convert; for TIFF, the PNG it was made from): exact for
// the lossless ones, ≥ 40 dB for the lossy ones, whose byte ratio is printed. And sources whose
// embedded ICC profile is not sRGB (Adobe RGB (1998), Display P3), which are converted to sRGB.
#include <gtest/gtest.h>
#include <lcms2.h>

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/header_sniff.h"
#include "tiles/ingest.h"
#include "tiles/jpeg2000_rows.h"
#include "tiles/pyramid_reader.h"
#include "tiles/source_format.h"

namespace zoomwarp {
namespace {

using testing::TempDir;
using tiles::Raster;

constexpr int kWidth = 640, kHeight = 400;
constexpr double kLossless = std::numeric_limits<double>::infinity();

// Runs a Debian tool in `dir`; its output goes to the test's log only when it fails.
void run_in(const std::string& dir, const std::string& command) {
  const std::string logged = "cd '" + dir + "' && " + command + " > tool.log 2>&1";
  const int status = std::system(logged.c_str());
  if (status != 0) {
    std::ifstream log(dir + "/tool.log");
    std::cerr << std::string((std::istreambuf_iterator<char>(log)), {});
  }
  ASSERT_EQ(status, 0) << command;
}

std::uintmax_t bytes_of(const std::string& path) { return std::filesystem::file_size(path); }

class SourceFormats : public ::testing::Test {
 protected:
  void SetUp() override {
    reference_ = testing::crop(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"),
                               {900, 600, kWidth, kHeight});
    testing::write_image(path("source.png"), reference_);
    testing::write_image(path("source.tif"), reference_);
  }

  std::string path(const std::string& name) const { return dir_.path() + "/" + name; }
  void run(const std::string& command) const { run_in(dir_.path(), command); }

  // Ingests `file` and returns its stored level 0, after checking what the manifest says.
  Raster ingest(const std::string& file, const std::string& format, const std::string& compression) {
    tiles::Store store(path("store"));
    const std::string id = std::filesystem::path(file).stem().string();
    const tiles::Manifest m = tiles::ingest_image(store, file, id, {});
    EXPECT_EQ(m.source_format, format) << file;
    EXPECT_EQ(m.compression, compression) << file;
    EXPECT_EQ(m.width, kWidth) << file;
    EXPECT_EQ(m.height, kHeight) << file;
    tiles::PyramidReader reader(64 << 20);
    return reader.read_level(*store.find(id), 0, {0, 0, kWidth, kHeight});
  }

  // For a lossy source: level 0 against `decoded` (the independent decoder's picture of it).
  void expect_lossy(const std::string& file, const std::string& format, const Raster& decoded) {
    const Raster stored = ingest(file, format, "jpeg");
    const double db = testing::psnr(stored, decoded);
    std::cout << "[ figures ] " << format << ": level 0 " << db << " dB from the decoded source; source "
              << bytes_of(file) << " bytes, " << double(bytes_of(file)) / bytes_of(path("source.png"))
              << " of the PNG\n";
    EXPECT_GE(db, 40.0) << file;
    EXPECT_GT(testing::psnr(decoded, reference_), 30.0) << file << ": the tool made another picture";
  }

  TempDir dir_;
  Raster reference_;
};

TEST_F(SourceFormats, LosslessJpeg2000IsStoredExactly) {
  run("opj_compress -i source.tif -o lossless.jp2");
  run("opj_decompress -i lossless.jp2 -o lossless-decoded.png");
  EXPECT_EQ(testing::psnr(testing::load_image(path("lossless-decoded.png")), reference_), kLossless);
  EXPECT_EQ(testing::psnr(ingest(path("lossless.jp2"), "jp2", "zip:1"), reference_), kLossless);
  // A bare codestream, as archives also keep them.
  run("opj_compress -i source.tif -o codestream.j2k");
  EXPECT_EQ(testing::psnr(ingest(path("codestream.j2k"), "j2k", "zip:1"), reference_), kLossless);
}

// Issue 42: a tiled JPEG 2000 is read tile by tile (tiles/jpeg2000_rows.h), an untiled one by
// bands of rows; both exactly. Tiles that do not divide the image, an image area and a tile grid
// that start off the reference grid's origin, tile-parts split by resolution (a tile complete
// only at the end of the codestream), 16 bits, and bands of one row to the whole image.
TEST_F(SourceFormats, TiledJpeg2000IsReadTileByTileAndUntiledByBands) {
  run("opj_compress -i source.tif -o tiled.jp2 -t 96,80");
  EXPECT_EQ(testing::psnr(ingest(path("tiled.jp2"), "jp2", "zip:1"), reference_), kLossless);
  run("opj_compress -i source.tif -o offset.j2k -t 96,80 -d 37,21 -T 10,5");
  EXPECT_EQ(testing::psnr(ingest(path("offset.j2k"), "j2k", "zip:1"), reference_), kLossless);
  run("opj_compress -i source.tif -o parts.jp2 -t 128,128 -TP R -p RPCL");
  EXPECT_EQ(testing::psnr(ingest(path("parts.jp2"), "jp2", "zip:1"), reference_), kLossless);
  testing::write_image(path("deep.tif"), reference_, 16);
  run("opj_compress -i deep.tif -o deep-tiled.jp2 -t 256,256");
  EXPECT_EQ(testing::psnr(ingest(path("deep-tiled.jp2"), "jp2", "zip:1"), reference_), kLossless);

  run("opj_compress -i source.tif -o untiled.jp2");
  for (const std::uint64_t band_bytes : {std::uint64_t(1), std::uint64_t(kWidth) * 3 * 4 * 37, std::uint64_t(1) << 30}) {
    tiles::Jpeg2000Rows rows(path("untiled.jp2"), "jp2", 2, band_bytes);
    ASSERT_TRUE(rows.supported()) << rows.why_not();
    EXPECT_FALSE(rows.tiled());
    Raster read(kWidth, kHeight, 3);
    // In uneven steps, as the pyramid builder asks (16 rows, or what its strip has room for).
    for (int y = 0; y < kHeight;) {
      const int n = std::min(kHeight - y, 13);
      rows.read(y, y + n, 3, read.pixels.data() + std::size_t(y) * kWidth * 3);
      y += n;
    }
    EXPECT_EQ(testing::psnr(read, reference_), kLossless) << rows.band_rows() << " rows a band";
  }
}

// High-Throughput JPEG 2000 (ISO 15444-15): Debian's OpenJPEG 2.5.0 decodes its block coder;
// OpenJPH's ojph_compress (openjph-tools) makes bare HTJ2K codestreams, lossless here, tiled and
// not.
TEST_F(SourceFormats, HighThroughputJpeg2000IsStoredExactly) {
  testing::write_image(path("source.ppm"), reference_);
  run("ojph_compress -i source.ppm -o ht.j2c -reversible true");
  EXPECT_EQ(testing::psnr(ingest(path("ht.j2c"), "j2k", "zip:1"), reference_), kLossless);
  run("ojph_compress -i source.ppm -o ht-tiled.j2c -reversible true -tile_size \\{128,96\\}");
  EXPECT_EQ(testing::psnr(ingest(path("ht-tiled.j2c"), "j2k", "zip:1"), reference_), kLossless);
}

TEST_F(SourceFormats, SixteenBitJpeg2000IsStoredAsItsEightBits) {
  testing::write_image(path("deep.tif"), reference_, 16);
  run("opj_compress -i deep.tif -o deep.jp2");
  EXPECT_EQ(testing::psnr(ingest(path("deep.jp2"), "jp2", "zip:1"), reference_), kLossless);
}

TEST_F(SourceFormats, LossyJpeg2000IsStoredAsJpegTiles) {
  run("opj_compress -i source.tif -o lossy.jp2 -I -q 45");  // 9-7 wavelet, 45 dB
  run("opj_decompress -i lossy.jp2 -o lossy-decoded.png");
  expect_lossy(path("lossy.jp2"), "jp2", testing::load_image(path("lossy-decoded.png")));
}

TEST_F(SourceFormats, HeifAndAvifAreStoredAsJpegTiles) {
  run("heif-enc -q 90 source.png -o photo.heic");
  run("heif-convert photo.heic heic-decoded.png");
  expect_lossy(path("photo.heic"), "heif", testing::load_image(path("heic-decoded.png")));
  run("heif-enc -A -q 90 source.png -o photo.avif");
  run("heif-convert photo.avif avif-decoded.png");
  expect_lossy(path("photo.avif"), "avif", testing::load_image(path("avif-decoded.png")));
}

TEST_F(SourceFormats, BigTiffTiledTiffAndPyramidalTiffAreStoredExactly) {
  run("tiffcp -8 source.tif big.tif");
  EXPECT_EQ(testing::psnr(ingest(path("big.tif"), "tiff", "zip:1"), reference_), kLossless);
  run("tiffcp -t -w 128 -l 128 source.tif tiled.tif");
  EXPECT_EQ(testing::psnr(ingest(path("tiled.tif"), "tiff", "zip:1"), reference_), kLossless);
  // An overview page first, the full resolution second: the largest page is the image.
  testing::write_image(path("overview.tif"), testing::resize(reference_, kWidth / 4, kHeight / 4));
  run("tiffcp -t -w 64 -l 64 overview.tif source.tif pyramid.tif");
  EXPECT_EQ(testing::psnr(ingest(path("pyramid.tif"), "tiff", "zip:1"), reference_), kLossless);
}

// The upload path's early answers (server/session.cc) read the same headers.
TEST_F(SourceFormats, HeadersGiveFormatAndSizeFromTheFirstBytes) {
  run("opj_compress -i source.tif -o header.jp2");
  run("opj_compress -i source.tif -o header.j2k");
  run("heif-enc -q 50 source.png -o header.heic");
  run("heif-enc -A -q 50 source.png -o header.avif");
  for (const auto& [file, format] : {std::pair{"header.jp2", "jp2"}, {"header.j2k", "j2k"}, {"header.heic", "heif"},
                                     {"header.avif", "avif"}}) {
    std::ifstream in(path(file), std::ios::binary);
    std::string head(tiles::kHeaderSniffBytes, '\0');
    in.read(head.data(), std::streamsize(head.size()));
    head.resize(std::size_t(in.gcount()));
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(head.data());
    EXPECT_EQ(tiles::sniff_image_format(bytes, head.size()), format) << file;
    const tiles::SniffedHeader h = tiles::sniff_image_header(bytes, head.size());
    EXPECT_EQ(h.status, tiles::SniffedHeader::Status::kOk) << file << ": " << h.problem;
    EXPECT_EQ(h.width, std::uint64_t(kWidth)) << file;
    EXPECT_EQ(h.height, std::uint64_t(kHeight)) << file;
    // Cut before the size: not refused, not known.
    EXPECT_EQ(tiles::sniff_image_header(bytes, 12).status, tiles::SniffedHeader::Status::kIncomplete) << file;
  }
}

// A codestream whose header declares 60 000 × 60 000 pixels is refused from its header: OpenJPEG
// would otherwise try to decode it whole before OpenImageIO could report its size.
TEST_F(SourceFormats, AJpeg2000DeclaringAHugeImageIsRefusedBeforeDecoding) {
  run("opj_compress -i source.tif -o small.j2k");
  std::fstream f(path("small.j2k"), std::ios::binary | std::ios::in | std::ios::out);
  const unsigned char huge[8] = {0, 0, 0xEA, 0x60, 0, 0, 0xEA, 0x60};  // Xsiz, Ysiz = 60 000 (SIZ at byte 2)
  f.seekp(8);
  f.write(reinterpret_cast<const char*>(huge), 8);
  f.close();
  tiles::Store store(path("store"));
  try {
    tiles::ingest_image(store, path("small.j2k"), "huge", {});
    FAIL() << "ingested";
  } catch (const tiles::IngestError& e) {
    EXPECT_EQ(e.kind(), tiles::IngestError::Kind::kTooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("60000x60000"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(store.find("huge"));
}

// What must be decoded whole — a JPEG 2000 OpenJPEG cannot hand over tile by tile (subsampled
// components, read by OpenImageIO), an image turned upright by its EXIF orientation — is
// decoded whole within --max-decode-memory and refused, before decoding, past it.
TEST_F(SourceFormats, WholeImageDecodesAreBoundedByTheDecodeMemoryLimit) {
  run("opj_compress -i source.tif -o subsampled.jp2 -s 2,2");
  testing::write_image(path("turned.jpg"), reference_, 8, 6, 95);
  for (const char* file : {"subsampled.jp2", "turned.jpg"}) {
    tiles::Store store(path("store"));
    tiles::IngestOptions small;
    small.limits.max_decode_bytes = 512 << 10;
    try {
      tiles::ingest_image(store, path(file), "refused", small);
      ADD_FAILURE() << file << " ingested";
    } catch (const tiles::IngestError& e) {
      EXPECT_EQ(e.kind(), tiles::IngestError::Kind::kTooLarge) << e.what();
      EXPECT_NE(std::string(e.what()).find("--max-decode-memory"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("decoded whole"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(store.find("refused"));
    EXPECT_NO_THROW(tiles::ingest_image(store, path(file), "fits", {})) << file << " within the default limit";
  }
}

// --- ICC profiles -----------------------------------------------------------------------------

// An RGB profile from its primaries and tone curve, D65 white, as LittleCMS builds them: Adobe
// RGB (1998) (gamma 563/256) and Display P3 (sRGB's curve), the two wide gamuts cameras, phones
// and editors embed.
std::vector<std::uint8_t> rgb_profile(const char* name, cmsCIExyYTRIPLE primaries, cmsToneCurve* curve) {
  cmsCIExyY d65;
  cmsWhitePointFromTemp(&d65, 6504);
  cmsToneCurve* curves[3] = {curve, curve, curve};
  cmsHPROFILE p = cmsCreateRGBProfile(&d65, &primaries, curves);
  cmsMLU* description = cmsMLUalloc(nullptr, 1);
  cmsMLUsetASCII(description, "en", "US", name);
  cmsWriteTag(p, cmsSigProfileDescriptionTag, description);
  cmsMLUfree(description);
  cmsUInt32Number size = 0;
  cmsSaveProfileToMem(p, nullptr, &size);
  std::vector<std::uint8_t> bytes(size);
  cmsSaveProfileToMem(p, bytes.data(), &size);
  cmsCloseProfile(p);
  cmsFreeToneCurve(curve);
  return bytes;
}

std::vector<std::uint8_t> adobe_rgb() {
  return rgb_profile("Adobe RGB (1998)", {{0.64, 0.33, 1}, {0.21, 0.71, 1}, {0.15, 0.06, 1}},
                     cmsBuildGamma(nullptr, 563.0 / 256));
}

std::vector<std::uint8_t> display_p3() {
  const double srgb_curve[5] = {2.4, 1 / 1.055, 0.055 / 1.055, 1 / 12.92, 0.04045};  // IEC 61966-2.1
  return rgb_profile("Display P3", {{0.680, 0.320, 1}, {0.265, 0.690, 1}, {0.150, 0.060, 1}},
                     cmsBuildParametricToneCurve(nullptr, 4, srgb_curve));
}

// `srgb` re-encoded in the profile's colours, as an editor saving the picture in that space does.
Raster in_profile(const Raster& srgb, const std::vector<std::uint8_t>& icc) {
  cmsHPROFILE from = cmsCreate_sRGBProfile(), to = cmsOpenProfileFromMem(icc.data(), cmsUInt32Number(icc.size()));
  cmsHTRANSFORM t = cmsCreateTransform(from, TYPE_RGB_8, to, TYPE_RGB_8, INTENT_RELATIVE_COLORIMETRIC, 0);
  Raster out = srgb;
  cmsDoTransform(t, srgb.pixels.data(), out.pixels.data(), cmsUInt32Number(srgb.width * srgb.height));
  cmsDeleteTransform(t);
  cmsCloseProfile(from);
  cmsCloseProfile(to);
  return out;
}

void write_tagged(const std::string& path, const Raster& r, const std::vector<std::uint8_t>& icc) {
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << path;
  OIIO::ImageSpec spec(r.width, r.height, 3, OIIO::TypeDesc::UINT8);
  spec.attribute("ICCProfile", OIIO::TypeDesc(OIIO::TypeDesc::UINT8, int(icc.size())), icc.data());
  if (path.ends_with(".jpg")) spec.attribute("Compression", "jpeg:95");
  ASSERT_TRUE(out->open(path, spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, r.pixels.data())) << out->geterror();
  out->close();
}

TEST_F(SourceFormats, WideGamutSourcesAreConvertedToSrgb) {
  for (const auto& [name, icc] : {std::pair{"adobe-rgb", adobe_rgb()}, {"display-p3", display_p3()}}) {
    const Raster tagged = in_profile(reference_, icc);
    const double untouched = testing::psnr(tagged, reference_);
    write_tagged(path(std::string(name) + ".png"), tagged, icc);
    const double png_db = testing::psnr(ingest(path(std::string(name) + ".png"), "png", "zip:1"), reference_);
    write_tagged(path(std::string(name) + ".jpg"), tagged, icc);
    const double jpeg_db = testing::psnr(ingest(path(std::string(name) + ".jpg"), "jpeg", "jpeg"), reference_);
    std::cout << "[ figures ] " << name << ": level 0 against the sRGB picture " << png_db << " dB (PNG), " << jpeg_db
              << " dB (JPEG 95); the profile's pixels taken as sRGB would be " << untouched << " dB\n";
    EXPECT_GE(png_db, 45.0) << name << ": 8-bit rounding there and back only";
    EXPECT_GE(png_db, untouched + 15) << name << ": converted, not taken as sRGB";
    EXPECT_GE(jpeg_db, 35.0) << name;
  }
}

TEST_F(SourceFormats, AnSrgbProfileChangesNothingAndANonRgbProfileIsRefused) {
  cmsHPROFILE srgb = cmsCreate_sRGBProfile();
  cmsUInt32Number size = 0;
  cmsSaveProfileToMem(srgb, nullptr, &size);
  std::vector<std::uint8_t> bytes(size);
  cmsSaveProfileToMem(srgb, bytes.data(), &size);
  cmsCloseProfile(srgb);
  write_tagged(path("srgb.png"), reference_, bytes);
  EXPECT_EQ(testing::psnr(ingest(path("srgb.png"), "png", "zip:1"), reference_), kLossless);

  cmsHPROFILE lab = cmsCreateLab4Profile(nullptr);
  cmsSaveProfileToMem(lab, nullptr, &size);
  bytes.resize(size);
  cmsSaveProfileToMem(lab, bytes.data(), &size);
  cmsCloseProfile(lab);
  write_tagged(path("lab.tif"), reference_, bytes);  // PNG allows only RGB and grey profiles
  tiles::Store store(path("store"));
  try {
    tiles::ingest_image(store, path("lab.tif"), "lab", {});
    FAIL() << "ingested";
  } catch (const tiles::IngestError& e) {
    EXPECT_EQ(e.kind(), tiles::IngestError::Kind::kCorrupt);
    EXPECT_NE(std::string(e.what()).find("not an RGB profile"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(store.find("lab"));
}

}  // namespace
}  // namespace zoomwarp
