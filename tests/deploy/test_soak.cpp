// The soak's judge on samples made here (flat, growing, a process gone,
// too short), and a short soak of the real loop: every process sampled,
// the report written for people and programs.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "base/process.h"
#include "deploy/heap_profile.h"
#include "deploy/netns_rig.h"
#include "deploy/soak.h"
#include "integration/process_harness.h"

namespace holofuse::deploy {
namespace {

namespace fs = std::filesystem;

SoakSample sampleAt(double minute, std::vector<std::optional<ProcessUsage>> usage) {
  return SoakSample{minute, 0, std::move(usage)};
}

ProcessUsage usage(uint64_t rss_mb, int descriptors = 10, int threads = 4) {
  return ProcessUsage{rss_mb * 1024, rss_mb * 1024, descriptors, threads, std::nullopt};
}

// A soak of one server sampled every 10 s: memory at 45 MB with the
// noise a sample that reads frames in flight gives (uniform, +-1 MB, as
// measured on a healthy build), growing by mb_per_hour; descriptors and
// threads steady. A fixed generator, so every run sees the same series.
std::vector<SoakSample> serverSoak(double minutes, double mb_per_hour, uint32_t seed = 7) {
  std::vector<SoakSample> samples;
  uint32_t state = seed;
  auto uniform = [&] {  // in [-1, 1)
    state = state * 1664525u + 1013904223u;
    return (state >> 8) / double(1u << 23) - 1.0;
  };
  for (double minute = 1.0 / 6.0; minute <= minutes + 1e-9; minute += 1.0 / 6.0) {
    ProcessUsage u;
    u.rss_kb = static_cast<uint64_t>((45.0 + mb_per_hour * minute / 60.0 + uniform()) * 1024);
    u.peak_rss_kb = u.rss_kb;
    u.descriptors = 10;
    u.threads = 5;
    samples.push_back(sampleAt(minute, {u}));
  }
  return samples;
}

// A short churning soak of the real loop (2 pods at 64x48 and 5 fps, a
// session a second, sampled every 3 s after a 6-second warm-up), with
// the flags given; its output and log in out.
pid_t startChurningSoak(const fs::path& out, std::vector<std::string> flags) {
  flags.insert(flags.begin(), std::string(HOLOFUSE_BIN_DIR) + "/holofuse_loop");
  for (const char* flag : {"--pods", "2", "--size", "64x48", "--fps", "5", "--sample-seconds", "3",
                           "--warmup-minutes", "0.1", "--churn", "--churn-seconds", "1", "--out"})
    flags.push_back(flag);
  flags.push_back(out.string());
  return test::spawn(flags, out.string() + ".log");
}

const SoakTrend& trendOf(const SoakVerdict& verdict, const std::string& quantity) {
  for (const SoakTrend& t : verdict.trends)
    if (t.quantity == quantity) return t;
  throw std::runtime_error("no trend of " + quantity);
}

TEST(Soak, AStraightLineFitsExactlyAndItsIntervalHoldsIt) {
  std::vector<double> hours, values;
  for (int i = 0; i < 50; ++i) {
    hours.push_back(0.1 * i);
    values.push_back(3.0 + 2.0 * hours.back());
  }
  const TrendFit exact = fitTrend(hours, values);
  EXPECT_NEAR(exact.slope, 2.0, 1e-9);
  EXPECT_NEAR(exact.low, 2.0, 1e-9);
  EXPECT_NEAR(exact.high, 2.0, 1e-9);
  EXPECT_NEAR(exact.intercept, 3.0, 1e-9);
  EXPECT_EQ(exact.samples, 50u);
  // One wild value among fifty moves a median of slopes little.
  values[20] += 100;
  const TrendFit spiked = fitTrend(hours, values);
  EXPECT_NEAR(spiked.slope, 2.0, 0.05);
  EXPECT_LE(spiked.low, 2.0);
  EXPECT_GE(spiked.high, 2.0);
}

// Known answers: the noise a healthy server shows is flat once the run is
// long enough to tell, and no run is called leaking for it.
TEST(Soak, NoiseWithoutATrendIsFlat) {
  const SoakVerdict verdict = judgeSoak({"server"}, serverSoak(122, 0.0), 2);
  EXPECT_TRUE(verdict.flat) << ::testing::PrintToString(verdict.problems)
                            << ::testing::PrintToString(verdict.undecided);
  EXPECT_TRUE(verdict.passed);
  const SoakTrend& memory = trendOf(verdict, "rss_mb");
  EXPECT_EQ(memory.verdict, TrendVerdict::kFlat);
  EXPECT_NEAR(memory.limit, kMemoryLimitShare * 45.0, 0.02);
  EXPECT_LT(memory.fit.low, 0.0);
  EXPECT_GT(memory.fit.high, 0.0);
  EXPECT_EQ(trendOf(verdict, "descriptors").verdict, TrendVerdict::kFlat);
  EXPECT_EQ(trendOf(verdict, "threads").verdict, TrendVerdict::kFlat);
  // A heap as small as a server's between frames (0.2 MB) is held to the
  // floor, not to 0.5% of itself (1 KB/h, more exact than any soak).
  std::vector<SoakSample> small_heap = serverSoak(122, 0.0);
  for (SoakSample& sample : small_heap) sample.usage[0]->heap_kb = 200;
  const SoakTrend& heap = trendOf(judgeSoak({"server"}, small_heap, 2), "heap_mb");
  EXPECT_DOUBLE_EQ(heap.limit, kMemoryLimitFloorPerHour);
  EXPECT_EQ(heap.verdict, TrendVerdict::kFlat);
  // Half an hour of the same noise is too short to call flat, and is no
  // failure: undecided, with the run that would decide.
  const SoakVerdict short_run = judgeSoak({"server"}, serverSoak(30, 0.0), 2);
  EXPECT_TRUE(short_run.passed) << ::testing::PrintToString(short_run.problems);
  for (const SoakTrend& t : short_run.trends) EXPECT_NE(t.verdict, TrendVerdict::kLeaking);
}

// 1% of 45 MB an hour, twice the limit: undecided in half an hour, and
// leaking in a run as long as the judge said would decide.
TEST(Soak, OnePercentAnHourIsLeakingWithinTheRunLengthTheJudgeNames) {
  const SoakVerdict short_run = judgeSoak({"server"}, serverSoak(30, 0.45), 2);
  const SoakTrend& first = trendOf(short_run, "rss_mb");
  ASSERT_EQ(first.verdict, TrendVerdict::kUndecided) << first.fit.low << " " << first.fit.high;
  ASSERT_TRUE(std::isfinite(first.to_decide));
  EXPECT_GT(first.to_decide, 28.0 / 60.0);
  ASSERT_EQ(short_run.undecided.size(), 1u);
  EXPECT_NE(short_run.undecided[0].find("server rss_mb undecided"), std::string::npos)
      << short_run.undecided[0];
  EXPECT_NE(short_run.undecided[0].find("minutes of soak would decide"), std::string::npos);
  EXPECT_TRUE(short_run.passed);
  EXPECT_FALSE(short_run.flat);

  const double named_minutes = 2 + 60.0 * first.to_decide;
  const SoakVerdict long_run = judgeSoak({"server"}, serverSoak(named_minutes, 0.45), 2);
  const SoakTrend& memory = trendOf(long_run, "rss_mb");
  EXPECT_EQ(memory.verdict, TrendVerdict::kLeaking)
      << named_minutes << " min: " << memory.fit.low << " to " << memory.fit.high;
  EXPECT_NEAR(memory.fit.slope, 0.45, 0.15);
  EXPECT_FALSE(long_run.passed);
  ASSERT_EQ(long_run.problems.size(), 1u);
  EXPECT_NE(long_run.problems[0].find("server rss_mb is leaking: 0."), std::string::npos)
      << long_run.problems[0];

  // The report says it in each form: the table's verdict, a chart of the
  // samples with the fitted line, the trend's figures for programs.
  SoakReport report;
  report.settings = "a server of known answers";
  report.processes = {"server"};
  report.samples = serverSoak(named_minutes, 0.45);
  report.warmup_minutes = 2;
  report.verdict = long_run;
  const fs::path out = test::freshDir("soak_report");
  ASSERT_TRUE(writeSoakReport(report, out.string()));
  const std::string md = test::readFile(out / "soak.md");
  EXPECT_NE(md.find("| server | rss_mb |"), std::string::npos) << md;
  EXPECT_NE(md.find("| leaking |"), std::string::npos) << md;
  EXPECT_NE(md.find("th sample; soak.json has all"), std::string::npos) << "a long run's table";
  const std::string page = test::readFile(out / "soak.html");
  EXPECT_NE(page.find("server: resident MB"), std::string::npos);
  EXPECT_NE(page.find("<title>fit: 0."), std::string::npos) << "the fitted line is drawn";
  EXPECT_NE(page.find("/h (leaking)"), std::string::npos);
  std::ifstream in(out / "soak.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_FALSE(json["passed"].get<bool>());
  EXPECT_EQ(json["samples"].size(), report.samples.size());
  const auto& trend = json["trends"].at(0);
  EXPECT_EQ(trend["verdict"], "leaking");
  EXPECT_DOUBLE_EQ(trend["slope"].get<double>(), memory.fit.slope);
  EXPECT_GT(trend["slope_low"].get<double>(), trend["limit"].get<double>());
  fs::remove_all(out);
}

// A single spike (frames piled up at one sample, a picture being written)
// is no trend; a count that keeps rising is.
TEST(Soak, ASingleSpikeIsFlatAndACountThatKeepsRisingLeaks) {
  std::vector<SoakSample> spiked = serverSoak(122, 0.0);
  spiked[360].usage[0]->rss_kb += 20 * 1024;
  spiked[400].usage[0]->descriptors += 3;
  spiked[401].usage[0]->threads += 1;
  const SoakVerdict verdict = judgeSoak({"server"}, spiked, 2);
  EXPECT_TRUE(verdict.flat) << ::testing::PrintToString(verdict.problems)
                            << ::testing::PrintToString(verdict.undecided);
  std::vector<SoakSample> rising = serverSoak(62, 0.0);
  for (SoakSample& sample : rising)
    sample.usage[0]->descriptors += static_cast<int>(sample.minute / 10);  // one per 10 minutes
  const SoakVerdict leaking = judgeSoak({"server"}, rising, 2);
  EXPECT_EQ(trendOf(leaking, "descriptors").verdict, TrendVerdict::kLeaking);
  EXPECT_NEAR(trendOf(leaking, "descriptors").fit.slope, 6.0, 1.0);
  EXPECT_FALSE(leaking.passed);
}

// Memory that moves in steps lasting minutes (groups in flight, an arena
// grown and trimmed: a healthy server's 30 minutes went 61, 64, 68, 64,
// 68, 64 MB) is not a leak: its samples are far from independent, so the
// judge widens its interval by their autocorrelation. A real leak under
// the same steps still shows.
TEST(Soak, MemoryThatMovesInStepsIsNoLeakButALeakUnderTheStepsIs) {
  auto stepped = [](double mb_per_hour) {
    std::vector<SoakSample> samples = serverSoak(30, mb_per_hour);
    const double levels[] = {0, 3, 7, 3, 7, 3, 0, 7, 3, 7};  // 3 minutes each
    for (SoakSample& sample : samples) {
      const int step = std::min(9, static_cast<int>(sample.minute / 3.0));
      sample.usage[0]->rss_kb += static_cast<uint64_t>(levels[step] * 1024);
    }
    return samples;
  };
  const SoakVerdict healthy = judgeSoak({"server"}, stepped(0), 2);
  const SoakTrend& memory = trendOf(healthy, "rss_mb");
  EXPECT_NE(memory.verdict, TrendVerdict::kLeaking)
      << memory.fit.slope << " (" << memory.fit.low << " to " << memory.fit.high << ")";
  EXPECT_TRUE(healthy.passed);
  const SoakVerdict leaking = judgeSoak({"server"}, stepped(60), 2);
  EXPECT_EQ(trendOf(leaking, "rss_mb").verdict, TrendVerdict::kLeaking)
      << trendOf(leaking, "rss_mb").fit.low;
}

// A churning soak: a session every 8 s. The server's memory is judged
// against the sessions begun too: flat without a leak, leaking at 5 KB a
// session (the limit is 1 KB).
TEST(Soak, AChurningServerIsJudgedPerHundredSessions) {
  auto churned = [](double kb_per_session) {
    std::vector<SoakSample> samples = serverSoak(122, 0.0);
    for (SoakSample& sample : samples) {
      sample.sessions = static_cast<uint64_t>(sample.minute * 60.0 / 8.0);
      sample.usage[0]->rss_kb += static_cast<uint64_t>(kb_per_session * sample.sessions);
    }
    return samples;
  };
  const SoakVerdict healthy = judgeSoak({"server"}, churned(0), 2);
  const SoakTrend& per_session = trendOf(healthy, "rss_mb per 100 sessions");
  EXPECT_EQ(per_session.per, "100 sessions");
  EXPECT_EQ(per_session.verdict, TrendVerdict::kFlat)
      << per_session.fit.low << " to " << per_session.fit.high;
  EXPECT_DOUBLE_EQ(per_session.limit, kMemoryLimitPer100Sessions);
  EXPECT_EQ(trendOf(healthy, "descriptors per 100 sessions").verdict, TrendVerdict::kFlat);
  EXPECT_TRUE(healthy.flat) << ::testing::PrintToString(healthy.undecided);
  const SoakVerdict leaking = judgeSoak({"server"}, churned(5), 2);
  const SoakTrend& leak = trendOf(leaking, "rss_mb per 100 sessions");
  EXPECT_EQ(leak.verdict, TrendVerdict::kLeaking);
  EXPECT_NEAR(leak.fit.slope, 0.49, 0.05) << "5 KB a session is 0.49 MB per 100";
  EXPECT_FALSE(leaking.passed);
  // Without sessions, nothing is judged per session.
  for (const SoakTrend& t : judgeSoak({"server"}, serverSoak(30, 0.0), 2).trends)
    EXPECT_EQ(t.per, "h");
}

TEST(Soak, AProcessGoneOrASoakTooShortIsNotFlat) {
  const std::vector<SoakSample> gone = {
      sampleAt(3, {usage(100), usage(20)}), sampleAt(4, {usage(100), std::nullopt}),
      sampleAt(5, {usage(100), std::nullopt}), sampleAt(6, {usage(100), std::nullopt})};
  const SoakVerdict verdict = judgeSoak({"server", "pod 0"}, gone, 2);
  EXPECT_FALSE(verdict.passed);
  EXPECT_FALSE(verdict.flat);
  ASSERT_FALSE(verdict.problems.empty());
  EXPECT_EQ(verdict.problems[0], "pod 0 was gone at minute 4.0");
  const SoakVerdict short_one = judgeSoak({"server"}, {sampleAt(1, {usage(5)})}, 2);
  EXPECT_FALSE(short_one.passed);
  EXPECT_NE(short_one.problems.at(0).find("too short to tell: 0 sample(s) after the 2.0-minute"),
            std::string::npos)
      << short_one.problems.at(0);
}

// The real loop soaked for 30 s with churn, sampled every 3 s: a row per
// sample with every process alive (the restarted pod followed), the
// verdict consistent with the trends it lists, and every session and
// restart accounted for, by the soak and in the server's log.
TEST(Soak, TheLoopSoaksWithChurnAndEveryProcessSampled) {
  const fs::path out = test::freshDir("soak");
  const pid_t soak = startChurningSoak(out, {"--clients", "2", "--soak-minutes", "0.5"});
  const int code = test::waitExit(soak, 180);
  ASSERT_TRUE(code == 0 || code == 1) << test::readFile(out.string() + ".log");
  std::ifstream in(out / "soak.json");
  const auto report = nlohmann::json::parse(in);
  const std::vector<std::string> processes = {"server", "pod 0", "pod 1", "client 0", "client 1"};
  EXPECT_EQ(report["processes"].get<std::vector<std::string>>(), processes);
  ASSERT_GE(report["samples"].size(), 8u);
  size_t restarted_pod_running = 0;
  for (const auto& sample : report["samples"]) {
    for (const std::string& p : processes) {
      ASSERT_TRUE(sample["usage"][p].is_object()) << p << " gone at " << sample["minute"];
      EXPECT_GE(sample["usage"][p]["threads"].get<int>(), 1) << p;
      // A pod just restarted by the churn may be sampled before its main
      // (seen: 16 KB resident, the loader's pages), when it has not
      // written its heap yet: it is there, but not running yet.
      if (p == "pod 1" && !sample["usage"][p]["heap_kb"].is_number()) continue;
      restarted_pod_running += p == "pod 1";
      EXPECT_GT(sample["usage"][p]["rss_kb"].get<uint64_t>(), 1000u) << p;
      EXPECT_GT(sample["usage"][p]["descriptors"].get<int>(), 2) << p;
      // Each writes its heap in use: under its resident size.
      ASSERT_TRUE(sample["usage"][p]["heap_kb"].is_number()) << p;
      EXPECT_GT(sample["usage"][p]["heap_kb"].get<uint64_t>(), 100u) << p;
      EXPECT_LT(sample["usage"][p]["heap_kb"].get<uint64_t>(),
                sample["usage"][p]["rss_kb"].get<uint64_t>())
          << p;
    }
  }
  EXPECT_GT(restarted_pod_running, 0u) << "the restarted pod was checked running at least once";
  // Every quantity judged, the verdicts adding up to the report's, and the
  // exit code saying whether it passed.
  // Resident memory, heap in use, descriptors and threads of each (pod 1
  // restarts: not judged by trend), the server's also per session.
  ASSERT_EQ(report["trends"].size(), 4 * (processes.size() - 1) + 4);
  bool all_flat = true, any_leaking = false;
  for (const auto& trend : report["trends"]) {
    const std::string v = trend["verdict"].get<std::string>();
    EXPECT_TRUE(v == "flat" || v == "leaking" || v == "undecided") << v;
    EXPECT_LE(trend["slope_low"].get<double>(), trend["slope"].get<double>());
    EXPECT_GE(trend["slope_high"].get<double>(), trend["slope"].get<double>());
    all_flat &= v == "flat";
    any_leaking |= v == "leaking";
  }
  EXPECT_EQ(report["flat"].get<bool>(), all_flat);
  EXPECT_EQ(report["passed"].get<bool>(), !any_leaking);
  EXPECT_EQ(code == 0, report["passed"].get<bool>()) << "the exit code says the verdict";
  for (const char* file : {"soak.md", "soak.html", "client0/report.json", "client1/report.json"})
    EXPECT_TRUE(fs::exists(out / file)) << file;

  // Churn: sessions both ways and pod restarts both ways, each counted
  // once; the server saw every session that rendered join and every
  // session leave, and came back to its descriptors and threads.
  const auto& churn = report["churn"];
  ASSERT_TRUE(churn.is_object()) << report.dump();
  const auto count = [&](const char* key) { return churn[key].get<uint64_t>(); };
  EXPECT_GE(count("sessions"), 4u);
  EXPECT_EQ(count("sessions_failed"), 0u) << "see " << (out / "churn");
  EXPECT_EQ(count("sessions_bye") + count("sessions_killed"), count("sessions"));
  EXPECT_GE(count("sessions_bye"), 2u);
  EXPECT_GE(count("sessions_killed"), 1u);
  EXPECT_GE(count("pod_restarts"), 1u);
  EXPECT_LE(count("pod_restarts_killed"), count("pod_restarts"));
  // The two steady clients, the bye sessions (they rendered), and at most
  // every session joined; whoever joined left.
  EXPECT_GE(count("server_client_joins"), 2 + count("sessions_bye"));
  EXPECT_LE(count("server_client_joins"), 2 + count("sessions"));
  EXPECT_EQ(count("server_client_leaves"), count("server_client_joins"));
  // Both pods joined, and the restarted one each time (the last restart
  // may come as the soak ends).
  EXPECT_GE(count("server_pod_joins"), 1 + count("pod_restarts"));
  EXPECT_LE(count("server_pod_joins"), 2 + count("pod_restarts"));
  EXPECT_GE(count("server_pod_leaves"), count("pod_restarts") - 1);
  EXPECT_EQ(count("link_cuts"), 0u) << "no rig, no links to cut";
  EXPECT_LE(churn["descriptors_end"].get<int>(), churn["descriptors_start"].get<int>());
  EXPECT_LE(churn["threads_end"].get<int>(), churn["threads_start"].get<int>());
  uint64_t last_sessions = 0;
  for (const auto& sample : report["samples"]) {
    EXPECT_GE(sample["sessions"].get<uint64_t>(), last_sessions) << "sessions only grow";
    last_sessions = sample["sessions"].get<uint64_t>();
  }
  EXPECT_NE(test::readFile(out / "soak.md").find("Churn: "), std::string::npos);
  fs::remove_all(out);
}

// In a rig the churn also cuts pod 0's link (its end of the veth pair
// down for 5 s) and restores it; the sessions join through client 0's
// link and the restarted pod through its own. Every process lives through
// it, every cut is restored, and the rig's namespaces are gone afterwards.
TEST(Soak, ARigChurnsCutsAPodsLinkAndRestoresIt) {
  if (::geteuid() != 0) GTEST_SKIP() << "a rig needs root (network namespaces)";
  if (ipCommand().empty()) GTEST_SKIP() << "no ip command (Debian package iproute2)";
  const fs::path out = test::freshDir("soak_rig");
  const pid_t soak =
      startChurningSoak(out, {"--netns", "--clients", "1", "--soak-minutes", "0.75"});
  const int code = test::waitExit(soak, 240);
  const std::string log = test::readFile(out.string() + ".log");
  if (log.find("cannot build the rig") != std::string::npos)
    GTEST_SKIP() << "network namespaces are not permitted here: " << log;
  ASSERT_TRUE(code == 0 || code == 1) << log;
  std::ifstream in(out / "soak.json");
  const auto report = nlohmann::json::parse(in);
  EXPECT_EQ(code == 0, report["passed"].get<bool>()) << log;
  for (const auto& sample : report["samples"])
    for (const std::string p : {"server", "pod 0", "pod 1", "client 0"})
      ASSERT_TRUE(sample["usage"][p].is_object()) << p << " gone at " << sample["minute"];
  const auto& churn = report["churn"];
  const auto count = [&](const char* key) { return churn[key].get<uint64_t>(); };
  EXPECT_GE(count("link_cuts"), 1u) << churn.dump();
  EXPECT_EQ(count("link_restores"), count("link_cuts"));
  EXPECT_EQ(count("link_cut_failures"), 0u);
  EXPECT_EQ(count("sessions_failed"), 0u) << "see " << (out / "churn");
  EXPECT_GE(count("sessions_bye"), 1u);
  EXPECT_GE(count("sessions_killed"), 1u);
  EXPECT_GE(count("pod_restarts"), 1u);
  EXPECT_GE(count("server_pod_joins"), 1 + count("pod_restarts"));
  EXPECT_NE(test::readFile(out / "soak.md").find("cuts of pod 0's link"), std::string::npos);
  // The launcher has ended: its rig (hf<its pid>-...) with it.
  const FinishedProcess listed = runToEnd({ipCommand(), "netns", "list"}, 10000);
  EXPECT_EQ(listed.output.find("hf" + std::to_string(soak) + "-"), std::string::npos)
      << listed.output;
  fs::remove_all(out);
}

// heaptrack_print's account of what grew between two moments (--diff,
// --print-leaks), as heaptrack 1.4 writes it: each site's growth, its
// allocations, and the code that asked (not the standard library's frames
// the allocation passed through).
TEST(HeapProfile, TheAccountNamesTheSitesThatGrewAndTheCodeThatAsked) {
  const std::string printed = R"(reading file "end.gz" - please wait, this might take some time...
finished reading file, now analyzing data:

MEMORY LEAKS
1.02K leaked over 1 calls from
std::__new_allocator<>::allocate(unsigned long, void const*)
  at /usr/include/c++/12/bits/new_allocator.h:137
  in /srv/fusion_server
std::_Vector_base<>::_M_allocate(unsigned long)
  at /usr/include/c++/12/bits/stl_vector.h:378
1.02K leaked over 1 calls from:
    holofuse::Entry& std::deque<>::emplace_back<>(holofuse::Entry&&)
      at /usr/include/c++/12/bits/deque.tcc:176
    std::vector<>::push_back(void* const&)
      at /usr/include/c++/12/bits/stl_vector.h:1287
      in /srv/fusion_server
    holofuse::Sessions::add(int)
      at /src/sessions.cpp:42
    main
      at /src/main.cpp:8

483.33K leaked over 118 calls from
holofuse::Sessions::keep(int)
  at /src/sessions.cpp:6
  in /srv/fusion_server
483.33K leaked over 118 calls from:
    main
      at /src/main.cpp:8
      in /srv/fusion_server

-2.50K leaked over -3 calls from
holofuse::Frame::free()
  at /src/frame.cpp:3
  in /srv/fusion_server


total runtime: 1.22s.
calls to allocation functions: 119 (97/s)
peak heap memory consumption: 484.35K
total memory leaked: 482.85Kheaptrack stats:
)";
  const HeapGrowth growth = parseHeaptrackGrowth(printed);
  EXPECT_DOUBLE_EQ(growth.total_bytes, 482850);
  ASSERT_EQ(growth.sites.size(), 2u) << "what shrank is not growth";
  EXPECT_DOUBLE_EQ(growth.sites[0].bytes, 483330);
  EXPECT_EQ(growth.sites[0].calls, 118u);
  EXPECT_EQ(growth.sites[0].function, "holofuse::Sessions::keep(int)");
  EXPECT_EQ(growth.sites[0].location, "/src/sessions.cpp:6");
  EXPECT_EQ(growth.sites[1].function, "holofuse::Sessions::add(int)")
      << "past the std frames, those that return a type of ours too";
  EXPECT_EQ(growth.sites[1].location, "/src/sessions.cpp:42");
  EXPECT_DOUBLE_EQ(heaptrackBytes("12.5M"), 12.5e6);
  EXPECT_DOUBLE_EQ(heaptrackBytes("512B"), 512);
  EXPECT_EQ(parseHeaptrackGrowth("no leaks section\n").sites.size(), 0u);
}

// A real trace: a program's heap grows by 1 MiB in one function between
// two marks, and heaptrack, read by HeapProfile, names that function and
// that much. Each mark waits for the program to say its work is done.
TEST(HeapProfile, AProgramsGrowthBetweenTwoMarksIsNamedByItsFunction) {
  const fs::path folder = test::freshDir("heap_profile");
  auto profile = HeapProfile::find(folder.string());
  if (!profile.isOk()) GTEST_SKIP() << profile.status().message();
  ChildPipes pipes;
  SpawnOptions options;
  options.log_path = folder.string() + "/grower.log";
  auto grower = spawnProcess(profile.value().wrap({std::string(HOLOFUSE_BIN_DIR) + "/heap_grower"}),
                             options, &pipes);
  ASSERT_TRUE(grower.isOk()) << grower.status().message();
  const auto ask = [&](const std::string& line) {
    const std::string asked = line + "\n";
    ASSERT_EQ(::write(pipes.to_child, asked.data(), asked.size()),
              static_cast<ssize_t>(asked.size()));
    std::string answer;
    char c = 0;
    while (::read(pipes.from_child, &c, 1) == 1 && c != '\n') answer += c;
    ASSERT_EQ(answer, "done") << test::readFile(options.log_path);
  };
  ask("settle");
  ASSERT_TRUE(profile.value().mark("warm").isOk());
  ask("grow");
  ASSERT_TRUE(profile.value().mark("end").isOk());
  ::close(pipes.to_child);
  ::close(pipes.from_child);
  EXPECT_EQ(waitProcess(*grower, 30000), std::optional<int>(0));
  const auto growth = profile.value().growth("warm", "end");
  ASSERT_TRUE(growth.isOk()) << growth.status().message();
  ASSERT_FALSE(growth.value().sites.empty()) << test::readFile(growth.value().account);
  const HeapGrowthSite& top = growth.value().sites.front();
  EXPECT_NE(top.function.find("keepSessionState"), std::string::npos) << top.function;
  EXPECT_NEAR(top.bytes, 256.0 * 4096, 256.0 * 4096 * 0.01);
  EXPECT_EQ(top.calls, 256u);
  EXPECT_NEAR(growth.value().total_bytes, 256.0 * 4096, 256.0 * 4096 * 0.05);
  EXPECT_NE(top.location.find("heap_grower.cpp"), std::string::npos) << top.location;
}

}  // namespace
}  // namespace holofuse::deploy
