// Sessions: a scene reference and the names of the H-Graphs merged in it. The H-Graphs
// themselves live in the ResourceCache (they count against the memory budget); a session only
// lists their names. Sessions expire after an idle time-to-live.
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
  // Error(kFailedPrecondition). Throws Error(kResourceExhausted) when --max-sessions sessions
  // exist.
  v1::Session Create(const v1::Digest& scene, const std::string& id = "");
  // The session, its expiry extended (every use counts as activity). Throws InputError(field)
  // for a malformed name and Error(kNotFound, field) for an unknown or expired one.
  v1::Session Touch(const std::string& name, const std::string& field);
  std::vector<v1::Session> List() const;
  // Removes the session and returns the names of its H-Graphs (for the caller to drop).
  std::vector<std::string> Delete(const std::string& name, const std::string& field);

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
    v1::Digest scene;
    Clock::time_point create_time;
    Clock::time_point expire_time;
    std::vector<std::string> hgraphs;
    int next_hgraph = 1;
  };
  v1::Session ToProto(const std::string& name, const Record& record) const;
  static void ValidateName(const std::string& name, const std::string& field);

  const int max_sessions_;
  const std::chrono::milliseconds ttl_;
  mutable std::mutex mutex_;
  std::map<std::string, Record> sessions_;
};

}  // namespace hgraph::server
