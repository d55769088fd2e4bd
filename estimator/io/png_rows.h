// Row-by-row PNG decoding through libpng, so that a 16-bit photograph is
// converted to float one row at a time instead of through a whole decoded
// 16-bit copy (on 12 Mpx that copy is 25 MB and a pass over the pixels).
// Internal to io/ (decode.cc); OpenCV decodes what this does not take.
#ifndef WEAVEFIT_ESTIMATOR_IO_PNG_ROWS_H_
#define WEAVEFIT_ESTIMATOR_IO_PNG_ROWS_H_

#include <cstddef>
#include <cstdint>
#include <functional>

#include "absl/status/status.h"

namespace weavefit {

// The IHDR fields that decide how a PNG is read.
struct PngLayout {
  int width = 0;
  int height = 0;
  int bit_depth = 0;   // 1, 2, 4, 8 or 16
  int color_type = 0;  // 0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA
  bool interlaced = false;

  // Samples per pixel as stored (alpha included).
  int SamplesPerPixel() const;
  // Whether ReadPngRows takes this file: 8 or 16 bits, no palette, not
  // interlaced (Adam7 needs the whole image before any row is final).
  bool RowReadable() const;
};

// The layout from the IHDR chunk, which must come first (`n` >= 29 bytes).
absl::Status ReadPngLayout(const unsigned char* p, std::size_t n, PngLayout* layout);

// Each row in order as it is decoded: `y` and the row's samples, 8-bit or
// native-endian 16-bit, interleaved as stored. Returning a non-OK status
// stops decoding and is returned.
using PngRowSink = std::function<absl::Status(int y, const unsigned char* samples)>;

// Decodes a RowReadable() PNG of `layout` (from ReadPngLayout on the same
// bytes) and passes each row to `sink`. A corrupt or truncated stream gives
// InvalidArgument with libpng's message.
absl::Status ReadPngRows(const unsigned char* data, std::size_t size, const PngLayout& layout,
                         const PngRowSink& sink);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_IO_PNG_ROWS_H_
