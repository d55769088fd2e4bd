// Unit tests of glints/round_threads: the axial threads' own pitch from the
// lattice of glint lines that slide over the round threads with the mirror
// azimuth, on synthetic arc signals whose lines stand exactly where a round
// thread of known radius glints.
#include "estimator/glints/round_threads.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "estimator/glints/weave_lattice.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kRadiusMm = 23.0;
constexpr double kStepMm = 0.05;  // half a pixel of 0.1 mm

// Arc signals from `from_deg` to `to_deg` over `rows` rows: axial threads
// `pitch_mm` apart (each row its own random phase, as the threads wander),
// each glinting as a line 3 samples wide where its round top, of radius
// `rho_mm`, mirrors at azimuth `mirror_deg`: ρ·sin(μ − φ) of arc from the
// thread's top. Noise of 0.002 on a flat body.
ArcSignals RoundThreadLines(double from_deg, double to_deg, double pitch_mm, double rho_mm,
                            double mirror_deg, int rows, std::uint32_t seed) {
  ArcSignals s;
  s.radius_mm = kRadiusMm;
  s.step_rad = kStepMm / kRadiusMm;
  s.first_azimuth_rad = from_deg * kDeg;
  s.num_samples = static_cast<int>((to_deg - from_deg) * kDeg / s.step_rad);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.002);
  const double from_mm = s.first_azimuth_rad * kRadiusMm;
  const double to_mm = from_mm + s.num_samples * kStepMm;
  for (int r = 0; r < rows; ++r) {
    s.rows.push_back(10 + r);
    std::vector<double> row(s.num_samples, 0.02);
    const double first = (std::floor(from_mm / pitch_mm) - 1.0 + phase(rng)) * pitch_mm;
    for (double top = first; top < to_mm + pitch_mm; top += pitch_mm) {
      const double glint = top + rho_mm * std::sin(mirror_deg * kDeg - top / kRadiusMm);
      const int k = static_cast<int>(std::lround((glint - from_mm) / kStepMm));
      for (int j = k - 1; j <= k + 1; ++j) {
        if (j >= 0 && j < s.num_samples) row[j] += 0.05;
      }
    }
    for (double v : row) {
      s.values.push_back(static_cast<float>(v + noise(rng)));
      s.valid.push_back(1);
    }
  }
  return s;
}

struct Reading {
  AxialPitch apparent;
  ThreadPitch threads;
};

Reading Read(const std::vector<ArcSignals>& arcs, double mirror_deg,
             const RoundThreadOptions& options = {}) {
  absl::StatusOr<AxialPitch> p = EstimateAxialPitch(arcs, 0.5, 0.002, {});
  EXPECT_TRUE(p.ok()) << p.status();
  if (!p.ok()) return {};
  EXPECT_TRUE(p->found) << p->reason;
  return {*p, ThreadPitchFromGlints(*p, arcs, mirror_deg * kDeg, options)};
}

// Beside a lobe at 10°, both sides: the lines stand 1-2 % closer than the
// threads, and the threads' pitch comes back within a few tenths of a
// percent and 3 stated errors, with their roundness.
TEST(RoundThreadsTest, TheThreadsPitchComesBackFromLinesThatSlideOverThem) {
  const double pitch = 1.2;
  const double rho = 0.4;
  const double mirror = 10.0;
  const Reading r = Read({RoundThreadLines(-60.0, -10.0, pitch, rho, mirror, 64, 1),
                          RoundThreadLines(30.0, 65.0, pitch, rho, mirror, 64, 2)},
                         mirror);
  EXPECT_LT(r.apparent.pitch_mm, 0.99 * pitch);
  EXPECT_GE(r.threads.stretches, 4);
  EXPECT_NEAR(r.threads.pitch_mm, pitch, 0.003 * pitch);
  EXPECT_LE(std::fabs(r.threads.pitch_mm - pitch), 3.0 * r.threads.pitch_stderr_mm);
  EXPECT_NEAR(r.threads.glint_radius_mm, rho, 0.5 * rho);
  EXPECT_GT(r.threads.model_stderr_mm, 0.0);
  EXPECT_LE(r.threads.model_stderr_mm, r.threads.pitch_stderr_mm);
}

