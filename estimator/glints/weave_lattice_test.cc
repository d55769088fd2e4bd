// Unit tests of glints/weave_lattice: the axial threads' pitch from the
// lattice of their glint lines, on synthetic arc signals with exactly known
// lines (each row its own weave phase, noise, shading), and through the
// whole pipeline on renders whose axial threads glint one by one.
#include "estimator/glints/weave_lattice.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

// Arc signals of `rows` rows over `samples` samples of 0.05 mm (half a
// pixel of 0.1 mm): a glint line of `height` and 3 samples' width every
// `pitch_mm`, each row shifted by its own random phase, on a shading that
// rises across the arc (a Lambertian body), with Gaussian noise of `noise`.
// When `alternate` > 0, every other line is that many times brighter (one
// family of crossings clipped, the other faint).
// With `stagger` >= 0, the rows are not of random phase: row r is shifted
// by r·stagger pitches (0: lines along the axis; 0.5: a checkerboard).
ArcSignals Lines(double pitch_mm, int rows, int samples, double height, double noise,
                 double alternate = 0.0, std::uint32_t seed = 3, double stagger = -1.0) {
  ArcSignals s;
  s.radius_mm = 23.0;
  s.step_rad = 0.05 / s.radius_mm;
  s.first_azimuth_rad = -0.5 * samples * s.step_rad;
  s.num_samples = samples;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, noise);
  for (int r = 0; r < rows; ++r) {
    s.rows.push_back(10 + r);
    const double c = (stagger >= 0.0 ? r * stagger : phase(rng)) * pitch_mm;
    for (int k = 0; k < samples; ++k) {
      const double x = k * 0.05;
      const double shading = 0.02 + 0.03 * k / samples;
      const double cycles = (x - c) / pitch_mm;
      const double frac = cycles - std::floor(cycles);
      const double d = std::min(frac, 1.0 - frac) * pitch_mm;  // mm to the nearest line
      const bool odd = (static_cast<long>(std::floor(cycles + 0.5)) & 1) != 0;
      const double h = height * (alternate > 0.0 && odd ? alternate : 1.0);
      s.values.push_back(static_cast<float>(shading + (d < 0.075 ? h : 0.0) + gauss(rng)));
      s.valid.push_back(1);
    }
  }
  return s;
}

constexpr double kStepPx = 0.5;

TEST(AxialPitchTest, LinesOnAShadedBodyGiveTheirPitch) {
  const double pitch = 0.83;
  absl::StatusOr<AxialPitch> p =
      EstimateAxialPitch({Lines(pitch, 48, 3000, 0.05, 0.002)}, kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->found) << p->reason;
  EXPECT_NEAR(p->pitch_mm, pitch, 0.002 * pitch);
  EXPECT_GT(p->pitch_stderr_mm, 0.0);
  EXPECT_LE(std::fabs(p->pitch_mm - pitch), 3.0 * p->pitch_stderr_mm + 1e-4 * pitch);
  EXPECT_NEAR(p->pitches_in_arc, 3000 * 0.05 / pitch, 1.0);
  EXPECT_EQ(p->rows_used, 48);
}

// Every harmonic of a lattice of narrow lines is about as strong as its
// fundamental, and folded at twice the pitch the lattice keeps them all: the
// pitch is the shortest whose harmonics hold the lattice.
TEST(AxialPitchTest, NarrowLinesGiveTheirPitchNotAHarmonicOrTwiceIt) {
  for (double pitch : {0.4, 1.1, 2.3}) {
    absl::StatusOr<AxialPitch> p =
        EstimateAxialPitch({Lines(pitch, 32, 4000, 0.2, 0.002)}, kStepPx, 0.002, {});
    ASSERT_TRUE(p.ok()) << p.status();
    ASSERT_TRUE(p->found) << pitch << ": " << p->reason;
    EXPECT_NEAR(p->pitch_mm, pitch, 0.005 * pitch) << pitch;
  }
}

