// Column-averaged radiance L(φ) of a glossy plane weave on a circular cylinder
// (DESIGN.md §3), written once as templates for double and ceres::Jet.
//
// Geometry (DESIGN.md §2): φ is the azimuth of the mean surface normal from
// the direction to the camera, positive toward the image right; the light
// comes from the signed phase angle α, l = (sin α, cos α). A facet of tilt β
// (β = −arctan h′) has its normal at φ + β; it mirrors the light into the
// camera where φ + β = (α + v)/2, v being the direction to the camera seen
// from the surface point (v = 0 orthographic, see ViewAngleRad).
//
// Exact geometrical optics, no shadowing, tilt density p(β) per mean arc
// length:   L(φ) = E0 · cos(h) · p(β*) / (cos φ · cos β*),
//           β* = (α + v)/2 − φ,  h = (α − v)/2 (incidence on the facet).
// Derivation: a facet of mean-arc length ds and tilt β shows the camera a
// width ds·cos(φ+β)/cos β, and φ+β at the mirror is the half angle h; the
// image column covers ds·cos φ of mean arc.
//
// Difference from the paper's Eq. 4 (Pont & Koenderink 2003): Eq. 4 counts
// one of the two reflecting branches of each period and omits one factor
// sec β. We use the exact form above; the two differ by < 3 % in shape at
// m = 0.24 and only in absolute scale otherwise, which the fitted E0 absorbs.
//
// Blur (source angular size, optics, pixel footprint) is a Gaussian of
// standard deviation blur_rad in facet tilt β, i.e. in azimuth at fixed β. A
// source of angular standard deviation s gives blur_rad = s/2.
#ifndef WEAVEFIT_ESTIMATOR_OPTICS_RADIANCE_H_
#define WEAVEFIT_ESTIMATOR_OPTICS_RADIANCE_H_

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <ceres/jet.h>

