// Unit tests of io/: DecodeImage / EncodeImage round trips per format, the
// saturation mask, header reading, decoding errors and Luminance.
#include "estimator/io/decode.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/io/encode.h"
#include "estimator/io/image.h"

namespace weavefit {
namespace {

// A w×h image with the given channels, values uniform in [lo, hi) from a
// fixed seed.
Image RandomImage(int width, int height, int channels, float lo, float hi,
                  std::uint32_t seed) {
  Image image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(lo, hi);
  image.pixels.resize(static_cast<std::size_t>(width) * height * channels);
  for (float& v : image.pixels) v = value(rng);
  return image;
}

std::string Encode(const Image& image, EncodeFormat format) {
  absl::StatusOr<std::string> bytes = EncodeImage(image, format);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return bytes.ok() ? *bytes : std::string();
}

Image Decode(const std::string& bytes, const DecodeOptions& options = {}) {
  absl::StatusOr<Image> image = DecodeImage(bytes, options);
  EXPECT_TRUE(image.ok()) << image.status();
  return image.ok() ? *image : Image();
}

// An 8-bit file written by OpenCV itself (BGR order for 3 channels).
std::string EncodeWithOpenCv(const cv::Mat& mat, const char* ext) {
  std::vector<unsigned char> buffer;
  EXPECT_TRUE(cv::imencode(ext, mat, buffer));
  return std::string(buffer.begin(), buffer.end());
}

void ExpectSameShape(const Image& a, const Image& b) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  ASSERT_EQ(a.channels, b.channels);
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
}

TEST(SrgbTest, HandComputedValues) {
  EXPECT_FLOAT_EQ(SrgbToLinear(0.0f), 0.0f);
  EXPECT_FLOAT_EQ(SrgbToLinear(1.0f), 1.0f);
  // Linear segment below 0.04045.
  EXPECT_FLOAT_EQ(SrgbToLinear(0.04f), 0.04f / 12.92f);
  // ((0.5 + 0.055) / 1.055)^2.4.
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.2140411, 2e-6);
  for (float v = 0.0f; v <= 1.0f; v += 0.01f) {
    EXPECT_NEAR(LinearToSrgb(SrgbToLinear(v)), v, 2e-6) << v;
  }
}

TEST(DecodeTest, Png16RoundTripGray) {
  const Image original = RandomImage(37, 23, 1, 0.0f, 1.0f, 1);
  const std::string bytes = Encode(original, EncodeFormat::kPng16);
  const Image decoded = Decode(bytes);
  ExpectSameShape(decoded, original);
  EXPECT_EQ(decoded.format, "png");
  EXPECT_EQ(decoded.bit_depth, 16);
  for (std::size_t i = 0; i < original.pixels.size(); ++i) {
    ASSERT_NEAR(decoded.pixels[i], original.pixels[i], 0.5 / 65535 + 1e-7) << i;
  }
}

TEST(DecodeTest, Png16RoundTripRgbKeepsChannelOrder) {
  Image original = RandomImage(16, 9, 3, 0.0f, 1.0f, 2);
  // A pure red pixel must stay red (OpenCV works in BGR internally).
  original.pixels[0] = 0.9f;
  original.pixels[1] = 0.0f;
  original.pixels[2] = 0.1f;
  const Image decoded = Decode(Encode(original, EncodeFormat::kPng16));
  ExpectSameShape(decoded, original);
  EXPECT_NEAR(decoded.At(0, 0, 0), 0.9f, 1e-5);
  EXPECT_NEAR(decoded.At(0, 0, 1), 0.0f, 1e-5);
  EXPECT_NEAR(decoded.At(0, 0, 2), 0.1f, 1e-5);
  for (std::size_t i = 0; i < original.pixels.size(); ++i) {
    ASSERT_NEAR(decoded.pixels[i], original.pixels[i], 0.5 / 65535 + 1e-7) << i;
  }
}

TEST(DecodeTest, Png16ClipsOutOfRangeValues) {
  Image original = RandomImage(4, 4, 1, 0.2f, 0.8f, 3);
  original.pixels[0] = -0.5f;
  original.pixels[1] = 1.7f;
  const Image decoded = Decode(Encode(original, EncodeFormat::kPng16));
  ExpectSameShape(decoded, original);
  EXPECT_EQ(decoded.pixels[0], 0.0f);
  EXPECT_EQ(decoded.pixels[1], 1.0f);
}

