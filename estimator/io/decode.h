// Decoding an encoded photograph (PNG, TIFF, JPEG, EXR) to a linear Image.
#ifndef WEAVEFIT_ESTIMATOR_IO_DECODE_H_
#define WEAVEFIT_ESTIMATOR_IO_DECODE_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "estimator/io/image.h"

namespace weavefit {

struct DecodeOptions {
  // The file's values are already linear in radiance: skip the sRGB curve
  // that is otherwise applied to 8-bit files.
  bool pixels_linear = false;
  // Saturation level in the file's own units (255 for 8-bit, 65535 for
  // 16-bit); 0 means the format's maximum (integer formats) and, in every
  // format, a clip plateau if there is one: at least 2 samples (and under
  // half of them) at exactly the file's largest value, more than at any
  // value within 5 % below it (a 12-bit sensor in a 16-bit file clips at
  // 65520).
  double saturation_level = 0.0;
  // Largest accepted width × height, checked from the file header before
  // any pixel is allocated.
  std::int64_t max_pixels = 64LL * 1024 * 1024;

  // OK, or INVALID_ARGUMENT naming the field that broke its constraint.
  absl::Status Validate() const;
};

// Dimensions read from a file header without decoding the pixels.
struct ImageHeader {
  std::string format;  // "png", "tiff", "jpeg", "exr"
  int width = 0;
  int height = 0;
  // Samples per pixel as stored (alpha included) and bytes per sample, when
  // the header says (0 = unknown: DecodedBytes then assumes the most a
  // format allows).
  int samples = 0;
  int bytes_per_sample = 0;
  // Whether the decoder holds a whole decoded copy besides the float image
  // (OpenCV's path); PNG read row by row and EXR read into the float image
  // do not.
  bool whole_copy = true;
};

// The most bytes DecodeImage holds at once for a photograph with this
// header: the decoder's whole copy (when it makes one), the linear float
// image (1 or 3 channels) and a saturation mask as large as the image, at
// worst. Overflow-free for any header (dimensions below 2^31).
std::int64_t DecodedBytes(const ImageHeader& header);

// Recognises the format by its signature and reads the dimensions.
// INVALID_ARGUMENT for an empty, unknown or malformed header.
absl::StatusOr<ImageHeader> ReadImageHeader(const std::string& bytes);

// Decodes to linear float, 1 or 3 channels (alpha dropped). INVALID_ARGUMENT
// for undecodable input, RESOURCE_EXHAUSTED when the header's size exceeds
// options.max_pixels. Never throws.
absl::StatusOr<Image> DecodeImage(const std::string& bytes,
                                  const DecodeOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_IO_DECODE_H_
