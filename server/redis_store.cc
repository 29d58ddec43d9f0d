// RedisStore: Redis commands over our own socket (plain, or TLS through OpenSSL), with hiredis
// formatting the commands and parsing the replies. Debian 12's hiredis (0.14) has no TLS, and
// its blocking context has one timeout for everything; owning the socket gives both, and a
// deadline per operation.
#include <arpa/inet.h>
#include <fcntl.h>
#include <hiredis/hiredis.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/error.h"
#include "server/store.h"

namespace hgraph::server {
namespace {

using Clock = std::chrono::steady_clock;

// Sets the value if the one held starts with ARGV[1] (an empty ARGV[1]: if the key is absent).
constexpr const char* kSetIfPrefix = R"lua(
local p = ARGV[1]
if p == '' then
  if redis.call('EXISTS', KEYS[1]) == 1 then return 0 end
elseif redis.call('GETRANGE', KEYS[1], 0, #p - 1) ~= p then
  return 0
end
redis.call('SET', KEYS[1], ARGV[2], 'PX', ARGV[3])
return 1
)lua";

// Adds ARGV[1] to the set and makes it expire no sooner than ARGV[2] ms from now (PTTL is -1
// for the set SADD has just created).
constexpr const char* kAddMember = R"lua(
redis.call('SADD', KEYS[1], ARGV[1])
if redis.call('PTTL', KEYS[1]) < tonumber(ARGV[2]) then
  redis.call('PEXPIRE', KEYS[1], ARGV[2])
end
return 1
)lua";

std::string OpenSslError() {
  const unsigned long code = ERR_get_error();
  if (code == 0) return "no OpenSSL error queued";
  char text[256];
  ERR_error_string_n(code, text, sizeof(text));
  ERR_clear_error();
  return text;
}

// Bulk strings from this size on are read without hiredis (Connection::Receive).
constexpr long long kDirectBulkBytes = 64 << 10;

// One reply, copied out of hiredis's.
struct Reply {
  int type = 0;  // REDIS_REPLY_*
  std::string str;
  long long integer = 0;
  std::vector<Reply> elements;
};

Reply CopyReply(const redisReply* r) {
  Reply out;
  out.type = r->type;
  out.integer = r->integer;
  if (r->str != nullptr) out.str.assign(r->str, r->len);
  for (size_t i = 0; i < r->elements; ++i) out.elements.push_back(CopyReply(r->element[i]));
  return out;
}

struct ReaderDeleter {
  void operator()(redisReader* r) const { redisReaderFree(r); }
};
struct SslDeleter {
  void operator()(SSL* s) const { SSL_free(s); }
};

// One connection; used by one caller at a time. Not copyable.
class Connection {
 public:
  Connection(const RedisOptions& options, SSL_CTX* tls, Clock::time_point deadline)
      : reader_(redisReaderCreate()) {
    if (!reader_) throw StoreError("cannot allocate a reply reader");
    Open(options, deadline);
    if (tls != nullptr) StartTls(tls, options.address.host, deadline);
    if (!options.password.empty()) {
      std::vector<std::string> auth = {"AUTH"};
      if (!options.username.empty()) auth.push_back(options.username);
      auth.push_back(options.password);
      const Reply reply = Command({auth.begin(), auth.end()}, deadline);
      // The reply never echoes the password; the error text is Redis's own.
      if (reply.type == REDIS_REPLY_ERROR) throw StoreError("AUTH refused: " + reply.str);
    }
    if (options.address.db != 0) {
      const std::string db = std::to_string(options.address.db);
      const Reply reply = Command({"SELECT", db}, deadline);
      if (reply.type == REDIS_REPLY_ERROR) throw StoreError("SELECT refused: " + reply.str);
    }
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection() {
    ssl_.reset();
    if (fd_ >= 0) ::close(fd_);
  }

  // Sends the command (RESP: an array of bulk strings) and returns its reply. Arguments of
  // kDirectBulkBytes or more (a snapshot) are sent from where they are, not copied.
  Reply Command(const std::vector<std::string_view>& args, Clock::time_point deadline) {
    std::string wire = "*" + std::to_string(args.size()) + "\r\n";
    for (const std::string_view a : args) {
      wire += "$" + std::to_string(a.size()) + "\r\n";
      if (a.size() >= static_cast<size_t>(kDirectBulkBytes)) {
        Send(wire.data(), wire.size(), deadline);
        Send(a.data(), a.size(), deadline);
        wire.clear();
      } else {
        wire += a;
      }
      wire += "\r\n";
    }
    Send(wire.data(), wire.size(), deadline);
    return Receive(deadline);
  }

 private:
  void Open(const RedisOptions& options, Clock::time_point deadline) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* found = nullptr;
    const std::string port = std::to_string(options.address.port);
    if (const int rc = ::getaddrinfo(options.address.host.c_str(), port.c_str(), &hints, &found);
        rc != 0) {
      throw StoreError("cannot resolve " + options.address.host + ": " + gai_strerror(rc));
    }
    std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> list(found, &freeaddrinfo);
    std::string last = "no address";
    for (addrinfo* a = found; a != nullptr; a = a->ai_next) {
      const int fd =
          ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
      if (fd < 0) continue;
      if (::connect(fd, a->ai_addr, a->ai_addrlen) == 0 || errno == EINPROGRESS) {
        if (Wait(fd, POLLOUT, deadline)) {
          int error = 0;
          socklen_t size = sizeof(error);
          ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size);
          if (error == 0) {
            const int one = 1;
            ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
            fd_ = fd;
            return;
          }
          last = std::strerror(error);
        } else {
          last = "connect timed out";
        }
      } else {
        last = std::strerror(errno);
      }
      ::close(fd);
    }
    throw StoreError("cannot connect to " + options.address.host + ":" + port + ": " + last);
  }

