#include "core/adapter/json_io.h"

#include <google/protobuf/util/json_util.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>

#include "core/common/error.h"
#include "core/common/file_bytes.h"

namespace hgraph {

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
  // Printing fails only for messages we never build (Any with an unknown type).
  HGRAPH_CHECK(status.ok());
  return json;
}

void ParseJson(const std::string& json, const std::string& source,
               google::protobuf::Message* message) {
  message->Clear();
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, message, options);
  if (!status.ok()) {
    throw InputError(source, "not a valid " + message->GetDescriptor()->full_name() +
                                 " JSON document: " + std::string(status.message()));
  }
}

void ReadJsonFile(const std::string& path, google::protobuf::Message* message) {
  ParseJson(ReadTextFile(path), path, message);
}

std::string ReadTextFile(const std::string& path) {
  std::string contents;
  if (const std::optional<FileReadFailure> failure = TryReadFileBytes(path, &contents)) {
    if (!failure->at_open) throw Error(ErrorCode::kFailedPrecondition, path, "read failed");
    throw Error(failure->error == ENOENT ? ErrorCode::kNotFound : ErrorCode::kFailedPrecondition,
                path, std::string("cannot open: ") + std::strerror(failure->error));
  }
  return contents;
}

void WriteTextFile(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    throw Error(ErrorCode::kFailedPrecondition, path,
                std::string("cannot open for writing: ") + std::strerror(errno));
  }
  out << contents;
  out.close();
  if (!out) throw Error(ErrorCode::kFailedPrecondition, path, "write failed");
}

}  // namespace hgraph
