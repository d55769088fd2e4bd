#include "estimator/io/decode.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <type_traits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "estimator/io/png_rows.h"

namespace weavefit {
namespace {

// Samples at exactly a file's largest value that make it a clip level.
constexpr std::size_t kMinClipPlateau = 2;
// The values below the largest whose counts a plateau must exceed: those
// within this share of it (a few codes of any bit depth).
constexpr float kPlateauNeighbourhood = 0.05f;

// A clip plateau, flagged as saturated: several samples at exactly the
// file's largest value, more than at any value just below it. A sensor
// clips at its own full scale, which a file of more bits carries below its
// maximum (a 12-bit ADC in a 16-bit file: 65520 of 65535) and a raw
// converter's white level may set anywhere; a render or an EXR clipped at
// any level does the same. Free radiance data thins toward its maximum and
// almost never repeats it; clipped samples pile up there. Unflagged, the
// comb fit took clipped glints for whole ones (coarse gauze at −120°,
// 640×480 EXR: spacing 0.32° off, against 0.007° from the same render as a
// 16-bit TIFF; with only 3 clipped samples, 0.07° off), and a lobe clipped
// at 65520 was fitted as if its flat top were the light. A false plateau
// (a tie at the top of an unclipped tail) costs a few samples.
void MarkClipPlateau(Image* image) {
  const std::vector<float>& v = image->pixels;
  float top = 0.0f;
  std::size_t at_top = 0;
  for (float x : v) {
    if (x > top) {
      top = x;
      at_top = 1;
    } else if (x == top) {
      ++at_top;
    }
  }
  if (!(top > 0.0f) || at_top < kMinClipPlateau || 2 * at_top >= v.size()) return;
  std::vector<float> near;
  for (float x : v) {
    if (x < top && x >= top * (1.0f - kPlateauNeighbourhood)) near.push_back(x);
  }
  std::sort(near.begin(), near.end());
  std::size_t most_below = 0;
  for (std::size_t i = 0; i < near.size();) {
    std::size_t j = i;
    while (j < near.size() && near[j] == near[i]) ++j;
    most_below = std::max(most_below, j - i);
    i = j;
  }
  if (at_top <= most_below) return;
  const int channels = image->channels;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] != top) continue;
    const std::size_t p = i / channels;
    image->MarkSaturated(static_cast<int>(p % image->width), static_cast<int>(p / image->width));
  }
}