  void StartTls(SSL_CTX* tls, const std::string& host, Clock::time_point deadline) {
    ssl_.reset(SSL_new(tls));
    if (!ssl_) throw StoreError("TLS: " + OpenSslError());
    SSL_set_fd(ssl_.get(), fd_);
    SSL_set_tlsext_host_name(ssl_.get(), host.c_str());
    // The certificate must name the host (or its IP address).
    X509_VERIFY_PARAM* param = SSL_get0_param(ssl_.get());
    in6_addr ip6{};
    in_addr ip4{};
    if (::inet_pton(AF_INET, host.c_str(), &ip4) == 1 ||
        ::inet_pton(AF_INET6, host.c_str(), &ip6) == 1) {
      X509_VERIFY_PARAM_set1_ip_asc(param, host.c_str());
    } else {
      X509_VERIFY_PARAM_set1_host(param, host.c_str(), 0);
    }
    for (;;) {
      const int rc = SSL_connect(ssl_.get());
      if (rc == 1) return;
      const int error = SSL_get_error(ssl_.get(), rc);
      if (error == SSL_ERROR_WANT_READ && Wait(fd_, POLLIN, deadline)) continue;
      if (error == SSL_ERROR_WANT_WRITE && Wait(fd_, POLLOUT, deadline)) continue;
      const long verify = SSL_get_verify_result(ssl_.get());
      throw StoreError(
          std::string("TLS handshake failed: ") +
          (verify != X509_V_OK ? X509_verify_cert_error_string(verify) : OpenSslError().c_str()));
    }
  }