// One family of crossings glinting ten times brighter than the other (one
// clipped, one faint) is still one lattice at the pitch: each row is clamped
// to a few noise sigmas, so both weigh alike.
TEST(AxialPitchTest, LinesOfAlternatingBrightnessGiveThePitch) {
  const double pitch = 0.9;
  absl::StatusOr<AxialPitch> p =
      EstimateAxialPitch({Lines(pitch, 32, 3000, 0.03, 0.002, 10.0)}, kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->found) << p->reason;
  EXPECT_NEAR(p->pitch_mm, pitch, 0.005 * pitch);
}

// Stretches of arc on either side of the lobe add their spectra.
TEST(AxialPitchTest, TwoArcsBesideTheLobeAddUp) {
  const double pitch = 0.7;
  absl::StatusOr<AxialPitch> p = EstimateAxialPitch(
      {Lines(pitch, 24, 900, 0.05, 0.002, 0.0, 1), Lines(pitch, 24, 1500, 0.05, 0.002, 0.0, 2)},
      kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->found) << p->reason;
  EXPECT_NEAR(p->pitch_mm, pitch, 0.005 * pitch);
  EXPECT_EQ(p->rows_used, 48);
}

// Lines at the same azimuths in every row are threads running along the
// axis; a checkerboard (neighbouring rows half a period out of step) is a
// plain weave's relief, and rows of unrelated phase are neither.
TEST(AxialPitchTest, LinesAlongTheAxisAreToldFromACheckerboard) {
  const double pitch = 0.9;
  absl::StatusOr<AxialPitch> along =
      EstimateAxialPitch({Lines(pitch, 64, 3000, 0.05, 0.002, 0.0, 4, 0.0)}, kStepPx, 0.002, {});
  absl::StatusOr<AxialPitch> checker =
      EstimateAxialPitch({Lines(pitch, 64, 3000, 0.05, 0.002, 0.0, 4, 0.5)}, kStepPx, 0.002, {});
  absl::StatusOr<AxialPitch> unrelated =
      EstimateAxialPitch({Lines(pitch, 64, 3000, 0.05, 0.002, 0.0, 4)}, kStepPx, 0.002, {});
  ASSERT_TRUE(along.ok() && checker.ok() && unrelated.ok());
  ASSERT_TRUE(along->found && checker->found && unrelated->found);
  EXPECT_GT(along->aligned, 0.9);
  EXPECT_LT(checker->aligned, 0.02);
  EXPECT_LT(unrelated->aligned, 0.2);
  EXPECT_NEAR(checker->pitch_mm, pitch, 0.005 * pitch);
  // Rows that alternate hold their power at the frequency of their
  // alternation along the axis (here every row: the Nyquist frequency);
  // rows of unrelated phase spread it.
  EXPECT_GT(checker->checker, 0.9);
  EXPECT_LT(along->checker, 0.1);
  EXPECT_LT(unrelated->checker, 0.3);
}

// Threads two rows wide that alternate every thread: the power lies at a
// quarter of the rows' frequency along the axis, and at its negative.
TEST(AxialPitchTest, ThreadsAlternatingAlongTheAxisAreACheckerboard) {
  const double pitch = 0.9;
  ArcSignals s = Lines(pitch, 64, 3000, 0.05, 0.002, 0.0, 4, 0.0);
  ArcSignals shifted = Lines(pitch, 64, 3000, 0.05, 0.002, 0.0, 5, 0.5);
  for (int r = 0; r < 64; ++r) {
    if ((r / 2) % 2 == 0) continue;
    // Rows of the odd threads half a pitch along (as shifted's odd rows).
    const int from = 2 * (r / 4) + 1;
    std::copy(shifted.Row(from), shifted.Row(from) + 3000,
              s.values.begin() + static_cast<std::ptrdiff_t>(r) * 3000);
  }
  absl::StatusOr<AxialPitch> p = EstimateAxialPitch({s}, kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->found) << p->reason;
  EXPECT_NEAR(p->pitch_mm, pitch, 0.005 * pitch);
  EXPECT_LT(p->aligned, 0.05);
  EXPECT_GT(p->checker, 0.6);
}

