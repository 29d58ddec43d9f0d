// Bearer tokens and tenants (--auth-tokens). The token file maps each token to the tenant it
// speaks for; with it, every hgraph.v1 call must carry `authorization: Bearer <token>` and is
// refused with UNAUTHENTICATED otherwise. Sessions and their H-Graphs belong to the tenant that
// created them (server/session_registry.h); scenes and blobs are content-addressed and shared.
// Without a token file every call is the one anonymous tenant, as before tenants existed.
//
// Tokens are secrets: the table keeps only their SHA-256 digests, a presented token is hashed and
// compared with every entry in constant time, and no error or log line quotes a token or a line
// of the file (errors name the line number only).
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>
#include <string_view>
#include <vector>

namespace hgraph::server {

// The tenant of every call on a server without --auth-tokens.
inline constexpr std::string_view kAnonymousTenant = "";

// The parsed token file. Copyable and movable.
class TokenTable {
 public:
  // Shortest token accepted: a guessable token would make the tenant boundary decorative.
  static constexpr size_t kMinTokenChars = 16;
  static constexpr size_t kMaxTokenChars = 4096;
  static constexpr size_t kMaxTenantChars = 64;

  // One "TOKEN TENANT" pair per line, separated by spaces or tabs; '#' starts a comment (neither
  // a token nor a tenant may contain it), blank lines are skipped, a trailing CR is ignored.
  // A token is kMinTokenChars to kMaxTokenChars characters of RFC 6750's b64token alphabet
  // (A-Z a-z 0-9 - . _ ~ + /, then '=' padding), so that it fits an HTTP header as it is; a
  // tenant is 1 to kMaxTenantChars characters of A-Z a-z 0-9 . _ - (it appears in log lines).
  // One tenant may have several tokens (rotation); a token appears once. Throws
  // InputError("--auth-tokens") naming `source` and the line number of the first bad line, and
  // when the file holds no token at all.
  static TokenTable Parse(std::string_view text, const std::string& source);
  // Reads and parses the file; throws Error(kNotFound, "--auth-tokens") if it cannot be read.
  static TokenTable Load(const std::string& path);

  // The tenant the token belongs to, or nullptr. Takes the same time whichever entry matches
  // and whether any does (it depends on the presented token's length and the table's size only).
  const std::string* Find(std::string_view token) const;
  size_t size() const { return entries_.size(); }
  // The distinct tenants, sorted.
  std::vector<std::string> tenants() const;

 private:
  struct Entry {
    std::string sha256;  // hex digest of the token
    std::string tenant;
  };
  std::vector<Entry> entries_;
};

// Decides who a call comes from. Thread safe (immutable after construction); copyable.
class Authenticator {
 public:
  // Open: every call is kAnonymousTenant.
  Authenticator() = default;
  explicit Authenticator(TokenTable tokens);

  bool enabled() const { return enabled_; }

  // The tenant of a call from its `authorization` metadata values (gRPC lower-cases the key; a
  // call may carry the key more than once, which is refused as ambiguous). The scheme "Bearer"
  // is matched without regard to case (RFC 7235). Returns OK and sets *tenant, or
  // UNAUTHENTICATED: one message when the metadata is missing, and one and the same message for
  // a malformed value and an unknown token, so that a refusal tells nothing about the tokens.
  grpc::Status Authenticate(const std::vector<std::string_view>& authorization,
                            std::string* tenant) const;
  // The same, from the call's client metadata.
  grpc::Status Authenticate(const grpc::ServerContextBase& context, std::string* tenant) const;

 private:
  bool enabled_ = false;
  TokenTable tokens_;
};

}  // namespace hgraph::server
