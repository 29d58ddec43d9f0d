#include "core/common/client_text.h"

#include <gtest/gtest.h>

#include <string>

namespace hgraph {
namespace {

TEST(ClientText, ControlCharactersAreEscaped) {
  EXPECT_EQ(ClientText("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(ClientText(std::string("nul\0byte", 8)), "nul\\0byte");
  EXPECT_EQ(ClientText("\x1b[31mred\x7f"), "\\x1b[31mred\\x7f");
  // Printable text, UTF-8 and backslashes are kept as they are.
  EXPECT_EQ(ClientText("path-1 \xc3\xa9 C:\\x"), "path-1 \xc3\xa9 C:\\x");
}

TEST(ClientText, LongTextIsCutWithAMarker) {
  const std::string name(100000, 'n');
  const std::string text = ClientText(name);
  EXPECT_EQ(text, std::string(kClientTextMaxBytes, 'n') + "...(100000 bytes, cut)");
  EXPECT_EQ(ClientText(name, 10), "nnnnnnnnnn...(100000 bytes, cut)");
  EXPECT_EQ(ClientText(std::string(kClientTextMaxBytes, 'n')),
            std::string(kClientTextMaxBytes, 'n'));
}

TEST(ClientText, ApplyingItTwiceChangesNothingMore) {
  const std::string once = ClientText("a\nb\x01");
  EXPECT_EQ(ClientText(once), once);
}

}  // namespace
}  // namespace hgraph
