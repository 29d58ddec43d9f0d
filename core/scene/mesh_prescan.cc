#include "core/scene/mesh_prescan.h"

#include <cctype>
#include <charconv>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string_view>
#include <vector>

#include "core/common/error.h"

namespace hgraph {
namespace {

// Counts beyond this are refused outright: no mesh we accept has more elements.
constexpr uint64_t kMaxDeclaredCount = uint64_t{1} << 32;

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

std::optional<uint64_t> Count(std::string_view token) {
  uint64_t v = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return v;
}

// Line reader that skips blank and comment lines (OFF allows '#' comments).
class Lines {
 public:
  explicit Lines(std::string_view bytes) : bytes_(bytes) {}
  std::optional<std::string_view> Next() {
    while (position_ < bytes_.size()) {
      size_t end = bytes_.find('\n', position_);
      if (end == std::string_view::npos) end = bytes_.size();
      std::string_view line = bytes_.substr(position_, end - position_);
      position_ = end + 1;
      if (const size_t hash = line.find('#'); hash != std::string_view::npos) {
        line = line.substr(0, hash);
      }
      if (!Tokens(line).empty()) return line;
    }
    return std::nullopt;
  }
  size_t remaining() const { return position_ >= bytes_.size() ? 0 : bytes_.size() - position_; }

