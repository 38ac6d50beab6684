#include "deploy/soak.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "report/html.h"

namespace holofuse::deploy {
namespace {

const char* const kQuantities[] = {"rss_mb", "descriptors", "threads"};

double quantity(const ProcessUsage& usage, const std::string& name) {
  if (name == "rss_mb") return static_cast<double>(usage.rss_kb) / 1024.0;
  if (name == "descriptors") return usage.descriptors;
  return usage.threads;
}

std::string number(double value, int decimals) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::string minuteLabel(double minute) { return number(minute, minute < 10 ? 1 : 0); }

}  // namespace

SoakVerdict judgeSoak(const std::vector<std::string>& processes,
                      const std::vector<SoakSample>& samples, double warmup_minutes,
                      double tolerance) {
  SoakVerdict verdict;
  for (size_t p = 0; p < processes.size(); ++p) {
    for (const SoakSample& sample : samples) {
      if (p < sample.usage.size() && sample.usage[p]) continue;
      verdict.problems.push_back(processes[p] + " was gone at minute " +
                                 minuteLabel(sample.minute));
      break;
    }
  }
  std::vector<const SoakSample*> judged;
  for (const SoakSample& sample : samples)
    if (sample.minute >= warmup_minutes) judged.push_back(&sample);
  if (judged.size() < 2) {
    verdict.problems.push_back("too short to tell: " + std::to_string(judged.size()) +
                               " sample(s) after the " + minuteLabel(warmup_minutes) +
                               "-minute warm-up, 2 needed");
  }
  for (size_t p = 0; p < processes.size() && judged.size() >= 2; ++p) {
    for (const std::string q : kQuantities) {
      SoakTrend trend;
      trend.process = processes[p];
      trend.quantity = q;
      bool first = true;
      for (const SoakSample* sample : judged) {
        if (p >= sample->usage.size() || !sample->usage[p]) continue;
        const double v = quantity(*sample->usage[p], q);
        if (first) trend.first = trend.min = trend.max = v;
        trend.last = v;
        trend.min = std::min(trend.min, v);
        trend.max = std::max(trend.max, v);
        first = false;
      }
      if (first) continue;  // gone throughout: said above
      // A count (descriptors, threads) that rose and is back at its least
      // by the last sample was caught mid-task (a picture being written),
      // not leaking: a leak never gives its descriptor back.
      const bool count = q != "rss_mb";
      trend.flat =
          trend.max - trend.min <= tolerance * trend.min || (count && trend.last <= trend.min);
      if (!trend.flat) {
        verdict.problems.push_back(
            trend.process + " " + q + " moved from " + number(trend.first, 1) + " to " +
            number(trend.last, 1) + " (range " + number(trend.min, 1) + " to " +
            number(trend.max, 1) + ", more than " + number(100 * tolerance, 0) + "% of the least)");
      }
      verdict.trends.push_back(trend);
    }
  }
  verdict.flat = verdict.problems.empty();
  return verdict;
}

bool writeSoakReport(const SoakReport& report, const std::string& folder) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(folder, error);
  nlohmann::json json;
  json["settings"] = report.settings;
  json["warmup_minutes"] = report.warmup_minutes;
  json["processes"] = report.processes;
  json["flat"] = report.verdict.flat;
  json["problems"] = report.verdict.problems;
  for (const SoakSample& sample : report.samples) {
    nlohmann::json row;
    row["minute"] = sample.minute;
    for (size_t p = 0; p < report.processes.size(); ++p) {
      const auto& usage = p < sample.usage.size() ? sample.usage[p] : std::nullopt;
      row["usage"][report.processes[p]] = usage
                                              ? nlohmann::json{{"rss_kb", usage->rss_kb},
                                                               {"peak_rss_kb", usage->peak_rss_kb},
                                                               {"descriptors", usage->descriptors},
                                                               {"threads", usage->threads}}
                                              : nlohmann::json();
    }
    json["samples"].push_back(row);
  }
  for (const SoakTrend& t : report.verdict.trends) {
    json["trends"].push_back({{"process", t.process},
                              {"quantity", t.quantity},
                              {"first", t.first},
                              {"last", t.last},
                              {"min", t.min},
                              {"max", t.max},
                              {"flat", t.flat}});
  }