TEST(DecodeTest, Png8RoundTripIsExactOnCodeValues) {
  // Linear values that are exactly sRGB code values survive 8-bit encoding.
  Image original;
  original.width = 256;
  original.height = 1;
  original.channels = 1;
  for (int code = 0; code < 256; ++code) {
    original.pixels.push_back(SrgbToLinear(code / 255.0f));
  }
  const Image decoded = Decode(Encode(original, EncodeFormat::kPng8));
  ExpectSameShape(decoded, original);
  EXPECT_EQ(decoded.bit_depth, 8);
  for (int code = 0; code < 256; ++code) {
    ASSERT_FLOAT_EQ(decoded.pixels[code], SrgbToLinear(code / 255.0f)) << code;
  }
}

TEST(DecodeTest, Png8KnownValueIsLinearised) {
  const cv::Mat gray(3, 5, CV_8UC1, cv::Scalar(128));
  const std::string bytes = EncodeWithOpenCv(gray, ".png");
  const Image decoded = Decode(bytes);
  ASSERT_EQ(decoded.channels, 1);
  // ((128/255 + 0.055) / 1.055)^2.4 = 0.2158605.
  EXPECT_NEAR(decoded.At(2, 1), 0.2158605, 1e-6);
  EXPECT_FLOAT_EQ(decoded.At(2, 1), SrgbToLinear(128 / 255.0f));

  DecodeOptions linear;
  linear.pixels_linear = true;
  const Image raw = Decode(bytes, linear);
  EXPECT_FLOAT_EQ(raw.At(2, 1), 128 / 255.0f);
}

TEST(DecodeTest, Png8RgbKnownValues) {
  // OpenCV stores BGR: Scalar(b, g, r).
  const cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(10, 128, 250));
  const Image decoded = Decode(EncodeWithOpenCv(bgr, ".png"));
  ASSERT_EQ(decoded.channels, 3);
  EXPECT_FLOAT_EQ(decoded.At(1, 1, 0), SrgbToLinear(250 / 255.0f));
  EXPECT_FLOAT_EQ(decoded.At(1, 1, 1), SrgbToLinear(128 / 255.0f));
  EXPECT_FLOAT_EQ(decoded.At(1, 1, 2), SrgbToLinear(10 / 255.0f));
}

TEST(DecodeTest, Tiff16RoundTrip) {
  for (int channels : {1, 3}) {
    const Image original = RandomImage(29, 17, channels, 0.0f, 1.0f, 4);
    const std::string bytes = Encode(original, EncodeFormat::kTiff16);
    const Image decoded = Decode(bytes);
    ExpectSameShape(decoded, original);
    EXPECT_EQ(decoded.format, "tiff");
    EXPECT_EQ(decoded.bit_depth, 16);
    for (std::size_t i = 0; i < original.pixels.size(); ++i) {
      ASSERT_NEAR(decoded.pixels[i], original.pixels[i], 0.5 / 65535 + 1e-7)
          << "channels " << channels << " sample " << i;
    }
  }
}

TEST(DecodeTest, ExrRoundTripIsExactAndUnclipped) {
  for (int channels : {1, 3}) {
    Image original = RandomImage(31, 13, channels, -0.5f, 4.0f, 5);
    original.pixels[0] = 1e-30f;
    original.pixels[1] = 12345.678f;
    const std::string bytes = Encode(original, EncodeFormat::kExr);
    const Image decoded = Decode(bytes);
    ExpectSameShape(decoded, original);
    EXPECT_EQ(decoded.format, "exr");
    EXPECT_EQ(decoded.bit_depth, 32);
    for (std::size_t i = 0; i < original.pixels.size(); ++i) {
      ASSERT_EQ(decoded.pixels[i], original.pixels[i])
          << "channels " << channels << " sample " << i;
    }
    // EXR has no format maximum: nothing is saturated by default.
    EXPECT_EQ(decoded.SaturatedCount(), 0);
  }
}

