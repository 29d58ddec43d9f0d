// SHA-256 content digests of blobs and scenes (hgraph.v1.Digest): lower-case hex and size.
// Shared by the server and the remote clients, which must compute the same digest for a blob.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace hgraph {

// Incremental SHA-256 (OpenSSL EVP). Not copyable; movable.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(Sha256&&) noexcept;
  Sha256& operator=(Sha256&&) noexcept;
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void Update(std::string_view bytes);
  // Lower-case hex of the digest; the object cannot be updated afterwards.
  std::string HexDigest();

 private:
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
};

std::string Sha256Hex(std::string_view bytes);

// True for 64 lower-case hex digits.
bool IsSha256Hex(std::string_view text);

// 128 random bits from the operating system's CSPRNG as 32 hex digits (session ids must be
// unguessable, so a seeded generator would be wrong here).
std::string RandomHex128();

}  // namespace hgraph
