// Signed URLs (api/url_signing.h): a known answer from openssl dgst, what is signed, what breaks a
// signature, expiry, secret files.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

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

// The signed-string format (api/url_signing.h, README "Signed URLs") pinned for signers outside the
// project: HMAC-SHA256 over PATH?QUERY&expires=UNIX_SECONDS, hex, lower case. Computed
// independently of the code under test:
//   printf '%s' '/v1/images/boats/viewport?zoom=0.5&w=320&h=240&expires=1800000060' | openssl dgst -sha256 -hmac 'kkkkkkkkkkkkkkkkkkkkkkkkkkkkkkkk'
//   printf '%s' '/iiif/3/boats/info.json?expires=1800000060' | openssl dgst -sha256 -hmac 'kkkkkkkkkkkkkkkkkkkkkkkkkkkkkkkk'
TEST(UrlSigning, AKnownAnswer) {
  EXPECT_EQ(UrlSigner(kSecret).sign("/v1/images/boats/viewport", "zoom=0.5&w=320&h=240", kNow + 60),
            "/v1/images/boats/viewport?zoom=0.5&w=320&h=240&expires=1800000060"
            "&sig=b71fdfe3648f4ab11b67c0cd24bc80c65d7f1e1602c395fc97feecea4cf052c8");
  EXPECT_EQ(UrlSigner(kSecret).sign("/iiif/3/boats/info.json", "", kNow + 60),
            "/iiif/3/boats/info.json?expires=1800000060"
            "&sig=64f7aa5871fc63ef06e45c45956771e27dd158896bcef09324d1c10a1367c066")
      << "an empty query";
  // And the server takes what an outside signer computed.
  EXPECT_EQ(UrlSigner(kSecret).verify("/v1/images/boats/viewport",
                                      "zoom=0.5&w=320&h=240&expires=1800000060"
                                      "&sig=b71fdfe3648f4ab11b67c0cd24bc80c65d7f1e1602c395fc97feecea4cf052c8",
                                      kNow),
            Verdict::kValid);
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
    FAIL() << "a 6-byte secret file was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).find("s3cr3t"), std::string::npos) << "the message never holds the secret";
  }
}

// Service tokens (ID~EXPIRES~SIG in place of an IIIF image id): a private image's manifest signs
// its whole image service with one, valid until it expires.
TEST(ServiceTokens, AKnownAnswer) {
  // Computed independently of the code under test:
  //   printf '%s' 'iiif-image-service:boats~1800000060' | openssl dgst -sha256 -hmac 'kkkkkkkkkkkkkkkkkkkkkkkkkkkkkkkk'
  EXPECT_EQ(UrlSigner(kSecret).sign_service("boats", kNow + 60),
            "boats~1800000060~431f96b9e8632df5ff3313c25073969179d967ab4d9b5b2eb7218ff42b4a8418");
}

TEST(ServiceTokens, ValidUntilTheyExpire) {
  const UrlSigner signer(kSecret);
  const std::string token = signer.sign_service("boats", kNow + 60);
  std::string id;
  EXPECT_EQ(signer.verify_service(token, kNow, &id), Verdict::kValid);
  EXPECT_EQ(id, "boats");
  EXPECT_EQ(signer.verify_service(token, kNow + 60, &id), Verdict::kValid) << "valid through its expiry second";
  EXPECT_EQ(signer.verify_service(token, kNow + 61, &id), Verdict::kExpired);
  EXPECT_EQ(id, "boats") << "the image is named also when the token has expired";
  EXPECT_EQ(signer.verify_service("boats", kNow, &id), Verdict::kUnsigned) << "a plain id";
  EXPECT_EQ(id, "boats");
}