std::uint32_t ReadBigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
         (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

std::uint32_t ReadTiff(const unsigned char* p, int size, bool little) {
  std::uint32_t v = 0;
  for (int i = 0; i < size; ++i) {
    const int shift = little ? 8 * i : 8 * (size - 1 - i);
    v |= std::uint32_t{p[i]} << shift;
  }
  return v;
}

absl::Status Malformed(const std::string& format, const std::string& what) {
  return absl::InvalidArgumentError(
      absl::StrCat("malformed ", format, " header: ", what));
}

absl::StatusOr<ImageHeader> ReadPngHeader(const unsigned char* p,
                                          std::size_t n) {
  if (n < 24 || std::memcmp(p + 12, "IHDR", 4) != 0) {
    return Malformed("PNG", "no IHDR chunk (file truncated?)");
  }
  ImageHeader header{"png", static_cast<int>(ReadBigEndian32(p + 16)),
                     static_cast<int>(ReadBigEndian32(p + 20))};
  PngLayout layout;
  if (ReadPngLayout(p, n, &layout).ok() && layout.SamplesPerPixel() > 0) {
    // A palette is expanded to BGR by OpenCV, the only path that reads it.
    header.samples = layout.color_type == 3 ? 3 : layout.SamplesPerPixel();
    header.bytes_per_sample = layout.bit_depth == 16 ? 2 : 1;
    header.whole_copy = !layout.RowReadable();
  }
  return header;
}

// Walks the PNG chunk list: every chunk must fit in the data and the list
// must end with IEND. libpng would otherwise report a truncated file on
// stderr itself and OpenCV may return a partial image.
absl::Status CheckPngComplete(const unsigned char* p, std::size_t n) {
  std::size_t at = 8;
  while (at + 12 <= n) {
    const std::uint64_t length = ReadBigEndian32(p + at);
    if (std::memcmp(p + at + 4, "IEND", 4) == 0) return absl::OkStatus();
    at += 12 + length;
  }
  return absl::InvalidArgumentError(
      "could not decode png data: the file is truncated (no IEND chunk)");
}

absl::StatusOr<ImageHeader> ReadJpegHeader(const unsigned char* p,
                                           std::size_t n) {
  std::size_t i = 2;
  while (i + 4 <= n) {
    if (p[i] != 0xFF) return Malformed("JPEG", "marker expected");
    const unsigned char marker = p[i + 1];
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    const std::size_t length = (std::size_t{p[i + 2]} << 8) | p[i + 3];
    const bool is_sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                        marker != 0xC8 && marker != 0xCC;
    if (is_sof) {
      if (i + 9 > n) break;
      const int height = (p[i + 5] << 8) | p[i + 6];
      const int width = (p[i + 7] << 8) | p[i + 8];
      ImageHeader header{"jpeg", width, height};
      header.bytes_per_sample = p[i + 4] > 8 ? 2 : 1;
      if (i + 10 <= n) header.samples = p[i + 9];
      return header;
    }
    if (length < 2) return Malformed("JPEG", "segment length below 2");
    i += 2 + length;
  }
  return Malformed("JPEG", "no frame header (file truncated?)");
}

absl::StatusOr<ImageHeader> ReadTiffHeader(const unsigned char* p,
                                           std::size_t n) {
  const bool little = p[0] == 'I';
  if (ReadTiff(p + 2, 2, little) != 42) {
    return absl::InvalidArgumentError("BigTIFF files are not supported");
  }
  const std::uint64_t ifd = ReadTiff(p + 4, 4, little);
  if (ifd + 2 > n) return Malformed("TIFF", "IFD offset beyond the file");
  const std::uint32_t entries = ReadTiff(p + ifd, 2, little);
  int width = -1;
  int height = -1;
  for (std::uint32_t e = 0; e < entries; ++e) {
    const std::uint64_t at = ifd + 2 + 12ULL * e;
    if (at + 12 > n) return Malformed("TIFF", "IFD truncated");
    const std::uint32_t tag = ReadTiff(p + at, 2, little);
    const std::uint32_t type = ReadTiff(p + at + 2, 2, little);
    if (tag != 256 && tag != 257) continue;
    const std::uint32_t value = type == 3 ? ReadTiff(p + at + 8, 2, little)
                                          : ReadTiff(p + at + 8, 4, little);
    (tag == 256 ? width : height) = static_cast<int>(value);
  }
  if (width < 0 || height < 0) return Malformed("TIFF", "no image size tags");
  return ImageHeader{"tiff", width, height};
}

// An OpenEXR input stream over bytes held in memory.
class MemoryIStream : public Imf::IStream {
 public:
  explicit MemoryIStream(const std::string& bytes)
      : Imf::IStream("memory"), bytes_(bytes) {}
  bool read(char c[], int n) override {
    // Compared without adding to position_, which a corrupt offset table
    // can seek to near 2^64 (the sum wrapped, and the copy read far out of
    // bounds: found by fuzz_decode_minute).
    if (n < 0 || position_ > bytes_.size() ||
        static_cast<std::uint64_t>(n) > bytes_.size() - position_) {
      throw std::runtime_error("EXR data truncated");
    }
    std::memcpy(c, bytes_.data() + position_, n);
    position_ += n;
    return position_ < bytes_.size();
  }
  std::uint64_t tellg() override { return position_; }
  void seekg(std::uint64_t pos) override { position_ = pos; }

 private:
  const std::string& bytes_;
  std::uint64_t position_ = 0;
};

// The size in bytes of an EXR attribute type whose values have one (the
// OpenEXR file layout); 0 for the types of variable size and unknown ones.
int ExrFixedSize(const std::string& type) {
  static const std::map<std::string, int> kSizes = {
      {"box2i", 16}, {"box2f", 16},     {"int", 4},        {"float", 4},   {"double", 8},
      {"v2i", 8},    {"v2f", 8},        {"v2d", 16},       {"v3i", 12},    {"v3f", 12},
      {"v3d", 24},   {"m33f", 36},      {"m33d", 72},      {"m44f", 64},   {"m44d", 128},
      {"compression", 1}, {"lineOrder", 1}, {"envmap", 1}, {"deepImageState", 1},
      {"chromaticities", 32}, {"rational", 8}, {"keycode", 28}, {"timecode", 8},
      {"tiledesc", 9}};
  const auto it = kSizes.find(type);
  return it == kSizes.end() ? 0 : it->second;
}

// Reads the dataWindow attribute from the EXR header's attribute list
// (name\0 type\0 size value ..., ended by an empty name) without OpenEXR,
// which would also read the line offset table: the size is known, and
// checked against the limit, before anything else is read or allocated.
absl::StatusOr<ImageHeader> ReadExrHeader(const std::string& bytes) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  auto read_string = [&](std::size_t* at) -> absl::StatusOr<std::string> {
    const std::size_t end = bytes.find('\0', *at);
    if (end == std::string::npos || end - *at > 255) {
      return Malformed("EXR", "attribute name or type not terminated");
    }
    std::string out = bytes.substr(*at, end - *at);
    *at = end + 1;
    return out;
  };
  auto read_int = [&](std::size_t at) {
    return static_cast<std::int32_t>(std::uint32_t{p[at]} | (std::uint32_t{p[at + 1]} << 8) |
                                     (std::uint32_t{p[at + 2]} << 16) |
                                     (std::uint32_t{p[at + 3]} << 24));
  };
  if (n < 8) return Malformed("EXR", "file truncated");
  if (p[5] & 0x10) return absl::InvalidArgumentError("multi-part EXR files are not supported");
  // The whole attribute list is checked before OpenEXR reads it: every
  // value within the data, the fixed-size types at their size, and the
  // list ended. (ASan in fuzz_decode_minute found the heap corrupt while
  // OpenEXR 3.1 unwound from a header whose last attribute ran past the
  // end; that input alone does not reproduce it, so an earlier malformed
  // one may have done the damage. No list that runs past the data or
  // misstates a fixed size reaches OpenEXR now.)
  // Each attribute once: OpenEXR 3.1 kept the first of two data windows
  // where this walk kept the last, and wrote a 65731 × 48 window into the
  // 2 × 1 image sized from it (ASan, fuzz_decode_minute).
  std::optional<ImageHeader> header;
  std::set<std::string> names;
  std::size_t at = 8;
  while (true) {
    if (at >= n) return Malformed("EXR", "header not terminated");
    absl::StatusOr<std::string> name = read_string(&at);
    if (!name.ok()) return name.status();
    if (name->empty()) break;  // end of the header
    if (!names.insert(*name).second) return Malformed("EXR", "an attribute is given twice");
    absl::StatusOr<std::string> type = read_string(&at);
    if (!type.ok()) return type.status();
    if (at + 4 > n) return Malformed("EXR", "attribute size truncated");
    const std::int32_t size = read_int(at);
    at += 4;
    if (size < 0 || static_cast<std::size_t>(size) > n - at) {
      return Malformed("EXR", "attribute value truncated");
    }
    const int fixed = ExrFixedSize(*type);
    if (fixed > 0 && size != fixed) {
      // (The type is one of the known names; the attribute's own name may
      // be any bytes, and stays out of the message.)
      return Malformed("EXR", absl::StrCat("an attribute of type ", *type, " has size ", size,
                                           ", not ", fixed));
    }
    if (*name == "dataWindow" && *type == "box2i" && size == 16) {
      const std::int64_t width = std::int64_t{read_int(at + 8)} - read_int(at) + 1;
      const std::int64_t height = std::int64_t{read_int(at + 12)} - read_int(at + 4) + 1;
      if (width <= 0 || height <= 0 || width > (1 << 30) || height > (1 << 30)) {
        return Malformed("EXR", "data window is empty or absurd");
      }
      header = ImageHeader{"exr", static_cast<int>(width), static_cast<int>(height)};
      header->whole_copy = false;  // read straight into the float image
    }
    at += size;
  }
  if (!header) return Malformed("EXR", "no dataWindow attribute");
  return *header;
}

