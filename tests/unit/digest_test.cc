#include "core/common/digest.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace hgraph {
namespace {

// FIPS 180-2 test vectors: the client and the server must agree with every other SHA-256.
TEST(DigestTest, Sha256MatchesTheStandardVectors) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(DigestTest, IncrementalEqualsOneShot) {
  const std::string text = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  Sha256 sha;
  sha.Update(text.substr(0, 7));
  sha.Update(text.substr(7));
  const std::string hex = sha.HexDigest();
  EXPECT_EQ(hex, Sha256Hex(text));
  EXPECT_EQ(hex, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_TRUE(IsSha256Hex(hex));
}

TEST(DigestTest, IsSha256HexWantsLowerCaseHexOf64Digits) {
  EXPECT_FALSE(IsSha256Hex(""));
  EXPECT_FALSE(IsSha256Hex(std::string(63, 'a')));
  EXPECT_FALSE(IsSha256Hex(std::string(64, 'A')));
  EXPECT_FALSE(IsSha256Hex(std::string(63, 'a') + "g"));
  EXPECT_TRUE(IsSha256Hex(std::string(64, '0')));
}

TEST(DigestTest, RandomHex128IsFresh) {
  std::set<std::string> seen;
  for (int i = 0; i < 100; ++i) {
    const std::string id = RandomHex128();
    EXPECT_EQ(id.size(), 32u);
    EXPECT_TRUE(seen.insert(id).second);
  }
}

}  // namespace
}  // namespace hgraph
