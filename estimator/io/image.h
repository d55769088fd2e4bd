// Decoded photographs as plain data: linear float pixels and a saturation
// mask. OpenCV and OpenEXR stay inside io/ (STYLE.md).
#ifndef WEAVEFIT_ESTIMATOR_IO_IMAGE_H_
#define WEAVEFIT_ESTIMATOR_IO_IMAGE_H_

#include <cstdint>
#include <string>
#include <vector>

namespace weavefit {

// A linear-radiance image, row-major, channels interleaved (RGB order).
// Values are in the file's range divided by its maximum (1.0 = full scale
// for integer formats; EXR values as stored).
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> pixels;
  // One flag per pixel: any channel at or above the saturation level.
  std::vector<std::uint8_t> saturated;
  std::string format;  // "png", "tiff", "jpeg", "exr", or "" when synthetic
  int bit_depth = 32;  // of the source file's samples

  float At(int x, int y, int c = 0) const {
    return pixels[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }
  bool IsSaturated(int x, int y) const {
    return !saturated.empty() &&
           saturated[static_cast<std::size_t>(y) * width + x] != 0;
  }
  std::int64_t SaturatedCount() const;
};

// A single-channel image: Rec. 709 luminance of linear RGB, or a copy of a
// one-channel image. The saturation mask is carried over.
Image Luminance(const Image& image);

// The standard sRGB decoding curve, value in [0, 1].
float SrgbToLinear(float encoded);
// The standard sRGB encoding curve, value in [0, 1].
float LinearToSrgb(float linear);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_IO_IMAGE_H_
