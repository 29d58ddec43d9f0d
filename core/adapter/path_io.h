// Input paths: conversions to and from hgraph.v1 PathSet, and the two path file formats.
#pragma once

#include <string>
#include <vector>

#include "core/path/path.h"
#include "core/space/space.h"
#include "hgraph/v1/path.pb.h"

namespace hgraph {

// Unnamed paths are called "path<i>" so that every report can name them. Waypoints are copied
// as they are; HGraph validates them against the space.
std::vector<InputPath> PathsFromProto(const v1::PathSet& proto);
v1::Path PathToProto(const InputPath& path);
v1::PathSet PathsToProto(const std::vector<InputPath>& paths);

// Reads a paths file in either format, told apart by the first non-space character:
//  '{'   a proto3 JSON PathSet;
//  'State [' anywhere: OMPL's state printout, as in OMPL.app's .path files (ompl_cfg.h);
//  else  OMPL's matrix format (PathGeometric::printAsMatrix): one configuration per line as
//        whitespace-separated numbers, blank lines between paths, '#' starting a comment. A
//        comment line directly above a path's first waypoint names the path.
// In the text format a non-numeric or non-finite token, or a line whose count differs from the
// space's dimension, is an InputError naming "file:line". A missing file is Error(kNotFound).
std::vector<InputPath> LoadPathsFile(const std::string& path, const Space& space);
// Parses the text format; `source` names the file in errors.
std::vector<InputPath> ParsePathsText(const std::string& text, const std::string& source,
                                      const Space& space);

// Writes a ".json" file as a PathSet, a ".path" file as OMPL's PathGeometric printout in `space`
// (the format of OMPL.app's .path files: OmplStatePrint in ompl_cfg.h; no names), any other name
// in the text format (names become "# <name>" comments). Numbers are printed with enough digits
// to read back exactly. LoadPathsFile reads each of them back as the same waypoints.
void WritePathsFile(const std::string& path, const std::vector<InputPath>& paths,
                    const Space& space);
std::string PathsToText(const std::vector<InputPath>& paths);

}  // namespace hgraph
