// A stored H-Graph as bytes: everything a HybridizationSession holds (its inputs, options,
// nodes, edges with their check reports and clearance profiles, the lazy evaluation's evidence
// and the work no query has reported yet), so that a session loaded from them answers every
// query as the one saved would: the same path, and no check repeated for what was checked.
// The server's shared store (server/store.h) keeps H-Graphs this way across replicas.
//
// The bytes come back from outside the process (a shared store): LoadSession checks every
// length, index and configuration before it builds anything, and throws SnapshotError for bytes
// it cannot trust, never crashes on them.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/merge/merge.h"

namespace hgraph {

// Bumped whenever the layout changes: bytes of another format are refused, not misread.
inline constexpr uint32_t kSnapshotFormat = 4;

// Bytes that are not a snapshot this code can load (truncated, another format, indices out of
// range, configurations of another space). Copyable.
class SnapshotError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thread compatible: reads `session` only (the caller keeps other writers away).
std::string SaveSession(const HybridizationSession& session);
// Appends what SaveSession returns to *out (a record that ends with the snapshot is built in
// one buffer).
void AppendSession(const HybridizationSession& session, std::string* out);

// The session the bytes hold, checking its motions with `checker` (the scene and resolution the
// saved one used: the caller's to match). Throws SnapshotError.
HybridizationSession LoadSession(const ClearanceChecker& checker, std::string_view bytes);

}  // namespace hgraph
