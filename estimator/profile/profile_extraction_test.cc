// Unit tests of profile/profile_extraction on synthetic images whose pixel
// values are a known function of the azimuth φ.
#include "estimator/profile/profile_extraction.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>

#include "absl/status/status.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kBackground = 0.05;
constexpr double kNoise = 0.01;

// The radiance of the synthetic surface at azimuth φ.
double Truth(double phi) {
  return 0.2 + 0.1 * std::cos(3.0 * phi) + 0.05 * std::sin(phi);
}

CylinderGeometry TiltedGeometry() {
  CylinderGeometry g;
  g.center_x_px = 120.3;
  g.center_row_px = 79.5;
  g.radius_px = 90.0;
  g.axis_angle_rad = 2.0 * kDeg;
  g.top_row = 0;
  g.bottom_row = 159;
  g.left_observed = g.right_observed = true;
  return g;
}

// A 240×160 image: Truth(φ) on the cylinder, kBackground outside, Gaussian
// noise kNoise everywhere (fixed seed). φ is evaluated at the pixel centre.
Image SyntheticImage(const CylinderGeometry& g, const Projection& projection,
                     std::uint32_t seed = 3) {
  Image image;
  image.width = 240;
  image.height = 160;
  image.channels = 1;
  image.pixels.resize(static_cast<std::size_t>(image.width) * image.height);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, kNoise);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double offset = g.NormalisedOffset(x, y);
      const double phi = AzimuthFromOffset(offset, projection);
      const double value = std::isnan(phi) ? kBackground : Truth(phi);
      image.pixels[static_cast<std::size_t>(y) * image.width + x] =
          static_cast<float>(value + noise(rng));
    }
  }
  return image;
}

ProfileOptions Options(double bin_width_deg) {
  ProfileOptions options;
  options.bin_width_deg = bin_width_deg;
  return options;
}

// Checks the bin means against Truth at the bin centres: within the
// variation of Truth across a bin and across one pixel's footprint in
// azimuth (pixels are spread over the bins they cover, and a pixel spans
// 1/(R·cos φ) rad, several degrees near the limb), plus 5 standard errors.
void ExpectProfileMatchesTruth(const Profile& p, double radius_px,
                               double max_abs_deg) {
  ASSERT_GT(p.NumBins(), 0);
  int checked = 0;
  for (int i = 0; i < p.NumBins(); ++i) {
    ASSERT_GT(p.count[i], 0) << "bin " << i;
    const double phi = p.azimuth_rad[i];
    ASSERT_LT(std::fabs(phi), max_abs_deg * kDeg);
    const double slope = 0.35;  // bound on |Truth′|
    const double outer = std::min(std::fabs(phi) + p.bin_width_rad, max_abs_deg * kDeg);
    const double footprint = 1.0 / (radius_px * std::cos(outer));
    const double tolerance =
        slope * (0.5 * p.bin_width_rad + footprint) + 5.0 * p.stderr_mean[i];
    EXPECT_NEAR(p.mean[i], Truth(phi), tolerance) << "phi " << phi / kDeg;
    EXPECT_GT(p.stderr_mean[i], 0.0) << "phi " << phi / kDeg;
    EXPECT_LT(p.stderr_mean[i], 0.01) << "phi " << phi / kDeg;
    ++checked;
  }
  EXPECT_EQ(checked, p.NumBins());
}

TEST(ProfileExtractionTest, MeanFollowsAKnownFunctionOfAzimuth) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;  // orthographic
  const Image image = SyntheticImage(g, projection);
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(1.0));
  ASSERT_TRUE(p.ok()) << p.status();
  // Bins of 1° up to 86°: 2·86 bins, ascending, centred on (i − 86 + 0.5)°.
  ASSERT_EQ(p->NumBins(), 172);
  EXPECT_NEAR(p->bin_width_rad, 1.0 * kDeg, 1e-15);
  EXPECT_NEAR(p->azimuth_rad.front(), -85.5 * kDeg, 1e-12);
  EXPECT_NEAR(p->azimuth_rad.back(), 85.5 * kDeg, 1e-12);
  for (int i = 1; i < p->NumBins(); ++i) {
    EXPECT_NEAR(p->azimuth_rad[i] - p->azimuth_rad[i - 1], 1.0 * kDeg, 1e-12);
  }
  ExpectProfileMatchesTruth(*p, g.radius_px, 86.0);
  EXPECT_NEAR(p->background, kBackground, 0.002);
  EXPECT_NEAR(p->background_noise, kNoise, 0.0015);
  EXPECT_EQ(p->saturated_samples, 0);
}

