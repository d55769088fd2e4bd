#include "estimator/io/image.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace weavefit {

void SaturationMask::Mark(int x, int y, int width, int height) {
  if (row_at_.empty()) {
    width_ = width;
    row_at_.assign(static_cast<std::size_t>(height), -1);
  }
  if (row_at_[y] < 0) {
    row_at_[y] = static_cast<std::int32_t>(flags_.size() / width_);
    flags_.resize(flags_.size() + width_, 0);
  }
  flags_[static_cast<std::size_t>(row_at_[y]) * width_ + x] = 1;
}

std::int64_t SaturationMask::Count() const {
  if (flags_.empty()) return 0;
  // OpenCV's vectorised count.
  const cv::Mat mask(1, static_cast<int>(flags_.size()), CV_8U,
                     const_cast<std::uint8_t*>(flags_.data()));
  return cv::countNonZero(mask);
}

bool SaturationMask::operator==(const SaturationMask& other) const {
  if (empty() || other.empty()) return empty() && other.empty();
  if (width_ != other.width_ || row_at_.size() != other.row_at_.size()) return false;
  for (std::size_t y = 0; y < row_at_.size(); ++y) {
    const std::uint8_t* a = Row(static_cast<int>(y));
    const std::uint8_t* b = other.Row(static_cast<int>(y));
    if ((a == nullptr) != (b == nullptr)) return false;
    if (a != nullptr && !std::equal(a, a + width_, b)) return false;
  }
  return true;
}

std::int64_t Image::SaturatedCount() const { return saturated.Count(); }

Image Luminance(const Image& image) {
  if (image.channels == 1) return image;
  Image out;
  out.width = image.width;
  out.height = image.height;
  out.channels = 1;
  out.format = image.format;
  out.bit_depth = image.bit_depth;
  out.srgb = image.srgb;
  out.saturated = image.saturated;
  const std::size_t n = static_cast<std::size_t>(image.width) * image.height;
  out.pixels.resize(n);
  const int c = image.channels;
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = &image.pixels[i * c];
    out.pixels[i] = c >= 3 ? 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2]
                           : p[0];
  }
  return out;
}

double CodeStep(const Image& image, double level) {
  if (image.format.empty() || image.format == "exr") return 0.0;
  if (image.bit_depth != 8 && image.bit_depth != 16) return 0.0;
  const double code = 1.0 / ((1 << image.bit_depth) - 1);
  if (!image.srgb) return code;
  const double encoded = LinearToSrgb(static_cast<float>(std::clamp(level, 0.0, 1.0)));
  const double next = std::min(1.0, encoded + code);
  return SrgbToLinear(static_cast<float>(next)) - SrgbToLinear(static_cast<float>(next - code));
}

float SrgbToLinear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f
                             : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

float LinearToSrgb(float linear) {
  return linear <= 0.0031308f ? 12.92f * linear
                              : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

}  // namespace weavefit
