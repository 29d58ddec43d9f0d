// Flags that fill fields of a request proto. Each is registered once with the field it fills, so
// that a flag not given leaves its field unset (the engine's default, the same in process and
// through hgraph-server) and an error about the field names the flag too ("options.radius
// (--radius)"). Instead of a flag-to-field map kept by hand beside each add_option.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/common/error.h"

namespace hgraph::cli {

// Rethrows an InputError about a proto field set from a flag so that it names both
// ("measure.k (--k)"), `flags` mapping fields to flags; other errors are rethrown unchanged. Call
// only from a catch block.
[[noreturn]] void RethrowWithFlag(const Error& e, const std::map<std::string, std::string>& flags);

// Not copyable: the setters it keeps point to the values CLI11 parses into (held here).
template <typename Request>
class RequestFlags {
 public:
  RequestFlags() = default;
  RequestFlags(const RequestFlags&) = delete;
  RequestFlags& operator=(const RequestFlags&) = delete;

  // Registers `flag` ("--radius", or "-q,--quiet" style names) on `app`; when it is given, Apply
  // calls set(request, value). Errors about `field` (as core/adapter names it, "options.radius")
  // name the flag's long name.
  template <typename T>
  CLI::Option* Add(CLI::App* app, const std::string& flag, const std::string& help,
                   const std::string& field, std::function<void(Request&, const T&)> set) {
    auto value = std::make_shared<T>();
    CLI::Option* option = app->add_option(flag, *value, help);
    Name(field, option->get_name());
    setters_.push_back([option, value, set = std::move(set)](Request& request) {
      if (option->count() > 0) set(request, *value);
    });
    return option;
  }
  // Errors about `field`, which something else fills from `flag`, name the flag too.
  void Name(const std::string& field, const std::string& flag) { names_[field] = flag; }
  // Sets the fields of the flags given.
  void Apply(Request& request) const {
    for (const auto& set : setters_) set(request);
  }
  // Rethrows an error about a field of these flags naming the flag ("options.radius
  // (--radius)"); other errors unchanged. Call only from a catch block.
  [[noreturn]] void Rethrow(const Error& e) const { RethrowWithFlag(e, names_); }
  const std::map<std::string, std::string>& names() const { return names_; }

 private:
  std::map<std::string, std::string> names_;
  std::vector<std::function<void(Request&)>> setters_;
};

}  // namespace hgraph::cli
