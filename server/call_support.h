// What every call of the PathMerger service shares: the mapping of engine errors to canonical
// statuses, the call's deadline on its cancel token, the "busy" answer of a full worker pool,
// and the H-Graphs kept for re-queries. Internal to server/ (the handlers include it).
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/common/error.h"
#include "core/common/progress.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "core/space/space.h"
#include "hgraph/v1/service.pb.h"
#include "server/scene_store.h"
#include "server/service.h"
#include "server/status/status.h"
#include "server/worker_pool.h"

namespace hgraph::server {

using Clock = std::chrono::steady_clock;

// The one place a status the service answers gets its details (hgraph/v1/service.proto lists
// them): a google.rpc.Status in the status's binary details with an ErrorInfo (`reason`, domain
// "hgraph.v1", metadata "field" when one is named), a BadRequest field violation for a named
// field of INVALID_ARGUMENT, RESOURCE_EXHAUSTED and NOT_FOUND, and a RetryInfo when
// `retry_delay` is positive. OK stays OK.
grpc::Status DetailedStatus(grpc::StatusCode code, const std::string& message,
                            const std::string& field, const std::string& reason,
                            std::chrono::milliseconds retry_delay = std::chrono::milliseconds(0));

// Runs `body` and turns whatever it throws into a canonical status with its details. A
// cancellation that comes from the passed deadline (gRPC cancels the call at the deadline too)
// is DEADLINE_EXCEEDED.
grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token);

// The call's deadline, if any, on the token (the engine polls it).
void WireDeadline(grpc::CallbackServerContext* context, const CancelToken& token);

// RESOURCE_EXHAUSTED, reason SERVER_BUSY with RetryInfo: the worker pool's admission queue is
// full.
grpc::Status Busy(const WorkerPool& pool);

// Throws Error(kResourceExhausted, field) when `count` paths exceed --max-paths. `what` says
// what the count is ("paths per batch", "inputs of sessions/.../hgraphs/x").
void CheckPathCount(int64_t count, const std::string& field, const std::string& what,
                    const ServerOptions& options);

// Checks a batch against the server's limits (--max-paths, --max-waypoints) before any work.
void CheckBatchLimits(const v1::PathSet& paths, const ServerOptions& options);

// Runs `body`, which hands the request's `paths.paths` to the engine, and names the paths in an
// engine error as the request does: the engine names them as its own list ("paths[1]" or
// "paths"), the request nests them ("paths.paths[1]").
void WithRequestPaths(const std::function<void()>& body);

// Sets result.evaluation from the merge's options (unspecified: lazy).
void EchoEvaluation(const v1::MergeOptions& options, v1::MergeResult* result);

// What every reactor does around its work, written once: the deadline on its cancel token
// (unless the call outlives its client), the caller's tenant, admission to the worker pool with
// the slot released as soon as the work returns, the details of the status it ends with, and
// one call record (a log line and the gRPC metrics). Each reactor derives from it and from its
// gRPC reactor, and ends the call in Complete. Not copyable or movable.
class PathMergerService::CallBase {
 public:
  CallBase(PathMergerService* service, grpc::CallbackServerContext* context, std::string method,
           std::string session, bool wire_deadline = true);
  CallBase(const CallBase&) = delete;
  CallBase& operator=(const CallBase&) = delete;
  virtual ~CallBase() = default;

  // The caller's tenant (server/auth.h), for the session registry.
  const std::string& tenant() const { return tenant_; }
  const CancelToken& token() const { return token_; }

 protected:
  // Ends the call with `status`: the reactor's Finish (after its last write), once.
  virtual void Complete(const grpc::Status& status) = 0;

