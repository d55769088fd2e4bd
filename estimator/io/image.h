// Decoded photographs as plain data: linear float pixels and a saturation
// mask. OpenCV and OpenEXR stay inside io/ (STYLE.md).
#ifndef WEAVEFIT_ESTIMATOR_IO_IMAGE_H_
#define WEAVEFIT_ESTIMATOR_IO_IMAGE_H_

#include <cstdint>
#include <string>
#include <vector>

namespace weavefit {

// Which pixels of a w×h image are saturated, stored by row: only a row with
// a saturated pixel holds flags (one byte per pixel), so a photograph with a
// few clipped glints carries a few rows, not a second full-size plane (on
// 12 Mpx that plane is 12.6 MB, a quarter of the float image).
class SaturationMask {
 public:
  SaturationMask() = default;
  // Any flags set with Mark (x, y in the image), all clear before.
  void Mark(int x, int y, int width, int height);
  // Row y's flags (`width` bytes), or nullptr when none in the row is set.
  const std::uint8_t* Row(int y) const {
    return row_at_.empty() || row_at_[y] < 0 ? nullptr
                                             : flags_.data() + static_cast<std::size_t>(row_at_[y]) * width_;
  }
  bool At(int x, int y) const {
    const std::uint8_t* row = Row(y);
    return row != nullptr && row[x] != 0;
  }
  // No pixel flagged.
  bool empty() const { return flags_.empty(); }
  std::int64_t Count() const;
  void clear() { *this = SaturationMask(); }
  bool operator==(const SaturationMask& other) const;

 private:
  int width_ = 0;
  std::vector<std::int32_t> row_at_;  // per row: its slot in flags_, or -1
  std::vector<std::uint8_t> flags_;   // width_ bytes per slot
};

// A linear-radiance image, row-major, channels interleaved (RGB order).
// Values are in the file's range divided by its maximum (1.0 = full scale
// for integer formats; EXR values as stored).
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> pixels;
  // Pixels with any channel at or above the saturation level.
  SaturationMask saturated;
  std::string format;  // "png", "tiff", "jpeg", "exr", or "" when synthetic
  int bit_depth = 32;  // of the source file's samples
  bool srgb = false;   // the samples were decoded through the sRGB curve

  float At(int x, int y, int c = 0) const {
    return pixels[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }
  bool IsSaturated(int x, int y) const { return saturated.At(x, y); }
  void MarkSaturated(int x, int y) { saturated.Mark(x, y, width, height); }
  std::int64_t SaturatedCount() const;
};

// A single-channel image: Rec. 709 luminance of linear RGB, or a copy of a
// one-channel image. The saturation mask is carried over.
Image Luminance(const Image& image);

// One code value of `image`'s source file, in its linear units, at the
// linear level `level`: 1/(2^bits − 1) for 8- and 16-bit integer files
// decoded as linear, the step of the sRGB curve there for those decoded
// through it. 0 for float files (EXR) and synthetic images: their steps
// are far below any noise.
double CodeStep(const Image& image, double level);

// The standard sRGB decoding curve, value in [0, 1].
float SrgbToLinear(float encoded);
// The standard sRGB encoding curve, value in [0, 1].
float LinearToSrgb(float linear);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_IO_IMAGE_H_
