// The renderer and the optical model check each other (issue 3): a clean
// render whose thread phases cover the period evenly must show, in its
// column average, the model's L(φ) (DESIGN.md §3) — the peaks within 0.2°
// and the shape within a few percent RMS.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <vector>

#include "estimator/optics/radiance.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Case {
  ProfileModel model;
  double phase_angle_deg;
  double crest_tilt_deg;
};

class RenderConsistency : public ::testing::TestWithParam<Case> {};

// Clean scene: no noise, no ambient or axial light, a regular weave whose
// 16 neighbouring threads step the phase by 1/16 of a period, and a large
// radius so that a pixel spans 0.06° (negligible next to the 0.3° blur).
RenderScene CleanScene(const Case& c) {
  RenderScene s;
  s.model = c.model;
  s.phase_angle_deg = c.phase_angle_deg;
  s.crest_tilt_deg = c.crest_tilt_deg;
  s.width_px = 2100;
  s.radius_px = 1000.0;
  s.center_x_px = 1049.5;
  s.wavelength_mm = 1.0;
  s.amplitude_mm = c.model == ProfileModel::kSawtooth ? 0.06 : 0.0375;  // m = 0.24
  s.height_px = 347;  // 16 pitches of 0.5 mm at 0.023 mm/px
  s.phase_step = 1.0 / 16.0;
  s.regular_weave = true;
  s.gap_fraction = 0.0;
  s.axial_reflectance = 0.0;
  s.ambient = 0.0;
  s.background = 0.0;
  s.exposure = 0.001;
  s.source_blur_deg = 0.6;
  s.photons_full_scale = 0.0;
  s.read_noise = 0.0;
  s.quantisation_bits = 0;
  s.samples_per_pixel = 4;
  return s;
}

// The two maxima of f (one on each side of index `mid`), refined by a parabola.
std::pair<double, double> Peaks(const std::vector<double>& f, int mid) {
  auto refine = [&](int i) {
    const double d = f[i - 1] - 2 * f[i] + f[i + 1];
    return d < 0 ? i + 0.5 * (f[i - 1] - f[i + 1]) / d : static_cast<double>(i);
  };
  const int left = static_cast<int>(std::max_element(f.begin() + 1, f.begin() + mid) - f.begin());
  const int right = static_cast<int>(std::max_element(f.begin() + mid, f.end() - 1) - f.begin());
  return {refine(left), refine(right)};
}

