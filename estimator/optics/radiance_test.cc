// Unit tests of optics/radiance: tilt densities and the radiance model for
// double and ceres::Jet, hand-computed values, the paper's peak spacings, and
// a ceres::GradientChecker on an autodiff cost over Radiance (STYLE.md
// "Tests").
#include "estimator/optics/radiance.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/jet.h>
#include <ceres/manifold.h>
#include <ceres/numeric_diff_options.h>
#include <ceres/sized_cost_function.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
using Jet4 = ceres::Jet<double, 4>;

constexpr ProfileModel kModels[] = {ProfileModel::kSmooth,
                                    ProfileModel::kSinusoid,
                                    ProfileModel::kSawtooth};

// Central difference of f at x with a relative step.
double Derivative(const std::function<double(double)>& f, double x) {
  const double h = 1e-6 * std::max(1.0, std::fabs(x));
  return (f(x + h) - f(x - h)) / (2.0 * h);
}

// ∫ f(β) dβ over [lo, hi] by the trapezoid rule.
double Integrate(const std::function<double(double)>& f, double lo, double hi,
                 int steps) {
  const double h = (hi - lo) / steps;
  double sum = 0.5 * (f(lo) + f(hi));
  for (int i = 1; i < steps; ++i) sum += f(lo + i * h);
  return sum * h;
}

// The β > 0 maximiser of f over [lo, hi]: a coarse grid, then a fine one.
double ArgMax(const std::function<double(double)>& f, double lo, double hi) {
  double best = lo;
  double best_value = -1.0;
  const double coarse = (hi - lo) / 1000.0;
  for (double b = lo; b <= hi; b += coarse) {
    const double v = f(b);
    if (v > best_value) {
      best_value = v;
      best = b;
    }
  }
  const double center = best;
  for (double b = center - coarse; b <= center + coarse; b += coarse / 200.0) {
    const double v = f(b);
    if (v > best_value) {
      best_value = v;
      best = b;
    }
  }
  return best;
}

TEST(RadianceTest, ModelNames) {
  EXPECT_STREQ(ProfileModelName(ProfileModel::kSmooth), "SMOOTH");
  EXPECT_STREQ(ProfileModelName(ProfileModel::kSinusoid), "SINUSOID");
  EXPECT_STREQ(ProfileModelName(ProfileModel::kSawtooth), "SAWTOOTH");
}

TEST(RadianceTest, PaperPeakSpacings) {
  // Coarse copper gauze: λ = 2.88 mm, h0 = 0.108 mm (DESIGN.md §3).
  const double m_sin = SinusoidMaxSlope(0.108, 2.88);
  EXPECT_NEAR(m_sin, 0.2356, 1e-4);
  EXPECT_NEAR(m_sin, 2.0 * M_PI * 0.108 / 2.88, 1e-15);
  EXPECT_NEAR(PeakSpacingRad(m_sin) / kDeg, 26.516, 1e-3);
  EXPECT_NEAR(PeakSpacingRad(m_sin),
              2.0 * std::atan(2.0 * M_PI * 0.108 / 2.88), 1e-15);
  const double m_saw = SawtoothMaxSlope(0.108, 2.88);
  EXPECT_NEAR(m_saw, 0.15, 1e-12);
  EXPECT_NEAR(PeakSpacingRad(m_saw) / kDeg, 17.062, 1e-3);
  // Fig. 5: k = 1 (λ = 2π), h0 = 0.2 → m = 0.2.
  const double m_fig5 = SinusoidMaxSlope(0.2, 2.0 * M_PI);
  EXPECT_NEAR(m_fig5, 0.2, 1e-15);
  EXPECT_NEAR(PeakSpacingRad(m_fig5) / kDeg, 22.620, 1e-3);
  EXPECT_EQ(PeakSpacingRad(0.0), 0.0);
}

TEST(RadianceTest, GaussianDensityHandValues) {
  EXPECT_NEAR(GaussianDensity(0.0, 0.01), 39.89422804014327, 1e-10);
  EXPECT_NEAR(GaussianDensity(0.02, 0.01), 39.89422804014327 * std::exp(-2.0),
              1e-10);
  EXPECT_DOUBLE_EQ(SmoothTiltDensity(0.003, 0.01), GaussianDensity(0.003, 0.01));
}