  // One table of every sample (MB, descriptors, threads per process) and
  // one of the trends after the warm-up.
  html::Table samples;
  samples.header = {"minute"};
  for (const std::string& p : report.processes) samples.header.push_back(p + " MB / fd / thr");
  for (const SoakSample& sample : report.samples) {
    std::vector<std::string> row = {minuteLabel(sample.minute)};
    for (size_t p = 0; p < report.processes.size(); ++p) {
      const auto& usage = p < sample.usage.size() ? sample.usage[p] : std::nullopt;
      row.push_back(usage ? number(static_cast<double>(usage->rss_kb) / 1024.0, 1) + " / " +
                                std::to_string(usage->descriptors) + " / " +
                                std::to_string(usage->threads)
                          : "gone");
    }
    samples.rows.push_back(row);
  }
  html::Table trends;
  trends.header = {"process", "quantity", "first", "last", "least", "most", "flat"};
  trends.align = "ll";
  for (const SoakTrend& t : report.verdict.trends) {
    trends.rows.push_back({(t.flat ? "" : "!") + t.process, t.quantity, number(t.first, 1),
                           number(t.last, 1), number(t.min, 1), number(t.max, 1),
                           t.flat ? "yes" : "no"});
  }
  const std::string verdict =
      report.verdict.flat
          ? "Flat: after the warm-up every process's memory, descriptors and threads stayed "
            "within 5%."
          : "Not flat:";
  std::string problems;
  for (const std::string& p : report.verdict.problems) problems += "- " + p + "\n";

  std::ofstream md(fs::path(folder) / "soak.md");
  md << "# Soak\n\n"
     << report.settings << "; warm-up " << minuteLabel(report.warmup_minutes) << " minutes.\n\n"
     << verdict << "\n\n"
     << problems << (problems.empty() ? "" : "\n") << "## After the warm-up\n\n"
     << html::markdownTable(trends) << "\n## Every sample\n\n"
     << html::markdownTable(samples);

  // Resident memory by minute: the server, each client, and the largest pod.
  std::vector<std::string> minutes;
  std::vector<html::Series> series;
  for (const SoakSample& sample : report.samples) minutes.push_back(minuteLabel(sample.minute));
  html::Series largest_pod{"largest pod", {}};
  for (size_t p = 0; p < report.processes.size(); ++p) {
    const bool pod = report.processes[p].rfind("pod", 0) == 0;
    html::Series s{report.processes[p], {}};
    for (size_t i = 0; i < report.samples.size(); ++i) {
      const auto& usage =
          p < report.samples[i].usage.size() ? report.samples[i].usage[p] : std::nullopt;
      const double mb = usage ? static_cast<double>(usage->rss_kb) / 1024.0 : std::nan("");
      if (!pod) {
        s.values.push_back(mb);
        continue;
      }
      if (largest_pod.values.size() <= i) largest_pod.values.push_back(mb);
      if (!std::isnan(mb) && (std::isnan(largest_pod.values[i]) || mb > largest_pod.values[i]))
        largest_pod.values[i] = mb;
    }
    if (!pod) series.push_back(s);
  }
  if (!largest_pod.values.empty()) series.push_back(largest_pod);
  std::ofstream page(fs::path(folder) / "soak.html");
  page << html::page(
      "holofuse soak", "<h1>Soak</h1><p>" + html::escape(report.settings) + "; warm-up " +
                           minuteLabel(report.warmup_minutes) + " minutes.</p><p>" +
                           html::escape(verdict) + "</p><ul>" +
                           [&] {
                             std::string items;
                             for (const std::string& p : report.verdict.problems)
                               items += "<li>" + html::escape(p) + "</li>";
                             return items;
                           }() +
                           "</ul>" +
                           html::barChart("Resident memory by minute", minutes, series, "MB") +
                           "<h2>After the warm-up</h2>" + html::table(trends) +
                           "<h2>Every sample</h2>" + html::table(samples));
  std::ofstream(fs::path(folder) / "soak.json") << json.dump(1) << "\n";
  if (!md || !page) {
    std::fprintf(stderr, "[soak] cannot write the report into %s\n", folder.c_str());
    return false;
  }
  return true;
}

}  // namespace holofuse::deploy
