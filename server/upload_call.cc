#include <string>
#include <utility>

#include "server/call_support.h"
#include "server/service.h"

namespace hgraph::server {

// UploadBlob: collects the chunks on gRPC threads (copies only), then verifies the size and
// SHA-256 on the worker pool.
class PathMergerService::UploadCall final : public grpc::ServerReadReactor<v1::UploadBlobRequest> {
 public:
  UploadCall(PathMergerService* service, grpc::CallbackServerContext* context,
             v1::UploadBlobResponse* response)
      : service_(service), response_(response) {
    // Blobs are shared by digest, so the tenant is not kept; an unauthenticated stream is not read.
    std::string tenant;
    if (grpc::Status auth = service->options().auth.Authenticate(*context, &tenant); !auth.ok()) {
      Complete(auth);
      return;
    }
    StartRead(&chunk_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {
      EndOfStream();
      return;
    }
    if (first_) {
      first_ = false;
      digest_ = chunk_.digest();
      grpc::Status status = Invoke([&] { ValidateDigest(digest_, "digest"); }, token_);
      if (!status.ok()) return Complete(status);
      if (digest_.size_bytes() > service_->options().max_blob_bytes) {
        return Complete(grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                     "digest.size_bytes: " + std::to_string(digest_.size_bytes()) +
                                         " bytes exceed the limit of " +
                                         std::to_string(service_->options().max_blob_bytes) +
                                         " (--max-blob-bytes)"));
      }
      bytes_.reserve(static_cast<size_t>(digest_.size_bytes()));
    }
    if (static_cast<int64_t>(bytes_.size() + chunk_.data().size()) > digest_.size_bytes()) {
      return Complete(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                   "data: the chunks hold more than digest.size_bytes = " +
                                       std::to_string(digest_.size_bytes()) + " bytes"));
    }
    bytes_ += chunk_.data();
    StartRead(&chunk_);
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void EndOfStream() {
    if (first_) {
      return Complete(
          grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "digest: the stream held no message"));
    }
    const bool admitted = service_->pool().TrySubmit([this](WorkerPool::Slot& slot) {
      const grpc::Status status = Invoke(
          [&] {
            response_->set_stored(service_->scenes_.PutBlob(digest_, std::move(bytes_)));
            *response_->mutable_digest() = digest_;
          },
          token_);
      slot.Release();
      Complete(status);
    });
    if (!admitted) Complete(Busy(service_->pool()));
  }

  void Complete(const grpc::Status& status) {
    service_->RecordCall("UploadBlob", "", started_, status);
    Finish(status);
  }

  PathMergerService* service_;
  v1::UploadBlobResponse* response_;
  v1::UploadBlobRequest chunk_;
  v1::Digest digest_;
  std::string bytes_;
  bool first_ = true;
  Clock::time_point started_ = service_->RecordStart("UploadBlob");
  CancelToken token_;
};

grpc::ServerReadReactor<v1::UploadBlobRequest>* PathMergerService::UploadBlob(
    grpc::CallbackServerContext* context, v1::UploadBlobResponse* response) {
  return new UploadCall(this, context, response);
}

}  // namespace hgraph::server
