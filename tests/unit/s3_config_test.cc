// The S3 client's configuration (tiles/s3_config.h): credentials, region and endpoint from an AWS
// environment, with errors that name what is missing or malformed; s3://BUCKET/PREFIX locations;
// the URLs requests go to, keys encoded as SigV4 canonicalises them. No server: the requests
// themselves are tested against Swift in tests/http/s3_client_test.cc.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "tiles/s3_config.h"

namespace zoomwarp::tiles {
namespace {

using Env = std::map<std::string, std::string>;

S3Config from(const Env& env) {
  return S3Config::from_environment([&](const char* name) -> std::optional<std::string> {
    auto it = env.find(name);
    if (it == env.end()) return std::nullopt;
    return it->second;
  });
}

std::string error_of(const Env& env) {
  try {
    from(env);
  } catch (const S3ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(S3Config, FromTheEnvironmentWithDefaults) {
  const S3Config c = from({{"AWS_ACCESS_KEY_ID", "test:tester"}, {"AWS_SECRET_ACCESS_KEY", "testing"}});
  EXPECT_EQ(c.credentials().access_key_id, "test:tester");
  EXPECT_EQ(c.credentials().secret_access_key, "testing");
  EXPECT_EQ(c.credentials().session_token, "");
  EXPECT_EQ(c.region(), "us-east-1");
  EXPECT_EQ(c.endpoint(), "");
  EXPECT_FALSE(c.path_style());
  EXPECT_EQ(c.describe(), "AWS S3 (us-east-1)");
}

TEST(S3Config, EndpointRegionAndTokenFromTheEnvironment) {
  const S3Config c = from({{"AWS_ACCESS_KEY_ID", "k"},
                           {"AWS_SECRET_ACCESS_KEY", "s"},
                           {"AWS_SESSION_TOKEN", "tok"},
                           {"AWS_REGION", "eu-west-3"},
                           {"AWS_DEFAULT_REGION", "ap-south-1"},
                           {"AWS_ENDPOINT_URL", "http://other:1"},
                           {"AWS_ENDPOINT_URL_S3", "http://127.0.0.1:9000/"}});
  EXPECT_EQ(c.credentials().session_token, "tok");
  EXPECT_EQ(c.region(), "eu-west-3");                 // AWS_REGION before AWS_DEFAULT_REGION
  EXPECT_EQ(c.endpoint(), "http://127.0.0.1:9000");  // the S3-specific variable first, '/' dropped
  EXPECT_TRUE(c.path_style());
  EXPECT_EQ(c.describe(), "http://127.0.0.1:9000 (path-style, eu-west-3)");

  const S3Config d = from({{"AWS_ACCESS_KEY_ID", "k"},
                           {"AWS_SECRET_ACCESS_KEY", "s"},
                           {"AWS_REGION", ""},  // empty counts as unset
                           {"AWS_DEFAULT_REGION", "ap-south-1"},
                           {"AWS_ENDPOINT_URL_S3", ""},
                           {"AWS_ENDPOINT_URL", "https://minio.example:9000"}});
  EXPECT_EQ(d.region(), "ap-south-1");
  EXPECT_EQ(d.endpoint(), "https://minio.example:9000");
}

TEST(S3Config, MissingCredentialsAreNamed) {
  const std::string none = error_of({{"HOME", "/nonexistent"}});
  for (const char* named : {"AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY", "AWS_SHARED_CREDENTIALS_FILE",
                            "AWS_WEB_IDENTITY_TOKEN_FILE with AWS_ROLE_ARN", "AWS_CONTAINER_CREDENTIALS_FULL_URI"})
    EXPECT_NE(none.find(named), std::string::npos) << named << " in: " << none;
  const std::string secret = error_of({{"AWS_ACCESS_KEY_ID", "k"}, {"AWS_SECRET_ACCESS_KEY", ""}});
  EXPECT_NE(secret.find("AWS_SECRET_ACCESS_KEY is not set"), std::string::npos) << secret;
  const std::string key = error_of({{"AWS_SECRET_ACCESS_KEY", "s"}});
  EXPECT_NE(key.find("AWS_ACCESS_KEY_ID is not set"), std::string::npos) << key;
  EXPECT_EQ(key.find("s\""), std::string::npos);  // never the secret's value
}

TEST(S3Config, MalformedValuesNameTheirVariable) {
  const Env creds{{"AWS_ACCESS_KEY_ID", "k"}, {"AWS_SECRET_ACCESS_KEY", "s"}};
  auto with = [&](std::string name, std::string value) {
    Env e = creds;
    e[name] = value;
    return error_of(e);
  };
  EXPECT_EQ(with("AWS_ENDPOINT_URL_S3", "127.0.0.1:9000"),
            "AWS_ENDPOINT_URL_S3='127.0.0.1:9000' is not http(s)://host[:port]");
  EXPECT_EQ(with("AWS_ENDPOINT_URL", "http://host/path"), "AWS_ENDPOINT_URL='http://host/path' is not http(s)://host[:port]");
  EXPECT_EQ(with("AWS_ENDPOINT_URL", "ftp://host"), "AWS_ENDPOINT_URL='ftp://host' is not http(s)://host[:port]");
  EXPECT_EQ(with("AWS_REGION", "us:east"), "AWS_REGION='us:east' is not a region name (lower-case letters, digits, '-')");
  EXPECT_NE(with("AWS_SESSION_TOKEN", "a\r\nX-Evil: 1").find("line break"), std::string::npos);
}

TEST(S3Config, ExplicitValuesAreValidated) {
  EXPECT_NO_THROW(S3Config("k", "s", "us-east-1", "http://127.0.0.1:1"));
  EXPECT_THROW(S3Config("", "s"), S3ConfigError);
  EXPECT_THROW(S3Config("k", ""), S3ConfigError);
  EXPECT_THROW(S3Config("k", "s", "US-EAST-1"), S3ConfigError);
  EXPECT_THROW(S3Config("k", "s", "us-east-1", "http://"), S3ConfigError);
  EXPECT_THROW(S3Config("k", "s", "us-east-1", "http://user@host"), S3ConfigError);
  EXPECT_THROW(S3Config("k", "s", "us-east-1", "http://host?x=1"), S3ConfigError);
}

TEST(S3Config, UrlsPathStyleWithAnEndpointVirtualHostedOnAws) {
  const S3Config local("k", "s", "us-east-1", "http://127.0.0.1:9000");
  EXPECT_EQ(local.url("bkt", "a b/c+d"), "http://127.0.0.1:9000/bkt/a%20b/c%2Bd");
  EXPECT_EQ(local.url("bkt", ""), "http://127.0.0.1:9000/bkt");
  EXPECT_EQ(local.url("bkt", "", "list-type=2&prefix=a%2F"), "http://127.0.0.1:9000/bkt?list-type=2&prefix=a%2F");
  const S3Config aws("k", "s", "eu-west-1");
  EXPECT_EQ(aws.url("bkt", "x/y.tif"), "https://bkt.s3.eu-west-1.amazonaws.com/x/y.tif");
  EXPECT_EQ(aws.url("bkt", ""), "https://bkt.s3.eu-west-1.amazonaws.com/");
  // The wildcard certificate does not cover a dotted name: path-style on AWS's regional host.
  EXPECT_EQ(aws.url("my.bkt", "k"), "https://s3.eu-west-1.amazonaws.com/my.bkt/k");
}

TEST(S3Config, UriEncodingIsSigV4s) {
  EXPECT_EQ(s3_uri_encode("AZaz09-._~", false), "AZaz09-._~");
  EXPECT_EQ(s3_uri_encode("a b+c/d", true), "a%20b%2Bc/d");
  EXPECT_EQ(s3_uri_encode("a b+c/d", false), "a%20b%2Bc%2Fd");
  EXPECT_EQ(s3_uri_encode("\xc3\xbc=%*", true), "%C3%BC%3D%25%2A");  // ü, upper-case hex
  EXPECT_EQ(s3_uri_encode(std::string("\0\xff", 2), true), "%00%FF");
}

TEST(S3Config, LocationsAreParsedAndPrefixesNormalised) {
  EXPECT_EQ(parse_s3_location("s3://bucket"), (S3Location{"bucket", ""}));
  EXPECT_EQ(parse_s3_location("s3://bucket/"), (S3Location{"bucket", ""}));
  EXPECT_EQ(parse_s3_location("s3://bucket/images"), (S3Location{"bucket", "images/"}));
  EXPECT_EQ(parse_s3_location("s3://bucket//a/b/"), (S3Location{"bucket", "a/b/"}));
  EXPECT_EQ(parse_s3_location("s3://my.bucket-1/x y"), (S3Location{"my.bucket-1", "x y/"}));
  const S3Location l = parse_s3_location("s3://bucket/a/b");
  EXPECT_EQ(l.url(), "s3://bucket/a/b/");
  EXPECT_EQ(parse_s3_location(l.url()), l);

  for (const char* bad : {"bucket/x", "http://bucket/x", "s3:/bucket", "s3://", "s3:///x", "s3://Bucket/x",
                          "s3://ab", "s3://a..b", "s3://a_b", "s3://192.168.1.1/x", "s3://bucket/a\nb"}) {
    EXPECT_THROW(parse_s3_location(bad), S3ConfigError) << bad;
  }
  try {
    parse_s3_location("s3://My_Bucket/x");
    FAIL();
  } catch (const S3ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'My_Bucket' is not a valid bucket name"), std::string::npos) << e.what();
  }
}

TEST(S3Config, BucketNamesFollowAwsRules) {
  for (const char* good : {"abc", "a-b", "a.b.c", "0bucket9", "zoomwarp-images"})
    EXPECT_TRUE(valid_bucket_name(good)) << good;
  EXPECT_TRUE(valid_bucket_name(std::string(63, 'a')));
  for (const char* bad : {"ab", "-ab", "ab-", ".ab", "ab.", "a..b", "a.-b", "a-.b", "aBc", "a_b", "a b", "1.2.3.4",
                          "xn--abc", "sthree-abc", "abc-s3alias", "abc--ol-s3", "ab/c"})
    EXPECT_FALSE(valid_bucket_name(bad)) << bad;
  EXPECT_FALSE(valid_bucket_name(std::string(64, 'a')));
  EXPECT_TRUE(valid_bucket_name("1.2.3.4a"));  // not an address
}

}  // namespace
}  // namespace zoomwarp::tiles
