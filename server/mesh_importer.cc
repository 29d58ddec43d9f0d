#include "server/mesh_importer.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <vector>

#include "core/common/error.h"
#include "core/scene/mesh_wire.h"

namespace hgraph::server {
namespace {

using Clock = std::chrono::steady_clock;

// Closes a descriptor once.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { Reset(); }
  int get() const { return fd_; }
  void Reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

// Kills and reaps the child unless it was reaped already.
class Child {
 public:
  explicit Child(pid_t pid) : pid_(pid) {}
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      Wait();
    }
  }
  pid_t pid() const { return pid_; }
  void Kill() { ::kill(pid_, SIGKILL); }
  // The wait status.
  int Wait() {
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
    return status;
  }

 private:
  pid_t pid_;
};

std::string SignalName(int signal) {
  const char* name = sigdescr_np(signal);
  return "signal " + std::to_string(signal) + (name ? std::string(" (") + name + ")" : "");
}

void SetLimit(pid_t pid, int resource, rlim_t value) {
  const rlimit limit{.rlim_cur = value, .rlim_max = value};
  ::prlimit(pid, static_cast<__rlimit_resource>(resource), &limit, nullptr);
}

// Keeps printable ASCII from what the child wrote; it may have echoed hostile bytes.
std::string Printable(std::string_view text) {
  std::string out;
  for (char c : text.substr(0, 600)) {
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return out;
}

}  // namespace

std::string DefaultMeshImportHelper() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "hgraph-mesh-import";
  return (self.parent_path() / "hgraph-mesh-import").string();
}

// Builds with AddressSanitizer or ThreadSanitizer (scripts/sanitize.sh): their runtimes reserve
// terabytes of address space for shadow memory, so a child under RLIMIT_AS cannot even start.
// There the address-space limit is off; the CPU, time, descriptor and output limits still hold.
// ThreadSanitizer also writes a temporary file while it starts (/tmp/tsan.rodata.<pid>), so
// there the child's RLIMIT_FSIZE comes from the child itself, set before it reads a byte.
#if defined(__SANITIZE_THREAD__)
constexpr bool kThreadSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
constexpr bool kThreadSanitizer = true;
#else
constexpr bool kThreadSanitizer = false;
#endif
#else
constexpr bool kThreadSanitizer = false;
#endif
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kShadowMemory = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kShadowMemory = true;
#else
constexpr bool kShadowMemory = kThreadSanitizer;
#endif
#else
constexpr bool kShadowMemory = kThreadSanitizer;
#endif

MeshImporter::MeshImporter(MeshImportLimits limits) : limits_(std::move(limits)) {
  if (kShadowMemory) limits_.memory_mb = 0;
}

void MeshImporter::CheckHelper() const {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(limits_.helper_path, ec) ||
      ::access(limits_.helper_path.c_str(), X_OK) != 0) {
    throw Error(ErrorCode::kFailedPrecondition, "--mesh-import-helper",
                "'" + limits_.helper_path + "' is not an executable file");
  }
}

