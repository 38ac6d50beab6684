// The live judge's link: what the client sends survives the trip, and a
// judge that misbehaves (ends, answers garbage, cannot start) is an error
// that names it, never a hang or a crash of the client.
#include <gtest/gtest.h>

#include "render_client/frame_judge.h"

namespace holofuse::render {
namespace {

Camera someView() {
  Camera view = lookAtCamera(1000, {0.3, -1.2, 2.5}, {0, 0, 0}, {0, -1, 0}, 320, 240, 55.0);
  view.distortion = {0.01, -0.002, 0, 0, 0.0001};
  view.skew = 0.25;
  return view;
}

TEST(FrameJudge, ARequestComesBackAsItWasSent) {
  const JudgeRequest sent{"/tmp/out dir/frames/frame_000003.png", 1234567890123ull, someView()};
  const auto got = decodeJudgeRequest(encodeJudgeRequest(sent));
  ASSERT_TRUE(got.isOk()) << got.status().message();
  EXPECT_EQ(got->picture, sent.picture);
  EXPECT_EQ(got->frame_id, sent.frame_id);
  EXPECT_EQ(got->view.id, sent.view.id);
  EXPECT_EQ(got->view.width, 320u);
  EXPECT_EQ(got->view.height, 240u);
  // Bit for bit: the judge renders the truth from exactly this camera.
  EXPECT_EQ(got->view.fx, sent.view.fx);
  EXPECT_EQ(got->view.cy, sent.view.cy);
  EXPECT_EQ(got->view.skew, sent.view.skew);
  EXPECT_EQ(got->view.distortion, sent.view.distortion);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(got->view.translation[c], sent.view.translation[c]);
    for (int r = 0; r < 3; ++r) EXPECT_EQ(got->view.rotation[c][r], sent.view.rotation[c][r]);
  }
}

TEST(FrameJudge, AnswersComeBackAsTheyWereSent) {
  const auto judged =
      decodeJudgeAnswer(encodeJudgeAnswer({report::FrameQuality{31.25, 0.875}, ""}));
  ASSERT_TRUE(judged.isOk());
  ASSERT_TRUE(judged->quality);
  EXPECT_EQ(judged->quality->psnr_db, 31.25);
  EXPECT_EQ(judged->quality->ssim, 0.875);
  const auto nothing = decodeJudgeAnswer(encodeJudgeAnswer({}));
  ASSERT_TRUE(nothing.isOk());
  EXPECT_FALSE(nothing->quality);
  EXPECT_TRUE(nothing->error.empty());
  const auto failed = decodeJudgeAnswer(encodeJudgeAnswer({std::nullopt, "frame 3: 640x480"}));
  ASSERT_TRUE(failed.isOk());
  EXPECT_EQ(failed->error, "frame 3: 640x480");
  const auto garbage = decodeJudgeRequest("{\"picture\": 3}");
  ASSERT_FALSE(garbage.isOk());
  EXPECT_NE(garbage.status().message().find("judge request"), std::string::npos)
      << garbage.status().message();
}

// A judge that answers each line with its frame id as the PSNR: the
// answers arrive in order, one per request.
TEST(FrameJudge, EachRequestGetsItsOwnAnswerInOrder) {
  auto judge = FrameJudge::start(
      "while read -r line; do id=${line#*\\\"frame_id\\\":}; id=${id%%,*}; "
      "echo \"{\\\"quality\\\":{\\\"psnr_db\\\":$id,\\\"ssim\\\":0.5}}\"; done");
  ASSERT_TRUE(judge.isOk()) << judge.status().message();
  for (uint64_t id : {7u, 8u, 42u}) {
    const auto answer = judge->judge({"frame.png", id, someView()});
    ASSERT_TRUE(answer.isOk()) << answer.status().message();
    ASSERT_TRUE(answer->quality) << "frame " << id;
    EXPECT_EQ(answer->quality->psnr_db, static_cast<double>(id));
  }
}

TEST(FrameJudge, AJudgeThatEndsOrTalksNonsenseIsAnErrorForGood) {
  auto ends = FrameJudge::start("read -r line; exit 0");
  ASSERT_TRUE(ends.isOk());
  const auto first = ends->judge({"frame.png", 1, someView()});
  ASSERT_FALSE(first.isOk());
  EXPECT_NE(first.status().message().find("ended without answering"), std::string::npos)
      << first.status().message();
  EXPECT_FALSE(ends->judge({"frame.png", 2, someView()}).isOk()) << "gone stays gone";

  auto babbles = FrameJudge::start("read -r line; echo 'PSNR 30 dB'; cat >/dev/null");
  ASSERT_TRUE(babbles.isOk());
  const auto nonsense = babbles->judge({"frame.png", 1, someView()});
  ASSERT_FALSE(nonsense.isOk());
  EXPECT_NE(nonsense.status().message().find("PSNR 30 dB"), std::string::npos)
      << nonsense.status().message();
}

// The client renders on when its judge hangs: a judge that reads and never
// answers is gone once the answer is overdue, and stays gone.
TEST(FrameJudge, AJudgeThatNeverAnswersIsGoneAfterItsTimeout) {
  auto silent = FrameJudge::start("cat >/dev/null", 200);
  ASSERT_TRUE(silent.isOk());
  const auto answer = silent->judge({"frame.png", 1, someView()});
  ASSERT_FALSE(answer.isOk());
  EXPECT_NE(answer.status().message().find("did not answer within 200 ms"), std::string::npos)
      << answer.status().message();
  EXPECT_FALSE(silent->judge({"frame.png", 2, someView()}).isOk()) << "gone stays gone";
}

TEST(FrameJudge, AJudgeThatCannotStartIsNamed) {
  EXPECT_FALSE(FrameJudge::start("").isOk());
  // The shell starts; the program it names does not: the first frame says so.
  auto missing = FrameJudge::start("/nonexistent/holofuse_judge --scene x");
  ASSERT_TRUE(missing.isOk());
  const auto answer = missing->judge({"frame.png", 1, someView()});
  ASSERT_FALSE(answer.isOk());
  EXPECT_NE(answer.status().message().find("/nonexistent/holofuse_judge"), std::string::npos)
      << answer.status().message();
}

}  // namespace
}  // namespace holofuse::render