  // Whether the descriptor became ready for `events` before the deadline.
  static bool Wait(int fd, short events, Clock::time_point deadline) {
    for (;;) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{.fd = fd, .events = events, .revents = 0};
      const int rc = ::poll(&p, 1, static_cast<int>(left));
      if (rc > 0) return true;
      if (rc < 0 && errno != EINTR) return false;
    }
  }

  void Send(const char* data, size_t size, Clock::time_point deadline) {
    size_t sent = 0;
    while (sent < size) {
      if (ssl_) {
        size_t n = 0;
        const int rc = SSL_write_ex(ssl_.get(), data + sent, size - sent, &n);
        if (rc == 1) {
          sent += n;
          continue;
        }
        const int error = SSL_get_error(ssl_.get(), rc);
        if (error == SSL_ERROR_WANT_WRITE && Wait(fd_, POLLOUT, deadline)) continue;
        if (error == SSL_ERROR_WANT_READ && Wait(fd_, POLLIN, deadline)) continue;
        throw StoreError("TLS write failed or timed out: " + OpenSslError());
      }
      const ssize_t n = ::send(fd_, data + sent, size - sent, MSG_NOSIGNAL);
      if (n > 0) {
        sent += static_cast<size_t>(n);
      } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
        if (!Wait(fd_, POLLOUT, deadline)) throw StoreError("write timed out");
      } else {
        throw StoreError(std::string("write failed: ") + std::strerror(errno));
      }
    }
  }

  // Some bytes of the reply (at most `size`, at least one), waiting until the deadline.
  size_t ReadSome(char* into, size_t size, Clock::time_point deadline) {
    for (;;) {
      if (ssl_) {
        size_t n = 0;
        const int rc = SSL_read_ex(ssl_.get(), into, size, &n);
        if (rc == 1) return n;
        const int error = SSL_get_error(ssl_.get(), rc);
        if (error == SSL_ERROR_WANT_READ && Wait(fd_, POLLIN, deadline)) continue;
        if (error == SSL_ERROR_WANT_WRITE && Wait(fd_, POLLOUT, deadline)) continue;
        throw StoreError("TLS read failed or timed out: " + OpenSslError());
      }
      const ssize_t got = ::recv(fd_, into, size, 0);
      if (got > 0) return static_cast<size_t>(got);
      if (got == 0) throw StoreError("the store closed the connection");
      if ((errno == EAGAIN || errno == EINTR) && Wait(fd_, POLLIN, deadline)) continue;
      throw StoreError(errno == EAGAIN ? std::string("read timed out")
                                       : std::string("read failed: ") + std::strerror(errno));
    }
  }

  Reply Receive(Clock::time_point deadline) {
    char buffer[16384];
    // The reply's first line: a large bulk string (an H-Graph's snapshot, tens of MB) is read
    // straight into its string, not through hiredis's buffer and a copy of it.
    std::string head;
    for (;;) {
      head.append(buffer, ReadSome(buffer, sizeof(buffer), deadline));
      const size_t eol = head.find("\r\n");
      if (eol == std::string::npos) {
        if (head.size() < 32) continue;  // a first line is shorter: hiredis says what is wrong
        break;
      }
      if (head[0] == '$') {
        char* end = nullptr;
        const long long size = std::strtoll(head.c_str() + 1, &end, 10);
        if (end == head.c_str() + eol && size >= kDirectBulkBytes) {
          return ReadBulk(head, eol + 2, static_cast<size_t>(size), deadline);
        }
      }
      break;
    }
    Feed(head.data(), head.size());
    for (;;) {
      void* raw = nullptr;
      if (redisReaderGetReply(reader_.get(), &raw) != REDIS_OK) {
        throw StoreError(std::string("malformed reply: ") + reader_->errstr);
      }
      if (raw != nullptr) {
        auto* reply = static_cast<redisReply*>(raw);
        Reply out = CopyReply(reply);
        freeReplyObject(reply);
        return out;
      }
      Feed(buffer, ReadSome(buffer, sizeof(buffer), deadline));
    }
  }

  // A bulk string of `size` bytes whose first bytes (and its header) are in `head`, from `start`.
  Reply ReadBulk(const std::string& head, size_t start, size_t size, Clock::time_point deadline) {
    const size_t whole = size + 2;  // and its \r\n
    if (head.size() - start > whole) throw StoreError("unexpected bytes after a reply");
    Reply out;
    out.type = REDIS_REPLY_STRING;
    out.str.resize(whole);
    size_t got = head.size() - start;
    std::memcpy(out.str.data(), head.data() + start, got);
    while (got < whole) got += ReadSome(out.str.data() + got, whole - got, deadline);
    if (out.str[size] != '\r' || out.str[size + 1] != '\n') {
      throw StoreError("malformed reply: a bulk string without its end");
    }
    out.str.resize(size);
    return out;
  }

  void Feed(const char* bytes, size_t size) {
    if (redisReaderFeed(reader_.get(), bytes, size) != REDIS_OK) {
      throw StoreError("cannot buffer a reply");
    }
  }

  std::unique_ptr<redisReader, ReaderDeleter> reader_;
  std::unique_ptr<SSL, SslDeleter> ssl_;
  int fd_ = -1;
};

