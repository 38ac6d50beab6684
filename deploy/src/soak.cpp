#include "deploy/soak.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>

#include "report/html.h"

namespace holofuse::deploy {
namespace {

// heap_mb where the process writes its heap in use (a soak's children).
const char* const kQuantities[] = {"rss_mb", "heap_mb", "descriptors", "threads"};

double quantity(const ProcessUsage& usage, const std::string& name) {
  if (name == "rss_mb") return static_cast<double>(usage.rss_kb) / 1024.0;
  if (name == "heap_mb") return static_cast<double>(usage.heap_kb.value_or(0)) / 1024.0;
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

namespace {

// Runs of `run` consecutive samples averaged into one point each.
void averageRuns(const std::vector<double>& xs, const std::vector<double>& ys, size_t run,
                 std::vector<double>& x, std::vector<double>& y) {
  x.clear();
  y.clear();
  run = std::max<size_t>(run, 1);
  for (size_t i = 0; i < xs.size(); i += run) {
    double sx = 0, sy = 0;
    size_t k = 0;
    for (; k < run && i + k < xs.size(); ++k) {
      sx += xs[i + k];
      sy += ys[i + k];
    }
    x.push_back(sx / k);
    y.push_back(sy / k);
  }
}

// Theil and Sen's line through the points, with Sen's interval.
TrendFit theilSen(const std::vector<double>& x, const std::vector<double>& y) {
  TrendFit fit;
  std::vector<double> slopes;
  slopes.reserve(x.size() * (x.size() - (x.empty() ? 0 : 1)) / 2);
  for (size_t i = 0; i < x.size(); ++i) {
    for (size_t j = i + 1; j < x.size(); ++j) {
      if (x[j] != x[i]) slopes.push_back((y[j] - y[i]) / (x[j] - x[i]));
    }
  }
  if (slopes.empty()) return fit;
  std::sort(slopes.begin(), slopes.end());
  const size_t count = slopes.size();
  auto at = [&](double rank) {
    return slopes[static_cast<size_t>(std::clamp(rank, 0.0, double(count - 1)))];
  };
  fit.slope = count % 2 ? slopes[count / 2] : 0.5 * (slopes[count / 2 - 1] + slopes[count / 2]);
  // Sen's interval: the ranks (N -+ C) / 2 of the sorted slopes, C = z *
  // sqrt(var S), var S = m (m - 1) (2m + 5) / 18 for m points (ties only
  // narrow it, so this errs wide).
  const double m = static_cast<double>(x.size());
  const double c = 1.959964 * std::sqrt(m * (m - 1) * (2 * m + 5) / 18.0);
  fit.low = at(std::floor((double(count) - c) / 2.0));
  fit.high = at(std::ceil((double(count) + c) / 2.0));
  std::vector<double> residuals(x.size());
  for (size_t i = 0; i < x.size(); ++i) residuals[i] = y[i] - fit.slope * x[i];
  std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
  fit.intercept = residuals[residuals.size() / 2];
  return fit;
}

// The lag-1 autocorrelation of the points' residuals from the fit.
double residualAutocorrelation(const std::vector<double>& x, const std::vector<double>& y,
                               const TrendFit& fit) {
  std::vector<double> r(x.size());
  double mean = 0;
  for (size_t i = 0; i < x.size(); ++i) mean += (r[i] = y[i] - fit.intercept - fit.slope * x[i]);
  mean /= std::max<size_t>(r.size(), 1);
  double lagged = 0, total = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    total += (r[i] - mean) * (r[i] - mean);
    if (i > 0) lagged += (r[i] - mean) * (r[i - 1] - mean);
  }
  return total > 0 ? lagged / total : 0.0;
}

}  // namespace

TrendFit fitTrend(const std::vector<double>& hours, const std::vector<double>& values) {
  // Runs of consecutive samples averaged down to kTrendPoints points: the
  // pairs grow as the square of the points.
  const size_t n = std::min(hours.size(), values.size());
  const std::vector<double> xs(hours.begin(), hours.begin() + n),
      ys(values.begin(), values.begin() + n);
  std::vector<double> x, y;
  averageRuns(xs, ys, (n + kTrendPoints - 1) / kTrendPoints, x, y);
  TrendFit fit = theilSen(x, y);
  // Samples are not independent: a process's memory moves in steps that
  // last minutes (groups in flight, an arena grown and trimmed), and Sen's
  // interval over such samples is far too narrow (a healthy server's 30
  // minutes read 'leaking', 2.5 to 10 MB/h). Where the residuals' lag-1
  // autocorrelation rho is positive, runs of (1 + rho) / (1 - rho)
  // samples, the variance's inflation for such noise, are averaged into
  // one point and the line fitted again, at least 6 points kept.
  const double rho = residualAutocorrelation(x, y, fit);
  if (rho > 0.1 && x.size() >= 12) {
    const double inflation = std::min((1 + rho) / (1 - rho), double(x.size()) / 6.0);
    const size_t run = static_cast<size_t>(std::ceil(inflation));
    if (run > 1) {
      std::vector<double> bx, by;
      averageRuns(x, y, run, bx, by);
      fit = theilSen(bx, by);
    }
  }
  fit.samples = n;
  return fit;
}

const char* trendVerdictName(TrendVerdict verdict) {
  switch (verdict) {
    case TrendVerdict::kFlat:
      return "flat";
    case TrendVerdict::kLeaking:
      return "leaking";
    case TrendVerdict::kUndecided:
      break;
  }
  return "undecided";
}

namespace {

// The verdict of one fitted trend against its limit, said in verdict's
// problems (leaking) or undecided lists. run_to_decide says, in words, how
// long a run would decide, from the length in x units.
void decide(SoakTrend& trend, const std::vector<double>& x, const std::string& unit,
            const std::function<std::string(double)>& run_to_decide, SoakVerdict& verdict) {
  const TrendFit& f = trend.fit;
  const std::string slope_text = number(f.slope, 2) + unit + " (95%: " + number(f.low, 2) + " to " +
                                 number(f.high, 2) + ", limit " + number(trend.limit, 2) + ")";
  const std::string name = trend.process + " " + trend.quantity;
  if (f.high < trend.limit) {
    trend.verdict = TrendVerdict::kFlat;
  } else if (f.low > trend.limit) {
    trend.verdict = TrendVerdict::kLeaking;
    verdict.problems.push_back(name + " is leaking: " + slope_text);
  } else {
    // The interval's half on the limit's side narrows as the run's length
    // to the 3/2 (a slope's error over evenly spaced samples).
    trend.verdict = TrendVerdict::kUndecided;
    const double span = x.back() - x.front();
    const double distance = std::abs(trend.limit - f.slope);
    const double half = f.slope < trend.limit ? f.high - f.slope : f.slope - f.low;
    trend.to_decide = distance > 0 ? 1.5 * span * std::pow(half / distance, 2.0 / 3.0)
                                   : std::numeric_limits<double>::infinity();
    verdict.undecided.push_back(name + " undecided, " + slope_text + ": " +
                                (std::isfinite(trend.to_decide)
                                     ? run_to_decide(trend.to_decide)
                                     : "its slope sits at the limit; no run length decides"));
  }
  verdict.trends.push_back(trend);
}

}  // namespace

SoakVerdict judgeSoak(const std::vector<std::string>& processes,
                      const std::vector<SoakSample>& samples, double warmup_minutes,
                      const std::vector<std::string>& restarted) {
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
  if (judged.size() < 3) {
    verdict.problems.push_back("too short to tell: " + std::to_string(judged.size()) +
                               " sample(s) after the " + minuteLabel(warmup_minutes) +
                               "-minute warm-up, 3 needed");
  }
  // Sessions came and went (a churning soak): the server's quantities
  // against the sessions begun as well as against time.
  const bool churned =
      judged.size() >= 3 && judged.back()->sessions >= judged.front()->sessions + 3;
  for (size_t p = 0; p < processes.size() && judged.size() >= 3; ++p) {
    if (std::find(restarted.begin(), restarted.end(), processes[p]) != restarted.end()) continue;
    for (const std::string q : kQuantities) {
      SoakTrend trend;
      trend.process = processes[p];
      trend.quantity = q;
      std::vector<double> hours, sessions, values;
      for (const SoakSample* sample : judged) {
        if (p >= sample->usage.size() || !sample->usage[p]) continue;
        if (q == "heap_mb" && !sample->usage[p]->heap_kb) continue;
        const double v = quantity(*sample->usage[p], q);
        if (values.empty()) trend.first = trend.min = trend.max = v;
        trend.last = v;
        trend.min = std::min(trend.min, v);
        trend.max = std::max(trend.max, v);
        hours.push_back(sample->minute / 60.0);
        sessions.push_back(static_cast<double>(sample->sessions) / 100.0);
        values.push_back(v);
      }
      if (values.size() < 3) continue;  // gone: said above
      std::vector<double> sorted = values;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double level = sorted[sorted.size() / 2];
      const bool memory = q == "rss_mb" || q == "heap_mb";
      trend.fit = fitTrend(hours, values);
      trend.limit = memory ? std::max(kMemoryLimitShare * level, kMemoryLimitFloorPerHour)
                           : kCountLimitPerHour;
      decide(
          trend, hours, memory ? " MB/h" : "/h",
          [&](double to_decide) {
            return "about " + number(to_decide * 60.0 + warmup_minutes, 0) +
                   " minutes of soak would decide";
          },
          verdict);
      if (!churned || p != 0) continue;
      SoakTrend per_session = trend;
      per_session.quantity = q + " per 100 sessions";
      per_session.per = "100 sessions";
      per_session.fit = fitTrend(sessions, values);
      per_session.limit = memory ? kMemoryLimitPer100Sessions : kCountLimitPer100Sessions;
      per_session.to_decide = 0;
      decide(
          per_session, sessions, memory ? " MB/100 sessions" : "/100 sessions",
          [&](double to_decide) {
            return "about " + number(to_decide * 100.0, 0) + " sessions would decide";
          },
          verdict);
    }
  }
  verdict.passed = verdict.problems.empty();
  verdict.flat = verdict.passed && verdict.undecided.empty();
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
    if (report.churn) row["sessions"] = sample.sessions;
    for (size_t p = 0; p < report.processes.size(); ++p) {
      const auto& usage = p < sample.usage.size() ? sample.usage[p] : std::nullopt;
      row["usage"][report.processes[p]] =
          usage ? nlohmann::json{{"rss_kb", usage->rss_kb},
                                 {"peak_rss_kb", usage->peak_rss_kb},
                                 {"descriptors", usage->descriptors},
                                 {"threads", usage->threads},
                                 {"heap_kb", usage->heap_kb ? nlohmann::json(*usage->heap_kb)
                                                            : nlohmann::json()}}
                : nlohmann::json();
    }
    json["samples"].push_back(row);
  }
  json["passed"] = report.verdict.passed;
  json["undecided"] = report.verdict.undecided;
  for (const SoakTrend& t : report.verdict.trends) {
    json["trends"].push_back({{"process", t.process},
                              {"quantity", t.quantity},
                              {"first", t.first},
                              {"last", t.last},
                              {"min", t.min},
                              {"max", t.max},
                              {"per", t.per},
                              {"slope", t.fit.slope},
                              {"slope_low", t.fit.low},
                              {"slope_high", t.fit.high},
                              {"limit", t.limit},
                              {"verdict", trendVerdictName(t.verdict)},
                              {"to_decide", std::isfinite(t.to_decide) ? nlohmann::json(t.to_decide)
                                                                       : nlohmann::json()}});
  }
  if (report.churn) {
    const ChurnCounts& c = *report.churn;
    json["churn"] = {{"sessions", c.sessions},
                     {"sessions_bye", c.sessions_bye},
                     {"sessions_killed", c.sessions_killed},
                     {"sessions_failed", c.sessions_failed},
                     {"pod_restarts", c.pod_restarts},
                     {"pod_restarts_killed", c.pod_restarts_killed},
                     {"server_client_joins", c.server_client_joins},
                     {"server_client_leaves", c.server_client_leaves},
                     {"server_refusals", c.server_refusals},
                     {"link_cuts", c.link_cuts},
                     {"link_restores", c.link_restores},
                     {"link_cut_failures", c.link_cut_failures},
                     {"server_pod_joins", c.server_pod_joins},
                     {"server_pod_leaves", c.server_pod_leaves},
                     {"descriptors_start", c.descriptors_start},
                     {"descriptors_end", c.descriptors_end},
                     {"threads_start", c.threads_start},
                     {"threads_end", c.threads_end}};
  }

