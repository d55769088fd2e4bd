// libFuzzer target: the decoding path a request's bytes go through first
// (format sniffing, header size check, OpenCV/OpenEXR decoding, sRGB and
// saturation handling). Any input must give an Image or a Status, never a
// crash, a sanitizer report or an allocation past the pixel limit.
#include <cstddef>
#include <cstdint>
#include <string>

#include "estimator/io/decode.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // What the header claims is checked first, and must agree with DecodeImage.
  (void)weavefit::ReadImageHeader(bytes);
  weavefit::DecodeOptions options;
  options.max_pixels = 1 << 20;  // 1 Mpx: a lying header must be refused, not allocated
  absl::StatusOr<weavefit::Image> image = weavefit::DecodeImage(bytes, options);
  if (image.ok()) {
    // Touch every decoded value: a short buffer shows up here under ASan.
    volatile float sum = 0.0f;
    for (float v : image->pixels) sum = sum + v;
    (void)sum;
  }
  options.pixels_linear = true;
  options.saturation_level = 200.0;
  (void)weavefit::DecodeImage(bytes, options);
  return 0;
}