Image EmptyImage(int width, int height, int channels, const std::string& format, int bit_depth) {
  Image image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  image.format = format;
  image.bit_depth = bit_depth;
  image.pixels.resize(static_cast<std::size_t>(width) * height * channels);
  return image;
}

// How stored samples become linear values: 8-bit through the sRGB curve
// (unless the request says linear), others divided by full scale; samples
// at or above `saturation` (0 = none) are flagged.
struct RowScale {
  RowScale(int bit_depth, double full_scale, const DecodeOptions& options)
      : full_scale(full_scale) {
    saturation = options.saturation_level > 0 ? options.saturation_level
                                              : (bit_depth == 32 ? 0.0 : full_scale);
    srgb = bit_depth == 8 && !options.pixels_linear;
    for (int v = 0; v < 256; ++v) table[v] = srgb ? SrgbToLinear(v / 255.0f) : v / 255.0f;
  }
  double full_scale;
  bool srgb = false;
  double saturation = 0.0;
  float table[256];
};

// Row y of `image` from `in_channels` interleaved samples per pixel (the
// first three, or the first alone, are kept; `bgr` when they come in
// OpenCV's order).
template <typename T>
void ConvertRow(const T* row, int in_channels, bool bgr, int y, const RowScale& scale,
                Image* image) {
  const int channels = image->channels;
  const std::size_t first = static_cast<std::size_t>(y) * image->width;
  float* out = image->pixels.data() + first * channels;
  for (int x = 0; x < image->width; ++x) {
    const T* px = row + static_cast<std::size_t>(x) * in_channels;
    bool saturated = false;
    for (int c = 0; c < channels; ++c) {
      const int source = channels == 3 && bgr ? 2 - c : c;
      const float raw = static_cast<float>(px[source]);
      float& value = out[static_cast<std::size_t>(x) * channels + c];
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(raw)) {
          saturated = true;
          value = 0.0f;
          continue;
        }
      }
      if (scale.saturation > 0 && raw >= scale.saturation) saturated = true;
      if constexpr (std::is_same_v<T, std::uint8_t>) {
        value = scale.table[px[source]];
      } else {
        value = static_cast<float>(raw / scale.full_scale);
      }
    }
    if (saturated) image->MarkSaturated(x, y);
  }
}