TEST_P(RenderConsistency, ColumnAverageMatchesTheModel) {
  const Case c = GetParam();
  const RenderScene scene = CleanScene(c);
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  const Image& image = rendered->image;

  RadianceParams<double> p;
  p.model = c.model;
  p.max_slope = scene.MaxSlope();
  p.mirror_rad = scene.phase_angle_deg * kDeg / 2.0;
  p.blur_rad = scene.source_blur_deg * kDeg / 2.0;
  p.scale = scene.exposure / 2.0;
  // Columns across the lobe, mirror ± (arctan m + 2°).
  const double reach = std::atan(p.max_slope) + 2.0 * kDeg;
  std::vector<double> phi;
  std::vector<double> measured;
  std::vector<double> model;
  for (int x = 0; x < image.width; ++x) {
    const double offset = (x - scene.center_x_px) / scene.radius_px;
    if (std::fabs(offset) >= 0.99) continue;
    const double azimuth = std::asin(offset);
    if (std::fabs(azimuth - p.mirror_rad) > reach) continue;
    double sum = 0.0;
    for (int y = 0; y < image.height; ++y) sum += image.At(x, y);
    phi.push_back(azimuth);
    measured.push_back(sum / image.height);
    model.push_back(SpecularRadiance(p, azimuth));
  }
  ASSERT_GT(phi.size(), 100u);

  // Rounded crests only scale the level, by about 1/cos(α/2) (DESIGN.md §3):
  // compare shapes after matching the means.
  double mean_measured = 0.0;
  double mean_model = 0.0;
  for (std::size_t i = 0; i < phi.size(); ++i) {
    mean_measured += measured[i];
    mean_model += model[i];
  }
  const double gain = mean_measured / mean_model;
  if (c.crest_tilt_deg == 0.0) {
    EXPECT_NEAR(gain, 1.0, 0.03);
  }

  const int mid = static_cast<int>(phi.size() / 2);
  const auto [ml, mr] = Peaks(measured, mid);
  const auto [pl, pr] = Peaks(model, mid);
  auto azimuth_at = [&](double index) {
    const int i = static_cast<int>(index);
    return phi[i] + (index - i) * (phi[i + 1] - phi[i]);
  };
  EXPECT_NEAR(azimuth_at(ml) / kDeg, azimuth_at(pl) / kDeg, 0.2);
  EXPECT_NEAR(azimuth_at(mr) / kDeg, azimuth_at(pr) / kDeg, 0.2);
  // And the model's peaks stand at the caustics α/2 ± arctan m, pulled in
  // by the blur by less than its σ.
  const double b = std::atan(p.max_slope) / kDeg;
  EXPECT_NEAR(azimuth_at(pl) / kDeg, p.mirror_rad / kDeg - b, scene.source_blur_deg / 2.0);
  EXPECT_NEAR(azimuth_at(pr) / kDeg, p.mirror_rad / kDeg + b, scene.source_blur_deg / 2.0);

  // Shape over 0.5° windows: mid-lobe glints are far narrower than a pixel,
  // so single columns are a comb of the 16 phases (32 glints per 2.5°);
  // a window of 9 columns (0.5°) holds several teeth.
  auto box = [](const std::vector<double>& v, int half) {
    std::vector<double> out(v.size(), 0.0);
    for (int i = half; i + half < static_cast<int>(v.size()); ++i) {
      for (int k = -half; k <= half; ++k) out[i] += v[i + k] / (2 * half + 1);
    }
    return out;
  };
  const std::vector<double> measured_box = box(measured, 4);
  const std::vector<double> model_box = box(model, 4);
  double ss = 0.0;
  double peak = 0.0;
  for (std::size_t i = 4; i + 4 < phi.size(); ++i) {
    const double d = measured_box[i] - gain * model_box[i];
    ss += d * d;
    peak = std::max(peak, gain * model_box[i]);
  }
  const double rms = std::sqrt(ss / (phi.size() - 8)) / peak;
  EXPECT_LT(rms, 0.03) << "RMS shape difference relative to the peak";
  std::printf("%s phase %.0f deg: gain %.4f (1/cos(a/2) = %.4f), peak offsets %.3f %.3f deg, RMS shape %.4f of the peak\n",
              ProfileModelName(c.model), c.phase_angle_deg, gain, 1.0 / std::cos(c.phase_angle_deg * kDeg / 2.0),
              (azimuth_at(ml) - azimuth_at(pl)) / kDeg, (azimuth_at(mr) - azimuth_at(pr)) / kDeg, rms);
}

INSTANTIATE_TEST_SUITE_P(
    Profiles, RenderConsistency,
    ::testing::Values(Case{ProfileModel::kSinusoid, 0.0, 0.0},
                      Case{ProfileModel::kSinusoid, 30.0, 0.0},
                      Case{ProfileModel::kSinusoid, 60.0, 0.0},
                      Case{ProfileModel::kSawtooth, 30.0, 0.0},
                      Case{ProfileModel::kSinusoid, 60.0, 6.0}),
    [](const ::testing::TestParamInfo<Case>& info) {
      return std::string(ProfileModelName(info.param.model)) + "_phase" +
             std::to_string(static_cast<int>(info.param.phase_angle_deg)) +
             (info.param.crest_tilt_deg > 0 ? "_crest" : "");
    });

}  // namespace
}  // namespace weavefit
