#include "server/auth.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <map>
#include <set>

#include "core/common/digest.h"
#include "core/common/error.h"
#include "core/common/file_bytes.h"

namespace hgraph::server {
namespace {

constexpr char kFlag[] = "--auth-tokens";
constexpr char kMissing[] =
    "the call carries no authorization metadata; this server requires "
    "\"authorization: Bearer <token>\" (--auth-tokens)";
// One message for a malformed header and for an unknown token.
constexpr char kInvalid[] = "the authorization metadata does not hold a valid bearer token";

bool IsTokenChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
         c == '.' || c == '_' || c == '~' || c == '+' || c == '/';
}

// RFC 6750 b64token: 1*( ALPHA / DIGIT / "-" / "." / "_" / "~" / "+" / "/" ) *"="
bool IsB64Token(std::string_view token) {
  size_t end = token.size();
  while (end > 0 && token[end - 1] == '=') --end;
  if (end == 0) return false;
  return std::all_of(token.begin(), token.begin() + static_cast<long>(end), IsTokenChar);
}

bool IsTenantName(std::string_view tenant) {
  return !tenant.empty() && tenant.size() <= TokenTable::kMaxTenantChars &&
         std::all_of(tenant.begin(), tenant.end(), [](char c) {
           return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                  c == '.' || c == '_' || c == '-';
         });
}

bool IsBlank(char c) { return c == ' ' || c == '\t'; }

// The white-space separated fields of one line (comment and CR removed).
std::vector<std::string_view> Fields(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (const size_t hash = line.find('#'); hash != std::string_view::npos) {
    line = line.substr(0, hash);
  }
  std::vector<std::string_view> fields;
  size_t at = 0;
  while (at < line.size()) {
    while (at < line.size() && IsBlank(line[at])) ++at;
    const size_t start = at;
    while (at < line.size() && !IsBlank(line[at])) ++at;
    if (at > start) fields.push_back(line.substr(start, at - start));
  }
  return fields;
}

// Equal in time independent of where the strings differ (both are 64 hex digits).
bool ConstantTimeEqual(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  }
  return diff == 0;
}

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

TokenTable TokenTable::Parse(std::string_view text, const std::string& source) {
  TokenTable table;
  std::map<std::string, int> first_line;  // token digest -> line
  int line_number = 0;
  size_t at = 0;
  while (at <= text.size()) {
    size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(at, end - at);
    at = end + 1;
    ++line_number;
    const auto error = [&](const std::string& problem) {
      return InputError(kFlag, source + " line " + std::to_string(line_number) + ": " + problem);
    };
    if (line.find('\0') != std::string_view::npos) throw error("holds a NUL byte");
    const std::vector<std::string_view> fields = Fields(line);
    if (fields.empty()) continue;
    if (fields.size() != 2) {
      throw error("expected \"TOKEN TENANT\" (two fields separated by white space), found " +
                  std::to_string(fields.size()) + " field" + (fields.size() == 1 ? "" : "s"));
    }
    const std::string_view token = fields[0];
    const std::string_view tenant = fields[1];
    if (token.size() < kMinTokenChars || token.size() > kMaxTokenChars) {
      throw error("the token has " + std::to_string(token.size()) + " characters; " +
                  std::to_string(kMinTokenChars) + " to " + std::to_string(kMaxTokenChars) +
                  " are required");
    }
    if (!IsB64Token(token)) {
      throw error(
          "the token holds a character outside A-Z a-z 0-9 - . _ ~ + / (and trailing '=' "
          "padding)");
    }
    if (!IsTenantName(tenant)) {
      throw error("the tenant must be 1 to " + std::to_string(kMaxTenantChars) +
                  " characters of A-Z a-z 0-9 . _ -");
    }
    std::string digest = Sha256Hex(token);
    if (auto [it, inserted] = first_line.emplace(digest, line_number); !inserted) {
      throw error("repeats the token of line " + std::to_string(it->second) +
                  " (a token speaks for one tenant)");
    }
    table.entries_.push_back(Entry{.sha256 = std::move(digest), .tenant = std::string(tenant)});
  }
  if (table.entries_.empty()) {
    throw InputError(kFlag,
                     source + " holds no \"TOKEN TENANT\" line; every call would be refused");
  }
  return table;
}

TokenTable TokenTable::Load(const std::string& path) {
  return Parse(ReadFileBytes(path, kFlag), path);
}

const std::string* TokenTable::Find(std::string_view token) const {
  const std::string digest = Sha256Hex(token);
  // Every entry is compared, and the match is selected without a branch on the comparison, so
  // the time says nothing about which entry (if any) matched.
  size_t found = 0;  // index + 1, or 0
  for (size_t i = 0; i < entries_.size(); ++i) {
    const size_t equal = ConstantTimeEqual(entries_[i].sha256, digest);
    found |= (i + 1) & (size_t{0} - equal);
  }
  return found == 0 ? nullptr : &entries_[found - 1].tenant;
}

std::vector<std::string> TokenTable::tenants() const {
  std::set<std::string> names;
  for (const Entry& e : entries_) names.insert(e.tenant);
  return {names.begin(), names.end()};
}

Authenticator::Authenticator(TokenTable tokens) : enabled_(true), tokens_(std::move(tokens)) {}

grpc::Status Authenticator::Authenticate(const std::vector<std::string_view>& authorization,
                                         std::string* tenant) const {
  if (!enabled_) {
    *tenant = std::string(kAnonymousTenant);
    return grpc::Status::OK;
  }
  if (authorization.empty()) return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, kMissing);
  const grpc::Status invalid(grpc::StatusCode::UNAUTHENTICATED, kInvalid);
  if (authorization.size() != 1) return invalid;
  std::string_view value = authorization.front();
  constexpr std::string_view kScheme = "bearer";
  if (value.size() <= kScheme.size() ||
      !EqualsIgnoreCase(value.substr(0, kScheme.size()), kScheme) ||
      !IsBlank(value[kScheme.size()])) {
    return invalid;
  }
  value.remove_prefix(kScheme.size());
  while (!value.empty() && IsBlank(value.front())) value.remove_prefix(1);
  while (!value.empty() && IsBlank(value.back())) value.remove_suffix(1);
  if (value.empty() || value.size() > TokenTable::kMaxTokenChars) return invalid;
  const std::string* found = tokens_.Find(value);
  if (found == nullptr) return invalid;
  *tenant = *found;
  return grpc::Status::OK;
}

grpc::Status Authenticator::Authenticate(const grpc::ServerContextBase& context,
                                         std::string* tenant) const {
  std::vector<std::string_view> values;
  if (enabled_) {
    const auto range = context.client_metadata().equal_range("authorization");
    for (auto it = range.first; it != range.second; ++it) {
      values.emplace_back(it->second.data(), it->second.size());
    }
  }
  return Authenticate(values, tenant);
}

}  // namespace hgraph::server