TEST(ProfileExtractionTest, StandardErrorsReflectThePixelNoise) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  // A flat surface: the spread of the block means is pixel noise only, so
  // stderr·sqrt(count) estimates kNoise.
  Image image = SyntheticImage(g, projection);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, kNoise);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const bool inside = std::fabs(g.NormalisedOffset(x, y)) <= 1.0;
      image.pixels[static_cast<std::size_t>(y) * image.width + x] =
          static_cast<float>((inside ? 0.3 : kBackground) + noise(rng));
    }
  }
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(2.0));
  ASSERT_TRUE(p.ok()) << p.status();
  // Away from the limb, where a pixel falls into one or two bins (near the
  // limb it is spread over several and the bins' errors grow beyond
  // σ/sqrt(count)).
  double sum_ratio = 0.0;
  int bins = 0;
  for (int i = 0; i < p->NumBins(); ++i) {
    if (std::fabs(p->azimuth_rad[i]) > 60.0 * kDeg) continue;
    const double ratio = p->stderr_mean[i] * std::sqrt(p->count[i]) / kNoise;
    EXPECT_GT(ratio, 0.4) << i;
    EXPECT_LT(ratio, 1.8) << i;
    sum_ratio += ratio;
    ++bins;
  }
  ASSERT_EQ(bins, 60);
  EXPECT_NEAR(sum_ratio / bins, 1.0, 0.2);
}

// A 480×320 photograph of a cylinder (R = 180 px) whose level runs from
// 0.02 to 0.52 across it (or stays at the background's 0.02 with `dark`),
// with a band of thread-like glints (+0.4 on three rows of every eight,
// 6-17° of azimuth), under Poisson–Gaussian noise: variance 0.003² +
// gain·level.
Image PoissonGaussianImage(const CylinderGeometry& g, double gain, bool dark, std::uint32_t seed) {
  Image image;
  image.width = 480;
  image.height = 320;
  image.channels = 1;
  image.pixels.resize(static_cast<std::size_t>(image.width) * image.height);
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Projection projection;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double phi = AzimuthFromOffset(g.NormalisedOffset(x, y), projection);
      double value = 0.02;
      if (!std::isnan(phi)) {
        if (!dark) value += 0.25 * (1.0 + std::cos(2.0 * phi));
        if (phi > 0.1 && phi < 0.3 && y % 8 < 3) value += 0.4;
      }
      const double sigma = std::sqrt(0.003 * 0.003 + gain * value);
      image.pixels[static_cast<std::size_t>(y) * image.width + x] =
          static_cast<float>(value + sigma * normal(rng));
    }
  }
  return image;
}

CylinderGeometry WideGeometry() {
  CylinderGeometry g;
  g.center_x_px = 240.4;
  g.center_row_px = 159.5;
  g.radius_px = 180.0;
  g.top_row = 0;
  g.bottom_row = 319;
  g.left_observed = g.right_observed = true;
  return g;
}

TEST(ProfileExtractionTest, NoiseGainIsThePoissonPartOfTheSensorNoise) {
  const CylinderGeometry g = WideGeometry();
  const Projection projection;
  for (double gain : {1.0 / 300.0, 1.0 / 3000.0, 1.0 / 20000.0}) {
    const Image image = PoissonGaussianImage(g, gain, /*dark=*/false, 5);
    absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(0.5));
    ASSERT_TRUE(p.ok()) << p.status();
    // The glint band's pairs across thread edges are structure: the fit
    // leaves them out.
    EXPECT_NEAR(p->noise_gain / gain, 1.0, 0.1) << "gain " << gain;
    // A pixel's noise at a bin's level, from the background's and the gain.
    for (double at : {-0.8, -0.3, 0.5}) {
      const int i = static_cast<int>((at + M_PI / 2.0) / p->bin_width_rad);
      const int k = static_cast<int>(std::lround((p->azimuth_rad[i] - p->azimuth_rad[0]) / p->bin_width_rad));
      ASSERT_EQ(k, i);
      const double truth = std::sqrt(0.003 * 0.003 + gain * p->mean[i]);
      EXPECT_NEAR(p->PixelNoise(i) / truth, 1.0, 0.1) << "gain " << gain << " at " << at;
    }
  }
  // Without shot noise there is no gain to find.
  const Image flat = PoissonGaussianImage(g, 0.0, /*dark=*/false, 6);
  absl::StatusOr<Profile> p = ExtractProfile(flat, g, projection, Options(0.5));
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_LT(p->noise_gain, 0.05 / 20000.0);
}

