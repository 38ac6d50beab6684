// Image quality the way the papers measure it (docs/design.md section 7), for a
// rendered view against the true image of the same camera, inside that
// camera's foreground mask.
//
// Conventions, so anyone can recompute the numbers from the saved PNGs:
// - RMSE and PSNR: over every channel of every pixel inside the mask, peak
//   255. RMSE is reported in percent of 255. Identical images give PSNR
//   kPsnrCap (JSON has no infinity).
// - SSIM (Wang, Bovik, Sheikh and Simoncelli 2004): on luminance
//   Y = 0.299 R + 0.587 G + 0.114 B (not rounded), Gaussian window 11x11
//   with sigma 1.5 (weights normalised), K1 = 0.01, K2 = 0.03, L = 255,
//   population (not sample) statistics. The map covers the windows that
//   lie wholly inside the image (Wang's "valid" filtering); its mean is
//   taken over the windows whose centre is inside the mask. Each window's
//   statistics weigh only the pixels inside the mask (its Gaussian weights
//   restricted to them and renormalised), so neither the backdrop nor the
//   mask's outline counts: setting the backdrop to black instead would give
//   both images a shared edge along the outline and lift a noisy render's
//   SSIM from 0.31 to 0.66 (tests/eval/test_metrics.cpp).
// - Temporal flicker: mean absolute frame-to-frame change of the signed
//   error image (rendered - true), grey levels, over pixels inside both
//   frames' masks: a method that is wrong the same way every frame does not
//   flicker.
// - Seam visibility: RMS over the seam pixels (given, inside the mask) of
//   the gradient of the luminance error image (rendered - true), central
//   differences, grey levels per pixel. A blend that switches cameras
//   across a seam leaves a step in the error there; an error that is the
//   same on both sides (a colour offset) leaves none, and the truth's own
//   edges cancel.
// - Error regions: the squared error of the RMSE split by where it sits
//   (silhouette border, occlusion edge, seam, elsewhere; eval::errorRegions
//   in leave_one_out.h), so
//   a PSNR difference between two modes can be traced to a region.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "image/image.h"

namespace holofuse::metrics {

constexpr double kPsnrCap = 100.0;  // dB, for identical images

struct ImageQuality {
  double rmse_percent = 0;  // of 255
  double psnr_db = 0;
  double ssim = 0;
  size_t pixels = 0;  // inside the mask
};

// rendered: RGB or RGBA (alpha ignored); truth: RGB; mask: one channel,
// non-zero counts. All the same size (std::invalid_argument otherwise).
ImageQuality compareInMask(const Image8& rendered, const Image8& truth, const Image8& mask);

double psnrFromMse(double mse, double peak = 255.0);

// Luminance of an RGB(A) image, row major.
std::vector<double> luminance(const Image8& image);

// SSIM map of two greyscale images (w x h, row major) over the windows
// wholly inside the image: (w - 10) x (h - 10) values, the window centred on
// pixel (x + 5, y + 5) at index y * (w - 10) + x. Empty when an image is
// smaller than the window.
std::vector<double> ssimMap(const std::vector<double>& a, const std::vector<double>& b, int width,
                            int height);
// The same map with each window's weights restricted to the pixels where
// inside is 1 (0 elsewhere) and renormalised; 0 where a window holds none.
// With every pixel inside it equals ssimMap.
std::vector<double> maskedSsimMap(const std::vector<double>& a, const std::vector<double>& b,
                                  const std::vector<double>& inside, int width, int height);
// Mean of the map: the usual single SSIM value of two images.
double meanSsim(const std::vector<double>& a, const std::vector<double>& b, int width, int height);

// Intersection over union of two masks' foregrounds (non-zero pixels) of
// one size; 1 when both are empty.
double maskIoU(const Image8& a, const Image8& b);

// Signed error image (rendered - truth) per channel, for flicker.
struct ErrorImage {
  Image8 mask;
  std::vector<float> error;  // width * height * 3
};
ErrorImage errorImage(const Image8& rendered, const Image8& truth, const Image8& mask);
// Mean |e1 - e0| over pixels inside both masks and channels; 0 when none.
double flicker(const ErrorImage& previous, const ErrorImage& current);

// Two renders of one view (a: the baseline, b: the method against it)
// against its truth, inside the mask: where they differ at all (some
// channel by more than tolerance grey levels) and how much of the
// baseline's error sits there, and b's PSNR were its picture exact on the
// pixels where it differs: how much of the picture b's method changes, and
// what those changes could at most buy it. (It does not bound another
// setting of b's method, which would change other pixels.)
struct PictureAgreement {
  size_t pixels = 0;                                          // inside the mask
  size_t differing = 0;                                       // of them, where a and b differ
  double a_squared_error = 0, a_squared_error_differing = 0;  // summed over channels
  double b_squared_error_alike = 0;                           // b's, where they agree
  // b's PSNR with every differing pixel exact (kPsnrCap when b is exact
  // wherever they agree, or inside an empty mask).
  double bestPsnrOfB() const;
};
PictureAgreement pictureAgreement(const Image8& a, const Image8& b, const Image8& truth,
                                  const Image8& mask, int tolerance = 2);

// seams: one channel, non-zero where a seam triangle covers the pixel. The
// gradient is taken where both neighbours on an axis are inside the mask;
// negative (nothing to measure) when no seam pixel is.
double seamVisibility(const Image8& rendered, const Image8& truth, const Image8& mask,
                      const Image8& seams);

// Where an error sits, to tell which part of a picture a mode wins or
// loses. Each pixel inside the truth's mask falls in exactly one region,
// the first that applies in this order.
enum class ErrorRegion : uint8_t {
  kSilhouetteBorder,  // within a few pixels of the truth mask's edge
  kOcclusionEdge,     // near a depth jump of the mesh seen from the pose
  kSeam,              // on a seam triangle of the cameras the blend leans on
  kElsewhere,
};
inline constexpr size_t kErrorRegionCount = 4;
inline constexpr uint8_t kOutsideRegions = 255;   // outside the truth's mask
const char* errorRegionName(ErrorRegion region);  // "silhouette_border", ...

// Squared error summed over RGB and pixel counts per region.
struct RegionErrors {
  std::array<double, kErrorRegionCount> squared_error{};
  std::array<size_t, kErrorRegionCount> pixels{};
  void add(const RegionErrors& other);
};
RegionErrors regionErrors(const Image8& rendered, const Image8& truth, const Image8& regions);

// Pictures for --save-images: the error's size per pixel (mean absolute
// over RGB, 0 to 64 grey levels from black through red to yellow, black
// outside the mask) and the regions in four colours.
Image8 errorMapPicture(const Image8& rendered, const Image8& truth, const Image8& mask);
Image8 regionsPicture(const Image8& regions);

}  // namespace holofuse::metrics
