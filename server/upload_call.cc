// UploadBlob: a client stream of chunks. An unfinished upload holds what a finished blob would:
// its declared size is reserved in the cache's budget (--cache-bytes) from its first message,
// it takes an admission slot of the worker pool (--max-pending) from its start, and a stream
// that sends nothing for --upload-idle-timeout-s is aborted and its bytes released.
#include <spdlog/spdlog.h>

#include <atomic>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "server/call_support.h"
#include "server/service.h"

namespace hgraph::server {

// Collects the chunks on gRPC threads (copies only), then verifies the size and SHA-256 on the
// worker pool.
class PathMergerService::UploadCall final : public grpc::ServerReadReactor<v1::UploadBlobRequest>,
                                            public CallBase {
 public:
  UploadCall(PathMergerService* service, grpc::CallbackServerContext* context,
             v1::UploadBlobResponse* response)
      // No deadline on the token: an upload's only work is its verification.
      : CallBase(service, context, "UploadBlob", "", /*wire_deadline=*/false), response_(response) {
    // Blobs are shared by digest, so the tenant is not used; an unauthenticated stream is not
    // read.
    if (!Authenticated() || !Hold()) return;
    holds_slot_ = true;
    service_->AddUpload(this);
    registered_ = true;
    StartRead(&chunk_);
  }

  void OnReadDone(bool ok) override {
    std::lock_guard lock(mutex_);
    if (finished_) return;
    Touch();
    if (!ok) return EndOfStream();
    if (first_) {
      first_ = false;
      digest_ = chunk_.digest();
      grpc::Status status = Invoke([&] { ValidateDigest(digest_, "digest"); }, token_);
      if (!status.ok()) return CompleteLocked(status);
      if (digest_.size_bytes() > service_->options().max_blob_bytes) {
        return CompleteLocked(DetailedStatus(
            grpc::StatusCode::RESOURCE_EXHAUSTED,
            "digest.size_bytes: " + std::to_string(digest_.size_bytes()) +
                " bytes exceed the limit of " + std::to_string(service_->options().max_blob_bytes) +
                " (--max-blob-bytes)",
            "digest.size_bytes", "LIMIT_EXCEEDED"));
      }
      const size_t declared = static_cast<size_t>(digest_.size_bytes());
      if (!service_->cache_.Reserve(declared)) {
        // Busy, not a limit: what unfinished uploads reserve is released as they end.
        return CompleteLocked(DetailedStatus(
            grpc::StatusCode::RESOURCE_EXHAUSTED,
            "digest.size_bytes: " + std::to_string(declared) +
                " bytes do not fit in the server's cache budget now (--cache-bytes=" +
                std::to_string(service_->cache_.budget_bytes()) + ", of which " +
                std::to_string(service_->cache_.reserved_bytes()) +
                " are reserved by unfinished uploads); retry later",
            "digest.size_bytes", "SERVER_BUSY", std::chrono::milliseconds(1000)));
      }
      reserved_ = declared;
      bytes_.reserve(declared);
    }
    if (static_cast<int64_t>(bytes_.size() + chunk_.data().size()) > digest_.size_bytes()) {
      return CompleteLocked(DetailedStatus(grpc::StatusCode::INVALID_ARGUMENT,
                                           "data: the chunks hold more than digest.size_bytes = " +
                                               std::to_string(digest_.size_bytes()) + " bytes",
                                           "data", "INVALID_ARGUMENT"));
    }
    bytes_ += chunk_.data();
    StartRead(&chunk_);
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override {
    if (registered_) service_->RemoveUpload(this);
    {
      std::lock_guard lock(mutex_);
      ReleaseHoldsLocked();
    }
    delete this;
  }

  // Called by ExpireIdleUploads, under its lock (which keeps the call alive).
  bool IdleSince(Clock::time_point cutoff) const {
    return !working_.load() && Clock::time_point(Clock::duration(last_activity_.load())) < cutoff;
  }
  void Expire(std::chrono::milliseconds timeout) {
    Complete(DetailedStatus(grpc::StatusCode::ABORTED,
                            "UploadBlob: no data for " + std::to_string(timeout.count() / 1000) +
                                " s (--upload-idle-timeout-s); the upload was aborted and its " +
                                "bytes released",
                            "", "UPLOAD_IDLE"));
  }

 private:
  void Touch() { last_activity_.store(Clock::now().time_since_epoch().count()); }

  // Under mutex_.
  void EndOfStream() {
    if (first_) {
      return CompleteLocked(DetailedStatus(grpc::StatusCode::INVALID_ARGUMENT,
                                           "digest: the stream held no message", "digest",
                                           "INVALID_ARGUMENT"));
    }
    working_.store(true);
    // The slot held since the start becomes the verification job's.
    holds_slot_ = false;
    SubmitHeld([this] {
      {
        // From here on the blob counts against the budget as what it becomes, a cache entry.
        std::lock_guard lock(mutex_);
        ReleaseReservationLocked();
      }
      response_->set_stored(service_->scenes_.PutBlob(digest_, std::move(bytes_)));
      *response_->mutable_digest() = digest_;
    });
  }

  void ReleaseReservationLocked() {
    const size_t reserved = std::exchange(reserved_, 0);
    if (reserved > 0) service_->cache_.Unreserve(reserved);
  }
  void ReleaseHoldsLocked() {
    ReleaseReservationLocked();
    if (std::exchange(holds_slot_, false)) service_->pool().Unhold();
  }

  void Complete(const grpc::Status& status) override {
    std::lock_guard lock(mutex_);
    CompleteLocked(status);
  }
  // Finishes the call once: a read, the verification job and the idle reaper may each try.
  void CompleteLocked(const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    token_.Cancel();
    ReleaseHoldsLocked();
    Finish(Final(status));
  }

  v1::UploadBlobResponse* response_;
  // Guards everything below but the atomics: reads, the verification job and the reaper run on
  // different threads.
  std::mutex mutex_;
  v1::UploadBlobRequest chunk_;
  v1::Digest digest_;
  std::string bytes_;
  bool first_ = true;
  bool registered_ = false;
  bool finished_ = false;
  bool holds_slot_ = false;
  size_t reserved_ = 0;
  std::atomic<bool> working_{false};
  std::atomic<Clock::rep> last_activity_{Clock::now().time_since_epoch().count()};
};

grpc::ServerReadReactor<v1::UploadBlobRequest>* PathMergerService::UploadBlob(
    grpc::CallbackServerContext* context, v1::UploadBlobResponse* response) {
  return new UploadCall(this, context, response);
}

void PathMergerService::AddUpload(UploadCall* call) {
  std::lock_guard lock(uploads_mutex_);
  uploads_.insert(call);
}

void PathMergerService::RemoveUpload(UploadCall* call) {
  std::lock_guard lock(uploads_mutex_);
  uploads_.erase(call);
}

void PathMergerService::ExpireIdleUploads() {
  const std::chrono::milliseconds timeout = options_.upload_idle_timeout;
  const Clock::time_point cutoff = Clock::now() - timeout;
  // A call's OnDone (on a gRPC thread, after its Finish) waits here until the reaper is done
  // with it.
  std::lock_guard lock(uploads_mutex_);
  std::vector<UploadCall*> idle;
  for (UploadCall* call : uploads_) {
    if (call->IdleSince(cutoff)) idle.push_back(call);
  }
  for (UploadCall* call : idle) call->Expire(timeout);
  if (!idle.empty()) spdlog::info("aborted {} idle uploads", idle.size());
}

}  // namespace hgraph::server
