// Quality metrics against values published for a standard test image,
// against values computed by an independent implementation (scikit-image,
// tests/eval/reference_metrics.py) on images both sides build from the same
// integer formulas, plus the properties the masked evaluation relies on.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "eval/leave_one_out.h"
#include "metrics/image_metrics.h"

namespace holofuse::metrics {
namespace {

constexpr int kW = 64, kH = 48;

using Grey = std::vector<int>;

Grey base() {
  Grey a(kW * kH);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) a[y * kW + x] = (x * 7 + y * 13 + ((x * y) % 17) * 5) % 256;
  }
  return a;
}

Grey noisy(const Grey& a) {
  int64_t state = 12345;
  Grey b = a;
  for (int i = 0; i < kW * kH; ++i) {
    state = (state * 1103515245 + 12345) % (int64_t{1} << 31);
    b[i] = std::clamp(a[i] + static_cast<int>((state >> 16) % 41) - 20, 0, 255);
  }
  return b;
}

Grey blurred(const Grey& a) {
  Grey b = a;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      int s = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx)
          s += a[std::clamp(y + dy, 0, kH - 1) * kW + std::clamp(x + dx, 0, kW - 1)];
      }
      b[y * kW + x] = s / 9;
    }
  }
  return b;
}

Grey shifted(const Grey& a) {
  Grey b = a;
  for (int y = 0; y < kH; ++y) {
    for (int x = 1; x < kW; ++x) b[y * kW + x] = a[y * kW + x - 1];
  }
  return b;
}

Grey rescaled(const Grey& a) {
  Grey b = a;
  for (int& v : b) v = (v * 4 + 100) / 5;
  return b;
}

Image8 rgb(const Grey& g) {
  Image8 image(kW, kH, 3);
  for (size_t i = 0; i < g.size(); ++i) {
    for (int c = 0; c < 3; ++c) image.pixels[i * 3 + c] = static_cast<uint8_t>(g[i]);
  }
  return image;
}

struct Reference {
  const char* name;
  Grey (*make)(const Grey&);
  double ssim, psnr;
};

TEST(Metrics, MatchScikitImageOnFourDistortions) {
  // /usr/bin/python3 tests/eval/reference_metrics.py (scikit-image 0.19.3,
  // gaussian_weights, sigma 1.5, population covariance, data_range 255).
  const Reference references[] = {{"noisy", noisy, 0.9668327595, 26.8974668366},
                                  {"blurred", blurred, 0.4739344466, 13.6778094884},
                                  {"shifted", shifted, 0.2534724830, 10.1495011386},
                                  {"rescaled", rescaled, 0.9733803951, 24.0555336231}};
  const Grey a = base();
  const Image8 everywhere(kW, kH, 1, 255);
  for (const auto& r : references) {
    const ImageQuality q = compareInMask(rgb(r.make(a)), rgb(a), everywhere);
    EXPECT_NEAR(q.ssim, r.ssim, 1e-8) << r.name;
    EXPECT_NEAR(q.psnr_db, r.psnr, 1e-8) << r.name;
    EXPECT_NEAR(q.rmse_percent,
                100.0 * std::sqrt(255.0 * 255.0 / std::pow(10.0, r.psnr / 10.0)) / 255.0, 1e-8);
    EXPECT_EQ(q.pixels, size_t{kW * kH});
  }
}

// NumPy's legacy normal generator (np.random.seed, np.random.randn):
// MT19937 seeded as std::mt19937 seeds it, 53-bit doubles from two draws,
// and Marsaglia's polar method, which yields the pair's second value first.
class LegacyNumpyNormal {
 public:
  explicit LegacyNumpyNormal(uint32_t seed) : twister_(seed) {}
  double next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double x1 = 0, x2 = 0, r2 = 0;
    do {
      x1 = 2.0 * uniform() - 1.0;
      x2 = 2.0 * uniform() - 1.0;
      r2 = x1 * x1 + x2 * x2;
    } while (r2 >= 1.0 || r2 == 0.0);
    const double f = std::sqrt(-2.0 * std::log(r2) / r2);
    spare_ = f * x1;
    has_spare_ = true;
    return f * x2;
  }

 private:
  double uniform() {
    const uint32_t high = twister_() >> 5, low = twister_() >> 6;
    return (high * 67108864.0 + low) / 9007199254740992.0;
  }
  std::mt19937 twister_;
  double spare_ = 0;
  bool has_spare_ = false;
};