TEST(DecodeTest, ExrSaturationLevelAndNonFiniteValues) {
  Image original = RandomImage(8, 4, 1, 0.0f, 1.0f, 6);
  original.pixels[3] = 2.5f;
  original.pixels[5] = std::numeric_limits<float>::infinity();
  original.pixels[7] = std::numeric_limits<float>::quiet_NaN();
  const std::string bytes = Encode(original, EncodeFormat::kExr);

  const Image plain = Decode(bytes);
  // Non-finite samples are zeroed and flagged.
  EXPECT_EQ(plain.pixels[5], 0.0f);
  EXPECT_EQ(plain.pixels[7], 0.0f);
  EXPECT_TRUE(plain.IsSaturated(5, 0));
  EXPECT_TRUE(plain.IsSaturated(7, 0));
  EXPECT_FALSE(plain.IsSaturated(3, 0));
  EXPECT_EQ(plain.SaturatedCount(), 2);

  DecodeOptions options;
  options.saturation_level = 2.0;
  const Image clipped = Decode(bytes, options);
  EXPECT_TRUE(clipped.IsSaturated(3, 0));
  EXPECT_EQ(clipped.pixels[3], 2.5f);
  EXPECT_EQ(clipped.SaturatedCount(), 3);
}

// A render or a sensor that clipped leaves a plateau at the file's largest
// value: two or more samples there are flagged; a single largest value is
// taken as it is.
TEST(DecodeTest, ExrClipPlateauIsFlagged) {
  Image original = RandomImage(8, 4, 1, 0.0f, 0.9f, 7);
  original.pixels[9] = 1.0f;
  const Image single = Decode(Encode(original, EncodeFormat::kExr));
  EXPECT_EQ(single.SaturatedCount(), 0);
  original.pixels[20] = 1.0f;
  const Image clipped = Decode(Encode(original, EncodeFormat::kExr));
  EXPECT_TRUE(clipped.IsSaturated(1, 1));
  EXPECT_TRUE(clipped.IsSaturated(4, 2));
  EXPECT_EQ(clipped.SaturatedCount(), 2);
  EXPECT_EQ(clipped.pixels[20], 1.0f);
}

// A 12-bit sensor's data in a 16-bit file clips at 65520, below the
// format's maximum: the samples piled up there are flagged, in PNG and TIFF.
TEST(DecodeTest, ClipPlateauBelowTheFormatMaximumIsFlagged) {
  Image original = RandomImage(16, 8, 1, 0.1f, 0.9f, 11);
  const float white = 65520.0f / 65535.0f;
  for (int i : {5, 40, 41, 42, 77, 100}) original.pixels[i] = white;
  for (EncodeFormat format : {EncodeFormat::kPng16, EncodeFormat::kTiff16}) {
    const Image decoded = Decode(Encode(original, format));
    EXPECT_EQ(decoded.SaturatedCount(), 6);
    EXPECT_TRUE(decoded.IsSaturated(5, 0));
    EXPECT_TRUE(decoded.IsSaturated(4, 6));
  }
  // With the level given, only samples at or above it are.
  DecodeOptions options;
  options.saturation_level = 65535;
  EXPECT_EQ(Decode(Encode(original, EncodeFormat::kPng16), options).SaturatedCount(), 0);
}

// An unclipped tail thins toward its largest value: a tie there that is no
// larger than the counts just below it is not a plateau.
TEST(DecodeTest, TiesAtTheTopOfATailAreNotAPlateau) {
  Image original = RandomImage(16, 8, 1, 0.1f, 0.5f, 13);
  const float code = 1.0f / 65535.0f;
  const float top = 40000.0f * code;
  // Two samples at the top, three one code below, four two codes below.
  original.pixels[1] = original.pixels[2] = top;
  for (int i : {10, 11, 12}) original.pixels[i] = top - code;
  for (int i : {20, 21, 22, 23}) original.pixels[i] = top - 2.0f * code;
  EXPECT_EQ(Decode(Encode(original, EncodeFormat::kPng16)).SaturatedCount(), 0);
  // Five at the top: a pile-up.
  for (int i : {3, 4, 5}) original.pixels[i] = top;
  EXPECT_EQ(Decode(Encode(original, EncodeFormat::kPng16)).SaturatedCount(), 5);
}

TEST(DecodeTest, JpegRoundTripIsApproximate) {
  // A smooth gradient: JPEG at quality 95 keeps it within a few codes.
  Image original;
  original.width = 64;
  original.height = 32;
  original.channels = 1;
  for (int y = 0; y < original.height; ++y) {
    for (int x = 0; x < original.width; ++x) {
      original.pixels.push_back(0.05f + 0.9f * (x + y) / 94.0f);
    }
  }
  const std::string bytes = Encode(original, EncodeFormat::kJpeg);
  const Image decoded = Decode(bytes);
  ExpectSameShape(decoded, original);
  EXPECT_EQ(decoded.format, "jpeg");
  EXPECT_EQ(decoded.bit_depth, 8);
  double max_error = 0.0;
  for (std::size_t i = 0; i < original.pixels.size(); ++i) {
    const double e = std::fabs(LinearToSrgb(decoded.pixels[i]) -
                               LinearToSrgb(original.pixels[i]));
    max_error = std::max(max_error, e);
  }
  EXPECT_LT(max_error, 4.0 / 255.0);
  EXPECT_GT(max_error, 0.0) << "JPEG is lossy; an exact match is suspicious";
}

