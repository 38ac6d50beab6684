// Command-line parsing shared by every executable: a wrong flag or value
// prints what is wrong and how to get the usage, and exits 2 (CLI11's own
// exit codes are 100 and up); --help prints the usage and exits 0.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/settings.h"
#include "protocol/auth.h"
#include "protocol/handshake.h"

#define HOLOFUSE_PARSE_FLAGS(app, argc, argv) \
  try {                                       \
    (app).parse((argc), (argv));              \
  } catch (const CLI::ParseError& e) {        \
    return (app).exit(e) == 0 ? 0 : 2;        \
  }

namespace holofuse {

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

// The render client's user camera: "orbit", or "pod:N" to sit at pod N.
inline bool isViewName(const std::string& view) {
  return view == "orbit" || (view.rfind("pod:", 0) == 0 && view.size() > 4 &&
                             view.find_first_not_of("0123456789", 4) == std::string::npos);
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