TEST(RadianceTest, QuadratureNodesAreBounded) {
  EXPECT_EQ(SinusoidQuadratureNodes(0.0, 0.01), 64);
  EXPECT_EQ(SinusoidQuadratureNodes(0.24, 0.001),
            static_cast<int>(std::ceil(kSinusoidNodesPerBlur * 2.0 * M_PI * 0.24 / 0.001)));
  EXPECT_EQ(SinusoidQuadratureNodes(10.0, 1e-9), 8192);
}

// The quadrature's own nodes give the density a quadrature ten times as fine
// gives, to 1e-11 of the larger of it and 1 (its aliasing error, bounded in
// SinusoidQuadratureNodes, is 5e-13), across the lobe and past its
// caustics, for gentle to steep slopes and sharp to wide blurs. (Where a
// sharp blur and a steep slope want more than the 8192 nodes allowed, the
// error grows: 2e-10 at 0.02° and m = 0.44, 1e-3 at m = 0.8, as it did at
// three nodes per sigma, which the bound held to the same count.)
TEST(RadianceTest, SinusoidQuadratureIsExact) {
  auto every_node = [](double beta, double m, double sigma, int n) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      sum += GaussianDensity(beta - std::atan(m * SinusoidNodeSin(i, n)), sigma);
    }
    return sum / n;
  };
  for (double m : {0.05, 0.2, 0.44, 0.8}) {
    for (double sigma_deg : {0.02, 0.1, 0.5}) {
      const double sigma = sigma_deg * M_PI / 180.0;
      const int n = SinusoidQuadratureNodes(m, sigma);
      if (n == 8192) continue;  // at its bound (above)
      for (int k = 0; k <= 100; ++k) {
        const double beta = 1.2 * std::atan(m) * (k / 50.0 - 1.0);
        const double fine = every_node(beta, m, sigma, 10 * n);
        EXPECT_NEAR(SinusoidTiltDensity(beta, m, sigma), fine, 1e-11 * std::max(fine, 1.0))
            << "m " << m << " sigma " << sigma_deg << " deg, beta " << beta;
      }
    }
  }
}

TEST(RadianceTest, DensitiesIntegrateToOne) {
  for (double m : {0.05, 0.24, 0.6}) {
    for (double blur : {0.004, 0.02}) {
      const double reach = std::atan(m) + 10.0 * blur;
      // The trapezoid rule is spectrally accurate for these smooth integrands.
      const int steps = static_cast<int>(2.0 * reach / (blur / 4.0));
      const double sinusoid = Integrate(
          [&](double b) { return SinusoidTiltDensity(b, m, blur); }, -reach,
          reach, steps);
      const double sawtooth = Integrate(
          [&](double b) { return SawtoothTiltDensity(b, m, blur); }, -reach,
          reach, steps);
      const double smooth = Integrate(
          [&](double b) { return SmoothTiltDensity(b, blur); }, -reach, reach,
          steps);
      EXPECT_NEAR(sinusoid, 1.0, 1e-6) << "m " << m << " blur " << blur;
      const double rounded = Integrate(
          [&](double b) { return SawtoothTiltDensity(b, m, blur, 0.2); }, -reach,
          reach, steps);
      EXPECT_NEAR(sawtooth, 1.0, 1e-6) << "m " << m << " blur " << blur;
      EXPECT_NEAR(rounded, 1.0, 1e-6) << "m " << m << " blur " << blur;
      EXPECT_NEAR(smooth, 1.0, 1e-6) << "blur " << blur;
    }
  }
}

