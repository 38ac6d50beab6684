#include "metrics/image_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace holofuse::metrics {
namespace {

constexpr int kRadius = 5;  // 11 x 11 window
constexpr double kSigma = 1.5;
constexpr double kK1 = 0.01, kK2 = 0.03, kPeak = 255.0;

std::array<double, 2 * kRadius + 1> gaussianWeights() {
  std::array<double, 2 * kRadius + 1> w{};
  double sum = 0;
  for (int i = -kRadius; i <= kRadius; ++i)
    sum += w[i + kRadius] = std::exp(-(i * i) / (2 * kSigma * kSigma));
  for (double& v : w) v /= sum;
  return w;
}

// Separable weighted sums over the windows wholly inside the image.
std::vector<double> filterValid(const std::vector<double>& image, int width, int height) {
  static const auto w = gaussianWeights();
  const int out_w = width - 2 * kRadius, out_h = height - 2 * kRadius;
  std::vector<double> rows(static_cast<size_t>(out_w) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < out_w; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k)
        s += w[k] * image[static_cast<size_t>(y) * width + x + k];
      rows[static_cast<size_t>(y) * out_w + x] = s;
    }
  }
  std::vector<double> out(static_cast<size_t>(out_w) * out_h);
  for (int y = 0; y < out_h; ++y) {
    for (int x = 0; x < out_w; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k)
        s += w[k] * rows[static_cast<size_t>(y + k) * out_w + x];
      out[static_cast<size_t>(y) * out_w + x] = s;
    }
  }
  return out;
}

void requireSameSize(const Image8& a, const Image8& b, const char* what) {
  if (a.width != b.width || a.height != b.height) {
    throw std::invalid_argument(std::string(what) + ": " + std::to_string(a.width) + "x" +
                                std::to_string(a.height) + " against " + std::to_string(b.width) +
                                "x" + std::to_string(b.height));
  }
}

void requireInputs(const Image8& rendered, const Image8& truth, const Image8& mask) {
  requireSameSize(rendered, truth, "rendered and true image differ in size");
  requireSameSize(truth, mask, "true image and mask differ in size");
  if (rendered.channels < 3 || truth.channels < 3 || mask.channels != 1) {
    throw std::invalid_argument("expected RGB(A) images and a one-channel mask");
  }
}

}  // namespace

double psnrFromMse(double mse, double peak) {
  if (!(mse > 0)) return kPsnrCap;
  return std::min(kPsnrCap, 10.0 * std::log10(peak * peak / mse));
}

std::vector<double> luminance(const Image8& image) {
  std::vector<double> y(static_cast<size_t>(image.width) * image.height);
  for (size_t p = 0; p < y.size(); ++p) {
    const uint8_t* px = image.pixels.data() + p * image.channels;
    y[p] = image.channels >= 3 ? 0.299 * px[0] + 0.587 * px[1] + 0.114 * px[2] : px[0];
  }
  return y;
}

std::vector<double> ssimMap(const std::vector<double>& a, const std::vector<double>& b, int width,
                            int height) {
  return maskedSsimMap(a, b, std::vector<double>(a.size(), 1.0), width, height);
}

// Wang's statistics restricted to the subject: the mask's outline must not
// be an edge both images share.
std::vector<double> maskedSsimMap(const std::vector<double>& a, const std::vector<double>& b,
                                  const std::vector<double>& inside, int width, int height) {
  if (width <= 2 * kRadius || height <= 2 * kRadius) return {};
  const size_t n = static_cast<size_t>(width) * height;
  std::vector<double> ma(n), mb(n), maa(n), mbb(n), mab(n);
  for (size_t i = 0; i < n; ++i) {
    ma[i] = inside[i] * a[i];
    mb[i] = inside[i] * b[i];
    maa[i] = ma[i] * a[i];
    mbb[i] = mb[i] * b[i];
    mab[i] = ma[i] * b[i];
  }
  const auto weight = filterValid(inside, width, height);
  const auto s_a = filterValid(ma, width, height), s_b = filterValid(mb, width, height);
  const auto s_aa = filterValid(maa, width, height), s_bb = filterValid(mbb, width, height),
             s_ab = filterValid(mab, width, height);
  const double c1 = (kK1 * kPeak) * (kK1 * kPeak), c2 = (kK2 * kPeak) * (kK2 * kPeak);
  std::vector<double> map(weight.size(), 0.0);
  for (size_t i = 0; i < map.size(); ++i) {
    if (!(weight[i] > 0)) continue;
    const double mu_a = s_a[i] / weight[i], mu_b = s_b[i] / weight[i];
    const double var_a = s_aa[i] / weight[i] - mu_a * mu_a,
                 var_b = s_bb[i] / weight[i] - mu_b * mu_b;
    const double cov = s_ab[i] / weight[i] - mu_a * mu_b;
    map[i] = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) /
             ((mu_a * mu_a + mu_b * mu_b + c1) * (var_a + var_b + c2));
  }
  return map;
}