// Structure that is not the weave's lattice stands up to about 9 times
// above the spectra's floor, so lines along the axis must stand 20 times
// above it; rows alternating from one thread to the next are the weave's
// own pattern, and need only stand clear of noise.
TEST(AxialPitchTest, AWeakCheckerboardIsALatticeWhereWeakLinesAreNot) {
  const double pitch = 0.9;
  const double height = 0.0013;  // a little over half the noise: about 12 times the floor
  absl::StatusOr<AxialPitch> along =
      EstimateAxialPitch({Lines(pitch, 64, 1500, height, 0.002, 0.0, 4, 0.0)}, kStepPx, 0.002, {});
  absl::StatusOr<AxialPitch> checker =
      EstimateAxialPitch({Lines(pitch, 64, 1500, height, 0.002, 0.0, 4, 0.5)}, kStepPx, 0.002, {});
  ASSERT_TRUE(along.ok() && checker.ok());
  const AxialPitchOptions options;
  for (const AxialPitch* p : {&*along, &*checker}) {
    EXPECT_GT(p->contrast, options.min_alternating_contrast);
    EXPECT_LT(p->contrast, options.min_contrast);
  }
  EXPECT_FALSE(along->found);
  EXPECT_NE(along->reason.find("20 needed"), std::string::npos) << along->reason;
  ASSERT_TRUE(checker->found) << checker->reason;
  EXPECT_TRUE(checker->alternating);
  EXPECT_FALSE(checker->lines);
  EXPECT_NEAR(checker->pitch_mm, pitch, 0.01 * pitch);
}

