// Proto3 JSON documents and whole-file reads and writes, with errors that name the file.
#pragma once

#include <google/protobuf/message.h>

#include <string>

namespace hgraph {

// The message as indented proto3 JSON with snake_case names and every field printed, defaults
// included, so a reader sees the whole schema of a result.
std::string ToJson(const google::protobuf::Message& message);

// Parses proto3 JSON into `message` (cleared first). Unknown fields are rejected: a misspelt
// option would otherwise be silently ignored. Throws InputError naming `source` (a file name).
void ParseJson(const std::string& json, const std::string& source,
               google::protobuf::Message* message);

// Reads and parses a JSON file; a missing file is Error(kNotFound) naming the path.
void ReadJsonFile(const std::string& path, google::protobuf::Message* message);

// Whole-file reads and writes. A missing file is Error(kNotFound) naming the path; a file that
// cannot be written is Error(kFailedPrecondition).
std::string ReadTextFile(const std::string& path);
void WriteTextFile(const std::string& path, const std::string& contents);

}  // namespace hgraph
