#include "estimator/io/png_rows.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"

namespace weavefit {
namespace {

std::uint32_t BigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

struct Source {
  const unsigned char* data;
  std::size_t size;
  std::size_t at;
};

// libpng reports errors by longjmp to the setjmp in DecodeRows; the message
// is kept in the error pointer's buffer.
constexpr std::size_t kMessageSize = 256;

void OnError(png_structp png, png_const_charp message) {
  char* buffer = static_cast<char*>(png_get_error_ptr(png));
  std::snprintf(buffer, kMessageSize, "%s", message);
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp) {}

void Read(png_structp png, png_bytep out, std::size_t n) {
  auto* source = static_cast<Source*>(png_get_io_ptr(png));
  if (n > source->size - source->at) png_error(png, "the file is truncated");
  std::memcpy(out, source->data + source->at, n);
  source->at += n;
}

// The setjmp frame: only trivially destructible locals live here, so a
// longjmp out of libpng skips no destructor. Each row goes to `on_row`
// (a plain function pointer: it must not throw), which returns false to stop.
// Returns 0 when every row was read, 1 on a libpng error (message in
// `message`), 2 when `on_row` stopped.
int DecodeRows(Source* source, int height, bool swap16, unsigned char* row,
               std::size_t row_bytes, bool (*on_row)(void*, int, const unsigned char*),
               void* context, char* message) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, message, OnError, OnWarning);
  if (png == nullptr) {
    std::snprintf(message, kMessageSize, "libpng could not start");
    return 1;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(message, kMessageSize, "libpng could not start");
    return 1;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return 1;
  }
  png_set_read_fn(png, source, Read);
  png_read_info(png, info);
  if (swap16) png_set_swap(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != row_bytes) png_error(png, "row size differs from the header");
  for (int y = 0; y < height; ++y) {
    png_read_row(png, row, nullptr);
    if (!on_row(context, y, row)) {
      png_destroy_read_struct(&png, &info, nullptr);
      return 2;
    }
  }
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return 0;
}

struct SinkContext {
  const PngRowSink* sink;
  absl::Status status;
};

bool CallSink(void* context, int y, const unsigned char* row) {
  auto* c = static_cast<SinkContext*>(context);
  try {
    c->status = (*c->sink)(y, row);
  } catch (const std::exception& e) {
    c->status = absl::ResourceExhaustedError(absl::StrCat("png decoding: ", e.what()));
  }
  return c->status.ok();
}

}  // namespace

int PngLayout::SamplesPerPixel() const {
  switch (color_type) {
    case 0:
    case 3:
      return 1;
    case 2:
      return 3;
    case 4:
      return 2;
    case 6:
      return 4;
    default:
      return 0;
  }
}

bool PngLayout::RowReadable() const {
  return (bit_depth == 8 || bit_depth == 16) && color_type != 3 && SamplesPerPixel() > 0 &&
         !interlaced;
}

absl::Status ReadPngLayout(const unsigned char* p, std::size_t n, PngLayout* layout) {
  if (n < 29 || std::memcmp(p + 12, "IHDR", 4) != 0) {
    return absl::InvalidArgumentError("malformed png header: no IHDR chunk first");
  }
  layout->width = static_cast<int>(BigEndian32(p + 16) & 0x7fffffffu);
  layout->height = static_cast<int>(BigEndian32(p + 20) & 0x7fffffffu);
  layout->bit_depth = p[24];
  layout->color_type = p[25];
  layout->interlaced = p[28] != 0;
  return absl::OkStatus();
}

absl::Status ReadPngRows(const unsigned char* data, std::size_t size, const PngLayout& layout,
                         const PngRowSink& sink) {
  if (!layout.RowReadable()) {
    return absl::InvalidArgumentError("png layout not read row by row here");
  }
  const int bytes_per_sample = layout.bit_depth / 8;
  std::vector<unsigned char> row(static_cast<std::size_t>(layout.width) *
                                 layout.SamplesPerPixel() * bytes_per_sample);
  Source source{data, size, 0};
  SinkContext context{&sink, absl::OkStatus()};
  char message[kMessageSize] = "";
  const std::uint16_t probe = 1;
  const bool little_endian = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  const int result = DecodeRows(&source, layout.height, layout.bit_depth == 16 && little_endian,
                                row.data(), row.size(), CallSink, &context, message);
  if (result == 2) return context.status;
  if (result == 1) {
    return absl::InvalidArgumentError(absl::StrCat("could not decode png data: ", message));
  }
  return absl::OkStatus();
}

}  // namespace weavefit
