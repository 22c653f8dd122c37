// Signed URLs (api/url_signing.h): what is signed, what breaks a signature, expiry, secret files.
#include <gtest/gtest.h>

#include <fstream>

#include "api/url_signing.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

using api::UrlSigner;
using Verdict = UrlSigner::Verdict;

const std::string kSecret(32, 'k');
constexpr std::int64_t kNow = 1'800'000'000;

// Splits what sign() returns back into path and query, as the server receives them.
std::pair<std::string, std::string> split(const std::string& url) {
  const auto q = url.find('?');
  return {url.substr(0, q), url.substr(q + 1)};
}

TEST(UrlSigning, ASignedUrlVerifiesUntilItExpires) {
  const UrlSigner signer(kSecret);
  const auto [path, query] = split(signer.sign("/v1/images/a/viewport", "zoom=0.5&w=320&h=240", kNow + 60));
  EXPECT_EQ(path, "/v1/images/a/viewport");
  EXPECT_EQ(query.rfind("zoom=0.5&w=320&h=240&expires=1800000060&sig=", 0), 0u) << query;
  EXPECT_EQ(query.size() - query.find("sig=") - 4, 64u) << "hex HMAC-SHA256";
  EXPECT_EQ(signer.verify(path, query, kNow), Verdict::kValid);
  EXPECT_EQ(signer.verify(path, query, kNow + 60), Verdict::kValid) << "valid through its expiry second";
  EXPECT_EQ(signer.verify(path, query, kNow + 61), Verdict::kExpired);
}

TEST(UrlSigning, AnyChangeBreaksTheSignature) {
  const UrlSigner signer(kSecret);
  const auto [path, query] = split(signer.sign("/dzi/a.dzi", "", kNow + 60));
  EXPECT_EQ(signer.verify(path, query, kNow), Verdict::kValid);
  EXPECT_EQ(signer.verify("/dzi/b.dzi", query, kNow), Verdict::kBadSignature) << "another image";
  EXPECT_EQ(signer.verify(path, "x=1&" + query, kNow), Verdict::kBadSignature) << "a parameter added";
  std::string later = query;
  later.replace(later.find("expires=") + 8, 10, std::to_string(kNow + 9999));
  EXPECT_EQ(signer.verify(path, later, kNow), Verdict::kBadSignature) << "a later expiry";
  std::string flipped = query;
  flipped.back() = flipped.back() == '0' ? '1' : '0';
  EXPECT_EQ(signer.verify(path, flipped, kNow), Verdict::kBadSignature) << "one hex digit of the signature";
  EXPECT_EQ(signer.verify(path, query.substr(0, query.size() - 2), kNow), Verdict::kBadSignature) << "shortened";
  EXPECT_EQ(signer.verify(path, "sig=zz", kNow), Verdict::kBadSignature) << "not hex, no expiry";
  EXPECT_EQ(UrlSigner(std::string(32, 'j')).verify(path, query, kNow), Verdict::kBadSignature) << "another secret";
}

TEST(UrlSigning, ParameterOrderIsSignedAndOldSignaturesAreReplaced) {
  const UrlSigner signer(kSecret);
  const auto [path, query] = split(signer.sign("/v1/images/a/mesh", "w=16&h=16", kNow + 5));
  EXPECT_EQ(signer.verify(path, "h=16&w=16" + query.substr(query.find("&expires")), kNow), Verdict::kBadSignature);
  // Signing a signed URL again gives one expires and one sig, the new ones.
  const auto [path2, query2] = split(signer.sign(path, query, kNow + 10));
  EXPECT_EQ(query2.find("expires=" + std::to_string(kNow + 5)), std::string::npos);
  EXPECT_EQ(query2.find("sig="), query2.rfind("sig="));
  EXPECT_EQ(signer.verify(path2, query2, kNow), Verdict::kValid);
}

TEST(UrlSigning, UnsignedUrlsAreSaidToBe) {
  const UrlSigner signer(kSecret);
  EXPECT_EQ(signer.verify("/dzi/a.dzi", "", kNow), Verdict::kUnsigned);
  EXPECT_EQ(signer.verify("/dzi/a.dzi", "expires=1", kNow), Verdict::kUnsigned);
  EXPECT_TRUE(api::is_signature_parameter("sig"));
  EXPECT_TRUE(api::is_signature_parameter("expires"));
  EXPECT_FALSE(api::is_signature_parameter("kid"));
}

TEST(UrlSigning, SecretFilesAreHexOrRawAndLongEnough) {
  testing::TempDir dir;
  auto write = [&](const std::string& name, const std::string& content) {
    std::ofstream(dir.path() + "/" + name, std::ios::binary) << content;
    return dir.path() + "/" + name;
  };
  const std::string hex(64, 'a');  // 32 bytes of 0xaa
  const UrlSigner from_hex = UrlSigner::from_file(write("hex", hex + "\n"));
  const UrlSigner raw_equivalent(std::string(32, char(0xaa)));
  const auto [path, query] = split(raw_equivalent.sign("/p", "", kNow + 1));
  EXPECT_EQ(from_hex.verify(path, query, kNow), Verdict::kValid) << "hex is decoded";
  const UrlSigner raw = UrlSigner::from_file(write("raw", std::string(40, 'r')));
  EXPECT_EQ(split(raw.sign("/p", "", 1)).second, split(UrlSigner(std::string(40, 'r')).sign("/p", "", 1)).second);
  EXPECT_THROW(UrlSigner::from_file(write("short", std::string(31, 'r'))), std::runtime_error);
  EXPECT_THROW(UrlSigner::from_file(write("short-hex", std::string(62, 'a'))), std::runtime_error);
  EXPECT_THROW(UrlSigner::from_file(dir.path() + "/missing"), std::runtime_error);
  try {
    UrlSigner::from_file(write("secret-short", "s3cr3t"));
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).find("s3cr3t"), std::string::npos) << "the message never holds the secret";
  }
}

}  // namespace
}  // namespace zoomwarp
