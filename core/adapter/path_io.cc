#include "core/adapter/path_io.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <string_view>

#include "core/adapter/json_io.h"
#include "core/adapter/ompl_cfg.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

std::string DefaultName(int i) { return "path" + std::to_string(i); }

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

std::string_view Trim(std::string_view s) {
  while (!s.empty() && IsSpace(s.front())) s.remove_prefix(1);
  while (!s.empty() && IsSpace(s.back())) s.remove_suffix(1);
  return s;
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Shortest decimal text that reads back as the same double.
std::string Exact(double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

}  // namespace

std::vector<InputPath> PathsFromProto(const v1::PathSet& proto) {
  std::vector<InputPath> paths;
  paths.reserve(proto.paths_size());
  for (int i = 0; i < proto.paths_size(); ++i) {
    const v1::Path& p = proto.paths(i);
    InputPath path{.name = p.name().empty() ? DefaultName(i) : p.name()};
    path.waypoints.reserve(p.waypoints_size());
    for (const v1::Configuration& q : p.waypoints()) path.waypoints.push_back(ConfigFromProto(q));
    paths.push_back(std::move(path));
  }
  return paths;
}

v1::Path PathToProto(const InputPath& path) {
  v1::Path proto;
  proto.set_name(path.name);
  for (const Config& q : path.waypoints) *proto.add_waypoints() = ConfigToProto(q);
  return proto;
}

v1::PathSet PathsToProto(const std::vector<InputPath>& paths) {
  v1::PathSet proto;
  for (const InputPath& path : paths) *proto.add_paths() = PathToProto(path);
  return proto;
}

std::vector<InputPath> ParsePathsText(const std::string& text, const std::string& source,
                                      const Space& space) {
  std::vector<InputPath> paths;
  InputPath current;
  std::string pending_name;  // from a "# name" comment right before a path
  const auto finish = [&] {
    if (current.waypoints.empty()) return;
    const int i = static_cast<int>(paths.size());
    current.name = pending_name.empty() ? DefaultName(i) : pending_name;
    pending_name.clear();
    paths.push_back(std::move(current));
    current = InputPath();
  };

  std::string_view rest = text;
  int line_number = 0;
  while (!rest.empty()) {
    const size_t eol = rest.find('\n');
    std::string_view line = rest.substr(0, eol);
    rest = eol == std::string_view::npos ? std::string_view() : rest.substr(eol + 1);
    ++line_number;
    const std::string where = source + ":" + std::to_string(line_number);

    const size_t hash = line.find('#');
    if (hash != std::string_view::npos) {
      // A comment before a path's first waypoint names the path (WritePathsFile writes one).
      if (current.waypoints.empty() && Trim(line.substr(0, hash)).empty()) {
        pending_name = std::string(Trim(line.substr(hash + 1)));
        continue;
      }
      line = line.substr(0, hash);
    }
    line = Trim(line);
    if (line.empty()) {
      // Only a truly blank line separates paths; a comment line does not. A blank line also
      // detaches a preceding comment (a file header) from the next path.
      if (hash == std::string_view::npos) {
        finish();
        pending_name.clear();
      }
      continue;
    }

    std::vector<double> values;
    while (!line.empty()) {
      size_t end = 0;
      while (end < line.size() && !IsSpace(line[end])) ++end;
      std::string_view token = line.substr(0, end);
      line = Trim(line.substr(end));
      std::string_view digits = token;
      if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
      double v = 0;
      const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), v);
      if (result.ec != std::errc() || result.ptr != digits.data() + digits.size()) {
        throw InputError(where, "'" + std::string(token) + "' is not a number (expected " +
                                    std::to_string(space.dimension()) +
                                    " numbers per line, blank lines between paths, '#' comments)");
      }
      if (!std::isfinite(v)) {
        throw InputError(where, "coordinate " + std::to_string(values.size()) + " is not finite");
      }
      values.push_back(v);
    }
    if (static_cast<int>(values.size()) != space.dimension()) {
      throw InputError(where, "expected " + std::to_string(space.dimension()) +
                                  " numbers (the space's dimension), got " +
                                  std::to_string(values.size()));
    }
    current.waypoints.push_back(
        Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())));
  }
  finish();
  return paths;
}

std::vector<InputPath> LoadPathsFile(const std::string& path, const Space& space) {
  const std::string text = ReadTextFile(path);
  const size_t first = text.find_first_not_of(" \t\r\n\f\v");
  if (first != std::string::npos && text[first] == '{') {
    v1::PathSet proto;
    ParseJson(text, path, &proto);
    return PathsFromProto(proto);
  }
  if (LooksLikeOmplStatePrint(text)) return ParseOmplStatePrint(text, path, space);
  return ParsePathsText(text, path, space);
}

std::string PathsToText(const std::vector<InputPath>& paths) {
  std::string out;
  for (size_t i = 0; i < paths.size(); ++i) {
    if (i > 0) out += "\n";
    if (!paths[i].name.empty()) out += "# " + paths[i].name + "\n";
    for (const Config& q : paths[i].waypoints) {
      for (Eigen::Index k = 0; k < q.size(); ++k) {
        if (k > 0) out += " ";
        out += Exact(q[k]);
      }
      out += "\n";
    }
  }
  return out;
}

void WritePathsFile(const std::string& path, const std::vector<InputPath>& paths,
                    const Space& space) {
  if (EndsWith(path, ".json")) {
    WriteTextFile(path, ToJson(PathsToProto(paths)));
  } else if (EndsWith(path, ".path")) {
    WriteTextFile(path, OmplStatePrint(paths, space));
  } else {
    WriteTextFile(path, PathsToText(paths));
  }
}

}  // namespace hgraph