TEST(ProfileExtractionTest, NoiseGainIsNotReadFromGlintsAlone) {
  // A dark body: the only bright pixels are the glint band's, whose pairs
  // across thread edges differ by the structure. Its gain is either not
  // found (0) or found without the structure.
  const CylinderGeometry g = WideGeometry();
  const Projection projection;
  const double gain = 1.0 / 3000.0;
  const Image image = PoissonGaussianImage(g, gain, /*dark=*/true, 7);
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(0.5));
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_LT(p->noise_gain, 1.3 * gain);
}

TEST(ProfileExtractionTest, CountsAndBlockSumsAreConsistent) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  const Image image = SyntheticImage(g, projection);
  ProfileOptions options = Options(0.5);
  options.num_blocks = 8;
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, options);
  ASSERT_TRUE(p.ok()) << p.status();
  // Every pixel centred within the limb limit counts once in total, spread
  // over the bins its footprint covers.
  const double limb = 86.0 * kDeg;
  std::int64_t expected = 0;
  for (int y = g.top_row; y <= g.bottom_row; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double phi = AzimuthFromOffset(g.NormalisedOffset(x, y), projection);
      if (std::fabs(phi) < limb) ++expected;
    }
  }
  double total = 0.0;
  for (double c : p->count) total += c;
  // The axis is quantised to 1/32 px for the footprint tables, so a pixel
  // centred within 1/64 px of the limit may land on either side: at most a
  // few in the whole image.
  EXPECT_NEAR(total, static_cast<double>(expected), 0.05 * (g.bottom_row - g.top_row + 1));
  ASSERT_EQ(p->num_blocks, 8);
  ASSERT_EQ(p->block_sum.size(), static_cast<std::size_t>(8 * p->NumBins()));
  for (int i = 0; i < p->NumBins(); ++i) {
    double sum = 0.0;
    double n = 0.0;
    for (int b = 0; b < 8; ++b) {
      sum += p->block_sum[static_cast<std::size_t>(b) * p->NumBins() + i];
      n += p->block_count[static_cast<std::size_t>(b) * p->NumBins() + i];
    }
    EXPECT_NEAR(n, p->count[i], 1e-9);
    if (n > 0) {
      EXPECT_NEAR(sum / n, p->mean[i], 1e-12);
    }
  }
}

TEST(ProfileExtractionTest, MaxRowsReadsEvenlySpacedRowsOnly) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  const Image image = SyntheticImage(g, projection);
  ProfileOptions all = Options(1.0);
  ProfileOptions some = all;
  some.max_rows = 40;  // of 160: every 4th row
  absl::StatusOr<Profile> full = ExtractProfile(image, g, projection, all);
  absl::StatusOr<Profile> part = ExtractProfile(image, g, projection, some);
  ASSERT_TRUE(full.ok()) << full.status();
  ASSERT_TRUE(part.ok()) << part.status();
  ASSERT_EQ(part->NumBins(), full->NumBins());
  double full_count = 0.0;
  double part_count = 0.0;
  for (int i = 0; i < full->NumBins(); ++i) {
    full_count += full->count[i];
    part_count += part->count[i];
  }
  // A quarter of the pixels, and the same surface within the larger
  // errors of the rows read.
  EXPECT_NEAR(part_count / full_count, 0.25, 0.01);
  ExpectProfileMatchesTruth(*part, g.radius_px, 86.0);
  // Errors about twice as large (a quarter of the samples), on average
  // over the bins away from the limbs.
  double ratio = 0.0;
  int bins = 0;
  for (int i = 0; i < part->NumBins(); ++i) {
    if (std::fabs(part->azimuth_rad[i]) > 60.0 * kDeg) continue;
    ratio += part->stderr_mean[i] / full->stderr_mean[i];
    ++bins;
  }
  ASSERT_GT(bins, 0);
  EXPECT_NEAR(ratio / bins, 2.0, 0.5);
  EXPECT_NEAR(part->background, kBackground, 0.002);
  EXPECT_NEAR(part->background_noise, kNoise, 0.002);
  some.max_rows = -1;
  EXPECT_EQ(ExtractProfile(image, g, projection, some).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ProfileExtractionTest, SaturatedPixelsAreExcludedAndCounted) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  Image image = SyntheticImage(g, projection);
  // Every other row of the band 10° ≤ φ < 15° clipped at full scale; a few
  // saturated background pixels too, some right outside the limb, whose
  // footprints reach into the outermost bins.
  std::int64_t on_cylinder = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * image.width + x;
      const double phi = AzimuthFromOffset(g.NormalisedOffset(x, y), projection);
      if (y % 2 == 0 && phi >= 10.0 * kDeg && phi < 15.0 * kDeg) {
        image.pixels[i] = 1.0f;
        image.MarkSaturated(x, y);
        ++on_cylinder;
      }
      if (std::isnan(phi) && x % 7 == 0 && y % 5 == 0) {
        image.pixels[i] = 1.0f;
        image.MarkSaturated(x, y);
      }
    }
  }
  ASSERT_GT(on_cylinder, 100);
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(1.0));
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->saturated_samples, on_cylinder);
  // Each saturated pixel's weight is spread over the bins it covers.
  double saturated_weight = 0.0;
  for (double w : p->saturated) saturated_weight += w;
  EXPECT_NEAR(saturated_weight, static_cast<double>(on_cylinder), 1e-6);
  for (int i = 0; i < p->NumBins(); ++i) {
    const double phi = p->azimuth_rad[i];
    if (phi < 9.0 * kDeg || phi > 16.0 * kDeg) {
      EXPECT_EQ(p->saturated[i], 0.0) << phi / kDeg;
    }
  }
  ExpectProfileMatchesTruth(*p, g.radius_px, 86.0);
  // The clipped background pixels do not lift the background estimate.
  EXPECT_NEAR(p->background, kBackground, 0.002);

  // Without the mask the clipped pixels pull the band's means up.
  Image unmasked = image;
  unmasked.saturated.clear();
  absl::StatusOr<Profile> q = ExtractProfile(unmasked, g, projection, Options(1.0));
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->saturated_samples, 0);
  const int bin = static_cast<int>(std::floor(12.0)) + q->NumBins() / 2;  // 12°–13°
  EXPECT_GT(q->mean[bin], Truth(12.5 * kDeg) + 0.3);
  // Every other row of that bin was masked.
  EXPECT_LT(p->count[bin], 0.6 * q->count[bin]);
  EXPECT_GT(p->count[bin], 0.4 * q->count[bin]);
}