// Published values: the IPOL article's reference program (imdiff of
// "Image quality metrics", www.ipol.im/pub/art/2011/g_lmii) on
// scikit-image's camera image (512x512 grey, since scikit-image 0.18)
// against the same image plus Gaussian noise of sigma 20 drawn with
// np.random.seed(5), clipped to [0, 255] and truncated to 8 bits, as
// scikit-image's test suite quotes them (test_PSNR_vs_IPOL,
// test_gaussian_structural_similarity_vs_IPOL, to 4 and 3 decimals). The
// image comes from Debian's python3-skimage (./holofuse test fetches it).
TEST(Metrics, MatchTheValuesPublishedForTheCameraImage) {
  const std::string path = std::string(HOLOFUSE_REFERENCE_DIR) + "/camera.png";
  const cv::Mat camera = cv::imread(path, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(camera.empty())
      << path << " is missing: ./holofuse test fetches it from Debian's python3-skimage";
  ASSERT_EQ(camera.type(), CV_8UC1);
  ASSERT_EQ(camera.cols, 512);
  ASSERT_EQ(camera.rows, 512);
  LegacyNumpyNormal normal(5);
  Grey clean(512 * 512), noisy(512 * 512);
  for (int y = 0; y < 512; ++y) {
    for (int x = 0; x < 512; ++x) {
      const int i = y * 512 + x;
      clean[i] = camera.at<uint8_t>(y, x);
      noisy[i] = static_cast<int>(
          std::clamp(clean[i] + 20.0 * normal.next(), 0.0, 255.0));  // truncated, as astype
    }
  }
  Image8 clean_rgb(512, 512, 3), noisy_rgb(512, 512, 3);
  for (int i = 0; i < 512 * 512; ++i) {
    for (int c = 0; c < 3; ++c) {
      clean_rgb.pixels[i * 3 + c] = static_cast<uint8_t>(clean[i]);
      noisy_rgb.pixels[i * 3 + c] = static_cast<uint8_t>(noisy[i]);
    }
  }
  const ImageQuality q = compareInMask(noisy_rgb, clean_rgb, Image8(512, 512, 1, 255));
  EXPECT_NEAR(q.psnr_db, 22.409353363576034, 1e-5);  // ours: 22.4093528
  EXPECT_NEAR(q.ssim, 0.357959091663361, 1e-4);      // ours: 0.3579642
}

TEST(Metrics, ConstantImagesFollowTheLuminanceTermAlone) {
  // No variance: SSIM = (2 mu_a mu_b + C1) / (mu_a^2 + mu_b^2 + C1).
  const double c1 = (0.01 * 255) * (0.01 * 255);
  const std::vector<double> a(kW * kH, 100.0), b(kW * kH, 110.0);
  EXPECT_NEAR(meanSsim(a, b, kW, kH), (2 * 100.0 * 110 + c1) / (100.0 * 100 + 110.0 * 110 + c1),
              1e-12);
  EXPECT_DOUBLE_EQ(meanSsim(a, a, kW, kH), 1.0);
  EXPECT_DOUBLE_EQ(psnrFromMse(0.0), kPsnrCap) << "identical images: capped, never infinite";
  EXPECT_NEAR(psnrFromMse(100.0), 10 * std::log10(255.0 * 255.0 / 100.0), 1e-12);
}

TEST(Metrics, OnlyTheMaskCounts) {
  const Grey a = base();
  Image8 mask(kW, kH, 1, 0);
  for (int y = 10; y < 38; ++y) {
    for (int x = 12; x < 50; ++x) *mask.at(x, y) = 255;
  }
  Image8 rendered = rgb(noisy(a)), changed_outside = rendered;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      if (*mask.at(x, y) == 0)
        changed_outside.at(x, y)[1] = static_cast<uint8_t>(255 - changed_outside.at(x, y)[1]);
    }
  }
  const ImageQuality q = compareInMask(rendered, rgb(a), mask);
  const ImageQuality same = compareInMask(changed_outside, rgb(a), mask);
  EXPECT_EQ(q.pixels, size_t{28 * 38});
  EXPECT_DOUBLE_EQ(q.psnr_db, same.psnr_db);
  EXPECT_DOUBLE_EQ(q.ssim, same.ssim);
  EXPECT_LT(q.ssim, 1.0);
  const ImageQuality perfect = compareInMask(rgb(a), rgb(a), mask);
  EXPECT_DOUBLE_EQ(perfect.ssim, 1.0);
  EXPECT_DOUBLE_EQ(perfect.rmse_percent, 0.0);
  EXPECT_THROW(compareInMask(Image8(kW, kH - 1, 3), rgb(a), mask), std::invalid_argument);
}