// A faint pattern whose rows alternate in part only (36 of 64 rows a
// checkerboard, the rest of unrelated phase) is not taken for the weave's:
// below the strong contrast the rows must alternate with more of its power
// than a strong lattice's rows must.
TEST(AxialPitchTest, AFaintPatternAlternatingInPartIsNoLattice) {
  const double pitch = 0.9;
  ArcSignals s = Lines(pitch, 64, 1500, 0.0013, 0.002, 0.0, 4, 0.5);
  const ArcSignals unrelated = Lines(pitch, 64, 1500, 0.0013, 0.002, 0.0, 5);
  std::copy(unrelated.values.begin() + 36 * 1500, unrelated.values.end(),
            s.values.begin() + 36 * 1500);
  absl::StatusOr<AxialPitch> p = EstimateAxialPitch({s}, kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_LT(p->contrast, AxialPitchOptions().min_contrast);
  EXPECT_GE(p->checker, AxialPitchOptions().min_checker_share);
  EXPECT_LT(p->checker, AxialPitchOptions().min_weak_checker_share);
  EXPECT_FALSE(p->found) << p->checker;
  EXPECT_NE(p->reason.find("these hold"), std::string::npos) << p->reason;
}

// A plain weave's period at half the lines' frequency lies in a
// checkerboard (every other line brighter, neighbouring rows half a period
// out of step, as a lobe's circumferential glints are); every other line
// brighter in every row is a coarser pattern of lines along the axis. (The
// lines stand 1 and 2 noise sigmas high, under the clamp.)
TEST(AxialPitchTest, HalfTheFrequencyIsToldAlongTheAxisFromACheckerboard) {
  const double pitch = 0.9;
  absl::StatusOr<AxialPitch> coarser =
      EstimateAxialPitch({Lines(pitch, 64, 3000, 0.002, 0.002, 2.0, 4, 0.0)}, kStepPx, 0.002, {});
  absl::StatusOr<AxialPitch> weave =
      EstimateAxialPitch({Lines(pitch, 64, 3000, 0.002, 0.002, 2.0, 4, 1.0)}, kStepPx, 0.002, {});
  ASSERT_TRUE(coarser.ok() && weave.ok());
  ASSERT_TRUE(coarser->found && weave->found);
  EXPECT_NEAR(coarser->pitch_mm, pitch, 0.005 * pitch);
  EXPECT_NEAR(weave->pitch_mm, pitch, 0.005 * pitch);
  EXPECT_GT(coarser->half_contrast, 0.05 * coarser->contrast);
  EXPECT_GT(weave->half_contrast, 0.05 * weave->contrast);
  EXPECT_GT(coarser->half_aligned, 0.8);
  EXPECT_LT(weave->half_aligned, 0.02);
  EXPECT_GT(weave->aligned, 0.9);
}

// Two bright columns at the same samples in every row (a lobe's caustics,
// 40 samples wide each) beside faint lines (1.5 noise sigmas): read with
// them, the lattice is theirs; left out (shading included), the lines'
// pitch and alignment come back as without them.
TEST(AxialPitchTest, CausticsLeftOutLeaveTheLinesAlone) {
  const double pitch = 0.9;
  ArcSignals s = Lines(pitch, 64, 3000, 0.003, 0.002, 0.0, 5, 0.0);
  for (int r = 0; r < 64; ++r) {
    for (int k : {1000, 2100}) {
      for (int j = k; j < k + 40; ++j) s.values[static_cast<std::size_t>(r) * 3000 + j] += 0.3f;
    }
  }
  std::vector<std::pair<double, double>> caustics;
  for (int k : {1000, 2100}) {
    caustics.push_back({s.first_azimuth_rad + (k - 2) * s.step_rad,
                        s.first_azimuth_rad + (k + 42) * s.step_rad});
  }
  absl::StatusOr<AxialPitch> p = EstimateAxialPitch({s}, kStepPx, 0.002, {}, caustics);
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->found) << p->reason;
  EXPECT_NEAR(p->pitch_mm, pitch, 0.005 * pitch);
  EXPECT_GT(p->aligned, 0.9);
}

// Noise alone, over as few rows as a short cylinder gives or as many as the
// band holds, stands below even the contrast a checkerboard needs.
TEST(AxialPitchTest, NoiseAloneHasNoLattice) {
  const AxialPitchOptions options;
  for (int rows : {16, 48, 128}) {
    for (std::uint32_t seed = 1; seed <= 6; ++seed) {
      absl::StatusOr<AxialPitch> p =
          EstimateAxialPitch({Lines(1.0, rows, 3000, 0.0, 0.002, 0.0, seed)}, kStepPx, 0.002, {});
      ASSERT_TRUE(p.ok()) << p.status();
      EXPECT_FALSE(p->found) << rows << " rows, seed " << seed;
      EXPECT_NE(p->reason.find("no lattice"), std::string::npos) << p->reason;
      EXPECT_LT(p->contrast, options.min_alternating_contrast) << rows << " rows, seed " << seed;
    }
  }
}

TEST(AxialPitchTest, TooFewLinesInViewAreNotCounted) {
  // 2.5 lines over the arc.
  absl::StatusOr<AxialPitch> p =
      EstimateAxialPitch({Lines(2.0, 48, 100, 0.05, 0.002)}, kStepPx, 0.002, {});
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_FALSE(p->found);
  EXPECT_FALSE(p->reason.empty());
}

