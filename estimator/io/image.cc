#include "estimator/io/image.h"

#include <cmath>

#include <opencv2/core.hpp>

namespace weavefit {

std::int64_t Image::SaturatedCount() const {
  if (saturated.empty()) return 0;
  // OpenCV's vectorised count (a plain loop costs ~5 ms at 12 Mpx).
  const cv::Mat mask(height, width, CV_8U, const_cast<std::uint8_t*>(saturated.data()));
  return cv::countNonZero(mask);
}

Image Luminance(const Image& image) {
  if (image.channels == 1) return image;
  Image out;
  out.width = image.width;
  out.height = image.height;
  out.channels = 1;
  out.format = image.format;
  out.bit_depth = image.bit_depth;
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

float SrgbToLinear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f
                             : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

float LinearToSrgb(float linear) {
  return linear <= 0.0031308f ? 12.92f * linear
                              : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

}  // namespace weavefit
