// An evaluation plan and its scoring: what one row of the evaluation
// renders (a pose per view, the camera it leaves out, the truth it is
// compared with) and the rendering and comparison of every mode over it.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/eta.h"
#include "base/statistics.h"
#include "base/status.h"
#include "eval/leave_one_out.h"
#include "eval_pipeline.h"
#include "geometry/camera.h"
#include "gpu/vulkan_context.h"

namespace holofuse::eval {

// The medians and 95th percentiles the evaluation reports.
inline double median(const std::vector<double>& v) { return percentile(v, 50); }
inline double percentile95(const std::vector<double>& v) { return percentile(v, 95); }

// A scene to evaluate, from the synthetic library or from a dataset: its
// cameras' reported poses, and every frame as the client would receive it.
struct SceneInput {
  std::vector<Camera> reported;
  std::vector<FrameData> frames;
};

// One view a row of the evaluation renders on every frame and compares
// with its truth.
struct ViewSequence {
  Camera pose;  // rendered from, at its size, to compare pixel for pixel
  // Before the scene's viewpoint jump, the pose rendered from instead (and
  // nothing compared): the jump then lands on pose.
  std::optional<Camera> pose_before_jump;
  // The camera whose image takes no part (not in the blend, the vote, the
  // seams or the global visibility), and whose hull without it is used
  // where one was carved; -1: every camera takes part.
  int left_out = -1;
  // The truth: camera truth's true image, or novel pose truth's
  // (FrameData::novel_truth).
  int truth = 0;
  bool novel_truth = false;
  std::string name;  // "camera 3", "novel 1": image file names and progress
};

// What one row renders and compares with: one sequence per view.
struct EvaluationPlan {
  std::string what;  // "held out camera", "camera kept", "novel view": for progress lines
  std::vector<ViewSequence> sequences;
};

// The truth a sequence's frame is compared with: colour and mask.
std::pair<const Image8&, const Image8&> truthOf(const FrameData& frame,
                                                const ViewSequence& sequence);

// Leave-one-camera-out (or, with keep_camera, each chosen camera's pose
// with its image kept in): the chosen cameras' poses, each compared with
// its own image; under a viewpoint jump of jump_degrees along the ring,
// the first half of the frames render from the camera the jump starts at.
EvaluationPlan cameraPlan(const EvalOptions& options, const SceneInput& input, double jump_degrees,
                          bool keep_camera);

// Novel views: each pose seen with every camera blended, compared with the
// scene's truth there (frames' novel_truth, in poses' order).
EvaluationPlan novelPlan(const std::vector<Camera>& poses);

// The whole run's progress over its parts (each scene's leave-one-out row,
// its camera-kept row, each novel view): every line the caller's callback
// gets ends with the part it is in and the time the run has left, at the
// pace so far counted in shares of parts.
class RunProgress {
 public:
  RunProgress(std::function<void(const std::string&)> sink, size_t parts)
      : sink_(std::move(sink)), parts_(parts) {}
  // A line from the current part, of which `part_done` (0..1) is done.
  void say(const std::string& line, double part_done);
  void partDone() { ++parts_done_; }

 private:
  std::function<void(const std::string&)> sink_;
  size_t parts_ = 1, parts_done_ = 0;
  Eta eta_;
};

// Every mode, every sequence of the plan, every frame of one scene, into
// result's modes (and its montage4d agreement); with options.save_images
// the pictures go under options.out_dir/images. An error names the image
// that could not be written.
Status evaluateModes(const EvalOptions& options, gpu::VulkanContext& context,
                     const SceneInput& input, const EvaluationPlan& plan, SceneResult& result,
                     RunProgress& progress);

}  // namespace holofuse::eval
