#include "server/store.h"

#include <algorithm>
#include <cctype>

#include "core/common/client_text.h"
#include "core/common/error.h"

namespace hgraph::server {

MemoryStore::Entry* MemoryStore::Live(const std::string& key) {
  auto it = entries_.find(key);
  if (it == entries_.end()) return nullptr;
  if (it->second.expire <= Clock::now()) {
    entries_.erase(it);
    return nullptr;
  }
  return &it->second;
}

std::optional<std::string> MemoryStore::Get(const std::string& key) {
  std::lock_guard lock(mutex_);
  const Entry* entry = Live(key);
  if (entry == nullptr) return std::nullopt;
  return entry->value;
}

std::optional<std::string> MemoryStore::GetPrefix(const std::string& key, size_t bytes) {
  std::lock_guard lock(mutex_);
  const Entry* entry = Live(key);
  if (entry == nullptr) return std::nullopt;
  return entry->value.substr(0, bytes);
}

void MemoryStore::Set(const std::string& key, std::string_view value,
                      std::chrono::milliseconds ttl) {
  std::lock_guard lock(mutex_);
  entries_[key] = Entry{.value = std::string(value), .expire = Clock::now() + ttl};
}

bool MemoryStore::SetIfPrefix(const std::string& key, std::string_view expected_prefix,
                              std::string_view value, std::chrono::milliseconds ttl) {
  std::lock_guard lock(mutex_);
  const Entry* entry = Live(key);
  if (expected_prefix.empty() ? entry != nullptr
                              : entry == nullptr || !entry->value.starts_with(expected_prefix)) {
    return false;
  }
  entries_[key] = Entry{.value = std::string(value), .expire = Clock::now() + ttl};
  return true;
}

bool MemoryStore::Exists(const std::string& key) {
  std::lock_guard lock(mutex_);
  return Live(key) != nullptr;
}

void MemoryStore::Expire(const std::vector<std::string>& keys, std::chrono::milliseconds ttl) {
  std::lock_guard lock(mutex_);
  for (const std::string& key : keys) {
    if (Entry* entry = Live(key)) entry->expire = Clock::now() + ttl;
  }
}

void MemoryStore::Delete(const std::vector<std::string>& keys) {
  std::lock_guard lock(mutex_);
  for (const std::string& key : keys) entries_.erase(key);
}

std::vector<std::optional<std::string>> MemoryStore::GetMany(const std::vector<std::string>& keys) {
  std::lock_guard lock(mutex_);
  std::vector<std::optional<std::string>> out;
  for (const std::string& key : keys) {
    const Entry* entry = Live(key);
    out.push_back(entry == nullptr ? std::nullopt : std::optional<std::string>(entry->value));
  }
  return out;
}

std::optional<std::chrono::milliseconds> MemoryStore::TimeToLive(const std::string& key) {
  std::lock_guard lock(mutex_);
  const Entry* entry = Live(key);
  if (entry == nullptr) return std::nullopt;
  return std::chrono::duration_cast<std::chrono::milliseconds>(entry->expire - Clock::now());
}

void MemoryStore::AddMember(const std::string& key, const std::string& member,
                            std::chrono::milliseconds ttl) {
  std::lock_guard lock(mutex_);
  const Clock::time_point expire = Clock::now() + ttl;
  Entry* entry = Live(key);
  if (entry == nullptr) entry = &(entries_[key] = Entry{.expire = expire});
  entry->members.insert(member);
  entry->expire = std::max(entry->expire, expire);
}

std::vector<std::string> MemoryStore::Members(const std::string& key) {
  std::lock_guard lock(mutex_);
  const Entry* entry = Live(key);
  if (entry == nullptr) return {};
  return {entry->members.begin(), entry->members.end()};
}

void MemoryStore::RemoveMembers(const std::string& key, const std::vector<std::string>& members) {
  std::lock_guard lock(mutex_);
  Entry* entry = Live(key);
  if (entry == nullptr) return;
  for (const std::string& m : members) entry->members.erase(m);
  if (entry->members.empty()) entries_.erase(key);  // as Redis drops an empty set
}

StoreAddress ParseStoreAddress(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return InputError("--store",
                      "must be \"memory\", \"redis://HOST[:PORT][/DB]\" or "
                      "\"rediss://HOST[:PORT][/DB]\": " +
                          why + " in \"" + ClientText(text) + "\"");
  };
  StoreAddress address;
  if (text == "memory") return address;
  std::string rest;
  if (text.starts_with("redis://")) {
    rest = text.substr(8);
  } else if (text.starts_with("rediss://")) {
    rest = text.substr(9);
    address.tls = true;
  } else {
    throw bad("unknown scheme");
  }
  address.redis = true;
  if (rest.find('@') != std::string::npos) {
    // Not echoed: the text holds a password.
    throw InputError("--store",
                     "must not hold credentials (\"user:password@\"): they would show in process "
                     "listings and logs; put them in --store-password-file");
  }
  std::string db;
  if (const size_t slash = rest.find('/'); slash != std::string::npos) {
    db = rest.substr(slash + 1);
    rest.resize(slash);
  }
  std::string port;
  if (rest.starts_with("[")) {
    const size_t close = rest.find(']');
    if (close == std::string::npos) throw bad("an unclosed '[' of an IPv6 address");
    address.host = rest.substr(1, close - 1);
    const std::string after = rest.substr(close + 1);
    if (!after.empty()) {
      if (after[0] != ':') throw bad("text after the IPv6 address");
      port = after.substr(1);
      if (port.empty()) throw bad("an empty port");
    }
  } else {
    const size_t colon = rest.find(':');
    address.host = rest.substr(0, colon);
    if (colon != std::string::npos) {
      port = rest.substr(colon + 1);
      if (port.empty()) throw bad("an empty port");
    }
  }
  if (address.host.empty()) throw bad("no host");
  const auto digits = [](const std::string& s) {
    return !s.empty() && s.size() <= 5 &&
           std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
  };
  if (!port.empty()) {
    if (!digits(port) || std::stoi(port) < 1 || std::stoi(port) > 65535) {
      throw bad("port \"" + ClientText(port) + "\" is not in [1, 65535]");
    }
    address.port = std::stoi(port);
  }
  if (!db.empty()) {
    if (!digits(db) || std::stoi(db) > 15) {
      throw bad("database \"" + ClientText(db) + "\" is not in [0, 15]");
    }
    address.db = std::stoi(db);
  }
  return address;
}

}  // namespace hgraph::server
