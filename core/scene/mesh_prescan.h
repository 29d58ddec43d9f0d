// Checks the counts a mesh file declares against the bytes it has, before a parser allocates
// for them: a 45-byte OFF claiming 10^9 vertices, or a PLY whose header never ends, is refused
// here instead of growing or hanging the importer. Formats are recognised by their content
// (assimp does the same when the extension does not match), so a wrong format hint does not
// skip the check. Other formats pass through unchanged. Thread safe (pure functions).
#pragma once

#include <string>

namespace hgraph {

// Throws InputError(field) if `bytes` is an OFF or PLY file whose header is malformed, whose
// declared element counts need more bytes than it holds, or (OFF) whose faces name vertices
// it does not have or that is cut short.
void PrescanMeshBytes(const std::string& bytes, const std::string& field);

}  // namespace hgraph
