// Unit tests of the row-by-row PNG path (io/png_rows.h through DecodeImage):
// every layout it takes gives the values OpenCV's decoder gives for the same
// file, the layouts it leaves to OpenCV still decode, a corrupt stream is a
// clear error, and the saturation mask exists only when a pixel is saturated.
#include "estimator/io/png_rows.h"

#include <gtest/gtest.h>
#include <png.h>

#include <csetjmp>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "estimator/io/decode.h"
#include "estimator/io/image.h"

namespace weavefit {
namespace {

void AppendBytes(png_structp png, png_bytep data, std::size_t n) {
  auto* out = static_cast<std::string*>(png_get_io_ptr(png));
  out->append(reinterpret_cast<const char*>(data), n);
}
void Flush(png_structp) {}

// A PNG of `samples` (big-endian already for 16 bits) written by libpng with
// the given layout; a palette of grey levels for colour type 3.
std::string WritePng(int width, int height, int bit_depth, int color_type, bool interlaced,
                     const std::vector<unsigned char>& samples) {
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    ADD_FAILURE() << "libpng could not write the test file";
    return std::string();
  }
  png_set_write_fn(png, &out, AppendBytes, Flush);
  png_set_IHDR(png, info, width, height, bit_depth, color_type,
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  std::vector<png_color> palette(256);
  if (color_type == PNG_COLOR_TYPE_PALETTE) {
    for (int i = 0; i < 256; ++i) {
      palette[i] = {static_cast<png_byte>(i), static_cast<png_byte>(255 - i),
                    static_cast<png_byte>(i / 2)};
    }
    png_set_PLTE(png, info, palette.data(), 1 << bit_depth);
  }
  png_write_info(png, info);
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  std::vector<png_bytep> rows(height);
  for (int y = 0; y < height; ++y) {
    rows[y] = const_cast<png_bytep>(samples.data() + y * row_bytes);
  }
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

std::vector<unsigned char> RandomBytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<unsigned char> out(n);
  for (unsigned char& b : out) b = static_cast<unsigned char>(byte(rng));
  return out;
}

// What the OpenCV path makes of the file: its decoded samples (BGR(A) order)
// scaled as DecodeImage scales them.
Image ThroughOpenCv(const std::string& bytes, bool linear) {
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  const cv::Mat m = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  Image image;
  image.width = m.cols;
  image.height = m.rows;
  image.channels = m.channels() >= 3 ? 3 : 1;
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      for (int c = 0; c < image.channels; ++c) {
        const int source = image.channels == 3 ? 2 - c : 0;
        const int index = x * m.channels() + source;
        if (m.depth() == CV_16U) {
          image.pixels.push_back(
              static_cast<float>(static_cast<float>(m.ptr<std::uint16_t>(y)[index]) / 65535.0));
        } else {
          const float v = m.ptr<std::uint8_t>(y)[index] / 255.0f;
          image.pixels.push_back(linear ? v : SrgbToLinear(v));
        }
      }
    }
  }
  return image;
}

struct Layout {
  int bit_depth;
  int color_type;
  bool interlaced;
  int channels;  // of the decoded Image
};

class PngLayoutTest : public testing::TestWithParam<Layout> {};

