// Client strings (names, ids, digests, paths) as they may appear in a log line or an error
// message: control characters (NUL, newlines, escapes) written as \0, \n, \r, \t or \xNN, and
// anything past `max_bytes` cut with a marker, so that a name can neither forge a log line nor
// blow up a status message past gRPC's metadata limit. Backslashes stay as they are, so that
// applying it twice changes nothing more (the service applies it to every error message too).
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>

namespace hgraph {

inline constexpr size_t kClientTextMaxBytes = 200;

inline std::string ClientText(std::string_view text, size_t max_bytes = kClientTextMaxBytes) {
  std::string out;
  const size_t kept = text.size() <= max_bytes ? text.size() : max_bytes;
  out.reserve(kept + 32);
  for (size_t i = 0; i < kept; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    switch (c) {
      case '\0': out += "\\0"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20 || c == 0x7f) {
          char hex[5];
          std::snprintf(hex, sizeof(hex), "\\x%02x", c);
          out += hex;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  if (kept < text.size()) {
    out += "...(" + std::to_string(text.size()) + " bytes, cut)";
  }
  return out;
}

}  // namespace hgraph
