// Command-line parsing shared by every executable: a wrong flag or value
// prints what is wrong and how to get the usage, and exits 2 (CLI11's own
// exit codes are 100 and up); --help prints the usage and exits 0.
#pragma once

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <iterator>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "config/rig_file.h"
#include "config/settings.h"
#include "protocol/auth.h"
#include "protocol/handshake.h"

#define HOLOFUSE_PARSE_FLAGS(app, argc, argv)     \
  try {                                           \
    (app).parse((argc), (argv));                  \
  } catch (const CLI::ParseError& e) {            \
    return ::holofuse::exitOnFlagError((app), e); \
  }

namespace holofuse {

// --rig FILE (docs/rig-file.md): the program reads its part of a rig file
// as flags, through CLI11's configuration hook, so that a flag given on the
// command line wins over the file and the file's values pass the same
// checks as the flags'. A key the program has no flag for is refused with
// the file and line it is on.
class RigConfig : public CLI::Config {
 public:
  // The program's part, picked once the command line is read (a pod's by
  // its --pod-id).
  using Part = std::function<StatusOr<std::vector<RigOption>>(const RigFile&)>;

  RigConfig(const CLI::App& app, std::string program, Part part)
      : app_(app), program_(std::move(program)), part_(std::move(part)) {}

  std::string to_config(const CLI::App*, bool, bool, std::string) const override { return ""; }

  std::vector<CLI::ConfigItem> from_config(std::istream& in) const override {
    const std::string path = app_.get_config_ptr()->as<std::string>();
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    auto rig = RigFile::parse(text, path);
    if (!rig.isOk()) throw CLI::ConfigError("--rig: " + rig.status().message());
    auto part = part_(*rig);
    if (!part.isOk()) throw CLI::ConfigError("--rig: " + part.status().message());
    std::vector<CLI::ConfigItem> items;
    std::vector<RigOption> read;
    for (const RigOption& option : *part) {
      const CLI::Option* flag = app_.get_option_no_throw("--" + option.name);
      if (flag == nullptr || flag == app_.get_config_ptr())
        throw CLI::ConfigError("--rig: " + option.where + ": '" + option.name + "' is not a " +
                               program_ + " flag (" + program_ + " --help lists them)");
      if (flag->count() > 0) continue;  // the command line's wins
      // So does a flag given there that excludes this one: --replay over a
      // synthetic pod's --size, --no-auth over the file's --key-file.
      const auto excluded = flag->get_excludes();
      if (std::any_of(excluded.begin(), excluded.end(),
                      [](const CLI::Option* other) { return other->count() > 0; }))
        continue;
      if (!flag->get_configurable())
        throw CLI::ConfigError("--rig: " + option.where + ": --" + option.name +
                               " is not for a rig file");
      if (flag->get_expected_min() == 0 && option.values.size() != 1)
        throw CLI::ConfigError("--rig: " + option.where + ": --" + option.name +
                               " is a switch: true or false");
      items.push_back({{}, option.name, option.values});
      read.push_back(option);
    }
    from_file_ = read;
    if (!read.empty())
      std::fprintf(stderr, "[%s] from the rig file %s: %s\n", program_.c_str(), path.c_str(),
                   RigFile::describe(read).c_str());
    return items;
  }

  // Where the values of the flags a message names came from in the rig
  // file ("" when none did).
  std::string whereFrom(const std::string& message) const {
    std::string where;
    for (const RigOption& option : from_file_) {
      // (CLI11 names a file's value by its key alone at times: "no-auth: ...".)
      if (message.rfind(option.name + ":", 0) == 0) {
        where += (where.empty() ? "" : "; ") + ("--" + option.name) + " from " + option.where;
        continue;
      }
      const std::string flag = "--" + option.name;
      for (size_t at = message.find(flag); at != std::string::npos;
           at = message.find(flag, at + 1)) {
        const size_t end = at + flag.size();
        if (end < message.size() &&
            (std::isalnum(static_cast<unsigned char>(message[end])) || message[end] == '-'))
          continue;
        where += (where.empty() ? "" : "; ") + flag + " from " + option.where;
        break;
      }
    }
    return where;
  }