std::shared_ptr<const Mesh> MeshImporter::Import(const std::string& bytes,
                                                 const std::string& format,
                                                 const MeshLoadOptions& options,
                                                 const std::string& field,
                                                 const CancelToken& token) const {
  CheckMeshScale(options, field);
  if (bytes.empty()) throw InputError(field, "mesh data is empty");
  const std::string request =
      EncodeMeshRequest({.format = format, .options = options, .bytes = bytes});
  const auto started = Clock::now();
  const auto deadline = started + limits_.timeout;

  // stdin is a socket so that writing to a child that died fails with EPIPE instead of raising
  // SIGPIPE in the server; every descriptor is close-on-exec so that concurrent imports do not
  // inherit each other's.
  int in_pair[2];
  int out_pipe[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, in_pair) != 0) {
    throw Error(ErrorCode::kResourceExhausted, field, "cannot start the mesh importer (socket)");
  }
  Fd in_parent(in_pair[0]), in_child(in_pair[1]);
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) {
    throw Error(ErrorCode::kResourceExhausted, field, "cannot start the mesh importer (pipe)");
  }
  Fd out_parent(out_pipe[0]), out_child(out_pipe[1]);
  ::shutdown(in_parent.get(), SHUT_RD);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in_child.get(), 0);
  posix_spawn_file_actions_adddup2(&actions, out_child.get(), 1);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addclosefrom_np(&actions, 3);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // The server blocks SIGTERM/SIGINT in every thread and may ignore others: the child starts
  // with no signal blocked and every disposition at its default.
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setflags(&attr,
                           POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
  const std::string memory_arg = std::to_string(limits_.memory_mb);
  const std::string cpu_arg = std::to_string(limits_.cpu_s);
  std::vector<char*> argv = {const_cast<char*>(limits_.helper_path.c_str()),
                             const_cast<char*>("--memory-mb"),
                             const_cast<char*>(memory_arg.c_str()),
                             const_cast<char*>("--cpu-s"),
                             const_cast<char*>(cpu_arg.c_str()),
                             nullptr};
  char* envp[] = {nullptr};
  pid_t pid = -1;
  const int spawned =
      ::posix_spawn(&pid, limits_.helper_path.c_str(), &actions, &attr, argv.data(), envp);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (spawned != 0) {
    throw Error(
        ErrorCode::kFailedPrecondition, field,
        "cannot start the mesh importer '" + limits_.helper_path + "': " + std::strerror(spawned));
  }
  Child child(pid);
  // Limits set from here too, so that they hold whatever the helper does; it sets the same
  // ones itself before it reads a byte.
  if (limits_.memory_mb > 0) SetLimit(pid, RLIMIT_AS, static_cast<rlim_t>(limits_.memory_mb) << 20);
  SetLimit(pid, RLIMIT_CPU, static_cast<rlim_t>(limits_.cpu_s));
  SetLimit(pid, RLIMIT_CORE, 0);
  if (!kThreadSanitizer) SetLimit(pid, RLIMIT_FSIZE, 0);
  in_child.Reset();
  out_child.Reset();
  ::fcntl(in_parent.get(), F_SETFL, O_NONBLOCK);
  ::fcntl(out_parent.get(), F_SETFL, O_NONBLOCK);

  const uint64_t max_reply = MaxMeshReplyBytes(options);
  std::string reply;
  size_t written = 0;
  bool too_long = false;
  std::string stopped;
  char buffer[1 << 16];
  while (out_parent.get() >= 0) {
    if (token.cancelled()) throw Error(ErrorCode::kCancelled, field, "cancelled by the caller");
    const auto now = Clock::now();
    if (now >= deadline || token.deadline_passed()) {
      stopped = now >= deadline
                    ? "did not finish within " + std::to_string(limits_.timeout.count()) +
                          " ms (--mesh-import-timeout-s)"
                    : "did not finish before the call's deadline";
      break;
    }
    pollfd fds[2] = {{.fd = out_parent.get(), .events = POLLIN, .revents = 0},
                     {.fd = in_parent.get(), .events = POLLOUT, .revents = 0}};
    const int wait_ms = static_cast<int>(std::min<int64_t>(
        50, std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count() + 1));
    const int ready = ::poll(fds, in_parent.get() >= 0 ? 2 : 1, wait_ms);
    if (ready < 0 && errno != EINTR) break;
    if (in_parent.get() >= 0 && (fds[1].revents & (POLLOUT | POLLERR | POLLHUP))) {
      const ssize_t n = ::send(in_parent.get(), request.data() + written, request.size() - written,
                               MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) written += static_cast<size_t>(n);
      if ((n < 0 && errno != EAGAIN && errno != EINTR) || written == request.size()) {
        in_parent.Reset();  // EOF for the child, or it stopped reading
      }
    }
    if (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) {
      const ssize_t n = ::read(out_parent.get(), buffer, sizeof buffer);
      if (n == 0) {
        out_parent.Reset();
      } else if (n > 0) {
        if (reply.size() + static_cast<size_t>(n) > max_reply) {
          too_long = true;
          break;
        }
        reply.append(buffer, static_cast<size_t>(n));
      } else if (errno != EAGAIN && errno != EINTR) {
        out_parent.Reset();
      }
    }
  }
  const int64_t elapsed_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - started).count();
  if (!stopped.empty() || too_long) child.Kill();
  const int status = child.Wait();
  const std::string prefix =
      "mesh import (format '" + format + "', " + std::to_string(bytes.size()) + " bytes) ";
  if (!stopped.empty()) {
    throw InputError(
        field, prefix + stopped + " and was stopped after " + std::to_string(elapsed_ms) + " ms");
  }
  if (too_long) throw InputError(field, prefix + "wrote more output than its limits allow");
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    if (signal == SIGXCPU || signal == SIGKILL) {
      throw InputError(field, prefix + "hit its CPU limit of " + std::to_string(limits_.cpu_s) +
                                  " s (--mesh-import-cpu-s) and was killed (" + SignalName(signal) +
                                  ")");
    }
    throw InputError(field,
                     prefix + "crashed with " + SignalName(signal) + " (the file is malformed)");
  }
  const int exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  const MeshReply decoded = DecodeMeshReply(reply, options);
  if (!decoded.refused.empty()) {
    throw InputError(field, Printable(decoded.refused));
  }
  if (exit_code == 3) {
    throw InputError(field, prefix + "ran out of memory (limit " +
                                std::to_string(limits_.memory_mb) +
                                " MiB, --mesh-import-memory-mb)");
  }
  if (!decoded.mesh || exit_code != 0) {
    throw InputError(field, prefix + "failed (exit status " + std::to_string(exit_code) +
                                ") with " +
                                (decoded.malformed.empty() ? "no result" : decoded.malformed));
  }
  return decoded.mesh;
}

}  // namespace hgraph::server