TEST(DecodeTest, SaturationMaskAtFormatMaximum) {
  Image original = RandomImage(10, 3, 1, 0.1f, 0.9f, 7);
  original.pixels[4] = 1.0f;        // full scale
  original.pixels[12] = 1.5f;       // clipped to full scale
  original.pixels[20] = 0.99999f;   // one code below full scale in 16 bit
  for (EncodeFormat format :
       {EncodeFormat::kPng16, EncodeFormat::kTiff16, EncodeFormat::kPng8}) {
    const Image decoded = Decode(Encode(original, format));
    ASSERT_FALSE(decoded.saturated.empty());
    EXPECT_TRUE(decoded.IsSaturated(4, 0));
    EXPECT_TRUE(decoded.IsSaturated(2, 1));
    if (format != EncodeFormat::kPng8) {
      EXPECT_FALSE(decoded.IsSaturated(0, 2));
      EXPECT_EQ(decoded.SaturatedCount(), 2);
    }
  }
}

TEST(DecodeTest, SaturationMaskWithCustomLevel) {
  // 16 bit: level in file units.
  Image original;
  original.width = 4;
  original.height = 1;
  original.channels = 1;
  original.pixels = {59999 / 65535.0f, 60000 / 65535.0f, 61000 / 65535.0f,
                     0.5f};
  DecodeOptions options;
  options.saturation_level = 60000;
  const Image decoded = Decode(Encode(original, EncodeFormat::kPng16), options);
  EXPECT_FALSE(decoded.IsSaturated(0, 0));
  EXPECT_TRUE(decoded.IsSaturated(1, 0));
  EXPECT_TRUE(decoded.IsSaturated(2, 0));
  EXPECT_FALSE(decoded.IsSaturated(3, 0));

  // 8 bit: a pixel saturates when any channel reaches the level.
  cv::Mat bgr(1, 3, CV_8UC3, cv::Scalar(0, 0, 0));
  bgr.at<cv::Vec3b>(0, 0) = {199, 100, 100};
  bgr.at<cv::Vec3b>(0, 1) = {10, 200, 10};  // green at the level
  bgr.at<cv::Vec3b>(0, 2) = {255, 0, 0};
  DecodeOptions eight;
  eight.saturation_level = 200;
  const Image rgb = Decode(EncodeWithOpenCv(bgr, ".png"), eight);
  EXPECT_FALSE(rgb.IsSaturated(0, 0));
  EXPECT_TRUE(rgb.IsSaturated(1, 0));
  EXPECT_TRUE(rgb.IsSaturated(2, 0));
  EXPECT_EQ(rgb.SaturatedCount(), 2);
}

TEST(ReadImageHeaderTest, DimensionsPerFormat) {
  const Image original = RandomImage(41, 19, 3, 0.0f, 1.0f, 8);
  const struct {
    EncodeFormat format;
    const char* name;
  } cases[] = {{EncodeFormat::kPng16, "png"},
               {EncodeFormat::kPng8, "png"},
               {EncodeFormat::kTiff16, "tiff"},
               {EncodeFormat::kExr, "exr"},
               {EncodeFormat::kJpeg, "jpeg"}};
  for (const auto& c : cases) {
    const std::string bytes = Encode(original, c.format);
    absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
    ASSERT_TRUE(header.ok()) << c.name << ": " << header.status();
    EXPECT_EQ(header->format, c.name);
    EXPECT_EQ(header->width, 41) << c.name;
    EXPECT_EQ(header->height, 19) << c.name;
  }
}

TEST(DecodeErrorTest, EmptyInput) {
  absl::StatusOr<Image> image = DecodeImage("", DecodeOptions());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ReadImageHeader("").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(DecodeErrorTest, RandomBytes) {
  std::mt19937 rng(9);
  std::string bytes(4096, '\0');
  for (char& c : bytes) c = static_cast<char>(rng() & 0xFF);
  bytes[0] = 'x';  // no accidental signature
  absl::StatusOr<Image> image = DecodeImage(bytes, DecodeOptions());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(image.status().message()).find("unrecognised"),
            std::string::npos)
      << image.status();
}