TEST(AxialPitchTest, BadOptionsAreRefused) {
  AxialPitchOptions options;
  options.min_contrast = 1.0;
  EXPECT_EQ(EstimateAxialPitch({Lines(1.0, 4, 500, 0.05, 0.002)}, kStepPx, 0.002, options)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EstimateAxialPitch({Lines(1.0, 4, 500, 0.05, 0.002)}, 0.0, 0.002, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// A sawtooth mirrors only at its two caustics, so its circumferential
// glints do not repeat along the arc; its axial threads' lines do, and give
// the wavelength (twice their pitch in a plain weave) with an honest error.
TEST(AxialPitchTest, ASawtoothsWavelengthComesFromItsAxialThreads) {
  RenderScene scene;
  scene.width_px = 640;
  scene.height_px = 400;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 2.4;
  scene.amplitude_mm = 0.12;  // m = 0.2
  scene.phase_angle_deg = -30.0;
  scene.axial_glint_width = 0.15;
  scene.axial_float_width = 0.3;  // a plain weave's floats
  scene.stray_light = 0.02;
  scene.seed = 11;
  absl::StatusOr<Rendered> r = RenderPhotograph(scene);
  ASSERT_TRUE(r.ok()) << r.status();
  Acquisition acquisition;
  acquisition.phase_angle_rad = scene.phase_angle_deg * M_PI / 180.0;
  acquisition.cylinder_diameter_mm = scene.diameter_mm;
  absl::StatusOr<Estimate> e = EstimateFromImage(r->image, acquisition, {});
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->model, ProfileModel::kSawtooth);
  ASSERT_TRUE(e->wavelength_mm.resolved);
  EXPECT_LE(std::fabs(e->wavelength_mm.value - scene.wavelength_mm),
            3.0 * e->wavelength_mm.stderr_value);
  // Its glints slide over the round axial threads (glints/round_threads.h).
  EXPECT_NEAR(e->wavelength_mm.value, scene.wavelength_mm, 0.005 * scene.wavelength_mm);
  ASSERT_TRUE(e->amplitude_mm.resolved);
  EXPECT_LE(std::fabs(e->amplitude_mm.value - scene.amplitude_mm),
            3.0 * e->amplitude_mm.stderr_value);
}

// A stray-lit plain weave shows its relief: each circumferential thread's
// shading repeats with λ, its neighbours' half a period out of step. A
// sawtooth's glints do not repeat along the arc, and without axial threads
// glinting the relief alone gives its period, with an error that counts
// the pattern's drift of phase; without stray light nothing does.
TEST(AxialPitchTest, AStrayLitSawtoothsWavelengthComesFromItsRelief) {
  RenderScene scene;
  scene.width_px = 640;
  scene.height_px = 400;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 1.6;
  scene.amplitude_mm = 0.16;  // m = 0.4
  scene.phase_angle_deg = -34.0;
  scene.stray_light = 0.06;
  scene.stray_texture = 0.5;
  scene.seed = 11;
  Acquisition acquisition;
  acquisition.phase_angle_rad = scene.phase_angle_deg * M_PI / 180.0;
  acquisition.cylinder_diameter_mm = scene.diameter_mm;
  absl::StatusOr<Rendered> r = RenderPhotograph(scene);
  ASSERT_TRUE(r.ok()) << r.status();
  absl::StatusOr<Estimate> e = EstimateFromImage(r->image, acquisition, {});
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->model, ProfileModel::kSawtooth);
  ASSERT_TRUE(e->wavelength_mm.resolved);
  EXPECT_LE(std::fabs(e->wavelength_mm.value - scene.wavelength_mm),
            3.0 * e->wavelength_mm.stderr_value);
  EXPECT_NEAR(e->wavelength_mm.value, scene.wavelength_mm, 0.03 * scene.wavelength_mm);
  EXPECT_LT(e->wavelength_mm.stderr_value, 0.05 * scene.wavelength_mm);
  bool said = false;
  for (const std::string& w : e->warnings)
    said = said || w.find("weave's relief") != std::string::npos;
  EXPECT_TRUE(said);

  scene.stray_light = 0.0;
  r = RenderPhotograph(scene);
  ASSERT_TRUE(r.ok()) << r.status();
  e = EstimateFromImage(r->image, acquisition, {});
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(e->wavelength_mm.resolved);
}

}  // namespace
}  // namespace weavefit