// The mask's outline is not structure the two images share: a window on
// it weighs only the pixels inside. A render that is noisy everywhere
// scores about what the same noise scores over the whole image, not near 1
// as a black backdrop's edge, common to both, would make it.
TEST(Metrics, TheMaskOutlineIsNotStructureBothImagesShare) {
  const Grey flat(kW * kH, 100);
  const Image8 truth = rgb(flat), rendered = rgb(noisy(flat));
  const double whole = compareInMask(rendered, truth, Image8(kW, kH, 1, 255)).ssim;
  Image8 mask(kW, kH, 1, 0);
  for (int y = 14; y < 34; ++y) {
    for (int x = 20; x < 44; ++x) *mask.at(x, y) = 255;
  }
  const double masked = compareInMask(rendered, truth, mask).ssim;
  EXPECT_LT(whole, 0.5) << "noise of +-20 on a flat image";
  EXPECT_NEAR(masked, whole, 0.05) << "the outline would lift it towards 1";
  // Against Wang's statistics written out window by window: the Gaussian
  // weights of the pixels inside, renormalised, on an L-shaped mask.
  const Grey a = base(), b = noisy(a);
  Image8 l_mask(kW, kH, 1, 0);
  for (int y = 8; y < 40; ++y) {
    for (int x = 6; x < 30 + (y > 28 ? 30 : 0); ++x) *l_mask.at(x, y) = 255;
  }
  double gauss[11], total = 0;
  for (int k = 0; k < 11; ++k) total += gauss[k] = std::exp(-(k - 5) * (k - 5) / (2 * 1.5 * 1.5));
  const double c1 = 0.01 * 255 * 0.01 * 255, c2 = 0.03 * 255 * 0.03 * 255;
  double sum = 0;
  int windows = 0;
  for (int cy = 5; cy < kH - 5; ++cy) {
    for (int cx = 5; cx < kW - 5; ++cx) {
      if (*l_mask.at(cx, cy) == 0) continue;
      double w = 0, ma = 0, mb = 0, aa = 0, bb = 0, ab = 0;
      for (int dy = -5; dy <= 5; ++dy) {
        for (int dx = -5; dx <= 5; ++dx) {
          if (*l_mask.at(cx + dx, cy + dy) == 0) continue;
          const double g = gauss[dx + 5] * gauss[dy + 5] / (total * total);
          const double va = a[(cy + dy) * kW + cx + dx], vb = b[(cy + dy) * kW + cx + dx];
          w += g;
          ma += g * va;
          mb += g * vb;
          aa += g * va * va;
          bb += g * vb * vb;
          ab += g * va * vb;
        }
      }
      ma /= w;
      mb /= w;
      const double var_a = aa / w - ma * ma, var_b = bb / w - mb * mb, cov = ab / w - ma * mb;
      sum +=
          (2 * ma * mb + c1) * (2 * cov + c2) / ((ma * ma + mb * mb + c1) * (var_a + var_b + c2));
      ++windows;
    }
  }
  EXPECT_NEAR(compareInMask(rgb(b), rgb(a), l_mask).ssim, sum / windows, 1e-9);
}