double meanSsim(const std::vector<double>& a, const std::vector<double>& b, int width, int height) {
  const auto map = ssimMap(a, b, width, height);
  double sum = 0;
  for (double v : map) sum += v;
  return map.empty() ? 0.0 : sum / static_cast<double>(map.size());
}

ImageQuality compareInMask(const Image8& rendered, const Image8& truth, const Image8& mask) {
  requireInputs(rendered, truth, mask);
  const int w = static_cast<int>(truth.width), h = static_cast<int>(truth.height);
  ImageQuality q;
  double squared = 0;
  const std::vector<double> ya = luminance(rendered), yb = luminance(truth);
  std::vector<double> inside(mask.pixels.size(), 0.0);
  for (size_t p = 0; p < mask.pixels.size(); ++p) {
    if (mask.pixels[p] == 0) continue;
    inside[p] = 1.0;
    ++q.pixels;
    for (int c = 0; c < 3; ++c) {
      const double d = double(rendered.pixels[p * rendered.channels + c]) -
                       double(truth.pixels[p * truth.channels + c]);
      squared += d * d;
    }
  }
  const double mse = q.pixels ? squared / (3.0 * static_cast<double>(q.pixels)) : 0.0;
  q.rmse_percent = 100.0 * std::sqrt(mse) / 255.0;
  q.psnr_db = psnrFromMse(mse);
  const auto map = maskedSsimMap(ya, yb, inside, w, h);
  double sum = 0;
  size_t count = 0;
  for (int y = 0; y + 2 * kRadius < h; ++y) {
    for (int x = 0; x + 2 * kRadius < w; ++x) {
      if (mask.pixels[static_cast<size_t>(y + kRadius) * w + x + kRadius] == 0) continue;
      sum += map[static_cast<size_t>(y) * (w - 2 * kRadius) + x];
      ++count;
    }
  }
  q.ssim = count ? sum / static_cast<double>(count) : 0.0;
  return q;
}

PictureAgreement pictureAgreement(const Image8& a, const Image8& b, const Image8& truth,
                                  const Image8& mask, int tolerance) {
  requireInputs(a, truth, mask);
  requireInputs(b, truth, mask);
  PictureAgreement agreement;
  for (size_t p = 0; p < mask.pixels.size(); ++p) {
    if (mask.pixels[p] == 0) continue;
    ++agreement.pixels;
    double a_squared = 0, b_squared = 0;
    bool differ = false;
    for (int c = 0; c < 3; ++c) {
      const int va = a.pixels[p * a.channels + c], vb = b.pixels[p * b.channels + c];
      const int vt = truth.pixels[p * truth.channels + c];
      a_squared += double(va - vt) * double(va - vt);
      b_squared += double(vb - vt) * double(vb - vt);
      differ = differ || std::abs(va - vb) > tolerance;
    }
    agreement.a_squared_error += a_squared;
    if (differ) {
      ++agreement.differing;
      agreement.a_squared_error_differing += a_squared;
    } else {
      agreement.b_squared_error_alike += b_squared;
    }
  }
  return agreement;
}

double PictureAgreement::bestPsnrOfB() const {
  return pixels ? psnrFromMse(b_squared_error_alike / (3.0 * static_cast<double>(pixels)))
                : kPsnrCap;
}

ErrorImage errorImage(const Image8& rendered, const Image8& truth, const Image8& mask) {
  requireInputs(rendered, truth, mask);
  ErrorImage e{mask, std::vector<float>(mask.pixels.size() * 3, 0.0f)};
  for (size_t p = 0; p < mask.pixels.size(); ++p) {
    for (int c = 0; c < 3; ++c) {
      e.error[p * 3 + c] = static_cast<float>(int(rendered.pixels[p * rendered.channels + c]) -
                                              int(truth.pixels[p * truth.channels + c]));
    }
  }
  return e;
}

double maskIoU(const Image8& a, const Image8& b) {
  size_t inter = 0, either = 0;
  const size_t n = std::min(a.pixels.size(), b.pixels.size());
  for (size_t i = 0; i < n; ++i) {
    const bool x = a.pixels[i] != 0, y = b.pixels[i] != 0;
    inter += x && y;
    either += x || y;
  }
  return either ? static_cast<double>(inter) / static_cast<double>(either) : 1.0;
}

double flicker(const ErrorImage& previous, const ErrorImage& current) {
  if (previous.error.size() != current.error.size()) return 0.0;
  double sum = 0;
  size_t count = 0;
  for (size_t p = 0; p < current.mask.pixels.size(); ++p) {
    if (current.mask.pixels[p] == 0 || previous.mask.pixels[p] == 0) continue;
    for (int c = 0; c < 3; ++c)
      sum += std::abs(current.error[p * 3 + c] - previous.error[p * 3 + c]);
    count += 3;
  }
  return count ? sum / static_cast<double>(count) : 0.0;
}