 private:
  const CLI::App& app_;
  std::string program_;
  Part part_;
  mutable std::vector<RigOption> from_file_;
};

// Adds --rig FILE to app for the program named program.
inline void addRigFlag(CLI::App& app, const std::string& program, RigConfig::Part part) {
  app.set_config("--rig", "",
                 "read this " + program +
                     "'s part of a rig file (YAML: hosts, pod ids, cameras, the server's "
                     "address, key files, links; docs/rig-file.md); flags given here override "
                     "it");
  app.config_formatter(std::make_shared<RigConfig>(app, program, std::move(part)));
}

// Levenshtein distance: edits (insert, delete, replace) from a to b.
inline size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The flag of app nearest to `given` (a word from the command line), when
// it is near enough to be a typo of it: "--frames" for "--frame" or
// "--frmaes"; "" otherwise.
inline std::string nearestFlag(const CLI::App& app, std::string_view given) {
  while (!given.empty() && given.front() == '-') given.remove_prefix(1);
  given = given.substr(0, given.find('='));
  std::string best;
  size_t best_distance = SIZE_MAX;
  for (const CLI::Option* option : app.get_options()) {
    for (const std::string& name : option->get_lnames()) {
      const size_t distance = editDistance(given, name);
      if (distance < best_distance) best_distance = distance, best = "--" + name;
    }
  }
  return !given.empty() && best_distance <= std::max<size_t>(2, given.size() / 3) ? best : "";
}

// What a flag error exits with (2; 0 after --help), after the message and,
// when the value came from a rig file, where in it; a flag not known is
// followed by the one it is nearest to.
inline int exitOnFlagError(const CLI::App& app, const CLI::ParseError& error) {
  // (CLI11 reads only the configuration file: say which flag named it.)
  if (error.get_name() == "FileError") {
    std::fprintf(stderr, "--rig: %s\n", error.what());
    return 2;
  }
  const int code = app.exit(error);
  if (dynamic_cast<const CLI::ExtrasError*>(&error) != nullptr) {
    const std::string what = error.what();
    std::istringstream words(what.substr(what.find(": ") + 2));
    for (std::string word; words >> word;) {
      if (word.size() < 2 || word[0] != '-') continue;
      if (const std::string near = nearestFlag(app, word); !near.empty())
        std::fprintf(stderr, "%s: did you mean %s? (--help lists every flag)\n", word.c_str(),
                     near.c_str());
    }
  }
  if (auto rig = std::dynamic_pointer_cast<RigConfig>(app.get_config_formatter())) {
    if (const std::string where = rig->whereFrom(error.what()); !where.empty())
      std::fprintf(stderr, "(%s)\n", where.c_str());
  }
  return code == 0 ? 0 : 2;
}

// This machine's name, as a rig file's hosts name it.
inline std::string hostName() {
  char name[256] = {};
  ::gethostname(name, sizeof name - 1);
  return name;
}

// The id a flag was given on the command line, for picking a rig file's
// part, or an error that names the flag.
inline StatusOr<uint32_t> givenId(const CLI::App& app, const std::string& flag,
                                  std::optional<uint32_t> fallback) {
  const CLI::Option* option = app.get_option(flag);
  if (option->count() == 0) {
    if (fallback) return *fallback;
    return Status(StatusCode::kMalformed, "give " + flag + ": which of the rig's it is");
  }
  const std::string& text = option->results().front();
  uint32_t id = 0;
  char tail = 0;
  // (%u would take "-1" as 4294967295.)
  if (text.empty() || text[0] == '-' || std::sscanf(text.c_str(), "%u%c", &id, &tail) != 1)
    return Status(StatusCode::kMalformed, flag + " '" + text + "' is not an id");
  return id;
}

// A table's settings as flags of app (but those in except): each refuses
// at parse time, naming itself, what its set() refuses; apply() then sets
// the given ones on a struct.
template <typename S>
class SettingFlags {
 public:
  SettingFlags(CLI::App& app, const std::vector<Setting<S>>& table,
               const std::vector<std::string>& except = {}) {
    for (const Setting<S>& setting : table) {
      if (std::find(except.begin(), except.end(), setting.flag) != except.end()) continue;
      auto given = std::make_unique<Given>(Given{setting, nullptr, {}});
      CLI::Validator valid(
          [set = setting.set](std::string& text) {
            S scratch{};
            return set(scratch, text);
          },
          setting.choices.empty() ? "" : "one of " + joined(setting.choices));
      given->option = app.add_option(setting.flag, given->value, setting.help)->check(valid);
      given_.push_back(std::move(given));
    }
  }
  bool given(const std::string& flag) const {
    for (const auto& g : given_) {
      if (g->setting.flag == flag) return g->option->count() > 0;
    }
    return false;
  }
  CLI::Option* option(const std::string& flag) const {
    for (const auto& g : given_) {
      if (g->setting.flag == flag) return g->option;
    }
    return nullptr;
  }
  std::vector<CLI::Option*> options() const {
    std::vector<CLI::Option*> all;
    for (const auto& g : given_) all.push_back(g->option);
    return all;
  }
  void apply(S& settings) const {
    for (const auto& g : given_) {
      if (g->option->count() > 0) g->setting.set(settings, g->value);
    }
  }