// The density sums only the nodes near β, found by arcsine: the same sum
// as over every node, for tilts inside, at and beyond the caustic, near
// ±90°, for a flat surface, and for node counts of every residue mod 4
// (where the two runs of nodes meet at θ = π/2 and 3π/2).
TEST(RadianceTest, SinusoidDensitySumsTheNodesNearTheTilt) {
  auto every_node = [](double beta, double m, double sigma, int n) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      const double s = std::sin(2.0 * M_PI * (i + 0.5) / n);
      sum += GaussianDensity(beta - std::atan(m * s), sigma);
    }
    return sum / n;
  };
  for (int n : {64, 65, 66, 67, 1000}) {
    for (double m : {0.0, 0.05, 0.4, 2.5, -0.4}) {
      for (double sigma : {0.002, 0.02, 0.2}) {
        for (double beta : {-1.5, -0.5, -0.3, -0.0499, 0.0, 0.1, 0.38, 0.3805, 1.19, 1.56}) {
          double windowed = 0.0;
          ForSinusoidNodesNear(beta, std::fabs(m), 9.0 * sigma, n, [&](int i) {
            windowed += GaussianDensity(beta - std::atan(std::fabs(m) * SinusoidNodeSin(i, n)),
                                        sigma);
          });
          windowed /= n;
          const double full = every_node(beta, m, sigma, n);
          EXPECT_NEAR(windowed, full, 1e-12 * std::max(full, 1.0))
              << "n " << n << " m " << m << " sigma " << sigma << " beta " << beta;
          // The density itself, in doubles and in Jets, is that sum over its
          // own nodes.
          const double own = every_node(beta, m, sigma, SinusoidQuadratureNodes(m, sigma));
          EXPECT_NEAR(SinusoidTiltDensity(beta, m, sigma), own, 1e-12 * std::max(own, 1.0));
          using J = ceres::Jet<double, 1>;
          EXPECT_NEAR(SinusoidTiltDensity(J(beta), J(m, 0), J(sigma)).a, own,
                      1e-12 * std::max(own, 1.0));
        }
      }
    }
  }
}

TEST(RadianceTest, SinusoidDensityJetsCarryTheTemplatesDerivatives) {
  // The Jet overload (plain arithmetic, chain rule at the end) gives the
  // generic template's value and derivatives by β, m and σ, for either sign
  // of m and through combined seeds.
  using J = ceres::Jet<double, 3>;
  for (double m : {0.05, 0.4, -0.4, 2.5}) {
    for (double sigma : {0.002, 0.02, 0.2}) {
      for (double beta : {-0.5, -0.0499, 0.0, 0.1, 0.38, 1.19}) {
        J b(beta, 0), s(m, 1), w(sigma, 2);
        b.v[1] = 0.5;  // β moving with m too: the derivatives add
        const J fast = SinusoidTiltDensity(b, s, w);
        const J slow = SinusoidTiltDensity<J>(b, s, w);
        const double scale = std::max(std::fabs(slow.a), 1.0);
        EXPECT_NEAR(fast.a, slow.a, 1e-12 * scale) << m << " " << sigma << " " << beta;
        for (int k = 0; k < 3; ++k) {
          EXPECT_NEAR(fast.v[k], slow.v[k], 1e-9 * std::max(std::fabs(slow.v[k]), scale))
              << "derivative " << k << " m " << m << " sigma " << sigma << " beta " << beta;
        }
        // A quadrature sized for a sharper blur (more nodes) gives the same.
        const J finer = SinusoidTiltDensity(b, s, w, 0.3 * sigma);
        EXPECT_NEAR(finer.a, slow.a, 1e-9 * scale) << m << " " << sigma << " " << beta;
      }
    }
  }
}

TEST(RadianceTest, SinusoidDensityApproachesTheCaustic) {
  // With little blur, inside the caustics the density is the unblurred
  // sec²β / (π·sqrt(m² − tan²β)) (DESIGN.md §3).
  const double m = 0.24;
  const double blur = 0.001;
  for (double t : {-0.18, -0.12, 0.0, 0.06, 0.12, 0.2}) {
    const double beta = std::atan(t);
    const double sec2 = 1.0 + t * t;
    const double exact = sec2 / (M_PI * std::sqrt(m * m - t * t));
    EXPECT_NEAR(SinusoidTiltDensity(beta, m, blur) / exact, 1.0, 5e-3)
        << "tan beta " << t;
  }
  // Hand value at β = 0: 1 / (π·m) = 1.32629.
  EXPECT_NEAR(SinusoidTiltDensity(0.0, m, blur), 1.32629, 5e-3);
  // Well outside the caustics nothing is left.
  EXPECT_LT(SinusoidTiltDensity(std::atan(m) + 0.02, m, blur), 1e-10);
}