TEST(ProfileExtractionTest, PerspectiveLimitsBinsToTheVisibleLimb) {
  CylinderGeometry g = TiltedGeometry();
  g.axis_angle_rad = -1.0 * kDeg;
  const Projection projection{23.0, 60.0};  // limb at arccos(23/60) = 67.46°
  const Image image = SyntheticImage(g, projection, 5);
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(1.0));
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->NumBins(), 2 * 67);
  ExpectProfileMatchesTruth(*p, g.radius_px, std::acos(23.0 / 60.0) / kDeg);
}

// Bins reach exactly to max_abs_azimuth_deg when it is a multiple of the
// bin width (86° / 0.25° = 344 bins per side), despite the rounding of the
// conversion to radians.
TEST(ProfileExtractionTest, BinsReachTheAzimuthLimit) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  const Image image = SyntheticImage(g, projection);
  for (double width : {0.25, 0.5, 1.0, 2.0}) {
    absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, Options(width));
    ASSERT_TRUE(p.ok()) << p.status();
    const int per_side = static_cast<int>(std::lround(86.0 / width));
    EXPECT_EQ(p->NumBins(), 2 * per_side) << "bin width " << width;
    EXPECT_NEAR(p->azimuth_rad.back() / kDeg, 86.0 - 0.5 * width, 1e-9);
  }
  // Not a multiple: the last whole bin inside the limit.
  ProfileOptions options = Options(0.3);
  absl::StatusOr<Profile> p = ExtractProfile(image, g, projection, options);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->NumBins(), 2 * 286);  // 286 · 0.3° = 85.8°
}

TEST(ProfileExtractionTest, RejectsInconsistentInput) {
  const CylinderGeometry g = TiltedGeometry();
  const Projection projection;
  const Image image = SyntheticImage(g, projection);

  Image rgb = image;
  rgb.channels = 3;
  rgb.pixels.resize(rgb.pixels.size() * 3);
  EXPECT_EQ(ExtractProfile(rgb, g, projection, ProfileOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);

  CylinderGeometry outside = g;
  outside.bottom_row = image.height;
  EXPECT_EQ(ExtractProfile(image, outside, projection, ProfileOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  CylinderGeometry flat = g;
  flat.radius_px = 0.0;
  EXPECT_EQ(ExtractProfile(image, flat, projection, ProfileOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);

  ProfileOptions options;
  options.bin_width_deg = 0.0;
  EXPECT_NE(std::string(options.Validate().message()).find("bin_width_deg"),
            std::string::npos);
  options = ProfileOptions();
  options.num_blocks = 1;
  EXPECT_NE(std::string(options.Validate().message()).find("num_blocks"),
            std::string::npos);
  options = ProfileOptions();
  options.max_abs_azimuth_deg = 90.0;
  EXPECT_NE(std::string(options.Validate().message()).find("max_abs_azimuth_deg"),
            std::string::npos);
  EXPECT_EQ(ExtractProfile(image, g, projection, options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace weavefit
