#include "estimator/io/encode.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace weavefit {
namespace {

class MemoryOStream : public Imf::OStream {
 public:
  MemoryOStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (position_ + n > bytes_.size()) bytes_.resize(position_ + n);
    std::memcpy(&bytes_[position_], c, n);
    position_ += n;
  }
  std::uint64_t tellp() override { return position_; }
  void seekp(std::uint64_t pos) override { position_ = pos; }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
  std::uint64_t position_ = 0;
};

absl::StatusOr<std::string> EncodeExr(const Image& image) {
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    const char* rgb[] = {"R", "G", "B"};
    const bool gray = image.channels == 1;
    for (int c = 0; c < image.channels; ++c) {
      header.channels().insert(gray ? "Y" : rgb[c], Imf::Channel(Imf::FLOAT));
    }
    MemoryOStream stream;
    {
      // The file's destructor writes the line offset table, so the bytes
      // are complete only after this scope.
      Imf::OutputFile file(stream, header);
      Imf::FrameBuffer frame;
      const std::size_t x_stride = sizeof(float) * image.channels;
      for (int c = 0; c < image.channels; ++c) {
        char* base = const_cast<char*>(
            reinterpret_cast<const char*>(image.pixels.data() + c));
        frame.insert(gray ? "Y" : rgb[c],
                     Imf::Slice(Imf::FLOAT, base, x_stride,
                                x_stride * image.width));
      }
      file.setFrameBuffer(frame);
      file.writePixels(image.height);
    }
    return stream.bytes();
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("EXR encoding failed: ", e.what()));
  }
}

}  // namespace

absl::StatusOr<EncodeFormat> ParseEncodeFormat(const std::string& name) {
  if (name == "png" || name == "png16") return EncodeFormat::kPng16;
  if (name == "png8") return EncodeFormat::kPng8;
  if (name == "tiff" || name == "tif") return EncodeFormat::kTiff16;
  if (name == "exr") return EncodeFormat::kExr;
  if (name == "jpeg" || name == "jpg") return EncodeFormat::kJpeg;
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown image format '", name, "' (png, png8, tiff, exr, jpeg)"));
}

const char* EncodeFormatExtension(EncodeFormat format) {
  switch (format) {
    case EncodeFormat::kPng16:
    case EncodeFormat::kPng8:
      return "png";
    case EncodeFormat::kTiff16:
      return "tiff";
    case EncodeFormat::kExr:
      return "exr";
    case EncodeFormat::kJpeg:
      return "jpg";
  }
  return "bin";
}

absl::StatusOr<std::string> EncodeImage(const Image& image,
                                        EncodeFormat format) {
  if (image.width <= 0 || image.height <= 0 ||
      (image.channels != 1 && image.channels != 3) ||
      image.pixels.size() != static_cast<std::size_t>(image.width) *
                                 image.height * image.channels) {
    return absl::InvalidArgumentError("image to encode is empty or malformed");
  }
  if (format == EncodeFormat::kExr) return EncodeExr(image);
  const bool eight_bit =
      format == EncodeFormat::kPng8 || format == EncodeFormat::kJpeg;
  const int type = CV_MAKETYPE(eight_bit ? CV_8U : CV_16U, image.channels);
  cv::Mat mat(image.height, image.width, type);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      for (int c = 0; c < image.channels; ++c) {
        const float v = std::clamp(image.At(x, y, c), 0.0f, 1.0f);
        // OpenCV writes BGR.
        const int dest = image.channels == 3 ? 2 - c : 0;
        const std::size_t at =
            static_cast<std::size_t>(x) * image.channels + dest;
        if (eight_bit) {
          mat.ptr<std::uint8_t>(y)[at] = static_cast<std::uint8_t>(
              std::lround(LinearToSrgb(v) * 255.0f));
        } else {
          mat.ptr<std::uint16_t>(y)[at] =
              static_cast<std::uint16_t>(std::lround(v * 65535.0f));
        }
      }
    }
  }
  std::vector<int> params;
  const char* ext = ".png";
  if (format == EncodeFormat::kJpeg) {
    ext = ".jpg";
    params = {cv::IMWRITE_JPEG_QUALITY, 95};
  } else if (format == EncodeFormat::kTiff16) {
    ext = ".tiff";
  } else {
    params = {cv::IMWRITE_PNG_COMPRESSION, 6};
  }
  std::vector<unsigned char> buffer;
  try {
    if (!cv::imencode(ext, mat, buffer, params)) {
      return absl::InternalError(absl::StrCat("could not encode ", ext));
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("encoding failed: ", e.what()));
  }
  return std::string(buffer.begin(), buffer.end());
}

}  // namespace weavefit