absl::StatusOr<Image> DecodeExr(const std::string& bytes,
                                const DecodeOptions& options,
                                const ImageHeader& header) {
  try {
    MemoryIStream stream(bytes);
    Imf::InputFile file(stream);
    const Imath::Box2i window = file.header().dataWindow();
    // The image is sized from weavefit's own reading of the header: OpenEXR
    // must write the same window into it.
    if (std::int64_t{window.max.x} - window.min.x + 1 != header.width ||
        std::int64_t{window.max.y} - window.min.y + 1 != header.height) {
      return Malformed("EXR", "the data window OpenEXR reads is not the header's");
    }
    const Imf::ChannelList& list = file.header().channels();
    std::vector<std::string> names;
    if (list.findChannel("R") && list.findChannel("G") &&
        list.findChannel("B")) {
      names = {"R", "G", "B"};
    } else if (list.findChannel("Y")) {
      names = {"Y"};
    } else if (list.begin() != list.end()) {
      names = {list.begin().name()};
    } else {
      return absl::InvalidArgumentError("EXR file has no channels");
    }
    Image image;
    image.width = header.width;
    image.height = header.height;
    image.channels = static_cast<int>(names.size());
    image.format = "exr";
    image.bit_depth = list.findChannel(names[0])->type == Imf::HALF ? 16 : 32;
    image.pixels.assign(
        static_cast<std::size_t>(image.width) * image.height * image.channels,
        0.0f);
    Imf::FrameBuffer frame;
    const std::size_t x_stride = sizeof(float) * image.channels;
    const std::size_t y_stride = x_stride * image.width;
    // OpenEXR addresses pixel (x, y) at base + x·xStride + y·yStride with the
    // data window's absolute coordinates: shift the base accordingly.
    const std::ptrdiff_t origin =
        -static_cast<std::ptrdiff_t>(window.min.x) * image.channels -
        static_cast<std::ptrdiff_t>(window.min.y) * image.width *
            image.channels;
    for (int c = 0; c < image.channels; ++c) {
      char* base = reinterpret_cast<char*>(image.pixels.data() + c) +
                   origin * static_cast<std::ptrdiff_t>(sizeof(float));
      frame.insert(names[c],
                   Imf::Slice(Imf::FLOAT, base, x_stride, y_stride, 1, 1, 0.0));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    const std::size_t count = static_cast<std::size_t>(image.width) * image.height;
    for (std::size_t i = 0; i < count; ++i) {
      for (int c = 0; c < image.channels; ++c) {
        const float v = image.pixels[i * image.channels + c];
        if (!std::isfinite(v)) {
          image.pixels[i * image.channels + c] = 0.0f;
          image.MarkSaturated(static_cast<int>(i % image.width), static_cast<int>(i / image.width));
        } else if (options.saturation_level > 0 &&
                   v >= options.saturation_level) {
          image.MarkSaturated(static_cast<int>(i % image.width), static_cast<int>(i / image.width));
        }
      }
    }
    return image;
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("could not decode EXR data: ", e.what()));
  }
}