TEST(Metrics, FlickerIsTheChangeOfTheErrorNotTheError) {
  const Grey a = base();
  const Image8 truth = rgb(a), mask(kW, kH, 1, 255);
  Grey brighter = a;
  for (int& v : brighter) v = std::min(255, v + 10);
  // Wrong by the same amount twice: no flicker.
  const auto e0 = errorImage(rgb(brighter), truth, mask),
             e1 = errorImage(rgb(brighter), truth, mask);
  EXPECT_DOUBLE_EQ(flicker(e0, e1), 0.0);
  // Right, then wrong: the mean change of the error.
  const auto right = errorImage(truth, truth, mask);
  double expected = 0;
  for (size_t i = 0; i < a.size(); ++i) expected += brighter[i] - a[i];
  EXPECT_NEAR(flicker(right, e1), expected / static_cast<double>(a.size()), 1e-9);
}

// A blend that switches cameras across a seam leaves a step in the error
// there; a colour offset everywhere, or a step away from the seams, does
// not count.
TEST(Metrics, SeamVisibilityIsTheErrorsStepAlongTheSeams) {
  Image8 truth(32, 16, 3), mask(32, 16, 1, 255), seams(32, 16, 1, 0);
  for (uint32_t y = 0; y < 16; ++y) {
    for (uint32_t x = 0; x < 32; ++x) {
      for (int c = 0; c < 3; ++c) truth.at(x, y)[c] = static_cast<uint8_t>(60 + 4 * x + y);
      if (x >= 14 && x <= 17) *seams.at(x, y) = 255;  // a seam band down the middle
    }
  }
  auto shifted = [&](int from_x, int by) {
    Image8 out = truth;
    for (uint32_t y = 0; y < 16; ++y) {
      for (uint32_t x = static_cast<uint32_t>(from_x); x < 32; ++x) {
        for (int c = 0; c < 3; ++c) out.at(x, y)[c] = static_cast<uint8_t>(out.at(x, y)[c] + by);
      }
    }
    return out;
  };
  EXPECT_DOUBLE_EQ(seamVisibility(truth, truth, mask, seams), 0.0);
  EXPECT_NEAR(seamVisibility(shifted(0, 20), truth, mask, seams), 0.0, 1e-9)
      << "an offset everywhere";
  EXPECT_NEAR(seamVisibility(shifted(26, 20), truth, mask, seams), 0.0, 1e-9)
      << "a step away from the seams";
  // A step of 20 between x = 15 and 16: central differences of 10 at those
  // two columns of the four in the band, nothing vertically.
  EXPECT_NEAR(seamVisibility(shifted(16, 20), truth, mask, seams), std::sqrt(2 * 100.0 / 4), 1e-9);
  // Outside the mask nothing counts: nothing to measure.
  EXPECT_LT(seamVisibility(shifted(16, 20), truth, Image8(32, 16, 1, 0), seams), 0.0);
  EXPECT_LT(seamVisibility(truth, truth, mask, Image8(32, 16, 1, 0)), 0.0) << "no seam pixels";
  EXPECT_THROW(seamVisibility(truth, truth, mask, Image8(8, 8, 1, 0)), std::invalid_argument);
}

// Two pictures against one truth: where they differ beyond the
// tolerance, how much of the first's error is there, and the second's
// PSNR with those pixels exact.
TEST(Metrics, PictureAgreementBoundsWhatTheDifferingPixelsCanGain) {
  Image8 truth(4, 2, 3, 100), mask(4, 2, 1, 255);
  *mask.at(3, 1) = 0;  // outside: never counts
  Image8 a = truth, b = truth;
  a.at(0, 0)[0] = 110;  // a wrong by 10 where b is right: they differ
  a.at(1, 0)[1] = 104;  // both wrong by 4 and 6: within 2 of each other, alike
  b.at(1, 0)[1] = 106;
  a.at(2, 0)[2] = 90;  // both wrong, 13 apart: they differ
  b.at(2, 0)[2] = 103;
  a.at(3, 1)[0] = b.at(3, 1)[0] = 0;  // outside the mask
  const PictureAgreement g = pictureAgreement(a, b, truth, mask);
  EXPECT_EQ(g.pixels, 7u);
  EXPECT_EQ(g.differing, 2u);
  EXPECT_DOUBLE_EQ(g.a_squared_error, 100 + 16 + 100);
  EXPECT_DOUBLE_EQ(g.a_squared_error_differing, 100 + 100);
  EXPECT_DOUBLE_EQ(g.b_squared_error_alike, 36);
  EXPECT_DOUBLE_EQ(g.bestPsnrOfB(), psnrFromMse(36.0 / 21.0));
  // b's own PSNR can never beat it: b exact where they differ is the best b.
  EXPECT_LE(compareInMask(b, truth, mask).psnr_db, g.bestPsnrOfB());
  EXPECT_EQ(pictureAgreement(a, b, truth, mask, 20).differing, 0u) << "a wider tolerance";
  EXPECT_DOUBLE_EQ(pictureAgreement(a, a, truth, mask).bestPsnrOfB(),
                   compareInMask(a, truth, mask).psnr_db)
      << "identical pictures: no gain to be had";
  EXPECT_THROW(pictureAgreement(a, Image8(3, 2, 3), truth, mask), std::invalid_argument);
}

}  // namespace
}  // namespace holofuse::metrics

