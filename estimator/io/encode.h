// Encoding a linear Image to a file format (used by the renderer).
#ifndef WEAVEFIT_ESTIMATOR_IO_ENCODE_H_
#define WEAVEFIT_ESTIMATOR_IO_ENCODE_H_

#include <string>

#include "absl/status/statusor.h"
#include "estimator/io/image.h"

namespace weavefit {

enum class EncodeFormat {
  kPng16,   // 16-bit linear PNG
  kPng8,    // 8-bit sRGB PNG
  kTiff16,  // 16-bit linear TIFF
  kExr,     // 32-bit float EXR (linear, unclipped)
  kJpeg,    // 8-bit sRGB JPEG, quality 95
};

// Parses "png", "png8", "tiff", "exr", "jpeg"/"jpg".
absl::StatusOr<EncodeFormat> ParseEncodeFormat(const std::string& name);
// File extension (without the dot) for a format.
const char* EncodeFormatExtension(EncodeFormat format);

// Encodes linear values in [0, 1] (clipped, except for EXR) to bytes.
absl::StatusOr<std::string> EncodeImage(const Image& image,
                                        EncodeFormat format);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_IO_ENCODE_H_