absl::StatusOr<Image> DecodeWithOpenCv(const std::string& bytes,
                                       const DecodeOptions& options,
                                       const ImageHeader& header) {
  cv::Mat decoded;
  try {
    const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U,
                      const_cast<char*>(bytes.data()));
    decoded = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("could not decode ", header.format, " data: ", e.what()));
  }
  if (decoded.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "could not decode ", header.format, " data (truncated or corrupt file?)"));
  }
  if (decoded.cols != header.width || decoded.rows != header.height) {
    return absl::InvalidArgumentError("decoded size differs from the header");
  }
  double full_scale = 1.0;
  int bit_depth = 32;
  switch (decoded.depth()) {
    case CV_8U:
      full_scale = 255.0;
      bit_depth = 8;
      break;
    case CV_16U:
      full_scale = 65535.0;
      bit_depth = 16;
      break;
    case CV_32F:
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("unsupported sample type in ", header.format, " file"));
  }
  const int in_channels = decoded.channels();
  Image image = EmptyImage(decoded.cols, decoded.rows, in_channels >= 3 ? 3 : 1, header.format,
                           bit_depth);
  const RowScale scale(bit_depth, full_scale, options);
  image.srgb = scale.srgb;
  // Straight from the decoded samples, row by row (no float copy of the
  // whole image: on 12 Mpx that is 50 MB and a pass over the pixels).
  for (int y = 0; y < image.height; ++y) {
    // OpenCV stores BGR(A); Image is RGB.
    switch (decoded.depth()) {
      case CV_8U:
        ConvertRow(decoded.ptr<std::uint8_t>(y), in_channels, true, y, scale, &image);
        break;
      case CV_16U:
        ConvertRow(decoded.ptr<std::uint16_t>(y), in_channels, true, y, scale, &image);
        break;
      default:
        ConvertRow(decoded.ptr<float>(y), in_channels, true, y, scale, &image);
        break;
    }
  }
  return image;
}

// A PNG that libpng can hand over row by row (PngLayout::RowReadable): each
// row converted as it is decoded, so no whole decoded copy is ever held.
absl::StatusOr<Image> DecodePngByRows(const std::string& bytes, const DecodeOptions& options,
                                      const PngLayout& layout) {
  const int in_channels = layout.SamplesPerPixel();
  Image image = EmptyImage(layout.width, layout.height, in_channels >= 3 ? 3 : 1, "png",
                           layout.bit_depth);
  const RowScale scale(layout.bit_depth, layout.bit_depth == 8 ? 255.0 : 65535.0, options);
  image.srgb = scale.srgb;
  absl::Status s = ReadPngRows(
      reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), layout,
      [&](int y, const unsigned char* samples) {
        if (layout.bit_depth == 8) {
          ConvertRow(samples, in_channels, false, y, scale, &image);
        } else {
          ConvertRow(reinterpret_cast<const std::uint16_t*>(samples), in_channels, false, y, scale,
                     &image);
        }
        return absl::OkStatus();
      });
  if (!s.ok()) return s;
  return image;
}

}  // namespace

absl::Status DecodeOptions::Validate() const {
  if (!(saturation_level >= 0.0)) {
    return absl::InvalidArgumentError(
        "saturation_level must be >= 0 (0 = the format's maximum)");
  }
  if (max_pixels <= 0) {
    return absl::InvalidArgumentError("max_pixels must be > 0");
  }
  return absl::OkStatus();
}