#include "metrics/geometry_metrics.h"

namespace holofuse::eval {
namespace {

using metrics::chamferDistance;
using metrics::compareInMask;
using metrics::ErrorRegion;
using metrics::ImageQuality;
using metrics::kOutsideRegions;
using metrics::psnrFromMse;
using metrics::RegionErrors;
using metrics::regionErrors;

Mesh pointsAt(std::initializer_list<glm::vec3> points) {
  Mesh mesh;
  mesh.positions = points;
  return mesh;
}

// Each pixel inside the mask lands in one region, the border first, then a
// depth jump's neighbourhood, then the seams; the squared errors split
// among them add up to the whole.
TEST(Metrics, ErrorRegionsSplitTheMaskedErrorByWhereItSits) {
  const uint32_t w = 40, h = 30;
  Image8 mask(w, h, 1, 0);
  for (uint32_t y = 5; y < 25; ++y)
    for (uint32_t x = 5; x < 35; ++x) mask.pixels[y * w + x] = 255;
  DepthMap depth{w, h, std::vector<double>(static_cast<size_t>(w) * h, kNoDepth)};
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x)
      depth.depth[y * w + x] = x < 20 ? 1.0 : 1.5;  // a jump between x 19 and 20
  }
  Image8 seams(w, h, 1, 0);
  for (uint32_t y = 0; y < h; ++y) seams.pixels[y * w + 30] = 255;  // a seam down column 30
  const Image8 regions = errorRegions(mask, depth, seams, 3, 0.05);
  auto at = [&](uint32_t x, uint32_t y) { return regions.pixels[y * w + x]; };
  EXPECT_EQ(at(0, 0), kOutsideRegions);
  EXPECT_EQ(at(5, 15), uint8_t(ErrorRegion::kSilhouetteBorder));  // on the mask's edge
  EXPECT_EQ(at(7, 15), uint8_t(ErrorRegion::kSilhouetteBorder));  // 3 px from the background at x 4
  EXPECT_EQ(at(8, 15), uint8_t(ErrorRegion::kElsewhere));         // 4 px from it
  EXPECT_EQ(at(17, 15), uint8_t(ErrorRegion::kOcclusionEdge));    // 2 px from the jump
  EXPECT_EQ(at(22, 15), uint8_t(ErrorRegion::kOcclusionEdge));
  EXPECT_EQ(at(16, 15), uint8_t(ErrorRegion::kOcclusionEdge));  // 3 px from it
  EXPECT_EQ(at(15, 15), uint8_t(ErrorRegion::kElsewhere));
  EXPECT_EQ(at(20, 6), uint8_t(ErrorRegion::kSilhouetteBorder));  // the border wins over the jump
  EXPECT_EQ(at(30, 15), uint8_t(ErrorRegion::kSeam));
  EXPECT_EQ(at(31, 15), uint8_t(ErrorRegion::kElsewhere));
  EXPECT_EQ(at(32, 15),
            uint8_t(ErrorRegion::kSilhouetteBorder));  // 3 px from the background at x 35