 private:
  std::string_view bytes_;
  size_t position_ = 0;
};

// OFF: "[ST][C][N][4][n]OFF", then "vertices faces edges", then one vertex per line, then one
// face per line ("k i_1 ... i_k"). The whole file is checked: it is small next to the parse.
void PrescanOff(std::string_view bytes, const std::string& field) {
  Lines lines(bytes);
  std::optional<std::string_view> line = lines.Next();
  std::vector<std::string_view> header = Tokens(*line);
  // The counts may follow the keyword on the same line.
  std::vector<std::string_view> counts(header.begin() + 1, header.end());
  if (counts.empty()) {
    line = lines.Next();
    if (!line) throw InputError(field, "OFF file ends after its keyword (no vertex/face counts)");
    counts = Tokens(*line);
  }
  if (counts.size() < 2) throw InputError(field, "OFF header: expected vertex and face counts");
  const std::optional<uint64_t> vertices = Count(counts[0]);
  const std::optional<uint64_t> faces = Count(counts[1]);
  if (!vertices || !faces || *vertices > kMaxDeclaredCount || *faces > kMaxDeclaredCount) {
    throw InputError(field,
                     "OFF header: vertex and face counts must be non-negative integers "
                     "below 2^32");
  }
  // A vertex line holds at least "x y z\n" (6 bytes), a face line at least "k i\n" (4 bytes).
  const uint64_t needed = *vertices * 6 + *faces * 4;
  if (needed > lines.remaining()) {
    throw InputError(field, "OFF header declares " + std::to_string(*vertices) + " vertices and " +
                                std::to_string(*faces) + " faces, which need at least " +
                                std::to_string(needed) + " bytes; the file has " +
                                std::to_string(lines.remaining()) + " after the header");
  }
  for (uint64_t v = 0; v < *vertices; ++v) {
    line = lines.Next();
    if (!line || Tokens(*line).size() < 3) {
      throw InputError(field, "OFF file is cut short or malformed at vertex " + std::to_string(v) +
                                  " of " + std::to_string(*vertices));
    }
  }
  for (uint64_t f = 0; f < *faces; ++f) {
    line = lines.Next();
    const std::vector<std::string_view> t = line ? Tokens(*line) : std::vector<std::string_view>();
    const std::optional<uint64_t> k = t.empty() ? std::nullopt : Count(t[0]);
    if (!k || *k < 1 || *k + 1 > t.size()) {
      throw InputError(field, "OFF file is cut short or malformed at face " + std::to_string(f) +
                                  " of " + std::to_string(*faces));
    }
    for (uint64_t i = 1; i <= *k; ++i) {
      const std::optional<uint64_t> index = Count(t[i]);
      if (!index || *index >= *vertices) {
        throw InputError(field, "OFF face " + std::to_string(f) + " names vertex " +
                                    std::string(t[i].substr(0, 24)) + ", but the file has " +
                                    std::to_string(*vertices) + " vertices");
      }
    }
  }
}

int PlyScalarBytes(std::string_view type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
      type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

// PLY: the header must end (end_header), name known types, and its elements must fit in the
// bytes after it: binary properties by their size (a list by its count field), ASCII ones by
// at least two characters each.
void PrescanPly(std::string_view bytes, const std::string& field) {
  const size_t end = bytes.find("end_header");
  if (end == std::string_view::npos) {
    throw InputError(field, "PLY header has no end_header line");
  }
  size_t body = bytes.find('\n', end);
  body = body == std::string_view::npos ? bytes.size() : body + 1;
  const uint64_t available = bytes.size() - body;
  std::istringstream header{std::string(bytes.substr(0, end))};
  std::string text;
  bool ascii = false;
  bool have_format = false;
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t min_bytes = 0;
  };
  std::vector<Element> elements;
  while (std::getline(header, text)) {
    const std::vector<std::string_view> t = Tokens(text);
    if (t.empty() || t[0] == "ply" || t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "format") {
      if (t.size() < 2 ||
          (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian")) {
        throw InputError(field, "PLY header: unknown format line");
      }
      ascii = t[1] == "ascii";
      have_format = true;
    } else if (t[0] == "element") {
      const std::optional<uint64_t> count = t.size() == 3 ? Count(t[2]) : std::nullopt;
      if (!count || *count > kMaxDeclaredCount) {
        throw InputError(field, "PLY header: an element line needs a name and a count below 2^32");
      }
      elements.push_back({std::string(t[1].substr(0, 32)), *count, 0});
    } else if (t[0] == "property") {
      if (elements.empty()) throw InputError(field, "PLY header: property before any element");
      int size = 0;
      if (t.size() >= 5 && t[1] == "list") {
        size = PlyScalarBytes(t[2]);
        if (size == 0 || PlyScalarBytes(t[3]) == 0) {
          throw InputError(field, "PLY header: unknown list property type");
        }
      } else if (t.size() >= 3) {
        size = PlyScalarBytes(t[1]);
        if (size == 0) throw InputError(field, "PLY header: unknown property type");
      } else {
        throw InputError(field, "PLY header: malformed property line");
      }
      elements.back().min_bytes += ascii ? 2 : static_cast<uint64_t>(size);
    }
  }
  if (!have_format) throw InputError(field, "PLY header has no format line");
  uint64_t needed = 0;
  for (const Element& e : elements) {
    needed += e.count * e.min_bytes;  // both below 2^32 and 2^16 * 8: no overflow
    if (needed > available) {
      throw InputError(field, "PLY header declares " + std::to_string(e.count) + " '" + e.name +
                                  "' elements, more than the " + std::to_string(available) +
                                  " bytes after the header can hold");
    }
  }
}

bool IsOffKeyword(std::string_view token) {
  if (!token.ends_with("OFF")) return false;
  for (char c : token.substr(0, token.size() - 3)) {
    if (c != 'S' && c != 'T' && c != 'C' && c != 'N' && c != '4' && c != 'n') return false;
  }
  return true;
}

}  // namespace

void PrescanMeshBytes(const std::string& bytes, const std::string& field) {
  std::string_view view(bytes);
  // Skip a UTF-8 byte-order mark and leading blanks, as text parsers do.
  if (view.starts_with("\xEF\xBB\xBF")) view.remove_prefix(3);
  const size_t first = view.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return;
  const std::string_view rest = view.substr(first);
  if (rest.starts_with("ply") || rest.starts_with("PLY")) return PrescanPly(rest, field);
  Lines lines(rest);
  if (const std::optional<std::string_view> line = lines.Next()) {
    const std::vector<std::string_view> t = Tokens(*line);
    if (!t.empty() && IsOffKeyword(t[0])) PrescanOff(rest, field);
  }
}

}  // namespace hgraph
