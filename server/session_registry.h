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
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "hgraph/v1/scene.pb.h"
#include "hgraph/v1/service.pb.h"

namespace hgraph::server {

// Thread safe. Not copyable.
class SessionRegistry {
 public:
  using Clock = std::chrono::system_clock;

  // `tenant_max_sessions` > 0: at most that many live sessions per tenant (--tenant-max-sessions).
  SessionRegistry(int max_sessions, std::chrono::milliseconds ttl, int tenant_max_sessions = 0);
  SessionRegistry(const SessionRegistry&) = delete;
  SessionRegistry& operator=(const SessionRegistry&) = delete;

  // A new session on `scene`, named "sessions/<id>" with `id` if given (32 lower-case hex
  // digits; InputError("session_id") otherwise), else a random id. An existing session of that
  // id on the same scene is returned as it is (a retried create), one on another scene throws
  // Error(kFailedPrecondition), one of another tenant Error(kPermissionDenied). Throws
  // Error(kResourceExhausted) when --max-sessions sessions exist, ServiceError
  // RESOURCE_EXHAUSTED TENANT_QUOTA when the tenant has --tenant-max-sessions.
  v1::Session Create(const v1::Digest& scene, const std::string& id, const std::string& tenant);
  // The session, its expiry extended (every use counts as activity). Throws InputError(field)
  // for a malformed name, Error(kNotFound, field) for an unknown or expired one and
  // Error(kPermissionDenied, field) for one of another tenant.
  v1::Session Touch(const std::string& name, const std::string& field, const std::string& tenant);
  // The tenant's sessions only, in name order: at most `page_size` of those after the session
  // `after` (a name; empty: from the first). `more` tells whether any come after the last one.
  std::vector<v1::Session> List(const std::string& tenant, const std::string& after = "",
                                size_t page_size = SIZE_MAX, bool* more = nullptr) const;
  // Removes the session and returns the names of its H-Graphs (for the caller to drop). The
  // same errors as Touch.
  std::vector<std::string> Delete(const std::string& name, const std::string& field,
                                  const std::string& tenant);

  // What a session knows of one of its H-Graph names. Names are never given out twice in a
  // session: an evicted or deleted H-Graph's name stays retired while the session lives.
  enum class HGraphState { kUnknown, kRunning, kKept, kRetired };

  // Reserves the H-Graph name "sessions/<id>/hgraphs/<hgraph_id>" for a merge that starts now
  // (`hgraph_id` empty: 32 random hex digits; else InputError("hgraph_id") unless 1 to 63
  // lower-case letters, digits and '-', starting with a letter or digit), recording
  // `fingerprint`, the request's. A name already known: ServiceError ABORTED MERGE_RUNNING
  // while its merge runs, ALREADY_EXISTS for another fingerprint, NOT_FOUND HGRAPH_NOT_FOUND once
  // retired; a kept one with the same fingerprint is returned with `*repeat` true (the caller
  // answers what the first merge did). The session must exist (NOT_FOUND) and be the tenant's
  // (PERMISSION_DENIED); the caller has touched it.
  std::string ReserveHGraph(const std::string& session, const std::string& hgraph_id,
                            const std::string& fingerprint, const std::string& tenant,
                            bool* repeat);
  // The reserved name's merge finished and its H-Graph is kept: listed in the session from now
  // on. Throws Error(kNotFound, "session") when the session was deleted meanwhile.
  void KeepHGraph(const std::string& hgraph);
  // Forgets a reserved name whose merge failed (a retry may run it again); unknown names are
  // ignored.
  void AbandonHGraph(const std::string& hgraph);
  // Retires a kept H-Graph name (after eviction or deletion); unknown names are ignored.
  void RemoveHGraph(const std::string& hgraph);
  HGraphState StateOf(const std::string& hgraph) const;

  // A session another replica created (read from the shared store), added as it is unless this
  // registry holds it already. Returns false when --max-sessions sessions exist.
  bool Adopt(const std::string& name, const std::string& tenant, const v1::Digest& scene,
             Clock::time_point create_time);
  // An H-Graph another replica built (loaded from the shared store), kept from now on with the
  // fingerprint of its merge. Unless its session is unknown here, or the name is running or
  // retired here: then false.
  bool AdoptHGraph(const std::string& hgraph, const std::string& fingerprint);
  // Forgets a kept H-Graph name (evicted from this replica's cache while the shared store still
  // holds it): StateOf says kUnknown, and a later call may load it again.
  void ForgetHGraph(const std::string& hgraph);
  // The sessions used since `since` (their expiry extended after since + ttl), each with its
  // tenant, for refreshing their entries in the shared store.
  std::vector<std::pair<std::string, v1::Session>> UsedSince(Clock::time_point since) const;

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
    std::vector<std::string> hgraphs;  // kept, in the order their merges finished
    struct HGraphEntry {
      HGraphState state = HGraphState::kRunning;
      std::string fingerprint;
    };
    std::map<std::string, HGraphEntry> names;  // every H-Graph name given out
  };
  // The record of the session an H-Graph name belongs to, or nullptr. Under mutex_.
  Record* RecordOf(const std::string& hgraph);
  const Record* RecordOf(const std::string& hgraph) const;
  v1::Session ToProto(const std::string& name, const Record& record) const;
  static void ValidateName(const std::string& name, const std::string& field);
  static void CheckOwner(const std::string& name, const Record& record, const std::string& field,
                         const std::string& tenant);

  const int max_sessions_;
  const int tenant_max_sessions_;
  const std::chrono::milliseconds ttl_;
  mutable std::mutex mutex_;
  std::map<std::string, Record> sessions_;
};

}  // namespace hgraph::server