TEST(ServiceTokens, AnyChangeBreaksThem) {
  const UrlSigner signer(kSecret);
  const std::string token = signer.sign_service("boats", kNow + 60);  // boats~1800000060~<64 hex>
  const std::string sig = token.substr(token.rfind('~') + 1);
  std::string id;
  // Another image with this image's token: refused, and named as the image asked for.
  EXPECT_EQ(signer.verify_service("other~1800000060~" + sig, kNow, &id), Verdict::kBadSignature);
  EXPECT_EQ(id, "other");
  EXPECT_EQ(signer.verify_service("boats~1800009999~" + sig, kNow, &id), Verdict::kBadSignature) << "a later expiry";
  std::string flipped = token;
  flipped.back() = flipped.back() == '0' ? '1' : '0';
  EXPECT_EQ(signer.verify_service(flipped, kNow, &id), Verdict::kBadSignature) << "one hex digit of the signature";
  std::string first_digit = token;
  const std::size_t at = token.rfind('~') + 1;
  first_digit[at] = first_digit[at] == 'f' ? 'e' : 'f';
  EXPECT_EQ(signer.verify_service(first_digit, kNow, &id), Verdict::kBadSignature) << "its first digit";
  EXPECT_EQ(UrlSigner(std::string(32, 'j')).verify_service(token, kNow, &id), Verdict::kBadSignature)
      << "another secret";
}

TEST(ServiceTokens, MalformedOnesAreBadSignatures) {
  const UrlSigner signer(kSecret);
  const std::string token = signer.sign_service("boats", kNow + 60);
  const std::string sig = token.substr(token.rfind('~') + 1);
  for (const std::string& bad : std::vector<std::string>{
           "boats~",                                     // nothing after the id
           "boats~1800000060",                           // no signature
           "boats~1800000060~",                          // an empty signature
           "boats~~" + sig,                              // no expiry
           "boats~18e8~" + sig,                          // an expiry that is not a number
           "boats~-1~" + sig,                            // nor negative
           "boats~1800000060~" + sig.substr(0, 63),      // an odd number of digits
           "boats~1800000060~" + sig.substr(0, 62),      // a shortened signature
           "boats~1800000060~" + sig + "00",             // a longer one
           "boats~1800000060~" + std::string(64, 'z'),   // not hex
           "boats~1800000060~" + sig + "~x",             // a fourth part
           "~1800000060~" + sig,                         // no id
       }) {
    SCOPED_TRACE(bad);
    std::string id;
    EXPECT_EQ(signer.verify_service(bad, kNow, &id), Verdict::kBadSignature);
  }
}

// The two kinds sign different strings (a URL's starts with '/'), so neither passes for the other.
TEST(ServiceTokens, AUrlSignatureIsNeverAServiceTokenNorTheOtherWay) {
  const UrlSigner signer(kSecret);
  std::string id;
  for (const std::string path : {"/iiif/3/boats", "/iiif/3/boats/info.json", "boats"}) {
    SCOPED_TRACE(path);
    const auto [p, query] = split(signer.sign(path, "", kNow + 60));
    ASSERT_EQ(signer.verify(p, query, kNow), Verdict::kValid);
    const std::string url_sig = query.substr(query.find("sig=") + 4);
    EXPECT_EQ(signer.verify_service("boats~1800000060~" + url_sig, kNow, &id), Verdict::kBadSignature);
  }
  const std::string token = signer.sign_service("boats", kNow + 60);
  const std::string token_sig = token.substr(token.rfind('~') + 1);
  for (const std::string path : {"/iiif/3/boats", "/iiif/3/boats/info.json", "/iiif/3/boats/full/max/0/default.jpg"}) {
    SCOPED_TRACE(path);
    EXPECT_EQ(signer.verify(path, "expires=1800000060&sig=" + token_sig, kNow), Verdict::kBadSignature);
  }
  // A token in the path is not a signed URL: its query has no signature.
  EXPECT_EQ(signer.verify("/iiif/3/" + token + "/info.json", "", kNow), Verdict::kUnsigned);
}

}  // namespace
}  // namespace zoomwarp