TEST(RadianceTest, BlurredSinusoidPeaksPulledInward) {
  // DESIGN.md §3: blur pulls each caustic maximum inward by roughly 0.4× its
  // width; for a Gaussian of σ the shift is about 0.77σ (≈ 0.33 FWHM).
  const double m = 0.24;
  for (double blur : {0.005, 0.01, 0.02}) {
    const auto density = [&](double b) { return SinusoidTiltDensity(b, m, blur); };
    const double caustic = std::atan(m);
    const double right = ArgMax(density, 0.0, caustic + 5.0 * blur);
    const double left = -ArgMax([&](double b) { return density(-b); }, 0.0,
                                caustic + 5.0 * blur);
    const double shift = caustic - right;
    EXPECT_GT(shift, 0.6 * blur) << "blur " << blur;
    EXPECT_LT(shift, 0.4 * 2.3548 * blur) << "blur " << blur;
    EXPECT_NEAR(left, -right, 0.01 * blur) << "symmetric, blur " << blur;
  }
}

TEST(RadianceTest, SawtoothDensityPeaksAtTheFacetTilts) {
  const double m = 0.15;
  const double blur = 0.005;
  const auto density = [&](double b) { return SawtoothTiltDensity(b, m, blur); };
  EXPECT_NEAR(ArgMax(density, 0.0, 0.3), std::atan(m), 1e-5);
  // Half the facets at each tilt: the peak is half a Gaussian's maximum.
  EXPECT_NEAR(density(std::atan(m)), 0.5 * GaussianDensity(0.0, blur), 1e-9);
  EXPECT_LT(density(0.0), 1e-100);
}

// The maximiser of f over [lo, hi]: a grid of step `coarse`, then a grid of
// step `fine` over the two coarse steps around its best node.
double GridArgMax(const std::function<double(double)>& f, double lo, double hi,
                  double coarse, double fine) {
  double best = lo;
  double best_value = f(lo);
  const int n = static_cast<int>(std::ceil((hi - lo) / coarse));
  for (int i = 1; i <= n; ++i) {
    const double x = std::min(hi, lo + i * coarse);
    const double v = f(x);
    if (v > best_value) {
      best_value = v;
      best = x;
    }
  }
  const double center = best;
  const int m = static_cast<int>(std::ceil(coarse / fine));
  for (int i = -m; i <= m; ++i) {
    const double x = std::clamp(center + i * fine, lo, hi);
    const double v = f(x);
    if (v > best_value) {
      best_value = v;
      best = x;
    }
  }
  return best;
}

// The paper's split peaks in the radiance itself, not only in the tilt
// density: with a small blur (0.05° in β) the two maxima of the specular
// radiance across the cylinder sit at α/2 ± arctan m (orthographic, so the
// mirror is at α/2), with the light in front and well off to the side, where
// the 1/(cos φ · cos β*) foreshortening is asymmetric. The coarse copper
// gauze as a sinusoid (m = 0.2356) and as a sawtooth (m = 0.15). Each side of
// the mirror is searched on its own grid out to 2° beyond the caustic: steps
// of 0.1° (two blur widths: inside the caustic the lobe rises monotonically
// toward it and outside it falls within a few σ, so the best node is within
// one step of the peak), then 0.002°.
TEST(RadianceTest, CausticPeaksOfBlurredSpecularRadianceAtHalfAlphaPlusMinusArctanM) {
  const double blur = 0.05 * kDeg;
  const struct {
    ProfileModel model;
    double max_slope;
  } cases[] = {{ProfileModel::kSinusoid, SinusoidMaxSlope(0.108, 2.88)},
               {ProfileModel::kSawtooth, SawtoothMaxSlope(0.108, 2.88)}};
  for (const auto& c : cases) {
    for (double alpha_deg : {0.0, 30.0, 60.0}) {
      RadianceParams<double> p;
      p.model = c.model;
      p.max_slope = c.max_slope;
      p.mirror_rad = alpha_deg / 2.0 * kDeg;
      p.blur_rad = blur;
      p.phase_angle_rad = alpha_deg * kDeg;
      const auto radiance = [&](double phi) { return SpecularRadiance(p, phi); };
      const double half_split = std::atan(c.max_slope);
      const double reach = half_split + 2.0 * kDeg;
      const double left = GridArgMax(radiance, p.mirror_rad - reach, p.mirror_rad,
                                     0.1 * kDeg, 0.002 * kDeg);
      const double right = GridArgMax(radiance, p.mirror_rad, p.mirror_rad + reach,
                                      0.1 * kDeg, 0.002 * kDeg);
      EXPECT_NEAR(left / kDeg, (p.mirror_rad - half_split) / kDeg, 0.2)
          << ProfileModelName(c.model) << " alpha " << alpha_deg;
      EXPECT_NEAR(right / kDeg, (p.mirror_rad + half_split) / kDeg, 0.2)
          << ProfileModelName(c.model) << " alpha " << alpha_deg;
      // They are the lobe's maxima, not its edges: the mirror itself is lower.
      EXPECT_GT(radiance(left), radiance(p.mirror_rad));
      EXPECT_GT(radiance(right), radiance(p.mirror_rad));
    }
  }
}