  // Where the server's heap grew, by allocation site (heaptrack).
  html::Table growth_sites;
  std::string growth_text;
  if (report.heap_growth) {
    const HeapGrowth& g = *report.heap_growth;
    nlohmann::json sites = nlohmann::json::array();
    growth_sites.header = {"grew by KB", "allocations made", "asked for by", "at"};
    growth_sites.align = "rrll";
    for (const HeapGrowthSite& site : g.sites) {
      sites.push_back({{"bytes", site.bytes},
                       {"calls", site.calls},
                       {"function", site.function},
                       {"location", site.location}});
      growth_sites.rows.push_back(
          {number(site.bytes / 1e3, 1), std::to_string(site.calls), site.function, site.location});
    }
    json["heap_growth"] = {
        {"total_bytes", g.total_bytes}, {"sites", sites}, {"account", g.account}};
    growth_text = "The server's heap held " + number(g.total_bytes / 1e3, 1) +
                  " KB more at the last sample than at the warm-up's end (heaptrack; its full "
                  "account: " +
                  g.account + "). The sites that grew most:";
  } else if (!report.heap_profile_problem.empty()) {
    json["heap_growth"] = {{"problem", report.heap_profile_problem}};
    growth_text = "No heap profile: " + report.heap_profile_problem;
  }

