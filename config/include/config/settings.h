// A program's settings as a table over its settings struct, written once per
// setting: the flag that sets it, its help, what it takes, and how the
// struct's field reads from and writes to text. From the one table a
// program binds its flags (SettingFlags, config/command_line.h), the launcher passes a struct on
// as the flags its process reads back (settingArguments), and eval and the
// sweep embed the struct and name its entries as knobs, so that a value one
// of them takes is a value every other takes.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

namespace holofuse {

template <typename S>
struct Setting {
  std::string flag, help;
  double min = 0, max = 0;           // a number in [min, max], unless choices are given
  std::vector<std::string> choices;  // or one of these
  // Sets the field from text: "" or what is wrong with the text.
  std::function<std::string(S&, const std::string&)> set;
  // The field as text that set() reads back to the same value.
  std::function<std::string(const S&)> get;
};

// "" and out set, or what is wrong: text is not a number in [min, max].
std::string parseNumberIn(const std::string& text, double min, double max, double& out);
// The same for a whole number: out set only when text is one, digits
// only, so that no 64-bit value is rounded through a double.
std::string parseNumberIn(const std::string& text, double min, double max, uint64_t& out);
// The shortest text that reads back as v; a value held as a float reads
// back as that float, so 0.15f is "0.15", not "0.150000006".
std::string formatNumber(double v);

// A number setting of the field field(settings) returns (a reference),
// held in units of 1/scale of the flag's (the flag in mm of a field in
// metres: scale 1000). A whole-number field refuses a fraction.
template <typename S, typename Field>
Setting<S> numberSetting(std::string flag, std::string help, double min, double max, Field field,
                         double scale = 1.0) {
  using T = std::remove_reference_t<std::invoke_result_t<Field, S&>>;
  Setting<S> setting{std::move(flag), std::move(help), min, max, {}, {}, {}};
  setting.set = [=](S& settings, const std::string& text) -> std::string {
    double v = 0;
    if (std::string error = parseNumberIn(text, min, max, v); !error.empty()) return error;
    if (std::is_integral_v<T> && v != std::floor(v)) return "'" + text + "' is not a whole number";
    field(settings) = static_cast<T>(v / scale);
    return "";
  };
  setting.get = [=](const S& settings) {
    return formatNumber(static_cast<double>(field(const_cast<S&>(settings))) * scale);
  };
  return setting;
}

// A number setting whose field is a std::optional: unset until given, so
// that a process reading the flag keeps a default of its own (a scene's
// seed) and settingArguments passes only what was given. Whole numbers are
// read as such, so that a 64-bit seed keeps every digit.
template <typename S, typename Field>
Setting<S> optionalNumberSetting(std::string flag, std::string help, double min, double max,
                                 Field field) {
  using T = typename std::remove_reference_t<std::invoke_result_t<Field, S&>>::value_type;
  Setting<S> setting{std::move(flag), std::move(help), min, max, {}, {}, {}};
  setting.set = [=](S& settings, const std::string& text) -> std::string {
    T v{};
    if (std::string error = parseNumberIn(text, min, max, v); !error.empty()) return error;
    field(settings) = v;
    return "";
  };
  setting.get = [=](const S& settings) {
    const auto& value = field(const_cast<S&>(settings));
    if (!value) return std::string();
    if constexpr (std::is_integral_v<T>) {
      return std::to_string(*value);
    } else {
      return formatNumber(*value);
    }
  };
  return setting;
}

// A text setting: check(text) is "" or what is wrong with the text.
template <typename S, typename Field>
Setting<S> textSetting(std::string flag, std::string help, Field field,
                       std::function<std::string(const std::string&)> check = {}) {
  Setting<S> setting{std::move(flag), std::move(help), 0, 0, {}, {}, {}};
  setting.set = [=](S& settings, const std::string& text) -> std::string {
    if (check) {
      if (std::string error = check(text); !error.empty()) return error;
    }
    field(settings) = text;
    return "";
  };
  setting.get = [=](const S& settings) { return field(const_cast<S&>(settings)); };
  return setting;
}

// A setting that takes one of choices: set(settings, choice) and
// get(settings) convert.
template <typename S>
Setting<S> choiceSetting(std::string flag, std::string help, std::vector<std::string> choices,
                         std::function<void(S&, const std::string&)> set,
                         std::function<std::string(const S&)> get) {
  Setting<S> setting{std::move(flag), std::move(help), 0, 0, std::move(choices), {},
                     std::move(get)};
  setting.set = [choices = setting.choices, set](S& settings,
                                                 const std::string& text) -> std::string {
    if (std::find(choices.begin(), choices.end(), text) == choices.end()) {
      std::string names;
      for (const auto& c : choices) names += (names.empty() ? "" : ", ") + c;
      return "'" + text + "' is not one of " + names;
    }
    set(settings, text);
    return "";
  };
  return setting;
}

// A switch shown as on or off.
template <typename S, typename Field>
Setting<S> onOffSetting(std::string flag, std::string help, Field field) {
  return choiceSetting<S>(
      std::move(flag), std::move(help), {"on", "off"},
      [=](S& settings, const std::string& text) { field(settings) = text == "on"; },
      [=](const S& settings) {
        return std::string(field(const_cast<S&>(settings)) ? "on" : "off");
      });
}

// The same setting on a struct that holds an Inner: part(outer) is it.
template <typename Outer, typename Inner, typename Part>
Setting<Outer> embedSetting(const Setting<Inner>& inner, Part part) {
  Setting<Outer> setting{inner.flag, inner.help, inner.min, inner.max, inner.choices, {}, {}};
  setting.set = [set = inner.set, part](Outer& outer, const std::string& text) {
    return set(part(outer), text);
  };
  setting.get = [get = inner.get, part](const Outer& outer) {
    return get(part(const_cast<Outer&>(outer)));
  };
  return setting;
}
template <typename Outer, typename Inner, typename Part>
void embedSettings(std::vector<Setting<Outer>>& into, const std::vector<Setting<Inner>>& table,
                   Part part) {
  for (const Setting<Inner>& inner : table) into.push_back(embedSetting<Outer>(inner, part));
}

// The settings of table named by flags, in flags' order: a program that
// takes some of another's flags binds them from the owner's table.
template <typename S>
std::vector<Setting<S>> pickSettings(const std::vector<Setting<S>>& table,
                                     const std::vector<std::string>& flags) {
  std::vector<Setting<S>> picked;
  for (const std::string& flag : flags) {
    for (const Setting<S>& setting : table) {
      if (setting.flag == flag) picked.push_back(setting);
    }
  }
  return picked;
}

template <typename S>
const Setting<S>* findSetting(const std::vector<Setting<S>>& table, const std::string& flag) {
  for (const Setting<S>& setting : table) {
    if (setting.flag == flag) return &setting;
  }
  return nullptr;
}

// The flags and values that make a process reading table set what
// settings holds: every setting whose value differs from a default S's,
// so the process keeps its own defaults for the rest.
template <typename S>
std::vector<std::string> settingArguments(const std::vector<Setting<S>>& table, const S& settings) {
  const S defaults{};
  std::vector<std::string> arguments;
  for (const Setting<S>& setting : table) {
    const std::string value = setting.get(settings);
    if (value != setting.get(defaults)) arguments.insert(arguments.end(), {setting.flag, value});
  }
  return arguments;
}

}  // namespace holofuse