TEST_P(PngLayoutTest, SameValuesAsOpenCv) {
  const Layout& l = GetParam();
  const int width = 37, height = 23;
  PngLayout probe;
  probe.bit_depth = l.bit_depth;
  probe.color_type = l.color_type;
  const std::size_t row_bits = static_cast<std::size_t>(width) * probe.SamplesPerPixel() * l.bit_depth;
  std::vector<unsigned char> samples =
      RandomBytes((row_bits + 7) / 8 * height, 7 + l.bit_depth + 17 * l.color_type);
  const std::string bytes = WritePng(width, height, l.bit_depth, l.color_type, l.interlaced, samples);
  ASSERT_FALSE(bytes.empty());
  PngLayout layout;
  ASSERT_TRUE(ReadPngLayout(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(),
                            &layout).ok());
  EXPECT_EQ(layout.width, width);
  EXPECT_EQ(layout.height, height);
  EXPECT_EQ(layout.interlaced, l.interlaced);
  for (bool linear : {false, true}) {
    DecodeOptions options;
    options.pixels_linear = linear;
    absl::StatusOr<Image> image = DecodeImage(bytes, options);
    ASSERT_TRUE(image.ok()) << image.status();
    const Image expected = ThroughOpenCv(bytes, linear);
    ASSERT_EQ(image->channels, l.channels);
    // OpenCV turns grey with alpha into BGRA: the grey is any of its three.
    const int stride = expected.channels / image->channels;
    ASSERT_EQ(image->pixels.size() * stride, expected.pixels.size());
    for (std::size_t i = 0; i < image->pixels.size(); ++i) {
      ASSERT_EQ(image->pixels[i], expected.pixels[i * stride]) << "sample " << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Layouts, PngLayoutTest,
    testing::Values(Layout{8, PNG_COLOR_TYPE_GRAY, false, 1}, Layout{16, PNG_COLOR_TYPE_GRAY, false, 1},
                    Layout{8, PNG_COLOR_TYPE_RGB, false, 3}, Layout{16, PNG_COLOR_TYPE_RGB, false, 3},
                    Layout{16, PNG_COLOR_TYPE_RGB_ALPHA, false, 3},
                    Layout{8, PNG_COLOR_TYPE_RGB_ALPHA, false, 3},
                    Layout{8, PNG_COLOR_TYPE_GRAY_ALPHA, false, 1},
                    Layout{16, PNG_COLOR_TYPE_GRAY_ALPHA, false, 1},
                    // Left to OpenCV: interlaced, palette.
                    Layout{16, PNG_COLOR_TYPE_GRAY, true, 1}, Layout{8, PNG_COLOR_TYPE_RGB, true, 3},
                    Layout{8, PNG_COLOR_TYPE_PALETTE, false, 3}));

TEST(PngRowsTest, WhichLayoutsAreReadByRows) {
  PngLayout l;
  l.bit_depth = 16;
  l.color_type = 0;
  EXPECT_TRUE(l.RowReadable());
  l.interlaced = true;
  EXPECT_FALSE(l.RowReadable());
  l.interlaced = false;
  l.color_type = 3;
  EXPECT_FALSE(l.RowReadable());
  l.color_type = 4;
  l.bit_depth = 4;
  EXPECT_FALSE(l.RowReadable());
  l.bit_depth = 8;
  EXPECT_TRUE(l.RowReadable());
  EXPECT_EQ(l.SamplesPerPixel(), 2);
}

TEST(PngRowsTest, CorruptImageDataIsAClearError) {
  const int width = 64, height = 48;
  const std::string good = WritePng(width, height, 16, PNG_COLOR_TYPE_GRAY, false,
                                    RandomBytes(width * height * 2, 3));
  const std::size_t idat = good.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  std::string bad = good;
  for (std::size_t i = idat + 40; i < idat + 90 && i < bad.size(); ++i) bad[i] ^= 0x5a;
  absl::StatusOr<Image> image = DecodeImage(bad, DecodeOptions());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(image.status().message().find("png"), std::string_view::npos) << image.status();
}

TEST(PngRowsTest, SinkErrorStopsDecoding) {
  const int width = 16, height = 16;
  const std::string bytes = WritePng(width, height, 8, PNG_COLOR_TYPE_GRAY, false,
                                     RandomBytes(width * height, 5));
  PngLayout layout;
  ASSERT_TRUE(ReadPngLayout(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(),
                            &layout).ok());
  int rows = 0;
  const absl::Status s = ReadPngRows(
      reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), layout,
      [&](int y, const unsigned char*) {
        ++rows;
        return y == 3 ? absl::CancelledError("stop at row 3") : absl::OkStatus();
      });
  EXPECT_EQ(s.code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(rows, 4);
}

TEST(PngRowsTest, MaskOnlyWhenSomethingIsSaturated) {
  const int width = 20, height = 10;
  std::vector<unsigned char> samples(width * height * 2, 0x40);
  const std::string clear = WritePng(width, height, 16, PNG_COLOR_TYPE_GRAY, false, samples);
  absl::StatusOr<Image> a = DecodeImage(clear, DecodeOptions());
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_TRUE(a->saturated.empty());
  EXPECT_EQ(a->SaturatedCount(), 0);
  // Pixel (7, 4) at full scale.
  samples[(4 * width + 7) * 2] = 0xff;
  samples[(4 * width + 7) * 2 + 1] = 0xff;
  const std::string one = WritePng(width, height, 16, PNG_COLOR_TYPE_GRAY, false, samples);
  absl::StatusOr<Image> b = DecodeImage(one, DecodeOptions());
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_EQ(b->SaturatedCount(), 1);
  EXPECT_TRUE(b->IsSaturated(7, 4));
  EXPECT_FALSE(b->IsSaturated(6, 4));
  EXPECT_EQ(b->At(7, 4), 1.0f);
}

}  // namespace
}  // namespace weavefit