  // False after completing the call with UNAUTHENTICATED when the caller's credentials fail.
  bool Authenticated();
  // Runs `body` on the worker pool (Invoke's status mapping), releases the slot, then completes
  // the call with `body`'s status. False after completing it with Busy() when the admission
  // queue is full.
  bool Submit(std::function<void()> body);
  // Takes an admission slot now for work submitted later by SubmitHeld (a client stream holds
  // it while it reads). False after completing the call with Busy().
  bool Hold();
  void SubmitHeld(std::function<void()> body);
  // Stores an H-Graph that a merge (or a Solve) under the reserved `name` built, for re-queries,
  // and names it in `out` (hgraph, generation, retention), which becomes stored->answer (what
  // GetHGraph and a repeat of the merge answer).
  void Keep(const std::string& session, const std::string& name,
            std::shared_ptr<StoredHGraph> stored, v1::MergePathsResponse* out);
  // Runs `body` here, on the gRPC thread (lookups only), and completes the call with its status.
  void RunHere(const std::function<void()>& body);
  // The status to finish with: counted and logged the first time (later calls only pass it
  // through), with details when the code that made it attached none (ErrorInfo with the code's
  // name as the reason).
  grpc::Status Final(const grpc::Status& status);

  PathMergerService* service_;
  const std::string method_;
  const std::string session_;
  const Clock::time_point started_;
  CancelToken token_;
  std::string tenant_;

 private:
  grpc::Status auth_;
  std::atomic<bool> recorded_{false};
};

// A server-streaming call's writes, written once: the work (on a worker, Submit) queues events
// with Send from any thread; they go out in order, one write in flight, and Complete's status
// follows the last. With `drop_on_error`, a call that fails ends with its status alone: the
// events not yet written are dropped (a result must not follow a failure).
template <typename Response>
class PathMergerService::StreamingCall : public grpc::ServerWriteReactor<Response>,
                                         public CallBase {
 public:
  StreamingCall(PathMergerService* service, grpc::CallbackServerContext* context,
                std::string method, std::string session, bool drop_on_error)
      : CallBase(service, context, std::move(method), std::move(session)),
        drop_on_error_(drop_on_error) {}

  void OnWriteDone(bool ok) override {
    if (!ok) token_.Cancel();
    Pump(/*write_done=*/true);
  }
  void OnCancel() override { token_.Cancel(); }
  // The Finish may come from OnWriteDone's Pump while Complete's own Pump is still to run on the
  // worker: the call is freed only once Complete has returned.
  void OnDone() override {
    {
      std::unique_lock lock(mutex_);
      completed_.wait(lock, [this] { return complete_returned_; });
    }
    delete this;
  }

 protected:
  // Queues one event; events go out in the order they were queued.
  void Send(Response event) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(event));
    }
    Pump(/*write_done=*/false);
  }

  void Complete(const grpc::Status& status) override {
    {
      std::lock_guard lock(mutex_);
      status_ = Final(status);
      done_ = true;
      if (drop_on_error_ && !status.ok()) {
        while (queue_.size() > (writing_ ? 1u : 0u)) queue_.pop_back();
      }
    }
    Pump(/*write_done=*/false);
    std::lock_guard lock(mutex_);
    complete_returned_ = true;
    completed_.notify_all();
  }

 private:
  // Starts the next write, or the Finish once the queue is drained after the work is done.
  void Pump(bool write_done) {
    enum { kNothing, kWrite, kFinish } action = kNothing;
    {
      std::lock_guard lock(mutex_);
      if (write_done) {
        writing_ = false;
        queue_.pop_front();
      }
      if (writing_ || finished_) return;
      if (!queue_.empty()) {
        writing_ = true;
        action = kWrite;
      } else if (done_) {
        finished_ = true;
        action = kFinish;
      }
    }
    // The front element stays put until its write is done (deque keeps references stable).
    if (action == kWrite) this->StartWrite(&queue_.front());
    if (action == kFinish) this->Finish(status_);
  }

  const bool drop_on_error_;
  std::mutex mutex_;
  std::deque<Response> queue_;
  bool writing_ = false;
  bool done_ = false;
  bool finished_ = false;
  bool complete_returned_ = false;  // OnDone waits for it
  std::condition_variable completed_;
  grpc::Status status_;
};