TEST(DecodeErrorTest, TruncatedFiles) {
  const Image original = RandomImage(64, 48, 3, 0.0f, 1.0f, 10);
  for (EncodeFormat format :
       {EncodeFormat::kPng16, EncodeFormat::kPng8, EncodeFormat::kTiff16,
        EncodeFormat::kExr}) {
    const std::string bytes = Encode(original, format);
    const std::string half = bytes.substr(0, bytes.size() / 2);
    absl::StatusOr<Image> image = DecodeImage(half, DecodeOptions());
    ASSERT_FALSE(image.ok()) << EncodeFormatExtension(format);
    EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument)
        << EncodeFormatExtension(format) << ": " << image.status();
  }
  // Only the PNG signature: no IHDR.
  const std::string png = Encode(original, EncodeFormat::kPng16);
  absl::StatusOr<Image> image = DecodeImage(png.substr(0, 10), DecodeOptions());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
}

// libjpeg only warns on a truncated stream and invents grey rows; the
// decoder must report the damage rather than return made-up pixels.
TEST(DecodeErrorTest, TruncatedJpeg) {
  const Image original = RandomImage(64, 48, 3, 0.0f, 1.0f, 10);
  const std::string bytes = Encode(original, EncodeFormat::kJpeg);
  ASSERT_TRUE(DecodeImage(bytes, DecodeOptions()).ok());
  for (std::size_t keep : {bytes.size() / 2, bytes.size() - 2}) {
    absl::StatusOr<Image> image =
        DecodeImage(bytes.substr(0, keep), DecodeOptions());
    ASSERT_FALSE(image.ok()) << "kept " << keep << " of " << bytes.size();
    EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  }
}

// A PNG signature and an IHDR chunk claiming width × height, then garbage
// instead of image data: only the header can be read.
std::string FakePngHeader(std::uint32_t width, std::uint32_t height) {
  std::string bytes("\x89PNG\r\n\x1a\n", 8);
  auto put32 = [&](std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) {
      bytes.push_back(static_cast<char>((v >> shift) & 0xFF));
    }
  };
  put32(13);
  bytes += "IHDR";
  put32(width);
  put32(height);
  bytes += std::string("\x10\x00\x00\x00\x00", 5);  // 16 bit gray
  put32(0);                                          // CRC (not checked)
  bytes += std::string(64, '\x5a');
  return bytes;
}

TEST(DecodeErrorTest, HugeHeaderIsRejectedBeforeDecoding) {
  const std::string bytes = FakePngHeader(100000, 100000);
  absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
  ASSERT_TRUE(header.ok()) << header.status();
  EXPECT_EQ(header->width, 100000);
  EXPECT_EQ(header->height, 100000);

  DecodeOptions options;
  options.max_pixels = 1000;
  absl::StatusOr<Image> image = DecodeImage(bytes, options);
  ASSERT_FALSE(image.ok());
  // Had decoding been attempted, the garbage body would give INVALID_ARGUMENT.
  EXPECT_EQ(image.status().code(), absl::StatusCode::kResourceExhausted)
      << image.status();
  // The default limit (64 Mpixel) also refuses 10^10 pixels.
  EXPECT_EQ(DecodeImage(bytes, DecodeOptions()).status().code(),
            absl::StatusCode::kResourceExhausted);
}

TEST(DecodeErrorTest, RealFileOverTheLimit) {
  const Image original = RandomImage(20, 20, 1, 0.0f, 1.0f, 11);
  const std::string bytes = Encode(original, EncodeFormat::kPng16);
  DecodeOptions options;
  options.max_pixels = 399;
  EXPECT_EQ(DecodeImage(bytes, options).status().code(),
            absl::StatusCode::kResourceExhausted);
  options.max_pixels = 400;
  EXPECT_TRUE(DecodeImage(bytes, options).ok());
}

TEST(DecodeErrorTest, ZeroSizeHeader) {
  absl::StatusOr<Image> image = DecodeImage(FakePngHeader(0, 10), DecodeOptions());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(DecodeOptionsTest, ValidateNamesTheField) {
  DecodeOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.saturation_level = -1.0;
  absl::Status status = options.Validate();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(status.message()).find("saturation_level"),
            std::string::npos);
  options = DecodeOptions();
  options.max_pixels = 0;
  status = options.Validate();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(status.message()).find("max_pixels"), std::string::npos);
}