// Evaluates every density and the full radiance with Jets, with the
// derivative parts seeded on (β or φ, m, blur, scale), and compares the
// value with the double evaluation and the derivatives with central
// differences.
TEST(RadianceTest, JetAgreesWithDouble) {
  const double m = 0.24;
  const double blur = 0.012;
  for (double beta : {-0.3, -0.2, -0.05, 0.0, 0.1, 0.23, 0.26}) {
    const Jet4 jb(beta, 0);
    const Jet4 jm(m, 1);
    const Jet4 js(blur, 2);
    struct Case {
      const char* name;
      Jet4 jet;
      std::function<double(double, double, double)> f;
    } cases[] = {
        {"sinusoid", SinusoidTiltDensity(jb, jm, js),
         [](double b, double mm, double s) { return SinusoidTiltDensity(b, mm, s); }},
        {"sawtooth", SawtoothTiltDensity(jb, jm, js),
         [](double b, double mm, double s) { return SawtoothTiltDensity(b, mm, s); }},
        {"smooth", SmoothTiltDensity(jb, js),
         [](double b, double, double s) { return SmoothTiltDensity(b, s); }},
    };
    for (const Case& c : cases) {
      const double value = c.f(beta, m, blur);
      const double scale = std::max(1.0, std::fabs(value));
      EXPECT_NEAR(c.jet.a, value, 1e-12 * scale) << c.name << " beta " << beta;
      const double d_beta = Derivative([&](double x) { return c.f(x, m, blur); }, beta);
      const double d_m = Derivative([&](double x) { return c.f(beta, x, blur); }, m);
      const double d_blur = Derivative([&](double x) { return c.f(beta, m, x); }, blur);
      const double tol = 1e-5 * std::max({1.0, std::fabs(d_beta), std::fabs(d_m),
                                          std::fabs(d_blur)});
      EXPECT_NEAR(c.jet.v[0], d_beta, tol) << c.name << " d/dbeta at " << beta;
      EXPECT_NEAR(c.jet.v[1], d_m, tol) << c.name << " d/dm at " << beta;
      EXPECT_NEAR(c.jet.v[2], d_blur, tol) << c.name << " d/dblur at " << beta;
      EXPECT_EQ(c.jet.v[3], 0.0) << c.name;
    }
  }
}

// Radiance with the four fitted parameters as values of x.
template <typename T>
T RadianceOf(ProfileModel model, const T* x, double azimuth_rad) {
  RadianceParams<T> p;
  p.model = model;
  p.max_slope = x[0];
  p.mirror_rad = x[1];
  p.blur_rad = x[2];
  p.scale = x[3];
  p.scatter = T(0.01);
  p.diffuse = T(0.02);
  p.background = T(0.005);
  p.phase_angle_rad = T(20.0 * kDeg);
  return Radiance(p, T(azimuth_rad));
}