// Lines that do not slide (threads flat on top or lines painted on) over a
// wide range of azimuths: the fit sees no compression and the prior does
// not put one in.
TEST(RoundThreadsTest, LinesThatStandStillAreTakenAsTheyAre) {
  const double pitch = 0.9;
  const Reading r = Read({RoundThreadLines(-70.0, -5.0, pitch, 0.0, 20.0, 64, 3),
                          RoundThreadLines(45.0, 70.0, pitch, 0.0, 20.0, 64, 4)},
                         20.0);
  EXPECT_NEAR(r.apparent.pitch_mm, pitch, 0.002 * pitch);
  EXPECT_NEAR(r.threads.pitch_mm, pitch, 0.003 * pitch);
  EXPECT_LT(r.threads.glint_radius_mm, 0.15 * pitch);
}

// With no stretch long enough for a local pitch, the prior alone corrects
// the lattice's pitch, by κ times the lattice's mean cos(μ − φ), and its
// spread is the error's model part.
TEST(RoundThreadsTest, WithoutLocalPitchesThePriorDecides) {
  AxialPitch apparent;
  apparent.found = true;
  apparent.pitch_mm = 1.0;
  apparent.pitch_stderr_mm = 0.001;
  ArcSignals arc;
  arc.radius_mm = kRadiusMm;
  arc.first_azimuth_rad = 0.0;
  arc.step_rad = 1e-3;
  arc.num_samples = 1;  // one sample, at the mirror: mean cos 1
  arc.rows = {0};
  RoundThreadOptions options;
  const ThreadPitch t = ThreadPitchFromGlints(apparent, {arc}, 0.0, options);
  EXPECT_EQ(t.stretches, 0);
  EXPECT_NEAR(t.mean_cos, 1.0, 1e-9);
  const double kappa = options.radius_pitches * 1.0 / kRadiusMm;
  EXPECT_NEAR(t.pitch_mm, 1.0 + kappa, 1e-9);
  EXPECT_NEAR(t.model_stderr_mm, options.radius_pitches_sd / kRadiusMm, 1e-9);
  EXPECT_NEAR(t.glint_radius_mm, options.radius_pitches, 1e-9);
}

// Local pitches that follow the model, and one stretch that followed other
// structure 3 % long: it is left out, and κ comes from the rest.
TEST(RoundThreadsTest, AStretchFarOffTheModelIsLeftOut) {
  const double pitch = 1.5;
  const double rho = 0.45;
  AxialPitch apparent;
  apparent.found = true;
  apparent.pitch_stderr_mm = 0.001;
  ArcSignals arc;
  arc.radius_mm = kRadiusMm;
  arc.step_rad = 0.01;
  arc.first_azimuth_rad = -60.0 * kDeg;
  arc.num_samples = static_cast<int>(120.0 * kDeg / arc.step_rad);
  arc.rows = {0};
  for (double deg : {-55.0, -40.0, -25.0, 25.0, 40.0, 55.0}) {
    LocalPitch l;
    l.azimuth_rad = deg * kDeg;
    l.pitch_mm = pitch * (1.0 - rho / kRadiusMm * std::cos(l.azimuth_rad));
    l.stderr_mm = 0.0005;
    apparent.local.push_back(l);
  }
  apparent.local.back().pitch_mm *= 1.03;
  apparent.pitch_mm = pitch / (1.0 + rho / kRadiusMm * 0.8);
  const ThreadPitch t = ThreadPitchFromGlints(apparent, {arc}, 0.0, RoundThreadOptions());
  EXPECT_EQ(t.stretches, 5);
  EXPECT_NEAR(t.glint_radius_mm, rho, 0.1 * rho);
}

TEST(RoundThreadsTest, BadOptionsAreRefused) {
  RoundThreadOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.radius_pitches_sd = 0.0;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = {};
  options.local_scatter = -0.1;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace weavefit