  Image8 truth(w, h, 3, 100), rendered(w, h, 3, 100);
  rendered.at(30, 15)[0] = 110;  // the seam: 100
  rendered.at(12, 15)[1] = 103;  // elsewhere: 9
  rendered.at(6, 10)[2] = 98;    // the border: 4
  rendered.at(0, 0)[0] = 0;      // outside the mask: not counted
  const RegionErrors e = regionErrors(rendered, truth, regions);
  EXPECT_DOUBLE_EQ(e.squared_error[size_t(ErrorRegion::kSeam)], 100.0);
  EXPECT_DOUBLE_EQ(e.squared_error[size_t(ErrorRegion::kElsewhere)], 9.0);
  EXPECT_DOUBLE_EQ(e.squared_error[size_t(ErrorRegion::kSilhouetteBorder)], 4.0);
  EXPECT_DOUBLE_EQ(e.squared_error[size_t(ErrorRegion::kOcclusionEdge)], 0.0);
  size_t pixels = 0;
  for (size_t count : e.pixels) pixels += count;
  EXPECT_EQ(pixels, 20u * 30u) << "every pixel of the mask, once";
  const ImageQuality q = compareInMask(rendered, truth, mask);
  EXPECT_NEAR(psnrFromMse(113.0 / (3.0 * pixels)), q.psnr_db, 1e-9);
}

TEST(GeometryMetrics, ChamferIsTheMeanOfBothNearestDistanceMeans) {
  const Mesh a = pointsAt({{0, 0, 0}, {1, 0, 0}});
  const Mesh b = pointsAt({{0, 0.1f, 0}, {1, 0, 0}, {5, 0, 0}});
  // a -> b: 0.1 and 0 (mean 0.05); b -> a: 0.1, 0, 4 (mean 1.3666).
  EXPECT_NEAR(chamferDistance(a, b), 0.5 * (0.05 + (0.1 + 0 + 4) / 3.0), 1e-6);
  EXPECT_DOUBLE_EQ(chamferDistance(a, a), 0.0);
  EXPECT_TRUE(std::isinf(chamferDistance(a, Mesh{})));
  // With triangles, to the nearest point of the surface, not of its
  // vertices: a small triangle 5 cm above a big one's inside is 5 cm from
  // it, though 29 cm from its nearest corner.
  Mesh big = pointsAt({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}),
       small = pointsAt({{0.2f, 0.2f, 0.05f}, {0.3f, 0.2f, 0.05f}, {0.2f, 0.3f, 0.05f}});
  big.indices = small.indices = {0, 1, 2};
  // big -> small: its corners reach the small triangle's nearest corners.
  const double big_to_small =
      (std::sqrt(0.08 + 0.0025) + 2 * std::sqrt(0.7 * 0.7 + 0.2 * 0.2 + 0.0025)) / 3.0;
  EXPECT_NEAR(chamferDistance(small, big), 0.5 * (0.05 + big_to_small), 1e-6);
  // Beyond an edge, the nearest point is on the edge: (0.6, 0.6, 0) is
  // sqrt(0.02) from (0.5, 0.5, 0) on the long edge; a lone point has no
  // triangles, so the way back is to it.
  const Mesh beyond_edge = pointsAt({{0.6f, 0.6f, 0.0f}});
  EXPECT_NEAR(chamferDistance(beyond_edge, big),
              0.5 * (std::sqrt(0.02) + (std::sqrt(0.72) + 2 * std::sqrt(0.52)) / 3.0), 1e-6);
  // A triangle with two corners on one point (as quantisation makes) is
  // its edge: (0.5, 0.1, 0) is 0.1 from the segment (0,0,0)-(1,0,0).
  Mesh sliver = pointsAt({{0, 0, 0}, {0, 0, 0}, {1, 0, 0}});
  sliver.indices = {0, 1, 2};
  const double to_sliver = chamferDistance(pointsAt({{0.5f, 0.1f, 0.0f}}), sliver);
  EXPECT_TRUE(std::isfinite(to_sliver));
  EXPECT_NEAR(to_sliver, 0.5 * (0.1 + (2 * std::sqrt(0.26) + std::sqrt(0.26)) / 3.0), 1e-6);
}

}  // namespace
}  // namespace holofuse::eval