TEST(EncodeTest, RejectsMalformedImagesAndParsesFormats) {
  Image bad;
  EXPECT_EQ(EncodeImage(bad, EncodeFormat::kPng16).status().code(),
            absl::StatusCode::kInvalidArgument);
  bad = RandomImage(4, 4, 1, 0.0f, 1.0f, 12);
  bad.pixels.pop_back();
  EXPECT_EQ(EncodeImage(bad, EncodeFormat::kPng16).status().code(),
            absl::StatusCode::kInvalidArgument);
  bad = RandomImage(4, 4, 2, 0.0f, 1.0f, 12);
  EXPECT_EQ(EncodeImage(bad, EncodeFormat::kExr).status().code(),
            absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(*ParseEncodeFormat("png"), EncodeFormat::kPng16);
  EXPECT_EQ(*ParseEncodeFormat("png8"), EncodeFormat::kPng8);
  EXPECT_EQ(*ParseEncodeFormat("tif"), EncodeFormat::kTiff16);
  EXPECT_EQ(*ParseEncodeFormat("exr"), EncodeFormat::kExr);
  EXPECT_EQ(*ParseEncodeFormat("jpg"), EncodeFormat::kJpeg);
  EXPECT_FALSE(ParseEncodeFormat("bmp").ok());
}

TEST(SaturationMaskTest, HoldsOnlyTheRowsWithAFlag) {
  SaturationMask mask;
  EXPECT_TRUE(mask.empty());
  EXPECT_EQ(mask.Row(3), nullptr);
  EXPECT_FALSE(mask.At(2, 3));
  EXPECT_EQ(mask.Count(), 0);
  mask.Mark(2, 3, 8, 5);
  mask.Mark(7, 3, 8, 5);
  mask.Mark(0, 1, 8, 5);
  EXPECT_FALSE(mask.empty());
  EXPECT_EQ(mask.Row(0), nullptr);
  EXPECT_EQ(mask.Row(2), nullptr);
  EXPECT_EQ(mask.Row(4), nullptr);
  ASSERT_NE(mask.Row(3), nullptr);
  EXPECT_EQ(mask.Row(3)[2], 1);
  EXPECT_EQ(mask.Row(3)[3], 0);
  EXPECT_TRUE(mask.At(7, 3));
  EXPECT_TRUE(mask.At(0, 1));
  EXPECT_FALSE(mask.At(1, 1));
  EXPECT_EQ(mask.Count(), 3);
  // The same flags marked in another order are the same mask.
  SaturationMask other;
  other.Mark(0, 1, 8, 5);
  other.Mark(7, 3, 8, 5);
  EXPECT_FALSE(other == mask);
  other.Mark(2, 3, 8, 5);
  EXPECT_TRUE(other == mask);
  mask.clear();
  EXPECT_TRUE(mask.empty());
  EXPECT_EQ(mask.Count(), 0);
  EXPECT_FALSE(mask == other);
}

TEST(LuminanceTest, Rec709Weights) {
  Image rgb;
  rgb.width = 4;
  rgb.height = 1;
  rgb.channels = 3;
  rgb.pixels = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0.5f, 0.5f, 0.5f};
  rgb.MarkSaturated(1, 0);
  rgb.format = "png";
  rgb.bit_depth = 16;
  const Image y = Luminance(rgb);
  ASSERT_EQ(y.channels, 1);
  ASSERT_EQ(y.pixels.size(), 4u);
  EXPECT_FLOAT_EQ(y.pixels[0], 0.2126f);
  EXPECT_FLOAT_EQ(y.pixels[1], 0.7152f);
  EXPECT_FLOAT_EQ(y.pixels[2], 0.0722f);
  EXPECT_FLOAT_EQ(y.pixels[3], 0.5f);  // the weights sum to 1
  EXPECT_EQ(y.saturated, rgb.saturated);
  EXPECT_TRUE(y.IsSaturated(1, 0));
  EXPECT_EQ(y.SaturatedCount(), 1);
  EXPECT_EQ(y.format, "png");
  EXPECT_EQ(y.bit_depth, 16);

  // A one-channel image is copied unchanged.
  const Image gray = RandomImage(3, 3, 1, 0.0f, 1.0f, 13);
  const Image same = Luminance(gray);
  EXPECT_EQ(same.pixels, gray.pixels);
  EXPECT_EQ(same.channels, 1);
}

}  // namespace
}  // namespace weavefit
