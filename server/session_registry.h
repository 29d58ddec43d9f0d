// Sessions: a scene reference and the names of the H-Graphs merged in it. The H-Graphs
// themselves live in the ResourceCache (they count against the memory budget); a session only
// lists their names. Sessions expire after an idle time-to-live.
//
// Every session belongs to the tenant that created it (server/auth.h; the one anonymous tenant
// without --auth-tokens), and so do its H-Graphs, which are reached only through their session.
// Another tenant naming it gets PERMISSION_DENIED, not NOT_FOUND: session names carry 128 random
// bits, so the code reveals nothing guessable, and NOT_FOUND would send clients into their
// recovery path (re-upload, re-create under the same name), which would fail the same way and
// hide a misconfigured token behind retries.
#pragma once

#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "hgraph/v1/scene.pb.h"
#include "hgraph/v1/service.pb.h"

namespace hgraph::server {

// Thread safe. Not copyable.
class SessionRegistry {
 public:
  using Clock = std::chrono::system_clock;

  SessionRegistry(int max_sessions, std::chrono::milliseconds ttl);
  SessionRegistry(const SessionRegistry&) = delete;
  SessionRegistry& operator=(const SessionRegistry&) = delete;

  // A new session on `scene`, named "sessions/<id>" with `id` if given (32 lower-case hex
  // digits; InputError("session_id") otherwise), else a random id. An existing session of that
  // id on the same scene is returned as it is (a retried create), one on another scene throws
  // Error(kFailedPrecondition), one of another tenant Error(kPermissionDenied). Throws
  // Error(kResourceExhausted) when --max-sessions sessions exist.
  v1::Session Create(const v1::Digest& scene, const std::string& id, const std::string& tenant);
  // The session, its expiry extended (every use counts as activity). Throws InputError(field)
  // for a malformed name, Error(kNotFound, field) for an unknown or expired one and
  // Error(kPermissionDenied, field) for one of another tenant.
  v1::Session Touch(const std::string& name, const std::string& field, const std::string& tenant);
  // The tenant's sessions only.
  std::vector<v1::Session> List(const std::string& tenant) const;
  // Removes the session and returns the names of its H-Graphs (for the caller to drop). The
  // same errors as Touch.
  std::vector<std::string> Delete(const std::string& name, const std::string& field,
                                  const std::string& tenant);

  // A fresh H-Graph name in the session ("sessions/<id>/hgraphs/<n>"), recorded in it.
  std::string AddHGraph(const std::string& session);
  // Forgets an H-Graph name (after eviction); unknown names are ignored.
  void RemoveHGraph(const std::string& hgraph);

  // Removes sessions idle past their expiry; returns the names of their H-Graphs.
  std::vector<std::string> ExpireIdle(Clock::time_point now);
  int size() const;

  // Splits "sessions/<id>/hgraphs/<n>" into its session name; throws InputError(field).
  static std::string SessionOfHGraph(const std::string& hgraph, const std::string& field);

 private:
  struct Record {
    std::string tenant;  // the owner
    v1::Digest scene;
    Clock::time_point create_time;
    Clock::time_point expire_time;
    std::vector<std::string> hgraphs;
    int next_hgraph = 1;
  };
  v1::Session ToProto(const std::string& name, const Record& record) const;
  static void ValidateName(const std::string& name, const std::string& field);
  static void CheckOwner(const std::string& name, const Record& record, const std::string& field,
                         const std::string& tenant);

  const int max_sessions_;
  const std::chrono::milliseconds ttl_;
  mutable std::mutex mutex_;
  std::map<std::string, Record> sessions_;
};

}  // namespace hgraph::server
