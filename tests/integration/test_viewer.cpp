// The client's viewer window (render_client --window on) under Xvfb with
// lavapipe: a real X server, a real swapchain, input by xdotool and a
// screenshot by ImageMagick's import.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "loop_test.h"

namespace {

using namespace holofuse::test;

// A display number no X server holds.
int freeDisplay() {
  for (int n = 90 + static_cast<int>(getpid() % 50);; ++n) {
    if (!fs::exists("/tmp/.X11-unix/X" + std::to_string(n)) &&
        !fs::exists("/tmp/.X" + std::to_string(n) + "-lock"))
      return n;
  }
}

// An Xvfb server of 320x240 on a free display (its log in out), once it
// serves; 0 if it did not start.
pid_t startXvfb(const fs::path& out, std::string* display) {
  *display = ":" + std::to_string(freeDisplay());
  const pid_t x =
      spawn({"/usr/bin/Xvfb", *display, "-screen", "0", "320x240x24", "-nolisten", "tcp"},
            out / "xvfb.log");
  if (!waitFor([&] { return fs::exists("/tmp/.X11-unix/X" + display->substr(1)); })) return 0;
  return x;
}

// Pixels of a BGR(A) image that are not black.
size_t litPixels(const cv::Mat& image, int x0, int y0, int w, int h) {
  size_t lit = 0;
  for (int y = y0; y < y0 + h && y < image.rows; ++y) {
    for (int x = x0; x < x0 + w && x < image.cols; ++x) {
      const uchar* p = image.ptr<uchar>(y) + x * image.channels();
      lit += p[0] > 8 || p[1] > 8 || p[2] > 8;
    }
  }
  return lit;
}

// Pixels a written RGBA picture covers (alpha not 0).
size_t coverage(const cv::Mat& picture) {
  if (picture.channels() != 4) return 0;
  size_t covered = 0;
  for (int y = 0; y < picture.rows; ++y)
    for (int x = 0; x < picture.cols; ++x) covered += picture.at<cv::Vec4b>(y, x)[3] != 0;
  return covered;
}

// The window shows the pictures the client renders (the screenshot lights
// about the pixels the written frame covers, at the window's place, and
// nothing beside it); Escape closes it, the client ends with 0, saying
// so, and the server sees it leave. Keys move the view, step the mode and
// keep a screenshot.
TEST(Viewer, AWindowShowsThePicturesKeysSteerItAndEscapeClosesIt) {
  for (const char* tool : {"/usr/bin/Xvfb", "/usr/bin/xdotool", "/usr/bin/import"})
    ASSERT_TRUE(fs::exists(tool)) << tool << " is missing: ./holofuse test installs it";
  const fs::path out = freshDir("viewer");
  std::string display;
  const pid_t x = startXvfb(out, &display);
  ASSERT_GT(x, 0) << readFile(out / "xvfb.log");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const pid_t pods[] = {startSmallPod(endpoint, 0, 2, out), startSmallPod(endpoint, 1, 2, out)};
  const pid_t client = spawn(
      {"/usr/bin/env", "DISPLAY=" + display, kBin + "/render_client", "--server", endpoint, "--out",
       (out / "client").string(), "--frames", "100000", "--size", "160x120", "--window", "on"},
      out / "client.log");
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "client") >= 4; }, 120))
      << readFile(out / "client.log");
  EXPECT_TRUE(logSays(out / "client.log", "[client] the pictures show in a window too"))
      << readFile(out / "client.log");
  auto press = [&](const std::string& key) {
    const pid_t xdotool = spawn({"/usr/bin/env", "DISPLAY=" + display, "/usr/bin/xdotool", "search",
                                 "--name", "holofuse client", "windowfocus", "--sync", "key", key},
                                out / "xdotool.log");
    EXPECT_EQ(waitExit(xdotool, 60), 0) << key << ": " << readFile(out / "xdotool.log");
  };
  // P hides the live panel, which the pictures below are compared
  // without; it comes back at the end.
  press("p");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] live panel off"); }))
      << readFile(out / "client.log");

  // The screen once the client has rendered two more pictures.
  auto screenAfterTwoPictures = [&](const std::string& name) {
    const size_t pictures = picturesIn(out / "client");
    EXPECT_TRUE(waitFor([&] { return picturesIn(out / "client") >= pictures + 2; }, 120));
    const fs::path file = out / (name + ".png");
    EXPECT_EQ(waitExit(spawn({"/usr/bin/env", "DISPLAY=" + display, "/usr/bin/import", "-window",
                              "root", file.string()},
                             out / "import.log"),
                       60),
              0)
        << readFile(out / "import.log");
    return cv::imread(file.string(), cv::IMREAD_COLOR);
  };
  const cv::Mat screen = screenAfterTwoPictures("screen");
  ASSERT_FALSE(screen.empty());
  // The written frames' coverage (alpha), which the window shows over
  // black: the screen shows one of them, and the orbit turns the subject
  // from frame to frame.
  size_t fewest = SIZE_MAX, most = 0;
  for (const auto& entry : fs::directory_iterator(out / "client" / "frames")) {
    if (entry.path().extension() != ".png") continue;
    const size_t covered = coverage(cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED));
    fewest = std::min(fewest, covered);
    most = std::max(most, covered);
  }
  ASSERT_GT(fewest, 500u) << "the subject is in every picture";
  // The window sits at the screen's origin (no window manager), its size
  // the client's.
  const size_t in_window = litPixels(screen, 0, 0, 160, 120);
  EXPECT_GT(in_window, fewest / 2) << "the subject drawn in the window";
  EXPECT_LT(in_window, 2 * most + 200);
  EXPECT_EQ(litPixels(screen, 160, 0, 160, 240) + litPixels(screen, 0, 120, 160, 120), 0u)
      << "nothing drawn outside the window";

  // Keys steer it: 1 sits at pod 0's camera, M steps to mode fragment, S
  // keeps the next picture; the view from pod 0 is another picture than
  // the orbit's.
  press("1");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] view pod:0"); }))
      << readFile(out / "client.log");
  press("m");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] mode fragment"); }))
      << readFile(out / "client.log");
  press("s");
  const fs::path kept = out / "client" / "screenshots" / "screenshot_001.png";
  ASSERT_TRUE(waitFor([&] { return fs::exists(kept); })) << readFile(out / "client.log");
  const cv::Mat from_pod = screenAfterTwoPictures("screen_pod0");
  ASSERT_FALSE(from_pod.empty());
  cv::Mat difference;
  cv::absdiff(screen(cv::Rect(0, 0, 160, 120)), from_pod(cv::Rect(0, 0, 160, 120)), difference);
  EXPECT_GT(litPixels(difference, 0, 0, 160, 120), 500u) << "pod 0's view is another picture";
  EXPECT_GT(coverage(cv::imread(kept.string(), cv::IMREAD_UNCHANGED)), 500u)
      << "the kept picture holds the subject";

  // F: each camera's weight as its colour; saturated pixels, which the
  // subject's own colours hold few of, fill the window.
  auto saturated = [](const cv::Mat& image) {
    size_t n = 0;
    for (int y = 0; y < 120; ++y) {
      for (int x = 0; x < 160; ++x) {
        const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
        n += std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}) > 150;
      }
    }
    return n;
  };
  press("f");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "overlay: cameras"); }))
      << readFile(out / "client.log");
  const cv::Mat overlaid = screenAfterTwoPictures("screen_overlay");
  ASSERT_FALSE(overlaid.empty());
  EXPECT_GT(saturated(overlaid), 2 * saturated(from_pod) + fewest / 4)
      << "the overlay colours the subject by camera";

  // From pod 1's camera, F again: pod 0's seams in red; C: pod 1's own
  // (where its view of the subject is cut by an occluding limb, which
  // pod 1 sees in every frame).
  auto red = [](const cv::Mat& image) {
    size_t n = 0;
    for (int y = 0; y < 120; ++y) {
      for (int x = 0; x < 160; ++x) {
        const cv::Vec3b p = image.at<cv::Vec3b>(y, x);  // BGR
        n += p[2] > 220 && p[1] < 40 && p[0] < 40;
      }
    }
    return n;
  };
  press("2");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] view pod:1"); }))
      << readFile(out / "client.log");
  press("f");
  press("c");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "overlay: seams of pod 1"); }))
      << readFile(out / "client.log");
  const cv::Mat seams = screenAfterTwoPictures("screen_seams");
  ASSERT_FALSE(seams.empty());
  EXPECT_GT(red(seams), 3 * red(from_pod) + 10) << "pod 1's seam triangles drawn in red";

  // T: sketchy stippling (over the seams overlay too), the subject in grey.
  press("t");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "stylisation: stipple"); }))
      << readFile(out / "client.log");
  const cv::Mat stippled = screenAfterTwoPictures("screen_stipple");
  ASSERT_FALSE(stippled.empty());
  size_t lit = 0, grey = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const cv::Vec3b p = stippled.at<cv::Vec3b>(y, x);
      if (p[0] < 8 && p[1] < 8 && p[2] < 8) continue;
      ++lit;
      grey += p[0] == p[1] && p[1] == p[2];
    }
  }
  EXPECT_GT(lit, fewest / 4) << "the stippled subject is drawn";
  EXPECT_GT(grey, lit * 9 / 10) << "in grey";

  // P again: the live panel in the top-left corner (its box, figures and
  // stage bar); the frames written never have it.
  press("p");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] live panel on"); }))
      << readFile(out / "client.log");
  const cv::Mat panel = screenAfterTwoPictures("screen_panel");
  ASSERT_FALSE(panel.empty());
  cv::Mat panel_strip;
  cv::absdiff(seams(cv::Rect(0, 0, 160, 24)), panel(cv::Rect(0, 0, 160, 24)), panel_strip);
  cv::cvtColor(panel_strip, panel_strip, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(panel_strip > 40), 300) << "the panel drawn";

  // M three times more: mode layered (protocol 1.10), which the server
  // hears at once and answers with texture layers in place of the camera
  // images; then M once more back to normal, and camera images again.
  // Each step: the client says the mode, the server what it now sends,
  // and the client what the frames carry once they change.
  auto stepsTo = [&](int steps, const std::string& mode, const std::string& sent,
                     const std::string& rendered) {
    for (int step = 0; step < steps; ++step) press("m");
    EXPECT_TRUE(waitFor([&] { return logSays(out / "client.log", "[client] mode " + mode); }))
        << readFile(out / "client.log");
    EXPECT_TRUE(waitFor([&] {
      return logSays(out / "server.log", "takes from the next frame: " + sent);
    })) << readFile(out / "server.log");
    EXPECT_TRUE(waitFor([&] {
      return logSays(out / "client.log", "[client] the frames carry " + rendered);
    })) << readFile(out / "client.log");
  };
  stepsTo(3, "layered", "texture layers", "texture layers: rendering them layered");
  const cv::Mat layered = screenAfterTwoPictures("screen_layered");
  ASSERT_FALSE(layered.empty());
  EXPECT_GT(litPixels(layered, 0, 24, 160, 96), fewest / 4) << "the layered subject is drawn";
  stepsTo(1, "normal", "camera images", "camera images: rendering them normal");

  press("Escape");
  EXPECT_EQ(waitExit(client, 60), 0) << readFile(out / "client.log");
  EXPECT_TRUE(logSays(out / "client.log", "dropped (closed by the user)"))
      << readFile(out / "client.log");
  EXPECT_TRUE(waitFor([&] {
    return logSays(out / "server.log", "the client's window was closed");
  })) << readFile(out / "server.log");
  for (pid_t pod : pods) kill(pod, SIGTERM);
  kill(server, SIGTERM);
  for (pid_t pod : pods) waitExit(pod, 60);
  waitExit(server, 60);
  kill(x, SIGTERM);
  waitExit(x, 60);
  if (!::testing::Test::HasFailure()) fs::remove_all(out);
}