TEST(RadianceTest, RadianceJetAgreesWithDouble) {
  const double x[4] = {0.24, 10.0 * kDeg, 0.01, 0.3};
  for (ProfileModel model : kModels) {
    for (double deg = -80.0; deg <= 80.0; deg += 3.7) {
      const double phi = deg * kDeg;
      Jet4 jx[4];
      for (int k = 0; k < 4; ++k) jx[k] = Jet4(x[k], k);
      const Jet4 jet = RadianceOf(model, jx, phi);
      const double value = RadianceOf(model, x, phi);
      EXPECT_NEAR(jet.a, value, 1e-12 * std::max(1.0, value))
          << ProfileModelName(model) << " phi " << deg;
      for (int k = 0; k < 4; ++k) {
        const double d = Derivative(
            [&](double v) {
              double y[4] = {x[0], x[1], x[2], x[3]};
              y[k] = v;
              return RadianceOf(model, y, phi);
            },
            x[k]);
        EXPECT_NEAR(jet.v[k], d, 1e-5 * std::max(1.0, std::fabs(d)))
            << ProfileModelName(model) << " phi " << deg << " param " << k;
      }
    }
  }
}

TEST(RadianceTest, FiniteOverTheValidRange) {
  for (ProfileModel model : kModels) {
    for (double m : {0.0, 0.05, 0.24, 1.0}) {
      for (double blur : {1e-4, 0.005, 0.05}) {
        for (double mirror_deg : {-40.0, 0.0, 25.0}) {
          for (double deg = -89.9; deg <= 89.9; deg += 1.9) {
            const double x[4] = {m, mirror_deg * kDeg, blur, 1.0};
            const double value = RadianceOf(model, x, deg * kDeg);
            ASSERT_TRUE(std::isfinite(value))
                << ProfileModelName(model) << " m " << m << " blur " << blur
                << " mirror " << mirror_deg << " phi " << deg;
            ASSERT_GE(value, 0.0);
            Jet4 jx[4];
            for (int k = 0; k < 4; ++k) jx[k] = Jet4(x[k], k);
            const Jet4 jet = RadianceOf(model, jx, deg * kDeg);
            ASSERT_TRUE(ceres::isfinite(jet))
                << ProfileModelName(model) << " m " << m << " blur " << blur
                << " mirror " << mirror_deg << " phi " << deg;
          }
        }
      }
    }
  }
}

TEST(RadianceTest, HandComputedRadiance) {
  // SMOOTH at the mirror point: β* = 0 and cos φ cancels cos(mirror), so
  // L = scale·G(0; σ) = scale / (sqrt(2π)·σ).
  RadianceParams<double> p;
  p.model = ProfileModel::kSmooth;
  p.mirror_rad = 0.1;
  p.blur_rad = 0.01;
  p.scale = 0.5;
  EXPECT_NEAR(Radiance(p, 0.1), 0.5 / (std::sqrt(2.0 * M_PI) * 0.01), 1e-10);
  // Off the mirror point: cos(0.1)·G(0.02; 0.01) / (cos 0.08 · cos 0.02).
  EXPECT_NEAR(Radiance(p, 0.08),
              0.5 * std::cos(0.1) * GaussianDensity(0.02, 0.01) /
                  (std::cos(0.08) * std::cos(0.02)),
              1e-10);

  // Scatter, diffuse and background, far from the specular lobe.
  p.scatter = 0.01;
  p.diffuse = 0.2;
  p.background = 0.003;
  p.phase_angle_rad = 0.2;
  const double phi = -0.9;
  const double specular = SpecularRadiance(p, phi);
  EXPECT_LT(specular, 1e-100);
  EXPECT_NEAR(Radiance(p, phi),
              0.01 * std::cos(0.1) / std::cos(phi) + 0.2 * std::cos(phi - 0.2) + 0.003,
              1e-12);
  // Behind the terminator (cos(φ − α) < 0) only the background is left.
  p.phase_angle_rad = 1.4;
  p.mirror_rad = 0.7;
  EXPECT_NEAR(Radiance(p, -0.3), 0.003, 1e-12);
  EXPECT_EQ(ScatterRadiance(p, -0.3), 0.0);
  EXPECT_EQ(DiffuseRadiance(p, -0.3), 0.0);
  // Near the limb the 1/cos φ factor is capped at 1 / kMinCosAzimuth.
  p.phase_angle_rad = 1.4;
  EXPECT_NEAR(ScatterRadiance(p, 89.9 * kDeg), 0.01 * std::cos(0.7) / kMinCosAzimuth,
              1e-12);
}