class RedisStore final : public Store {
 public:
  explicit RedisStore(const RedisOptions& options) : options_(options) {
    if (!options_.address.tls) return;
    tls_ = SSL_CTX_new(TLS_client_method());
    if (tls_ == nullptr) throw Error(ErrorCode::kInvalidArgument, "--store", OpenSslError());
    SSL_CTX_set_min_proto_version(tls_, TLS1_2_VERSION);
    SSL_CTX_set_verify(tls_, SSL_VERIFY_PEER, nullptr);
    const bool loaded =
        options_.ca_file.empty()
            ? SSL_CTX_set_default_verify_paths(tls_) == 1
            : SSL_CTX_load_verify_locations(tls_, options_.ca_file.c_str(), nullptr) == 1;
    if (!loaded) {
      const std::string why = OpenSslError();
      SSL_CTX_free(tls_);
      throw InputError("--store-ca-file", "cannot load the CA certificates: " + why);
    }
  }
  RedisStore(const RedisStore&) = delete;
  RedisStore& operator=(const RedisStore&) = delete;
  ~RedisStore() override {
    idle_.clear();
    if (tls_ != nullptr) SSL_CTX_free(tls_);
  }

  std::optional<std::string> Get(const std::string& key) override {
    Reply reply = Run({"GET", key});
    if (reply.type == REDIS_REPLY_NIL) return std::nullopt;
    Expect(reply, REDIS_REPLY_STRING, "GET");
    return std::move(reply.str);
  }

  std::optional<std::string> GetPrefix(const std::string& key, size_t bytes) override {
    if (bytes == 0) return Exists(key) ? std::optional<std::string>("") : std::nullopt;
    // GETRANGE answers "" for an absent key, and so for an empty value: EXISTS tells them apart.
    Reply reply = Run({"GETRANGE", key, "0", std::to_string(bytes - 1)});
    Expect(reply, REDIS_REPLY_STRING, "GETRANGE");
    if (reply.str.empty() && !Exists(key)) return std::nullopt;
    return std::move(reply.str);
  }

  void Set(const std::string& key, std::string_view value, std::chrono::milliseconds ttl) override {
    Expect(Run({"SET", key, value, "PX", std::to_string(ttl.count())}), REDIS_REPLY_STATUS, "SET");
  }

  bool SetIfPrefix(const std::string& key, std::string_view expected_prefix, std::string_view value,
                   std::chrono::milliseconds ttl) override {
    const Reply reply =
        Run({"EVAL", kSetIfPrefix, "1", key, expected_prefix, value, std::to_string(ttl.count())});
    Expect(reply, REDIS_REPLY_INTEGER, "EVAL");
    return reply.integer == 1;
  }

  bool Exists(const std::string& key) override {
    const Reply reply = Run({"EXISTS", key});
    Expect(reply, REDIS_REPLY_INTEGER, "EXISTS");
    return reply.integer > 0;
  }

  void Expire(const std::vector<std::string>& keys, std::chrono::milliseconds ttl) override {
    for (const std::string& key : keys) {
      Expect(Run({"PEXPIRE", key, std::to_string(ttl.count())}), REDIS_REPLY_INTEGER, "PEXPIRE");
    }
  }

  void Delete(const std::vector<std::string>& keys) override {
    if (keys.empty()) return;
    std::vector<std::string_view> args = {"DEL"};
    args.insert(args.end(), keys.begin(), keys.end());
    Expect(Run(args), REDIS_REPLY_INTEGER, "DEL");
  }