std::int64_t DecodedBytes(const ImageHeader& header) {
  const std::int64_t pixels =
      std::max<std::int64_t>(0, header.width) * std::max<std::int64_t>(0, header.height);
  // Unknown layouts at the most a format here allows: 4 samples of 32 bits.
  const std::int64_t samples = header.samples > 0 ? std::min(header.samples, 4) : 4;
  const std::int64_t bytes_per_sample =
      header.bytes_per_sample > 0 ? std::min(header.bytes_per_sample, 4) : 4;
  const std::int64_t copy = header.whole_copy ? samples * bytes_per_sample : 0;
  const std::int64_t image = (header.samples > 0 && header.samples < 3 ? 1 : 3) * 4;
  const std::int64_t mask = 1;
  return pixels * (copy + image + mask);
}

absl::StatusOr<ImageHeader> ReadImageHeader(const std::string& bytes) {
  if (bytes.empty()) return absl::InvalidArgumentError("image is empty (0 bytes)");
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  absl::StatusOr<ImageHeader> header;
  if (n >= 8 && std::memcmp(p, "\x89PNG\r\n\x1a\n", 8) == 0) {
    header = ReadPngHeader(p, n);
  } else if (n >= 3 && p[0] == 0xFF && p[1] == 0xD8 && p[2] == 0xFF) {
    header = ReadJpegHeader(p, n);
  } else if (n >= 8 && (std::memcmp(p, "II*\0", 4) == 0 ||
                        std::memcmp(p, "MM\0*", 4) == 0 ||
                        std::memcmp(p, "II+\0", 4) == 0 ||
                        std::memcmp(p, "MM\0+", 4) == 0)) {
    header = ReadTiffHeader(p, n);
  } else if (n >= 4 && std::memcmp(p, "\x76\x2f\x31\x01", 4) == 0) {
    header = ReadExrHeader(bytes);
  } else {
    return absl::InvalidArgumentError(
        "unrecognised image format (expected PNG, TIFF, JPEG or EXR)");
  }
  if (!header.ok()) return header;
  if (header->width <= 0 || header->height <= 0) {
    return Malformed(header->format, "zero or negative image size");
  }
  return header;
}

namespace {

// The samples of a photograph whose header was read and checked, by format.
absl::StatusOr<Image> DecodeSamples(const std::string& bytes, const DecodeOptions& options,
                                    const ImageHeader& header) {
  if (header.format == "exr") return DecodeExr(bytes, options, header);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (header.format == "png") {
    if (absl::Status s = CheckPngComplete(p, bytes.size()); !s.ok()) return s;
    PngLayout layout;
    if (absl::Status s = ReadPngLayout(p, bytes.size(), &layout); !s.ok()) return s;
    if (layout.RowReadable()) return DecodePngByRows(bytes, options, layout);
  }
  // libjpeg only warns about a truncated stream and fills the missing rows
  // with grey, so OpenCV would return made-up pixels: require the end-of-image
  // marker after the last start-of-scan (0xFF cannot occur unstuffed in
  // entropy-coded data).
  if (header.format == "jpeg") {
    const std::size_t sos = bytes.rfind("\xFF\xDA");
    const std::size_t eoi = bytes.rfind("\xFF\xD9");
    if (sos == std::string::npos || eoi == std::string::npos || eoi < sos) {
      return absl::InvalidArgumentError(
          "could not decode jpeg data: no end-of-image marker after the last "
          "scan (truncated file?)");
    }
  }
  return DecodeWithOpenCv(bytes, options, header);
}

}  // namespace

absl::StatusOr<Image> DecodeImage(const std::string& bytes,
                                  const DecodeOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
  if (!header.ok()) return header.status();
  const std::int64_t pixels =
      static_cast<std::int64_t>(header->width) * header->height;
  if (pixels > options.max_pixels) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "image of ", header->width, "x", header->height, " = ", pixels,
        " pixels exceeds the limit of ", options.max_pixels, " pixels"));
  }
  absl::StatusOr<Image> image = DecodeSamples(bytes, options, *header);
  if (image.ok() && options.saturation_level == 0) MarkClipPlateau(&*image);
  return image;
}

}  // namespace weavefit
