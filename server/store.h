// The store the replicas of a deployment share (--store): a key-value store with expiry that
// holds blobs, scenes, session records and H-Graph snapshots (server/shared_state.h says what
// goes under which key), so that a replica that does not hold a session or an H-Graph loads it
// instead of answering NOT_FOUND.
//
// --store memory (the default) shares nothing: each replica holds what it built, as a single
// server does. MemoryStore is the same interface inside one process (tests run two services on
// one); RedisStore talks to Redis (redis://, or rediss:// over TLS).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace hgraph::server {

// The store failed, timed out or answered something unexpected: the caller goes on from memory.
// Copyable.
class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Implementations are thread safe. Not copyable (polymorphic base).
class Store {
 public:
  Store() = default;
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;
  virtual ~Store() = default;

  // The value, or nullopt when absent (or expired). Throws StoreError.
  virtual std::optional<std::string> Get(const std::string& key) = 0;
  // The first `bytes` bytes of the value (fewer if it is shorter), or nullopt when absent.
  virtual std::optional<std::string> GetPrefix(const std::string& key, size_t bytes) = 0;
  // Sets the value, expiring after `ttl` (> 0). Throws StoreError.
  virtual void Set(const std::string& key, std::string_view value,
                   std::chrono::milliseconds ttl) = 0;
  // Compare-and-set: sets the value (as Set does) only if the value held now begins with
  // `expected_prefix`, or with an empty prefix only if the key is absent. Returns whether it was
  // set. Throws StoreError.
  virtual bool SetIfPrefix(const std::string& key, std::string_view expected_prefix,
                           std::string_view value, std::chrono::milliseconds ttl) = 0;
  virtual bool Exists(const std::string& key) = 0;
  // Extends the keys that exist to expire after `ttl`; absent keys are skipped.
  virtual void Expire(const std::vector<std::string>& keys, std::chrono::milliseconds ttl) = 0;
  virtual void Delete(const std::vector<std::string>& keys) = 0;
  // The values of `keys`, in their order (nullopt for an absent one). Throws StoreError.
  virtual std::vector<std::optional<std::string>> GetMany(const std::vector<std::string>& keys) = 0;
  // How long the key lives yet; nullopt when it is absent or never expires.
  virtual std::optional<std::chrono::milliseconds> TimeToLive(const std::string& key) = 0;

  // Sets of strings under a key (the indexes: a tenant's sessions, a session's H-Graphs).
  // Adds `member` to the set, which then expires no sooner than `ttl` (> 0) from now (Expire
  // and Delete apply to sets too). Throws StoreError.
  virtual void AddMember(const std::string& key, const std::string& member,
                         std::chrono::milliseconds ttl) = 0;
  // The set's members, in no particular order (none when absent).
  virtual std::vector<std::string> Members(const std::string& key) = 0;
  virtual void RemoveMembers(const std::string& key, const std::vector<std::string>& members) = 0;
  // Where the store is, for logs ("redis://host:6379/0"; never a password).
  virtual std::string Describe() const = 0;
};

// In one process. Thread safe. Not copyable.
class MemoryStore final : public Store {
 public:
  using Clock = std::chrono::steady_clock;
  std::optional<std::string> Get(const std::string& key) override;
  std::optional<std::string> GetPrefix(const std::string& key, size_t bytes) override;
  void Set(const std::string& key, std::string_view value, std::chrono::milliseconds ttl) override;
  bool SetIfPrefix(const std::string& key, std::string_view expected_prefix, std::string_view value,
                   std::chrono::milliseconds ttl) override;
  bool Exists(const std::string& key) override;
  void Expire(const std::vector<std::string>& keys, std::chrono::milliseconds ttl) override;
  void Delete(const std::vector<std::string>& keys) override;
  std::vector<std::optional<std::string>> GetMany(const std::vector<std::string>& keys) override;
  std::optional<std::chrono::milliseconds> TimeToLive(const std::string& key) override;
  void AddMember(const std::string& key, const std::string& member,
                 std::chrono::milliseconds ttl) override;
  std::vector<std::string> Members(const std::string& key) override;
  void RemoveMembers(const std::string& key, const std::vector<std::string>& members) override;
  std::string Describe() const override { return "memory"; }

 private:
  struct Entry {
    std::string value;
    std::set<std::string> members;  // a set's (AddMember)
    Clock::time_point expire;
  };
  // Under mutex_: the live entry of `key`, or nullptr (an expired one is dropped).
  Entry* Live(const std::string& key);
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

// Where --store points.
struct StoreAddress {
  bool redis = false;  // false: "memory", nothing shared
  bool tls = false;    // rediss://
  std::string host;
  int port = 6379;
  int db = 0;
};

// Parses "memory", "redis://HOST[:PORT][/DB]" or "rediss://HOST[:PORT][/DB]" (HOST a name,
// an IPv4 address or a bracketed IPv6 one; DB 0 to 15). Throws InputError("--store") naming
// what is wrong.
StoreAddress ParseStoreAddress(const std::string& text);

struct RedisOptions {
  StoreAddress address;
  std::string password;  // AUTH, from --store-password-file; empty: none
  std::string username;  // ACL user with the password; empty: the default user
  std::string ca_file;   // rediss://: PEM CA bundle to verify the server with; empty: the system's
  // Each operation (connect, or a command and its reply) fails after this long.
  std::chrono::milliseconds timeout{500};
  // After a failure, operations fail at once for this long instead of waiting on a store that
  // is down: a slow or dead store costs one timeout per interval, not one per call.
  std::chrono::milliseconds retry_after{1000};
};

// Connects lazily, on the first operation (so a server starts while Redis is down); keeps a
// pool of connections, one per concurrent caller. Throws InputError("--store-ca-file") for a CA
// file it cannot load.
std::unique_ptr<Store> MakeRedisStore(const RedisOptions& options);

}  // namespace hgraph::server