  std::vector<std::optional<std::string>> GetMany(const std::vector<std::string>& keys) override {
    if (keys.empty()) return {};
    std::vector<std::string_view> args = {"MGET"};
    args.insert(args.end(), keys.begin(), keys.end());
    Reply reply = Run(args);
    Expect(reply, REDIS_REPLY_ARRAY, "MGET");
    if (reply.elements.size() != keys.size()) throw StoreError("MGET: a reply of another size");
    std::vector<std::optional<std::string>> out;
    for (Reply& e : reply.elements) {
      if (e.type == REDIS_REPLY_NIL) {
        out.emplace_back(std::nullopt);
      } else {
        Expect(e, REDIS_REPLY_STRING, "MGET");
        out.emplace_back(std::move(e.str));
      }
    }
    return out;
  }

  std::optional<std::chrono::milliseconds> TimeToLive(const std::string& key) override {
    const Reply reply = Run({"PTTL", key});
    Expect(reply, REDIS_REPLY_INTEGER, "PTTL");
    if (reply.integer < 0) return std::nullopt;  // -2: absent, -1: no expiry
    return std::chrono::milliseconds(reply.integer);
  }

  void AddMember(const std::string& key, const std::string& member,
                 std::chrono::milliseconds ttl) override {
    Expect(Run({"EVAL", kAddMember, "1", key, member, std::to_string(ttl.count())}),
           REDIS_REPLY_INTEGER, "EVAL");
  }

  std::vector<std::string> Members(const std::string& key) override {
    Reply reply = Run({"SMEMBERS", key});
    Expect(reply, REDIS_REPLY_ARRAY, "SMEMBERS");
    std::vector<std::string> out;
    for (Reply& e : reply.elements) {
      Expect(e, REDIS_REPLY_STRING, "SMEMBERS");
      out.push_back(std::move(e.str));
    }
    return out;
  }

  void RemoveMembers(const std::string& key, const std::vector<std::string>& members) override {
    if (members.empty()) return;
    std::vector<std::string_view> args = {"SREM", key};
    args.insert(args.end(), members.begin(), members.end());
    Expect(Run(args), REDIS_REPLY_INTEGER, "SREM");
  }

  std::string Describe() const override {
    const StoreAddress& a = options_.address;
    const bool v6 = a.host.find(':') != std::string::npos;
    return std::string(a.tls ? "rediss://" : "redis://") + (v6 ? "[" + a.host + "]" : a.host) +
           ":" + std::to_string(a.port) + "/" + std::to_string(a.db);
  }

 private:
  static void Expect(const Reply& reply, int type, const char* command) {
    if (reply.type == type) return;
    if (reply.type == REDIS_REPLY_ERROR) {
      throw StoreError(std::string(command) + " refused: " + reply.str);
    }
    throw StoreError(std::string(command) + ": unexpected reply of type " +
                     std::to_string(reply.type));
  }

  // Runs one command on an idle connection (or a new one); a connection that failed is dropped.
  Reply Run(const std::vector<std::string_view>& args) {
    const Clock::time_point now = Clock::now();
    if (now < Clock::time_point(Clock::duration(down_until_.load()))) {
      throw StoreError("the store failed less than " +
                       std::to_string(options_.retry_after.count()) + " ms ago; not retried yet");
    }
    const Clock::time_point deadline = now + options_.timeout;
    std::unique_ptr<Connection> connection;
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        connection = std::move(idle_.back());
        idle_.pop_back();
      }
    }
    try {
      if (!connection) connection = std::make_unique<Connection>(options_, tls_, deadline);
      Reply reply = connection->Command(args, deadline);
      std::lock_guard lock(mutex_);
      idle_.push_back(std::move(connection));
      return reply;
    } catch (const StoreError&) {
      down_until_ = (Clock::now() + options_.retry_after).time_since_epoch().count();
      throw;
    }
  }

  const RedisOptions options_;
  SSL_CTX* tls_ = nullptr;
  std::mutex mutex_;
  std::vector<std::unique_ptr<Connection>> idle_;
  std::atomic<Clock::rep> down_until_{0};
};

}  // namespace

std::unique_ptr<Store> MakeRedisStore(const RedisOptions& options) {
  return std::make_unique<RedisStore>(options);
}

}  // namespace hgraph::server