double seamVisibility(const Image8& rendered, const Image8& truth, const Image8& mask,
                      const Image8& seams) {
  if (rendered.width != truth.width || rendered.height != truth.height ||
      mask.width != truth.width || mask.height != truth.height || seams.width != truth.width ||
      seams.height != truth.height) {
    throw std::invalid_argument("seamVisibility: images of different sizes");
  }
  const int w = static_cast<int>(truth.width), h = static_cast<int>(truth.height);
  const std::vector<double> r = luminance(rendered), t = luminance(truth);
  auto inside = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h && *mask.at(x, y) != 0;
  };
  auto error = [&](int x, int y) {
    return r[static_cast<size_t>(y) * w + x] - t[static_cast<size_t>(y) * w + x];
  };
  double sum = 0;
  size_t count = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (*seams.at(x, y) == 0 || !inside(x, y)) continue;
      double energy = 0;
      bool any = false;
      if (inside(x - 1, y) && inside(x + 1, y)) {
        const double g = 0.5 * (error(x + 1, y) - error(x - 1, y));
        energy += g * g;
        any = true;
      }
      if (inside(x, y - 1) && inside(x, y + 1)) {
        const double g = 0.5 * (error(x, y + 1) - error(x, y - 1));
        energy += g * g;
        any = true;
      }
      if (!any) continue;
      sum += energy;
      ++count;
    }
  }
  return count ? std::sqrt(sum / static_cast<double>(count)) : -1.0;
}

const char* errorRegionName(ErrorRegion region) {
  switch (region) {
    case ErrorRegion::kSilhouetteBorder:
      return "silhouette_border";
    case ErrorRegion::kOcclusionEdge:
      return "occlusion_edge";
    case ErrorRegion::kSeam:
      return "seam";
    case ErrorRegion::kElsewhere:
      return "elsewhere";
  }
  return "elsewhere";
}

void RegionErrors::add(const RegionErrors& other) {
  for (size_t r = 0; r < kErrorRegionCount; ++r) {
    squared_error[r] += other.squared_error[r];
    pixels[r] += other.pixels[r];
  }
}

RegionErrors regionErrors(const Image8& rendered, const Image8& truth, const Image8& regions) {
  if (rendered.width != truth.width || rendered.height != truth.height ||
      regions.width != truth.width || regions.height != truth.height || regions.channels != 1 ||
      rendered.channels < 3 || truth.channels < 3) {
    throw std::invalid_argument("regionErrors: rendered, truth and regions must be one size");
  }
  RegionErrors out;
  const size_t n = static_cast<size_t>(truth.width) * truth.height;
  for (size_t p = 0; p < n; ++p) {
    const uint8_t r = regions.pixels[p];
    if (r >= kErrorRegionCount) continue;
    double sum = 0;
    for (uint32_t c = 0; c < 3; ++c) {
      const double d = double(rendered.pixels[p * rendered.channels + c]) -
                       double(truth.pixels[p * truth.channels + c]);
      sum += d * d;
    }
    out.squared_error[r] += sum;
    ++out.pixels[r];
  }
  return out;
}

Image8 errorMapPicture(const Image8& rendered, const Image8& truth, const Image8& mask) {
  Image8 out(truth.width, truth.height, 3, 0);
  const size_t n = static_cast<size_t>(truth.width) * truth.height;
  for (size_t p = 0; p < n; ++p) {
    if (mask.pixels[p] == 0) continue;
    double sum = 0;
    for (uint32_t c = 0; c < 3; ++c) {
      sum += std::abs(double(rendered.pixels[p * rendered.channels + c]) -
                      double(truth.pixels[p * truth.channels + c]));
    }
    // 0..64 grey levels -> black, red, yellow.
    const double t = std::clamp(sum / 3.0 / 64.0, 0.0, 1.0);
    out.pixels[3 * p] = static_cast<uint8_t>(std::lround(255 * std::min(1.0, 2 * t)));
    out.pixels[3 * p + 1] = static_cast<uint8_t>(std::lround(255 * std::max(0.0, 2 * t - 1)));
  }
  return out;
}

Image8 regionsPicture(const Image8& regions) {
  // silhouette border blue, occlusion edge orange, seam magenta, elsewhere grey
  static constexpr std::array<std::array<uint8_t, 3>, kErrorRegionCount> kColours = {
      {{40, 90, 230}, {240, 140, 20}, {220, 40, 200}, {110, 110, 110}}};
  Image8 out(regions.width, regions.height, 3, 0);
  for (size_t p = 0; p < regions.pixels.size(); ++p) {
    const uint8_t r = regions.pixels[p];
    if (r >= kErrorRegionCount) continue;
    for (int c = 0; c < 3; ++c) out.pixels[3 * p + c] = kColours[r][c];
  }
  return out;
}

}  // namespace holofuse::metrics