 private:
  static std::string joined(const std::vector<std::string>& names) {
    std::string text;
    for (const auto& name : names) text += (text.empty() ? "" : ", ") + name;
    return text;
  }
  struct Given {
    Setting<S> setting;
    CLI::Option* option;
    std::string value;
  };
  std::vector<std::unique_ptr<Given>> given_;  // stable addresses: CLI11 writes into value
};

// An image size "WxH" with each side in 16..max_side: "" and width and
// height set, or what is wrong with the text.
inline std::string parseImageSize(const std::string& text, unsigned& width, unsigned& height,
                                  unsigned max_side = 4096) {
  unsigned w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%ux%u%c", &w, &h, &tail) != 2 || w < 16 || h < 16 ||
      w > max_side || h > max_side) {
    return "'" + text + "' is not WxH with each side in 16.." + std::to_string(max_side);
  }
  width = w;
  height = h;
  return "";
}

// A pod's or client's --key-file and --no-auth (SECURITY.md).
// Keep it alive and in place until parsed: CLI11 writes into it.
class PeerKeyFlags {
 public:
  PeerKeyFlags(CLI::App& app, const std::string& who) {
    app.add_option(
        "--key-file", key_file_,
        "the key this " + who + " authenticates with (default: $HOLOFUSE_KEY_FILE); SECURITY.md");
    app.add_flag("--no-auth", no_auth_,
                 "join a server that runs without authentication (ignores HOLOFUSE_KEY_FILE)")
        ->excludes("--key-file");
  }
  // After parsing: the key of (role, id) (empty with --no-auth or no key
  // file), or nullopt after saying what is wrong with the file.
  std::optional<std::vector<uint8_t>> load(protocol::Role role, uint32_t id) const {
    if (no_auth_) return std::vector<uint8_t>{};
    auto key = protocol::loadPeerKey(key_file_, role, id);
    if (!key.isOk()) {
      std::fprintf(stderr, "--key-file: %s\n", key.status().message().c_str());
      return std::nullopt;
    }
    return *key;
  }

 private:
  std::string key_file_;
  bool no_auth_ = false;
};

// --protocol 1.N: the newest protocol minor this program speaks. By default
// the newest this build knows; an older one makes it stand in for that
// release, as during a rolling upgrade (SPEC.md section 3: the version is
// negotiated per connection). Keep it alive until parsed.
class ProtocolFlag {
 public:
  ProtocolFlag(CLI::App& app, const std::string& who) {
    app.add_option("--protocol", text_,
                   "the newest protocol this " + who + " speaks, 1.0 to 1." +
                       std::to_string(protocol::kVersionMinor) +
                       " (default: the newest; an older one stands in for that release during a "
                       "rolling upgrade)")
        ->check([](const std::string& text) {
          const auto minor = protocol::parseProtocolVersion(text);
          return minor.isOk() ? std::string() : minor.status().message();
        });
  }
  // After parsing: the minor.
  uint8_t maxMinor() const {
    return text_.empty() ? protocol::kVersionMinor : *protocol::parseProtocolVersion(text_);
  }

 private:
  std::string text_;
};

}  // namespace holofuse
