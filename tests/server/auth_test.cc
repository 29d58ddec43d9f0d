// The --auth-tokens file parser and the bearer-token check (server/auth.h).
#include "server/auth.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "core/common/error.h"

namespace hgraph::server {
namespace {

constexpr char kTokenA[] = "tokenAAAAAAAAAAAAAAAAAAAAAAAAAAA";
constexpr char kTokenB[] = "tokenBBBBBBBBBBBBBBBBBBBBBBBBBBB";

// The message of the Error that parsing `text` throws (fails the test if none).
std::string ParseError(const std::string& text) {
  try {
    TokenTable::Parse(text, "tokens.txt");
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.field(), "--auth-tokens");
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

TEST(TokenTable, ParsesPairsCommentsAndBlankLines) {
  const TokenTable table = TokenTable::Parse(
      "# tokens of the two teams\n"
      "\n" +
          std::string(kTokenA) +
          " team-a\n"
          "   \t\n"
          "\t" +
          kTokenB +
          "\tteam_b   # rotated 2026-11\r\n"
          "another-token-of-team-a.v2= team-a\n",
      "tokens.txt");
  EXPECT_EQ(table.size(), 3u);
  ASSERT_NE(table.Find(kTokenA), nullptr);
  EXPECT_EQ(*table.Find(kTokenA), "team-a");
  ASSERT_NE(table.Find(kTokenB), nullptr);
  EXPECT_EQ(*table.Find(kTokenB), "team_b");
  ASSERT_NE(table.Find("another-token-of-team-a.v2="), nullptr);
  EXPECT_EQ(*table.Find("another-token-of-team-a.v2="), "team-a");
  EXPECT_EQ(table.tenants(), (std::vector<std::string>{"team-a", "team_b"}));
}

TEST(TokenTable, UnknownTokensAreNotFound) {
  const TokenTable table = TokenTable::Parse(std::string(kTokenA) + " a\n", "t");
  EXPECT_EQ(table.Find(""), nullptr);
  EXPECT_EQ(table.Find(std::string(kTokenA) + "x"), nullptr);
  EXPECT_EQ(table.Find(std::string(kTokenA).substr(1)), nullptr);
  EXPECT_EQ(table.Find("a"), nullptr);  // a tenant name is not a token
}

TEST(TokenTable, MalformedLinesNameTheLineAndNeverQuoteIt) {
  const std::string secret = "s3cretS3cretS3cret";
  struct Case {
    std::string text;
    std::string fragment;
  };
  const Case cases[] = {
      {"# header\n" + secret + "\n", "tokens.txt line 2: expected \"TOKEN TENANT\""},
      {secret + " a b\n",
       "line 1: expected \"TOKEN TENANT\" (two fields separated by white "
       "space), found 3 fields"},
      {"\n\nshort a\n", "line 3: the token has 5 characters; 16 to 4096 are required"},
      {secret + "!x a\n", "line 1: the token holds a character outside"},
      {"==" + secret + " a\n", "line 1: the token holds a character outside"},
      {secret + " tenant/x\n", "line 1: the tenant must be 1 to 64 characters"},
      {secret + " " + std::string(65, 't') + "\n", "line 1: the tenant must be 1 to 64"},
      {std::string(kTokenA) + " a\n" + secret + std::string("\0x b\n", 5), "line 2: holds a NUL"},
  };
  for (const Case& c : cases) {
    const std::string message = ParseError(c.text);
    EXPECT_NE(message.find(c.fragment), std::string::npos) << message;
    EXPECT_EQ(message.find(secret), std::string::npos) << message;
    EXPECT_EQ(message.find(kTokenA), std::string::npos) << message;
  }
}

TEST(TokenTable, DuplicateTokensAreRefusedEvenForTheSameTenant) {
  const std::string text = std::string(kTokenA) + " a\n" + kTokenB + " b\n# x\n" + kTokenA + " a\n";
  const std::string message = ParseError(text);
  EXPECT_NE(message.find("tokens.txt line 4: repeats the token of line 1"), std::string::npos)
      << message;
  EXPECT_EQ(message.find(kTokenA), std::string::npos) << message;
}

TEST(TokenTable, AFileWithoutTokensIsRefused) {
  EXPECT_NE(ParseError("# nothing yet\n\n").find("holds no \"TOKEN TENANT\" line"),
            std::string::npos);
  EXPECT_NE(ParseError("").find("holds no"), std::string::npos);
}

TEST(TokenTable, LoadNamesAnUnreadableFile) {
  try {
    TokenTable::Load("/nonexistent/hgraph-tokens.txt");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_NE(std::string(e.what()).find("--auth-tokens: cannot read /nonexistent/hgraph-tokens"),
              std::string::npos)
        << e.what();
  }
}

TEST(TokenTable, LoadReadsAFile) {
  const std::string path = testing::TempDir() + "/auth_test_tokens.txt";
  {
    std::ofstream out(path);
    out << kTokenA << " a\n";
  }
  const TokenTable table = TokenTable::Load(path);
  ASSERT_NE(table.Find(kTokenA), nullptr);
  EXPECT_EQ(*table.Find(kTokenA), "a");
  std::remove(path.c_str());
}

class AuthenticatorTest : public testing::Test {
 protected:
  AuthenticatorTest()
      : auth_(TokenTable::Parse(std::string(kTokenA) + " a\n" + kTokenB + " b\n", "t")) {}

  grpc::Status Check(const std::vector<std::string_view>& values, std::string* tenant) const {
    return auth_.Authenticate(values, tenant);
  }

  Authenticator auth_;
};

TEST_F(AuthenticatorTest, BearerTokensNameTheirTenant) {
  std::string tenant;
  ASSERT_TRUE(Check({std::string("Bearer ") + kTokenA}, &tenant).ok());
  EXPECT_EQ(tenant, "a");
  const std::string b = std::string("bearer \t") + kTokenB + " ";  // scheme case, extra blanks
  ASSERT_TRUE(Check({b}, &tenant).ok());
  EXPECT_EQ(tenant, "b");
}

TEST_F(AuthenticatorTest, MissingMalformedAndUnknownAreUnauthenticated) {
  std::string tenant = "unchanged";
  const grpc::Status missing = Check({}, &tenant);
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_NE(missing.error_message().find("no authorization metadata"), std::string::npos);

  const grpc::Status unknown = Check({"Bearer tokenCCCCCCCCCCCCCCCCCCCCCCCCCCC"}, &tenant);
  EXPECT_EQ(unknown.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  const std::string malformed[] = {
      kTokenA,                                // no scheme
      std::string("Basic ") + kTokenA,        // another scheme
      std::string("Bearer") + kTokenA,        // no blank after the scheme
      "Bearer ",                              // no token
      "Bearer " + std::string(5000, 'x'),     // longer than any token
      std::string("Bearer ") + kTokenA + "x"  // a known token's prefix
  };
  for (const std::string& value : malformed) {
    const grpc::Status status = Check({value}, &tenant);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << value;
    // The same answer as for an unknown token: a refusal says nothing about the table.
    EXPECT_EQ(status.error_message(), unknown.error_message()) << value;
  }
  // Two authorization values are ambiguous, even when both are valid.
  const std::string a = std::string("Bearer ") + kTokenA;
  const grpc::Status twice = Check({a, a}, &tenant);
  EXPECT_EQ(twice.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(twice.error_message(), unknown.error_message());
  EXPECT_EQ(tenant, "unchanged");
}

TEST(Authenticator, WithoutTokensEveryCallIsTheAnonymousTenant) {
  const Authenticator open;
  EXPECT_FALSE(open.enabled());
  std::string tenant = "x";
  EXPECT_TRUE(open.Authenticate(std::vector<std::string_view>{}, &tenant).ok());
  EXPECT_EQ(tenant, kAnonymousTenant);
  tenant = "x";
  EXPECT_TRUE(open.Authenticate({"Bearer whatever-is-sent-here"}, &tenant).ok());
  EXPECT_EQ(tenant, kAnonymousTenant);
}

}  // namespace
}  // namespace hgraph::server