namespace weavefit {

enum class ProfileModel { kSmooth = 1, kSinusoid = 2, kSawtooth = 3 };

const char* ProfileModelName(ProfileModel model);

// The value part of a scalar, for choices (quadrature size, branches) that
// must not depend on derivatives.
inline double ScalarValue(double x) { return x; }
template <typename T, int N>
inline double ScalarValue(const ceres::Jet<T, N>& x) {
  return ScalarValue(x.a);
}

// Gaussian density of x with standard deviation sigma.
template <typename T>
T GaussianDensity(const T& x, const T& sigma) {
  using std::exp;
  using std::sqrt;
  const double kInvSqrt2Pi = 0.3989422804014327;
  const T z = x / sigma;
  return T(kInvSqrt2Pi) * exp(T(-0.5) * z * z) / sigma;
}

// Number of quadrature nodes over one period of a sinusoid of max slope m,
// blurred by sigma: the node spacing h mapped to tilt (at most m per radian
// of phase) stays below sigma/kSinusoidNodesPerBlur. The integrand is
// smooth and periodic in the phase, its narrowest feature a Gaussian
// sigma/m wide, so the midpoint rule's error is its aliasing,
// exp(−2π²(sigma/(m·h))²) relative: 5e-13 at 1.2 nodes per sigma
// (SinusoidQuadratureIsExact measures it). Three nodes per sigma, used
// before, put it at 1e-77, and the lobe fits' own functions took a third
// more of the CPU (perf samples over the shared photographs' PNGs: 2990
// against 2231). Bounded to keep the cost predictable.
inline constexpr double kSinusoidNodesPerBlur = 1.2;
inline int SinusoidQuadratureNodes(double max_slope, double blur_rad) {
  const double kPi = 3.14159265358979323846;
  const double wanted =
      kSinusoidNodesPerBlur * 2.0 * kPi * std::fabs(max_slope) / std::max(blur_rad, 1e-6);
  return static_cast<int>(std::clamp(std::ceil(wanted), 64.0, 8192.0));
}

// Calls f(i) for each of n quadrature nodes θ_i = 2π(i + ½)/n whose tilt
// arctan(m·sin θ_i) lies within `reach` of β (m ≥ 0): those where sin θ
// lies in [tan(β − reach), tan(β + reach)]/m, two runs of indices found by
// arcsine, so the cost is the nodes near β, not all n.
template <typename F>
void ForSinusoidNodesNear(double beta, double max_slope, double reach, int n, F&& f) {
  const double kPi = 3.14159265358979323846;
  if (!(max_slope > 1e-12)) {
    if (std::fabs(beta) < reach) {
      for (int i = 0; i < n; ++i) f(i);
    }
    return;
  }
  const double lo_tilt = beta - reach;
  const double hi_tilt = beta + reach;
  const double lo = lo_tilt <= -0.5 * kPi ? -1.0 : std::tan(lo_tilt) / max_slope;
  const double hi = hi_tilt >= 0.5 * kPi ? 1.0 : std::tan(hi_tilt) / max_slope;
  if (lo > 1.0 || hi < -1.0) return;
  const double a = std::asin(std::max(lo, -1.0));
  const double b = std::asin(std::min(hi, 1.0));
  // Index runs of θ in [a, b] and [π − b, π − a]; θ < 0 wraps to θ + 2π.
  const double per = n / (2.0 * kPi);
  int c1 = static_cast<int>(std::ceil(a * per - 0.5));
  const int d1 = static_cast<int>(std::floor(b * per - 0.5));
  int c2 = static_cast<int>(std::ceil((kPi - b) * per - 0.5));
  const int d2 = static_cast<int>(std::floor((kPi - a) * per - 0.5));
  c2 = std::max(c2, d1 + 1);        // the runs meet at θ = π/2
  c1 = std::max(c1, d2 - n + 1);    // ... and at θ = 3π/2 ≡ −π/2
  for (int k = c1; k <= d1; ++k) f(k < 0 ? k + n : k);
  for (int i = c2; i <= d2; ++i) f(i);
}

// sin θ_i of SinusoidTiltDensity's node i of n.
inline double SinusoidNodeSin(int i, int n) {
  return std::sin(2.0 * 3.14159265358979323846 * (i + 0.5) / n);
}

// The nodes of n at one |m|: their tilts arctan(|m|·sin θ_i) and the
// tilts' derivatives by |m|, sin θ_i/(1 + m²·sin²θ_i). They depend on m only,
// and every bin of a profile fit (and every azimuth of peak picking's
// corrections) is evaluated at one m, so the last m's are kept per thread.
struct SinusoidNodes {
  std::vector<double> tilt;
  std::vector<double> dtilt_dslope;
};

inline const SinusoidNodes& SinusoidNodesAt(double max_slope, int n) {
  thread_local SinusoidNodes nodes;
  thread_local double cached_slope = std::numeric_limits<double>::quiet_NaN();
  const double m = std::fabs(max_slope);
  if (!(m == cached_slope) || static_cast<int>(nodes.tilt.size()) != n) {
    nodes.tilt.resize(n);
    nodes.dtilt_dslope.resize(n);
    for (int i = 0; i < n; ++i) {
      const double s = SinusoidNodeSin(i, n);
      nodes.tilt[i] = std::atan(m * s);
      nodes.dtilt_dslope[i] = s / (1.0 + m * m * s * s);
    }
    cached_slope = m;
  }
  return nodes;
}

// Blurred tilt density p_σ(β) of a sinusoid h0·sin(kx) with max slope m =
// k·h0, per mean arc length. The unblurred density is
// sec²β / (π·sqrt(m² − tan²β)) for |tan β| < m; substituting tan β =
// m·sin θ makes it uniform in θ, so the blurred density is the average of
// G(β − arctan(m·sin θ); σ) over θ in one period (midpoint rule, which is
// spectrally accurate for this smooth periodic integrand). The sign of m
// only renumbers the nodes (θ → θ + π).
//
// Only the nodes whose tilt lies within 9σ of β (by their values) are
// summed: a node beyond adds a Gaussian factor below 3e-18, to the value and
// to the derivatives alike, and the least-squares fits (T a ceres::Jet)
// spend most of their time here.
//
// `quadrature_blur_rad` (> 0) sizes the quadrature for that blur instead,
// when it is smaller: a fit whose bins each see their own blur (a lens blur
// grows in azimuth toward the limbs) sizes it for the sharpest, so that every
// bin of an evaluation shares one set of nodes (SinusoidNodesAt keeps one).
// More nodes than a bin needs only make its sum more exact (the midpoint
// rule over a smooth periodic integrand has converged long before).
inline int SinusoidNodesFor(double max_slope, double blur_rad, double quadrature_blur_rad) {
  return SinusoidQuadratureNodes(
      max_slope, quadrature_blur_rad > 0.0 ? std::min(quadrature_blur_rad, blur_rad) : blur_rad);
}

template <typename T>
T SinusoidTiltDensity(const T& beta, const T& max_slope, const T& blur_rad,
                      double quadrature_blur_rad = 0.0) {
  using std::atan;
  const double m = ScalarValue(max_slope);
  const double sign = m < 0.0 ? -1.0 : 1.0;
  const int n = SinusoidNodesFor(m, ScalarValue(blur_rad), quadrature_blur_rad);
  T sum(0.0);
  ForSinusoidNodesNear(ScalarValue(beta), std::fabs(m), 9.0 * ScalarValue(blur_rad), n,
                       [&](int i) {
                         const T tilt = atan(max_slope * T(sign * SinusoidNodeSin(i, n)));
                         sum += GaussianDensity(T(beta - tilt), blur_rad);
                       });
  return sum / T(n);
}

// The same for plain doubles, the hot path of peak picking's corrections,
// with the node tilts kept (SinusoidNodesAt). Equal to the template to
// rounding.
inline double SinusoidTiltDensity(const double& beta, const double& max_slope,
                                  const double& blur_rad, double quadrature_blur_rad = 0.0) {
  const int n = SinusoidNodesFor(max_slope, blur_rad, quadrature_blur_rad);
  const std::vector<double>& tilts = SinusoidNodesAt(max_slope, n).tilt;
  double sum = 0.0;
  ForSinusoidNodesNear(beta, std::fabs(max_slope), 9.0 * blur_rad, n,
                       [&](int i) { sum += GaussianDensity(beta - tilts[i], blur_rad); });
  return sum / n;
}

// The same for the fits' Jets, the hot path of the least-squares lobe fits:
// the sum and its partial derivatives by β, m and σ are taken in plain
// arithmetic over the kept node tilts, and the chain rule applied once at
// the end (the template's Jet atan and exp per node cost ten times as much).
// Equal to the template to rounding.
template <int N>
ceres::Jet<double, N> SinusoidTiltDensity(const ceres::Jet<double, N>& beta,
                                          const ceres::Jet<double, N>& max_slope,
                                          const ceres::Jet<double, N>& blur_rad,
                                          double quadrature_blur_rad = 0.0) {
  const double kInvSqrt2Pi = 0.3989422804014327;
  const double m = max_slope.a, b = beta.a, s = blur_rad.a;
  // tilt_i = arctan(m·sign·sin θ_i): its value is arctan(|m|·sin θ_i), its
  // derivative by m sign times that by |m|.
  const double sign = m < 0.0 ? -1.0 : 1.0;
  const int n = SinusoidNodesFor(m, s, quadrature_blur_rad);
  const SinusoidNodes& nodes = SinusoidNodesAt(m, n);
  double value = 0.0, by_beta = 0.0, by_slope = 0.0, by_blur = 0.0;
  ForSinusoidNodesNear(b, std::fabs(m), 9.0 * s, n, [&](int i) {
    const double z = (b - nodes.tilt[i]) / s;
    const double g = kInvSqrt2Pi * std::exp(-0.5 * z * z) / s;
    value += g;
    by_beta -= g * z / s;
    by_slope += g * z / s * nodes.dtilt_dslope[i];
    by_blur += g * (z * z - 1.0) / s;
  });
  ceres::Jet<double, N> out;
  out.a = value / n;
  out.v = (by_beta * beta.v + sign * by_slope * max_slope.v + by_blur * blur_rad.v) / n;
  return out;
}

// Blurred tilt density of a symmetric sawtooth: half the facets at
// +arctan m, half at −arctan m. A real sawtooth's corners are round: there
// a share c of the arc (`corner_share`) turns from one flank's tilt to the
// other's. To first order its tilts spread evenly over [−arctan m,
// arctan m], a box whose blurred density is the difference of two normal
// integrals. With c = 0 the ideal sawtooth of DESIGN.md §3; the box fills
// the level between the peaks, which a fit of the ideal one could only
// meet by pulling its two peaks inward.
template <typename T>
T SawtoothTiltDensity(const T& beta, const T& max_slope, const T& blur_rad,
                      const T& corner_share = T(0.0)) {
  using std::atan;
  using std::erf;
  const T b = atan(max_slope);
  const T flanks = T(0.5) * (GaussianDensity(T(beta - b), blur_rad) +
                             GaussianDensity(T(beta + b), blur_rad));
  if (!(ScalarValue(corner_share) > 0.0) || !(ScalarValue(b) > 0.0)) return flanks;
  const double kInvSqrt2 = 0.7071067811865476;
  const T box = T(0.5) * (erf((beta + b) * T(kInvSqrt2) / blur_rad) -
                          erf((beta - b) * T(kInvSqrt2) / blur_rad)) / (T(2.0) * b);
  return (T(1.0) - corner_share) * flanks + corner_share * box;
}

// Blurred tilt density of a smooth glossy surface: all facets at β = 0, so
// the lobe is the blur itself.
template <typename T>
T SmoothTiltDensity(const T& beta, const T& blur_rad) {
  return GaussianDensity(beta, blur_rad);
}

// `corner_share`: the sawtooth's rounded corners (SawtoothTiltDensity);
// the other models have none.
template <typename T>
T TiltDensity(ProfileModel model, const T& beta, const T& max_slope,
              const T& blur_rad, const T& corner_share = T(0.0),
              double quadrature_blur_rad = 0.0) {
  switch (model) {
    case ProfileModel::kSinusoid:
      return SinusoidTiltDensity(beta, max_slope, blur_rad, quadrature_blur_rad);
    case ProfileModel::kSawtooth:
      return SawtoothTiltDensity(beta, max_slope, blur_rad, corner_share);
    case ProfileModel::kSmooth:
      break;
  }
  return SmoothTiltDensity(beta, blur_rad);
}

// A real sawtooth is no pair of delta peaks: its corners are round and its
// facets not quite flat. On independently rendered sawtooths (corners
// rounded as tanh(8·cos), scripts/independent_scenes.py) peak picking's
// spacing read 0.3-2.2 % off, either sign, up to 4.4 stated errors where the
// smoothed comb's allowance did not cover it; the lobe fits, whose evenly
// spread corners (SawtoothTiltDensity) take most of that, still read such
// corners up to 1.5 % short where the lobe is smoothed as a comb. This share
// of the spacing is counted in its error wherever a sawtooth's split is read
// (peak picking, the lobe fits), common to the sample.
constexpr double kSawtoothShapeFloor = 0.01;

// Smallest cos φ used near the limb, where the 1/cos φ foreshortening factor
// diverges; beyond |φ| ≈ 87° a pixel averages over the limb anyway.
constexpr double kMinCosAzimuth = 0.05;

// Parameters of the full radiance model, all in library units.
template <typename T>
struct RadianceParams {
  ProfileModel model = ProfileModel::kSinusoid;
  T max_slope = T(0.0);      // tan of the largest facet tilt (m)
  T mirror_rad = T(0.0);     // azimuth of the mirror point, (α + v)/2 at v = 0
  T blur_rad = T(0.005);     // Gaussian σ in facet tilt
  T scale = T(1.0);          // E0 times camera gain
  T scatter = T(0.0);        // grazing surface-scattering level of axial threads
  T diffuse = T(0.0);        // Lambertian albedo term
  T background = T(0.0);     // additive level (ambient, flare)
  T phase_angle_rad = T(0.0);  // α, for the lit range of scatter and diffuse
  T corner_share = T(0.0);   // a sawtooth's arc in its rounded corners
  // The blur a sinusoid's quadrature is sized for, when smaller than
  // blur_rad (SinusoidTiltDensity); 0: blur_rad's own.
  double quadrature_blur_rad = 0.0;
};

// Specular radiance of the circumferential threads at azimuth φ
// (orthographic: the mirror condition is φ + β = mirror_rad).
template <typename T>
T SpecularRadiance(const RadianceParams<T>& p, const T& azimuth_rad) {
  using std::cos;
  using std::max;
  const T beta_star = p.mirror_rad - azimuth_rad;
  const T cos_phi = max(T(cos(azimuth_rad)), T(kMinCosAzimuth));
  const T density = TiltDensity(p.model, beta_star, p.max_slope, p.blur_rad, p.corner_share,
                                p.quadrature_blur_rad);
  // cos(h): the facet sees the light at the half angle; with v = 0 it is
  // cos(α/2) = cos(mirror_rad), constant over φ.
  return p.scale * cos(p.mirror_rad) * density / (cos_phi * cos(beta_star));
}

// Surface scattering of the threads along the axis (the paper's Fig. 8): a
// lobe ∝ cos(α/2)/cos φ over the lit and visible range, strongest at the limb.
template <typename T>
T ScatterRadiance(const RadianceParams<T>& p, const T& azimuth_rad) {
  using std::cos;
  using std::max;
  if (ScalarValue(cos(azimuth_rad - p.phase_angle_rad)) <= 0.0) return T(0.0);
  const T cos_phi = max(T(cos(azimuth_rad)), T(kMinCosAzimuth));
  return p.scatter * cos(p.phase_angle_rad / T(2.0)) / cos_phi;
}

// Lambertian term of coloured fabrics: ∝ max(0, cos(φ − α)).
template <typename T>
T DiffuseRadiance(const RadianceParams<T>& p, const T& azimuth_rad) {
  using std::cos;
  using std::max;
  return p.diffuse * max(T(cos(azimuth_rad - p.phase_angle_rad)), T(0.0));
}

template <typename T>
T Radiance(const RadianceParams<T>& p, const T& azimuth_rad) {
  return SpecularRadiance(p, azimuth_rad) + ScatterRadiance(p, azimuth_rad) +
         DiffuseRadiance(p, azimuth_rad) + p.background;
}

// Peak spacing on the cylinder for a max slope m: 2·arctan(m) (DESIGN.md §2).
double PeakSpacingRad(double max_slope);
// Max slope of a sinusoid h0·sin(2πx/λ): 2π·h0/λ.
double SinusoidMaxSlope(double amplitude_mm, double wavelength_mm);
// Max slope of a symmetric sawtooth of amplitude h0 (peak-to-peak 2·h0): 4·h0/λ.
double SawtoothMaxSlope(double amplitude_mm, double wavelength_mm);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_OPTICS_RADIANCE_H_