  // One table of the samples (MB, descriptors, threads per process; at
  // most kTableRows of them, evenly spread, soak.json holds all) and one
  // of the trends after the warm-up.
  constexpr size_t kTableRows = 60;
  const size_t stride = std::max<size_t>(1, (report.samples.size() + kTableRows - 1) / kTableRows);
  html::Table samples;
  samples.header = {"minute"};
  for (const std::string& p : report.processes) samples.header.push_back(p + " MB / fd / thr");
  for (size_t i = 0; i < report.samples.size(); i += stride) {
    const SoakSample& sample = report.samples[i];
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
  trends.header = {"process", "quantity", "first",        "last",  "least",  "most",
                   "slope",   "per",      "95% interval", "limit", "verdict"};
  trends.align = "ll";
  for (const SoakTrend& t : report.verdict.trends) {
    trends.rows.push_back({(t.verdict == TrendVerdict::kLeaking ? "!" : "") + t.process, t.quantity,
                           number(t.first, 1), number(t.last, 1), number(t.min, 1),
                           number(t.max, 1), number(t.fit.slope, 2), t.per,
                           number(t.fit.low, 2) + " to " + number(t.fit.high, 2),
                           number(t.limit, 2), trendVerdictName(t.verdict)});
  }
  const std::string verdict =
      report.verdict.flat
          ? "Flat: after the warm-up every process's memory, descriptors and threads grew "
            "less than their limits, with 95% confidence."
      : report.verdict.passed
          ? "Nothing leaks and every process lived, but not every quantity is decided yet:"
          : "Not passed:";
  std::string churn_text;
  if (report.churn) {
    const ChurnCounts& c = *report.churn;
    churn_text = "Churn: " + std::to_string(c.sessions) + " client sessions begun (" +
                 std::to_string(c.sessions_bye) + " left saying bye, " +
                 std::to_string(c.sessions_killed) + " killed mid-frame, " +
                 std::to_string(c.sessions_failed) + " ended otherwise), " +
                 std::to_string(c.pod_restarts) + " pod restarts (" +
                 std::to_string(c.pod_restarts_killed) + " by SIGKILL)" +
                 (c.link_cuts + c.link_cut_failures > 0
                      ? ", " + std::to_string(c.link_cuts) + " cuts of pod 0's link (" +
                            std::to_string(c.link_restores) + " restored, " +
                            std::to_string(c.link_cut_failures) + " failed)"
                      : std::string()) +
                 ". The server logged " + std::to_string(c.server_client_joins) +
                 " client joins, " + std::to_string(c.server_client_leaves) + " leaves and " +
                 std::to_string(c.server_refusals) + " refusals, and " +
                 std::to_string(c.server_pod_joins) + " pod joins and " +
                 std::to_string(c.server_pod_leaves) + " leaves. Its descriptors went from " +
                 std::to_string(c.descriptors_start) + " to " + std::to_string(c.descriptors_end) +
                 " and its threads from " + std::to_string(c.threads_start) + " to " +
                 std::to_string(c.threads_end) + " once the last session left.";
  }
  const std::string growth_md =
      growth_text.empty()
          ? ""
          : "## Where the server's heap grew\n\n" + growth_text + "\n\n" +
                (growth_sites.rows.empty() ? "" : html::markdownTable(growth_sites) + "\n");
  std::string problems;
  for (const std::string& p : report.verdict.problems) problems += "- " + p + "\n";
  for (const std::string& u : report.verdict.undecided) problems += "- " + u + "\n";

  std::ofstream md(fs::path(folder) / "soak.md");
  md << "# Soak\n\n"
     << report.settings << "; warm-up " << minuteLabel(report.warmup_minutes) << " minutes.\n\n"
     << verdict << "\n\n"
     << problems << (churn_text.empty() ? "" : "\n" + churn_text + "\n")
     << (problems.empty() ? "" : "\n") << "## After the warm-up\n\n"
     << html::markdownTable(trends)
     << "\nSlopes: Theil and Sen's (the median of the slopes between every two samples), "
        "with Sen's 95% interval. Flat: the interval lies under the limit (memory: "
     << number(100 * kMemoryLimitShare, 1)
     << "% of its level an hour; descriptors and threads: " << number(kCountLimitPerHour, 1)
     << " an hour); leaking: above it; undecided: across it.\n\n"
     << growth_md << "## Samples\n\n"
     << (stride > 1 ? "Every " + std::to_string(stride) + "th sample; soak.json has all.\n\n"
                    : std::string())
     << html::markdownTable(samples);

  // Each quantity of the server and the clients, and the memory of the pod
  // whose memory rose fastest, against time with the fitted line over the
  // judged minutes.
  std::string charts;
  auto trendOf = [&](const std::string& process, const std::string& q) -> const SoakTrend* {
    for (const SoakTrend& t : report.verdict.trends)
      if (t.process == process && t.quantity == q) return &t;
    return nullptr;
  };
  auto chartOf = [&](size_t p, const std::string& q, const std::string& label) {
    html::Line samples{"samples", {}, false};
    for (const SoakSample& sample : report.samples) {
      const auto& usage = p < sample.usage.size() ? sample.usage[p] : std::nullopt;
      if (usage && (q != "heap_mb" || usage->heap_kb))
        samples.points.emplace_back(sample.minute, quantity(*usage, q));
    }
    std::vector<html::Line> lines = {samples};
    if (const SoakTrend* t = trendOf(report.processes[p], q); t != nullptr) {
      const double end = report.samples.empty() ? 0 : report.samples.back().minute;
      auto at = [&](double minute) { return t->fit.intercept + t->fit.slope * minute / 60.0; };
      lines.push_back(
          {"fit: " + number(t->fit.slope, 2) + "/h (" + trendVerdictName(t->verdict) + ")",
           {{report.warmup_minutes, at(report.warmup_minutes)}, {end, at(end)}},
           true});
    }
    charts += html::lineChart(report.processes[p] + ": " + label, "minute", label, lines);
  };
  // A churning soak's server against the sessions begun, with the fitted
  // line per 100 sessions over the judged samples.
  auto sessionsChartOf = [&](size_t p, const std::string& q, const std::string& label) {
    const SoakTrend* t = trendOf(report.processes[p], q + " per 100 sessions");
    if (t == nullptr) return;
    html::Line samples{"samples", {}, false};
    double first = -1, last = 0;
    for (const SoakSample& sample : report.samples) {
      const auto& usage = p < sample.usage.size() ? sample.usage[p] : std::nullopt;
      if (!usage || (q == "heap_mb" && !usage->heap_kb)) continue;
      const auto sessions = static_cast<double>(sample.sessions);
      samples.points.emplace_back(sessions, quantity(*usage, q));
      if (sample.minute >= report.warmup_minutes && first < 0) first = sessions;
      last = sessions;
    }
    auto at = [&](double sessions) { return t->fit.intercept + t->fit.slope * sessions / 100.0; };
    const html::Line fit{"fit: " + number(t->fit.slope, 3) + " per 100 sessions (" +
                             trendVerdictName(t->verdict) + ")",
                         {{std::max(first, 0.0), at(std::max(first, 0.0))}, {last, at(last)}},
                         true};
    charts += html::lineChart(report.processes[p] + ": " + label + " against sessions",
                              "client sessions begun", label, {samples, fit});
  };
  size_t steepest_pod = report.processes.size();
  double steepest = -std::numeric_limits<double>::infinity();
  for (size_t p = 0; p < report.processes.size(); ++p) {
    if (report.processes[p].rfind("pod", 0) != 0) continue;
    const SoakTrend* t = trendOf(report.processes[p], "rss_mb");
    if (t != nullptr && t->fit.slope > steepest) {
      steepest = t->fit.slope;
      steepest_pod = p;
    }
  }
  for (size_t p = 0; p < report.processes.size(); ++p) {
    if (report.processes[p].rfind("pod", 0) == 0 && p != steepest_pod) continue;
    chartOf(p, "rss_mb", "resident MB");
    if (report.processes[p].rfind("pod", 0) == 0) continue;
    if (trendOf(report.processes[p], "heap_mb") != nullptr) chartOf(p, "heap_mb", "heap MB");
    sessionsChartOf(p, "heap_mb", "heap MB");
    sessionsChartOf(p, "rss_mb", "resident MB");
    chartOf(p, "descriptors", "descriptors");
    chartOf(p, "threads", "threads");
  }
  std::ofstream page(fs::path(folder) / "soak.html");
  page << html::page(
      "holofuse soak",
      "<h1>Soak</h1><p>" + html::escape(report.settings) + "; warm-up " +
          minuteLabel(report.warmup_minutes) + " minutes.</p><p>" + html::escape(verdict) + "</p>" +
          (churn_text.empty() ? "" : "<p>" + html::escape(churn_text) + "</p>") + "<ul>" +
          [&] {
            std::string items;
            for (const std::string& p : report.verdict.problems)
              items += "<li>" + html::escape(p) + "</li>";
            for (const std::string& u : report.verdict.undecided)
              items += "<li>" + html::escape(u) + "</li>";
            return items;
          }() +
          "</ul>" + charts + "<h2>After the warm-up</h2>" + html::table(trends) +
          (growth_text.empty()
               ? ""
               : "<h2>Where the server's heap grew</h2><p>" + html::escape(growth_text) + "</p>" +
                     (growth_sites.rows.empty() ? "" : html::table(growth_sites))) +
          "<h2>Samples</h2>" + html::table(samples));
  std::ofstream(fs::path(folder) / "soak.json") << json.dump(1) << "\n";
  if (!md || !page) {
    std::fprintf(stderr, "[soak] cannot write the report into %s\n", folder.c_str());
    return false;
  }
  return true;
}

}  // namespace holofuse::deploy