// A replay shows in the window as the live loop does (the launcher passes
// --window on to its client); without a display the client says so in
// one line and renders headless.
TEST(Viewer, AReplayShowsInTheWindowAndWithoutADisplayRendersHeadless) {
  const fs::path out = freshDir("viewer_replay");
  const fs::path recording = out / "recording";
  const pid_t live = spawn({"/usr/bin/env", "-u", "DISPLAY", kBin + "/holofuse_loop", "--pods", "2",
                            "--frames", "4", "--fps", "8", "--size", "160x120", "--out",
                            (out / "live").string(), "--record", recording.string()},
                           out / "live.log");
  ASSERT_EQ(waitExit(live, 240), 0) << readFile(out / "live.log");
  std::string display;
  const pid_t x = startXvfb(out, &display);
  ASSERT_GT(x, 0) << readFile(out / "xvfb.log");
  auto replay = [&](const std::vector<std::string>& env, const std::string& name) {
    std::vector<std::string> command = {"/usr/bin/env"};
    command.insert(command.end(), env.begin(), env.end());
    command.insert(command.end(),
                   {kBin + "/holofuse_loop", "--replay", recording.string(), "--speed", "max",
                    "--window", "on", "--out", (out / name).string()});
    EXPECT_EQ(waitExit(spawn(command, out / (name + ".log")), 240), 0)
        << readFile(out / (name + ".log"));
    return readFile(out / name / "logs" / "client.log");
  };
  const std::string shown = replay({"DISPLAY=" + display}, "shown");
  EXPECT_NE(shown.find("[client] the pictures show in a window too"), std::string::npos) << shown;
  EXPECT_NE(shown.find("[client] window: "), std::string::npos) << shown;
  const std::string headless = replay({"-u", "DISPLAY"}, "headless");
  EXPECT_NE(headless.find("[client] no window: "), std::string::npos) << headless;
  EXPECT_NE(headless.find("; rendering headless"), std::string::npos) << headless;
  EXPECT_EQ(headless.find("[client] window: "), std::string::npos) << headless;
  // At max speed a newer mesh may supersede one: each rendered frames.
  EXPECT_GT(readJson(out / "shown" / "report.json")["frames_rendered"].get<int>(), 0);
  EXPECT_GT(readJson(out / "headless" / "report.json")["frames_rendered"].get<int>(), 0);
  kill(x, SIGTERM);
  waitExit(x, 60);
  if (!::testing::Test::HasFailure()) fs::remove_all(out);
}

}  // namespace