// A server-streaming call that ends at once with `status` (recorded as `method`'s call): what a
// build without a module answers.
template <typename Response>
grpc::ServerWriteReactor<Response>* FinishedStream(PathMergerService* service,
                                                   const std::string& method,
                                                   const std::string& session,
                                                   const grpc::Status& status) {
  class Finished final : public grpc::ServerWriteReactor<Response> {
   public:
    explicit Finished(const grpc::Status& status) { this->Finish(status); }
    void OnDone() override { delete this; }
  };
  service->RecordCall(method, session, service->RecordStart(method), status);
  return new Finished(status);
}

// A request's start or goal (`field`): the one it sets, else the scene's own; InputError naming
// the field when neither has one.
Config EndpointOf(bool set, const v1::Configuration& given, const std::optional<Config>& scenes,
                  const std::string& field);

// An H-Graph kept for re-queries, with the local planner its edges were checked with.
struct PathMergerService::StoredHGraph {
  std::mutex mutex;         // guards session, version and generation
  std::mutex adding_mutex;  // held by AddToStored for its whole call: additions never race
  LoadedScene scene;
  std::unique_ptr<LocalPlanner> planner;
  std::unique_ptr<HybridizationSession> session;
  uint64_t version = 0;    // bumped each time a query's copy replaces `session`
  int64_t generation = 1;  // 1 after the merge, +1 per AddPaths (HGraph.generation)
  // The version of this H-Graph's snapshot in the shared store that `session` holds (0: none):
  // what the next write compares and sets.
  uint64_t store_version = 0;
  double resolution = 0;  // the planner's, for a replica that loads the snapshot
  std::string tenant;     // the owner of its session
  v1::Digest scene_digest;
  // What the merge was asked and answered (GetHGraph, and a repeat of its hgraph_id).
  v1::Measure measure;
  v1::MergeOptions options;
  std::string fingerprint;  // RequestFingerprint of the MergePathsRequest
  v1::MergePathsResponse answer;
  std::vector<std::string> input_names;  // the merge's, then each addition's
  // AddPaths' request ids (AIP-155), the last kMaxRequestIds of them, with the fingerprint of
  // the request and its answer; and the lock an AddPaths holds from its look-up here to its
  // answer's record, so that a repeat waits for the first to answer.
  static constexpr size_t kMaxRequestIds = 64;
  std::mutex requests_mutex;
  std::deque<std::pair<std::string, std::pair<std::string, v1::AddPathsResponse>>> requests;
};

// SHA-256 of `request`'s deterministic serialization with `ignored` (a field number of its
// message) cleared: what a repeat with the same request id must match.
std::string RequestFingerprint(const google::protobuf::Message& request, int ignored = 0);

// Searches a stored H-Graph under `measure` (Requery) without holding it: the query runs on a
// copy taken under the mutex, and the copy, with the edges the query checked, replaces the
// stored session if no other query did so meanwhile (else its checks are dropped; the answer
// stands either way). The copy costs memory for the length of the query, not the H-Graph's
// lock for every other caller.
// `report_clearance`: HybridizationSession::Query's.
MergeResult QueryStored(PathMergerService::StoredHGraph& stored, const MeasureSpec& measure,
                        const ProgressCallback& progress, const CancelToken& token,
                        std::optional<bool> report_clearance = std::nullopt);

// Adds paths to a stored H-Graph and searches it (AddPaths), on a copy as QueryStored does; the
// copy replaces the stored session whatever queries did meanwhile (their checks are dropped,
// the added paths never are). Returns the bridge candidates added through `candidates_added`.
// A Requery's or AddPaths' report_clearance: this query's, if the request sets it.
template <typename Request>
std::optional<bool> ReportClearance(const Request& request) {
  if (!request.has_report_clearance()) return std::nullopt;
  return request.report_clearance();
}

MergeResult AddToStored(PathMergerService::StoredHGraph& stored,
                        const std::vector<InputPath>& paths, const MeasureSpec& measure,
                        const CancelToken& token, int64_t* candidates_added,
                        std::optional<bool> report_clearance = std::nullopt);

}  // namespace hgraph::server