TEST(RadianceTest, SymmetricAboutTheMirrorAtNormalIncidence) {
  for (ProfileModel model : {ProfileModel::kSinusoid, ProfileModel::kSawtooth}) {
    const double x[4] = {0.24, 0.0, 0.01, 1.0};
    for (double deg = 0.5; deg < 40.0; deg += 1.3) {
      RadianceParams<double> p;
      p.model = model;
      p.max_slope = x[0];
      p.blur_rad = x[2];
      EXPECT_NEAR(SpecularRadiance(p, deg * kDeg), SpecularRadiance(p, -deg * kDeg),
                  1e-12 * std::max(1.0, SpecularRadiance(p, deg * kDeg)))
          << ProfileModelName(model) << " " << deg;
    }
  }
}

// Residual of one profile sample against Radiance; parameters in order
// (max_slope, mirror_rad, blur_rad, scale).
struct RadianceResidual {
  ProfileModel model;
  double azimuth_rad;
  double observed;
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    residual[0] = RadianceOf(model, x, azimuth_rad) - T(observed);
    return true;
  }
};

// Probes where the specular lobe carries the gradient: in its tails the
// Jacobian is ~1e-16 and the checker, which has no absolute floor, compares
// rounding noise; at a peak itself d/dm vanishes likewise.
TEST(RadianceTest, GradientCheckerOnAutoDiffCost) {
  const double x[4] = {0.24, 8.0 * kDeg, 0.012, 0.3};
  const double* parameters[] = {x};
  // The checker differentiates by Ridders' method, whose first step is at
  // least ridders_relative_initial_step_size in absolute terms (0.01 by
  // default): as large as the blur itself. Start at 1e-4 instead.
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  const double caustic = std::atan(x[0]);
  const double blur = x[2];
  struct Probe {
    ProfileModel model;
    std::vector<double> centers;  // azimuths of the lobe's peaks
  } probes[] = {
      {ProfileModel::kSmooth, {x[1]}},
      {ProfileModel::kSinusoid, {x[1] - caustic, x[1], x[1] + caustic}},
      {ProfileModel::kSawtooth, {x[1] - caustic, x[1] + caustic}},
  };
  int probed = 0;
  for (const Probe& probe : probes) {
    for (double center : probe.centers) {
      for (double offset : {-1.5, -0.6, 0.3, 0.7, 1.5}) {
        const double phi = center + offset * blur;
        std::unique_ptr<ceres::CostFunction> cost(
            new ceres::AutoDiffCostFunction<RadianceResidual, 1, 4>(
                new RadianceResidual{probe.model, phi, 0.1}));
        const ceres::GradientChecker checker(
            cost.get(),
            static_cast<const std::vector<const ceres::Manifold*>*>(nullptr),
            numeric);
        ceres::GradientChecker::ProbeResults results;
        EXPECT_TRUE(checker.Probe(parameters, 1e-6, &results))
            << ProfileModelName(probe.model) << " phi " << phi / kDeg
            << " deg: " << results.error_log;
        EXPECT_TRUE(results.return_value);
        ++probed;
      }
    }
  }
  EXPECT_EQ(probed, 30);
}

// The checker must be able to fail: a cost whose analytic Jacobian is off by
// a factor two in one column.
class WrongJacobianCost : public ceres::SizedCostFunction<1, 4> {
 public:
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* x = parameters[0];
    residuals[0] = RadianceOf(ProfileModel::kSinusoid, x, 5.0 * kDeg);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Jet4 jx[4];
      for (int k = 0; k < 4; ++k) jx[k] = Jet4(x[k], k);
      const Jet4 jet = RadianceOf(ProfileModel::kSinusoid, jx, 5.0 * kDeg);
      for (int k = 0; k < 4; ++k) jacobians[0][k] = jet.v[k];
      jacobians[0][0] *= 2.0;
    }
    return true;
  }
};

TEST(RadianceTest, GradientCheckerDetectsAWrongJacobian) {
  const double x[4] = {0.24, 8.0 * kDeg, 0.012, 0.3};
  const double* parameters[] = {x};
  WrongJacobianCost cost;
  const ceres::GradientChecker checker(
      &cost, static_cast<const std::vector<const ceres::Manifold*>*>(nullptr),
      ceres::NumericDiffOptions());
  ceres::GradientChecker::ProbeResults results;
  EXPECT_FALSE(checker.Probe(parameters, 1e-6, &results));
}

}  // namespace
}  // namespace weavefit
