// The viewer's overlays (BlendSettings::overlay, blend.frag.glsl): one
// pod's seams, geodesic distances and visibility as the field passes left
// them, drawn the same whatever the blend mode.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <vector>

#include "field_scenes.h"
#include "render_client/renderer.h"

namespace holofuse::render {
namespace {

using test::context;
using test::syntheticScene;
using test::viewImages;

// blend.frag.glsl's overlay colours, in 8 bits.
constexpr int kSeam[3] = {255, 0, 0};
constexpr int kRampAtZero[3] = {0, 0, 112};  // distanceRamp(0): at a seam

bool colourIs(const Image8& image, size_t pixel, const int (&rgb)[3], int slack = 1) {
  for (int c = 0; c < 3; ++c) {
    if (std::abs(static_cast<int>(image.pixels[4 * pixel + c]) - rgb[c]) > slack) return false;
  }
  return true;
}

bool onSubject(const Image8& image, size_t pixel) { return image.pixels[4 * pixel + 3] == 255; }

class Overlays : public ::testing::Test {
 protected:
  Overlays() : scene_(syntheticScene(4, 160, 120, 4)), renderer_(context(), 96, 72) {
    renderer_.setMesh(scene_.mesh);
    renderer_.setViews(viewImages(scene_));
  }

  Image8 render(BlendMode mode, Overlay overlay, uint32_t pod, int eye) {
    BlendSettings settings;
    settings.mode = mode;
    settings.overlay = overlay;
    settings.overlay_pod = pod;
    renderer_.render(scene_.views[static_cast<size_t>(eye)].camera, settings);
    return renderer_.finishRender();
  }

  size_t pixels() const { return size_t{96} * 72; }

  test::Scene scene_;
  Renderer renderer_;
};

// Opaque over the subject, the geodesic and visibility overlays show the
// fields, not the blend: every mode draws the same picture (modes normal
// and fragment run the field passes for the overlay's sake).
TEST_F(Overlays, ShowThePodsFieldsTheSameInEveryMode) {
  for (const Overlay overlay : {Overlay::kGeodesics, Overlay::kVisibility}) {
    SCOPED_TRACE(overlayName(overlay));
    const Image8 montage = render(BlendMode::kMontage4D, overlay, 1, 0);
    const Image8 plain = render(BlendMode::kMontage4D, Overlay::kNone, 1, 0);
    EXPECT_FALSE(montage.pixels == plain.pixels) << "the overlay draws something";
    for (const BlendMode mode : {BlendMode::kNormal, BlendMode::kHoloportation,
                                 BlendMode::kFragment, BlendMode::kMontage4D}) {
      EXPECT_TRUE(render(mode, overlay, 1, 0).pixels == montage.pixels) << blendModeName(mode);
    }
    std::set<uint32_t> colours;
    for (size_t p = 0; p < pixels(); ++p) {
      if (!onSubject(montage, p)) continue;
      colours.insert(uint32_t{montage.pixels[4 * p]} << 16 |
                     uint32_t{montage.pixels[4 * p + 1]} << 8 | montage.pixels[4 * p + 2]);
    }
    EXPECT_GT(colours.size(), 8u) << "a field, not one flat colour";
  }
}

// Seen from pod 0's own camera, pod 0 sees most of the subject;
// pod 2, across the ring, little of it.
TEST_F(Overlays, VisibilityIsGreenWhereThePodSeesTheSurface) {
  auto seenShare = [&](uint32_t pod) {
    const Image8 image = render(BlendMode::kNormal, Overlay::kVisibility, pod, 0);
    size_t subject = 0, seen = 0;
    for (size_t p = 0; p < pixels(); ++p) {
      if (!onSubject(image, p)) continue;
      ++subject;
      seen += image.pixels[4 * p + 1] > 150 && image.pixels[4 * p] < 80;
    }
    EXPECT_GT(subject, pixels() / 20) << "the subject is in view";
    return static_cast<double>(seen) / static_cast<double>(std::max<size_t>(subject, 1));
  };
  // Measured 0.77 and 0: the silhouette's rim and the limbs' sides are
  // edge-on to the pod, or behind another limb.
  EXPECT_GT(seenShare(0), 0.6);
  EXPECT_LT(seenShare(2), 0.1);
}

// A seam triangle's corners are the geodesics' seeds: wherever the seams
// overlay paints red, the distance overlay shows distance 0.
TEST_F(Overlays, SeamTrianglesLieAtGeodesicDistanceZero) {
  const Image8 seams = render(BlendMode::kMontage4D, Overlay::kSeams, 1, 1);
  const Image8 distances = render(BlendMode::kMontage4D, Overlay::kGeodesics, 1, 1);
  size_t subject = 0, red = 0, at_zero = 0;
  for (size_t p = 0; p < pixels(); ++p) {
    if (!onSubject(seams, p)) continue;
    ++subject;
    if (!colourIs(seams, p, kSeam, 0)) continue;
    ++red;
    at_zero += colourIs(distances, p, kRampAtZero);
  }
  EXPECT_GT(red, subject / 100) << "pod 1 has seams in view";
  EXPECT_LT(red, subject * 6 / 10);
  EXPECT_EQ(at_zero, red);
  // The seams are the pod's, not the mode's.
  EXPECT_TRUE(render(BlendMode::kHoloportation, Overlay::kSeams, 1, 1).pixels !=
              render(BlendMode::kHoloportation, Overlay::kNone, 1, 1).pixels);
}

// A pod the client has no camera of has no fields: no seams are drawn,
// and it sees nothing.
TEST_F(Overlays, APodNotInTheArraysShowsNoField) {
  EXPECT_TRUE(render(BlendMode::kMontage4D, Overlay::kSeams, 7, 0).pixels ==
              render(BlendMode::kMontage4D, Overlay::kNone, 7, 0).pixels);
  const Image8 visibility = render(BlendMode::kNormal, Overlay::kVisibility, 7, 0);
  for (size_t p = 0; p < pixels(); ++p) {
    if (onSubject(visibility, p)) {
      EXPECT_LT(visibility.pixels[4 * p + 1], 10) << "pixel " << p;
    }
  }
}

}  // namespace
}  // namespace holofuse::render
