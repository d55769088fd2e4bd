#include "estimator/cylinder/cylinder_detection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "estimator/cylinder/terminator.h"
#include "estimator/optics/radiance.h"
#include "estimator/stats/golden_section.h"
#include "estimator/stats/median.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

// Runs `left` on a second thread and `right` on this one, and returns when
// both are done: the two limbs' fits read the same bands and each writes
// only its own results, so they run side by side (on one core, or when no
// thread can be had, one after the other).
template <typename Left, typename Right>
void ForBothLimbs(Left&& left, Right&& right) {
  if (std::thread::hardware_concurrency() > 1) {
    try {
      std::thread other(std::forward<Left>(left));
      right();
      other.join();
      return;
    } catch (const std::system_error&) {
      // No thread: below, in turn.
    }
  }
  left();
  right();
}

struct LimbPoint {
  double row = 0.0;
  double column = 0.0;
};

struct Line {
  double at_center = 0.0;  // column at the reference row
  double slope = 0.0;      // columns per row
  double rms = 0.0;
  double at_center_stderr = 0.0;  // least-squares standard error of at_center
  std::vector<bool> inlier;
};

// Line column = a + slope·(row − center_row) through the limb points of the
// bands. Bands on a mount or a cylinder end, or hit by a stray glint, give
// points off the line, possibly many: the line with the most points within
// 1.5 px among those through every pair of points is kept (exhaustive, so
// deterministic), then refitted by least squares on its inliers.
Line FitLimbLine(const std::vector<LimbPoint>& points, double center_row) {
  constexpr double kInlierPx = 1.5;
  Line line;
  line.inlier.assign(points.size(), false);
  std::size_t best = 0;
  double best_a = 0.0;
  double best_slope = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (std::size_t j = i + 1; j < points.size(); ++j) {
      const double dr = points[j].row - points[i].row;
      if (std::fabs(dr) < 1e-9) continue;
      const double slope = (points[j].column - points[i].column) / dr;
      const double a = points[i].column + slope * (center_row - points[i].row);
      std::size_t count = 0;
      for (const LimbPoint& p : points) {
        count += std::fabs(p.column - a - slope * (p.row - center_row)) <= kInlierPx;
      }
      if (count > best) {
        best = count;
        best_a = a;
        best_slope = slope;
      }
    }
  }
  if (best == 0 && !points.empty()) {  // a single point
    best_a = points[0].column;
    best_slope = 0.0;
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    line.inlier[i] = std::fabs(points[i].column - best_a - best_slope * (points[i].row - center_row)) <= kInlierPx;
  }
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!line.inlier[i]) continue;
    const double x = points[i].row - center_row;
    sw += 1;
    sx += x;
    sy += points[i].column;
    sxx += x * x;
    sxy += x * points[i].column;
  }
  const double det = sw * sxx - sx * sx;
  if (sw >= 3 && det > 1e-9) {
    line.slope = (sw * sxy - sx * sy) / det;
    line.at_center = (sy - line.slope * sx) / sw;
  } else {
    line.slope = best_slope;
    line.at_center = best_a;
  }
  double sum_sq = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!line.inlier[i]) continue;
    const double r = points[i].column - line.at_center - line.slope * (points[i].row - center_row);
    sum_sq += r * r;
    ++n;
  }
  line.rms = n > 0 ? std::sqrt(sum_sq / n) : 0.0;
  if (n >= 3 && det > 1e-9) {
    line.at_center_stderr = std::sqrt(sum_sq / (n - 2) * sxx / det);
  } else {
    line.at_center_stderr = line.rms;
  }
  return line;
}

// At the limb toward the light, a rise inward of this share of the
// surface's level above the background is a glint (see RefineEdge); a band
// mean's noise and the cloth's texture rise by a few per cent.
constexpr double kEdgeRise = 0.5;
// From this phase angle on, the lobe's glints may reach the limb toward the
// light (its outer caustic, at α/2 + arctan m, within a few pixels of it).
constexpr double kGlintsReachLimbRad = 60.0 * M_PI / 180.0;
// From this phase angle on, the limb away from the light is in shadow over
// the edge fit's window (the terminator, |α| of azimuth from it, lies
// R·(1 − cos α) inside: 6 px at R = 256 px and 12°).
constexpr double kShadowedLimbRad = 12.0 * M_PI / 180.0;
// What one observed limb's placement may be off beyond its scatter over the
// bands, px: the edge model (a sharp step over each pixel's covered part)
// is not the photograph's (lens blur, thread relief, a renderer's or a
// sensor's pixel sampling, clipped pixels at a bright rim). Fixtures with
// the limbs on pixel boundaries put the radius 0.02-0.05 px short; limbs
// 0.4 px off them, 0.08 px short (the renderer's 4 samples per pixel
// quantise the edge to a quarter pixel); a rim of clipped grazing scatter,
// 0.12 px (DetectionCasesTest.ClippedGlintsWithBrightGrazingScatter).
constexpr double kLimbSystematicPx = 0.07;
// The same for an inferred limb: over 125 dark-limb renders its errors were
// 0.72 px rms, 1.95 px at worst (README), so the radius (half the distance
// to the observed limb) is off by about half that.
constexpr double kInferredLimbPx = 1.0;

// An edge away from the light whose 20-80 % rise is this much wider than
// the lit limb's is taken for a terminator (px): a limb's rise is a pixel or
// two wide, the lens's blur the same at both limbs.
constexpr double kSoftEdgePx = 2.5;
// The body in shadow counts as seen when its level stands this many column
// noises, and this share of the disc's typical level, from the background.
constexpr double kSeenShadowSigmas = 10.0;
constexpr double kSeenShadowShare = 0.1;
// Beyond a limb seen in shadow lies background: 4-10 px out, the tail of a
// lens blur of 1-2 px (σ) keeps a few per cent of the step, and the
// background's gradient is taken from that side's own strip, so the level
// there stands well under this share of the way to the shadow's. An edge
// found on the body's gradual roll-off toward its limb (the stray light
// falls off like cos φ there) has body, not background, beyond it, and
// leaves the level near half of the way or more.
constexpr double kLimbOutsideShare = 1.0 / 3.0;

// Standard errors of the radius and of each limb from the two limb lines:
// each line's own scatter and its systematic allowance (halved for the
// radius, half the distance between the limbs); the allowances' share apart.
// left_blur and right_blur: how far each limb moves (columns, signed) when
// the lens blur both are seen through moves by its own error; they move
// together, so the radius takes half their difference whole.
void SetRadiusStderr(const Line& left, double left_systematic, const Line& right,
                     double right_systematic, CylinderGeometry* g, double left_blur = 0.0,
                     double right_blur = 0.0) {
  const double systematic2 =
      left_systematic * left_systematic + right_systematic * right_systematic;
  const double through_blur = 0.5 * (right_blur - left_blur);
  g->radius_stderr_px = std::hypot(
      0.5 * std::sqrt(left.at_center_stderr * left.at_center_stderr +
                      right.at_center_stderr * right.at_center_stderr + systematic2),
      through_blur);
  g->radius_systematic_px = 0.5 * std::sqrt(systematic2);
  g->left_limb_stderr_px = std::hypot(std::hypot(left.at_center_stderr, left_systematic), left_blur);
  g->right_limb_stderr_px =
      std::hypot(std::hypot(right.at_center_stderr, right_systematic), right_blur);
  g->left_limb_systematic_px = left_systematic;
  g->right_limb_systematic_px = right_systematic;
  g->left_limb_blur_px = left_blur;
  g->right_limb_blur_px = right_blur;
}

// The pixels RefineEdge fits for one band's limb: from two outside the first
// estimate e0 to five inside, `inward` +1 when the surface lies at larger
// columns. Empty when fewer than 6 (or the radius is implausible).
struct Blur;

struct EdgeWindow {
  std::vector<int> xs;
  const std::vector<double>* v = nullptr;
  double background = 0.0;
  int inward = 1;
  double r = 0.0;
  // Depth inside the limb (px) where the light reaches: the terminator, at
  // the limb away from the light; no grazing scatter above it.
  double lit_from = 0.0;
  // The lens blur the model is seen through (SetBlur); none when null. Then
  // the surface inside the limb is cut into cells of kCellPx, each with its
  // grazing integral.
  const Blur* blur = nullptr;
  std::vector<double> cell_integral;
  // Extra pixels at each end of the window for a wide lens blur (WidePad).
  int pad = 0;
  // The body's diffuse shading under a broad stray source, R·cos φ, held
  // (LimbPlacer::RollOff; zero: none), and each cell's ∫cos φ (SetBlur).
  double rolloff = 0.0;
  std::vector<double> cell_cos;
};

constexpr double kCellPx = 0.25;
constexpr double kKernelStepPx = 0.02;
// Below this σ (px) the unblurred model is used: the blur is within the
// pixel's own footprint.
constexpr double kMinBlurPx = 0.2;
// The widest lens blur the limb fit considers at first, px.
constexpr double kMaxBlurPx = 1.5;
// A first fit at that cap (within kAtCapPx) is refitted through wider
// windows over lens blurs up to kWideMaxBlurPx: a blur of 2 px put the lit
// limb of a noise-free 640×480 render 3.2 px out and the radius 2.0 px long
// through the 9-pixel window, whose end cuts the blurred rise short.
constexpr double kAtCapPx = 0.1;
constexpr double kWideMaxBlurPx = 3.5;
// A lit limb's allowance for a lens blur proposed at the other limb but not
// used, px per px² of the proposal (DetectWithSideStrips).
constexpr double kUnusedBlurPxPerPx2 = 1.5;
// The same for a lit limb seen through the blur the limb in shadow proposed
// alone beyond 90°, px per px of that blur, when no glints cut its windows.
constexpr double kThroughOtherBlurPxPerPx = 0.5;

// The pixels added at each end of an edge window for lens blurs up to
// max_blur (beyond the first kMaxBlurPx): the blurred rise spans ±3σ.
int WidePad(double max_blur) {
  return max_blur > kMaxBlurPx ? static_cast<int>(std::ceil(3.0 * (max_blur - 0.5))) : 0;
}

EdgeWindow MakeEdgeWindow(const std::vector<double>& v, double background, double e0,
                          int inward, double radius_px, bool glints_may_reach,
                          double lit_from = 0.0, int pad = 0, double ramp_px = 0.0,
                          const std::vector<std::uint8_t>* clipped = nullptr) {
  EdgeWindow w;
  w.pad = pad;
  w.lit_from = lit_from;
  w.v = &v;
  w.background = background;
  w.inward = inward;
  w.r = radius_px;
  const int n = static_cast<int>(v.size());
  const int x_first = static_cast<int>(std::floor(e0 - inward * (2.0 + pad) + 0.5));
  for (int k = 0; k <= 8 + 2 * pad; ++k) {
    const int x = x_first + inward * k;
    if (x >= 0 && x < n) w.xs.push_back(x);
  }
  if (w.xs.size() < 6 || !(radius_px > 4.0)) {
    w.xs.clear();
    return w;
  }
  // Inside the limb toward the light the body and the grazing scatter only
  // fall or hold inward (1/cos φ is largest at the limb). A rise inward is
  // the specular lobe's glints, which reach that limb at large phase angles
  // (the outer caustic lies 5 px inside a 256 px limb at α = 130°, and moved
  // the fitted edge 0.4 px inward): with glints_may_reach, the window stops
  // before it, keeping at least 4 pixels (2 outside). (At the other limb a
  // rise is the terminator, 2 px inside it at α = 10°, which the window
  // keeps as before.)
  if (glints_may_reach) {
    double low = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < w.xs.size(); ++i) {
      const double inside = inward > 0 ? w.xs[i] - 0.5 - e0 : e0 - w.xs[i] - 0.5;
      if (inside < 1.0 + std::max<double>(pad, ramp_px)) continue;
      const double level = v[w.xs[i]];
      if (i >= static_cast<std::size_t>(4 + pad) &&
          level > low + kEdgeRise * std::max(low - background, 0.0)) {
        w.xs.resize(i);
        break;
      }
      low = std::min(low, level);
    }
  }
  // A clipped pixel's level is only a lower bound: the sensor stopped the
  // limb's bright rim of grazing scatter there, and the model, which rises
  // on, drew the edge inward (at 300 times the default exposure, the bench
  // sweep's scene, the radius 0.21 px short; 0.10 px with them left out. At
  // 10-100 times no limb pixel clips, and it is 0.03-0.06 px short all the
  // same). The window keeps the rest, or none when fewer than 6 remain.
  if (clipped != nullptr && !clipped->empty()) {
    std::vector<int> kept;
    for (int x : w.xs) {
      if ((*clipped)[x] == 0) kept.push_back(x);
    }
    if (kept.size() != w.xs.size()) w.xs = kept.size() >= 6 ? kept : std::vector<int>();
  }
  return w;
}

// The least-squares sums of RefineEdge's model at edge e over a window: each
// pixel's covered share c and capped grazing integral i against its level
// less the background's uncovered share, y = v − bg·(1 − c).
struct EdgeSums {
  double cc = 0, ci = 0, ii = 0, cy = 0, iy = 0, yy = 0;
};

// ∫ dd / max(cos φ, kMinCosAzimuth) over [lo, hi] at depths d inside a limb
// of radius r (sin φ = 1 − d/r): the optical models cap the grazing 1/cos φ
// there (optics/radiance.h).
double CappedGrazingIntegral(double r, double lo, double hi) {
  auto arc = [r](double d) { return std::asin(std::clamp(1.0 - d / r, -1.0, 1.0)); };
  const double d_cap = r * (1.0 - std::sqrt(1.0 - kMinCosAzimuth * kMinCosAzimuth));
  double sum = 0.0;
  if (lo < d_cap) {
    sum += (std::min(hi, d_cap) - lo) / kMinCosAzimuth;
    lo = d_cap;
  }
  if (hi > lo) sum += r * (arc(lo) - arc(hi));
  return sum;
}

// ∫ cos φ dd over [lo, hi] at depths d inside a limb of radius r (sin φ =
// 1 − d/r): with u = 1 − d/r, r·[F(u)] for F(u) = ½(u·√(1 − u²) + asin u).
double CosIntegral(double r, double lo, double hi) {
  auto f = [](double u) {
    u = std::clamp(u, -1.0, 1.0);
    return 0.5 * (u * std::sqrt(1.0 - u * u) + std::asin(u));
  };
  return hi > lo ? r * (f(1.0 - lo / r) - f(1.0 - hi / r)) : 0.0;
}

// The same two integrals from the limb (depth 0) to d, one asin each: a
// pixel's is the difference at its two ends, and neighbouring pixels share
// an end. (At d_cap, 1 − d/r = √(1 − k²), so asin there is acos k.)
double GrazingFromLimb(double r, double d) {
  const double d_cap = r * (1.0 - std::sqrt(1.0 - kMinCosAzimuth * kMinCosAzimuth));
  if (d <= d_cap) return std::max(d, 0.0) / kMinCosAzimuth;
  return d_cap / kMinCosAzimuth +
         r * (std::acos(kMinCosAzimuth) - std::asin(std::clamp(1.0 - d / r, -1.0, 1.0)));
}
double CosFromLimb(double r, double d) { return CosIntegral(r, 0.0, std::max(d, 0.0)); }

// A pixel's share of a point at offset t from its centre through a Gaussian
// lens blur σ, tabulated every kKernelStepPx out to 0.5 + 3σ.
std::vector<double> BlurKernel(double sigma, double* reach) {
  *reach = 0.5 + 3.0 * sigma;
  const int n = static_cast<int>(std::ceil(2.0 * *reach / kKernelStepPx)) + 1;
  std::vector<double> kernel(n);
  const double s2 = sigma * std::sqrt(2.0);
  for (int k = 0; k < n; ++k) {
    const double t = k * kKernelStepPx - *reach;
    kernel[k] = 0.5 * (std::erf((t + 0.5) / s2) - std::erf((t - 0.5) / s2));
  }
  return kernel;
}

// A lens blur and its kernel (BlurKernel); σ below kMinBlurPx is none.
struct Blur {
  double sigma = 0.0;
  std::vector<double> kernel;
  double reach = 0.0;
};

Blur MakeBlur(double sigma) {
  Blur b;
  b.sigma = sigma;
  if (sigma >= kMinBlurPx) b.kernel = BlurKernel(sigma, &b.reach);
  return b;
}

// How far inside a first limb estimate a blurred limb's own rise may run
// (px): a rise inward there is not a glint's (MakeEdgeWindow). The first
// estimate lies out on the rise, so 2.5σ; none through no blur.
double RampPx(const Blur& blur) { return blur.kernel.empty() ? 0.0 : 2.5 * blur.sigma; }

// Has the window seen through `blur` (kept by address: it must outlive the
// window's use), cutting its cells the first time.
void SetBlur(EdgeWindow* w, const Blur& blur) {
  if (blur.kernel.empty() || w->xs.empty()) {
    w->blur = nullptr;
    return;
  }
  if (w->cell_integral.empty()) {
    // Cells from the limb to past the deepest pixel (at most 9 px inside,
    // e within a pixel and a half of e0, and the pad's share of both) by
    // the widest kernel's reach.
    const int cells =
        static_cast<int>(std::ceil((11.0 + 3.0 * w->pad + 0.5 + 3.0 * kWideMaxBlurPx) / kCellPx));
    for (int k = 0; k < cells; ++k) {
      const double lo = std::max(k * kCellPx, w->lit_from);
      const double hi = (k + 1) * kCellPx;
      w->cell_integral.push_back(hi > lo ? CappedGrazingIntegral(w->r, lo, hi) : 0.0);
      if (w->rolloff != 0.0) w->cell_cos.push_back(CosIntegral(w->r, k * kCellPx, hi));
    }
  }
  w->blur = &blur;
}

// The kernel's shares of the cells through a blur, once per edge position:
// a cell is a quarter pixel, so the kernel at cell k's centre seen from
// pixel x depends on q = k − inward·4x alone. `shares[q − q_lo]` holds it
// (BlurKernel's table, interpolated linearly; zero beyond its reach), and
// `prefix` its running sum, for a pixel's covered share.
struct CellShares {
  int q_lo = 0;
  std::vector<double> shares;
  std::vector<double> prefix;  // prefix[j] = Σ shares[0..j)
};

constexpr int kCellsPerPx = 4;
static_assert(kCellsPerPx * kCellPx == 1.0, "a pixel holds a whole number of cells");

void SampleCellShares(const EdgeWindow& w, double e, CellShares* out) {
  const Blur& blur = *w.blur;
  const std::vector<double>& kernel = blur.kernel;
  const double last = static_cast<double>(kernel.size() - 1);
  // The kernel's table position of offset q: t = inward·(q + ½)·kCellPx +
  // e + reach, in steps of kKernelStepPx; it covers t in [0, last·step).
  const double span = last * kKernelStepPx;
  const double a = (-e - blur.reach) / kCellPx - 0.5;          // t = 0
  const double b = (span - e - blur.reach) / kCellPx - 0.5;    // t = span
  const double lo = w.inward > 0 ? a : -b;
  const double hi = w.inward > 0 ? b : -a;
  out->q_lo = static_cast<int>(std::floor(lo)) - 1;
  const int n = static_cast<int>(std::ceil(hi)) + 1 - out->q_lo + 1;
  out->shares.resize(n);
  out->prefix.resize(n + 1);
  out->prefix[0] = 0.0;
  const double step = w.inward * kCellPx / kKernelStepPx;
  double at = (w.inward * (out->q_lo + 0.5) * kCellPx + e + blur.reach) / kKernelStepPx;
  for (int j = 0; j < n; ++j, at += step) {
    double share = 0.0;
    if (at >= 0.0 && at < last) {
      const int m = static_cast<int>(at);
      const double f = at - m;
      share = (1.0 - f) * kernel[m] + f * kernel[m + 1];
    }
    out->shares[j] = share;
    out->prefix[j + 1] = out->prefix[j] + share;
  }
}

// The edge scans' fine stage (RefineEdge, LimbPlacer::JointLimb): the best
// of the positions every 0.005 px within 0.05 px of the coarse stage's best,
// `consider` returning each one's sum of squares. Within a tenth of a pixel
// of the coarse best the sum of squares has one minimum (the pixels'
// coverage varies smoothly with the edge; the blur's tabulated kernel adds
// ripples of a few thousandths of a pixel), so a golden section on those 21
// positions (LatticeMinimum) takes about 10 of them for 21. The sums are a
// third of detection's time (perf); the cylinders it finds moved by at most
// 0.006 px on the fixtures and 0.002 px on the shared photographs.
template <typename Consider>
void FineStepsAround(Consider&& consider, double coarse) {
  LatticeMinimum([&](int k) { return consider(coarse + 0.005 * k); }, -10, 10);
}

// ThroughBlur fits a limb again through the blur moved by its error, and
// the joint edge moves by hundredths of a pixel: from the unmoved fit's δ
// (`warm`), the positions every 0.005 px within kWarmReachPx of it are
// searched as the fine stage's are (LatticeMinimum: ~15 sums for 81, where
// the whole scan takes ~51 per band; those scans were a sixth of
// detection's sums). False when the least lies at the window's end: the
// edge moved farther, and the whole scan is needed. (A band's own edge,
// HeldShift's, has more than one minimum in reach, from noise and glints:
// searched near the unmoved edge, four of the shared photographs' radius
// errors moved by 10-40 %, so those scans stay whole.)
constexpr double kWarmReachPx = 0.2;

template <typename Consider>
bool NearWarmStart(Consider&& consider, double warm) {
  if (!std::isfinite(warm)) return false;
  constexpr int kSteps = 40;
  static_assert(kSteps * 0.005 == kWarmReachPx, "the window's end is kWarmReachPx");
  const int k = LatticeMinimum([&](int k) { return consider(warm + 0.005 * k); }, -kSteps, kSteps);
  return std::abs(k) < kSteps;
}

EdgeSums SumsAt(const EdgeWindow& w, double e) {
  EdgeSums t;
  thread_local CellShares cells;
  if (w.blur != nullptr) SampleCellShares(w, e, &cells);
  const int n_shares = static_cast<int>(cells.shares.size());
  const int n_cells = static_cast<int>(w.cell_integral.size());
  // Unblurred: the integrals from the limb at the last pixel's far end.
  double last_end = std::numeric_limits<double>::quiet_NaN();
  double last_grazing = 0.0, last_cos = 0.0;
  for (int x : w.xs) {
    double c = 0.0;        // covered share
    double i = 0.0;        // grazing integral
    double shading = 0.0;  // ∫cos φ over the covered share
    if (w.blur != nullptr) {
      // Through the lens blur: each cell's coverage and grazing integral
      // spread over the pixels by the kernel; the background fills the rest.
      // Cell k is share j = k − inward·4x − q_lo.
      const int shift = -w.inward * kCellsPerPx * x - cells.q_lo;
      const int k_lo = std::max(0, -shift);
      const int k_hi = std::min(n_cells - 1, n_shares - 1 - shift);
      if (k_hi >= k_lo) {
        c = kCellPx * (cells.prefix[k_hi + shift + 1] - cells.prefix[k_lo + shift]);
        const double* share = cells.shares.data() + shift;
        for (int k = k_lo; k <= k_hi; ++k) i += share[k] * w.cell_integral[k];
        if (w.rolloff != 0.0) {
          for (int k = k_lo; k <= k_hi; ++k) shading += share[k] * w.cell_cos[k];
        }
      }
    } else {
      const double d_lo = w.inward > 0 ? x - 0.5 - e : e - x - 0.5;
      const double lo = std::max(0.0, d_lo);
      const double hi = std::max(lo, d_lo + 1.0);
      c = hi - lo;
      const bool shared_end = lo == last_end;
      const double grazing_lo =
          shared_end ? last_grazing : GrazingFromLimb(w.r, std::max(lo, w.lit_from));
      const double cos_lo = w.rolloff == 0.0 ? 0.0 : shared_end ? last_cos : CosFromLimb(w.r, lo);
      last_end = hi;
      last_grazing = GrazingFromLimb(w.r, std::max(hi, w.lit_from));
      last_cos = w.rolloff == 0.0 ? 0.0 : CosFromLimb(w.r, hi);
      i = last_grazing - grazing_lo;
      shading = last_cos - cos_lo;
    }
    const double y = (*w.v)[x] - w.background * (1.0 - c) - w.rolloff * shading;
    t.cc += c * c;
    t.ci += c * i;
    t.ii += i * i;
    t.cy += c * y;
    t.iy += i * y;
    t.yy += y * y;
  }
  return t;
}

// With B profiled out (B = (cy − S·ci)/cc), the residual sum of squares at a
// held S is SSE(S) = at_zero − 2·S·num + S²·den.
struct HeldFit {
  double at_zero = 0, num = 0, den = 0;
};

HeldFit Held(const EdgeSums& t) {
  HeldFit h;
  if (!(t.cc > 0)) return h;
  h.at_zero = t.yy - t.cy * t.cy / t.cc;
  h.num = t.iy - t.ci * t.cy / t.cc;
  h.den = t.ii - t.ci * t.ci / t.cc;
  return h;
}

// The limb to a fraction of a pixel: the band's pixels from two outside the
// first estimate e0 to five inside (MakeEdgeWindow) are fitted, for edges e
// within a pixel of it, as background outside and, over the covered part of
// each pixel, a body level B plus a term S/cos φ (the grazing scatter,
// DESIGN.md §3, whose integrable 1/cos φ rise brightens the limb pixel
// itself and pushes a half-level crossing outward). cos φ is taken from the
// distance d inside the limb: sin φ = 1 − d/r. `inward` is +1 when the
// surface lies at larger columns (a left limb), −1 otherwise. B and S enter
// linearly. At a limb that is not `lit` (the one away from the light, in the
// cylinder's own shadow: DESIGN.md §3 has no scatter there) S is held at
// zero: fitted, noise alone makes it positive half the time (it is held at
// zero when negative), and its rise at the limb then pulls the edge inward
// (0.03-0.07 px at a body 0.02 above the background). A body shaded by a
// broad stray source adds `rolloff`·cos φ, held (LimbPlacer::RollOff).
double RefineEdge(const std::vector<double>& v, double background, double e0, int inward,
                  double radius_px, bool glints_may_reach, bool lit,
                  double fixed_scatter = std::numeric_limits<double>::quiet_NaN(),
                  double* scatter_out = nullptr, const Blur& blur = Blur(),
                  double center = std::numeric_limits<double>::quiet_NaN(),
                  double lit_from = 0.0, int pad = 0,
                  const std::vector<std::uint8_t>* clipped = nullptr, double rolloff = 0.0) {
  if (scatter_out != nullptr) *scatter_out = std::numeric_limits<double>::quiet_NaN();
  EdgeWindow w = MakeEdgeWindow(v, background, e0, inward, radius_px, glints_may_reach, lit_from,
                                pad, RampPx(blur), clipped);
  if (w.xs.empty()) return e0;
  w.rolloff = rolloff;
  SetBlur(&w, blur);
  double best_e = e0;
  double best_scatter = 0.0;
  double best_sse = std::numeric_limits<double>::infinity();
  auto consider = [&](double e) {
    const EdgeSums t = SumsAt(w, e);
    const double det = t.cc * t.ii - t.ci * t.ci;
    if (!(std::fabs(det) > 1e-12 * std::max(1.0, t.cc * t.ii))) {
      return std::numeric_limits<double>::infinity();
    }
    double scatter = (t.cc * t.iy - t.ci * t.cy) / det;
    // S held: zero at an unlit limb or when it comes out negative (scatter
    // only brightens: a plain step then), or given.
    if (!lit) {
      scatter = 0.0;
    } else if (std::isfinite(fixed_scatter)) {
      scatter = fixed_scatter;
    } else if (scatter < 0.0) {
      scatter = 0.0;
    }
    const HeldFit h = Held(t);
    const double sse = h.at_zero - 2.0 * scatter * h.num + scatter * scatter * h.den;
    if (sse < best_sse) {
      best_sse = sse;
      best_e = e;
      best_scatter = scatter;
    }
    return sse;
  };
  // Edges within a pixel of `center` (e0 unless given): every 0.05 px, then
  // the best of every 0.005 px around the best (FineStepsAround).
  const double c0 = std::isfinite(center) ? center : e0;
  for (int step = -20; step <= 20; ++step) consider(c0 + 0.05 * step);
  FineStepsAround(consider, best_e);
  if (scatter_out != nullptr) *scatter_out = best_scatter;
  return best_e;
}

// One band's first limb estimates (columns of the band's profile), and the
// background each limb stands on.
struct BandLimbs {
  bool found = false;
  double left_cross = 0.0;  // sub-pixel limb position
  double right_cross = 0.0;
  // The backdrop beside each limb (Backdrop), which its half-level
  // crossing is taken from.
  double left_background = 0.0;
  double right_background = 0.0;
  // All rows (FindShearedLimbs): the first column from each side where a
  // step fired; the limb lies at or beyond it.
  double left_fired = std::numeric_limits<double>::quiet_NaN();
  double right_fired = std::numeric_limits<double>::quiet_NaN();
  // Left out because a limb stood at the first column searched: the body
  // reaches into a side strip.
  bool at_strip = false;
  // Where the body's texture, not its level, placed the limb.
  bool left_textured = false;
  bool right_textured = false;
  // All rows: where the body's texture starts (NaN: nowhere).
  double left_texture = std::numeric_limits<double>::quiet_NaN();
  double right_texture = std::numeric_limits<double>::quiet_NaN();
};

// Sub-pixel position where a band profile crosses `level` between columns
// a and b (a < b or a > b), by linear interpolation between pixel centres.
double Crossing(const std::vector<double>& profile, int a, int b, double level) {
  const int step = b > a ? 1 : -1;
  for (int x = a; x != b; x += step) {
    const double p0 = profile[x] - level;
    const double p1 = profile[x + step] - level;
    if ((p0 <= 0) != (p1 <= 0)) {
      const double t = p0 / (p0 - p1);
      return x + step * t;
    }
  }
  return a;
}

// One band's texture: each column's variance down the band's rows,
// smoothed over kBox columns, and the level it must pass to show a body:
// the side strips' own (their median: the backdrop's noise) times the
// larger of 2 and the variance's sampling scatter, 6 standard errors.
struct BandTexture {
  std::vector<double> variance;
  double floor = 0.0;      // the strips' variance
  double threshold = 0.0;  // what a body's texture exceeds
};
// The texture of columns whose variances over `rows` rows are `variance`:
// smoothed, and its threshold the larger of `min_ratio` and the sampling
// scatter's 6 standard errors times the strips' own.
BandTexture TextureOf(std::vector<double> variance, int rows, int side, double min_ratio);

// Where a band's texture first stands above its threshold for three
// columns from each side strip inward (−1: nowhere), and the sub-pixel
// limb there: where the texture crosses half-way from the strips' to the
// body's a few columns in. A stray-lit woven body can stand at the
// backdrop's very level near its limbs and still show its weave: the
// threads' shading makes each column's pixels spread down the rows by 2-3
// times the noise (measured on renders with stray light at the backdrop's
// level), where the band mean shows no step at all.
struct TextureLimbs {
  int left = -1, right = -1;
  double left_cross = 0.0, right_cross = 0.0;
};
TextureLimbs FindTextureLimbs(const BandTexture& t, int side) {
  TextureLimbs out;
  const std::vector<double>& v = t.variance;
  const int w = static_cast<int>(v.size());
  if (w < 2 * side + 8 || !(t.threshold > 0.0)) return out;
  auto above = [&](int x) { return x >= 0 && x < w && v[x] > t.threshold; };
  for (int x = side; x + 2 < w - side && out.left < 0; ++x) {
    if (above(x) && above(x + 1) && above(x + 2)) out.left = x;
  }
  for (int x = w - 1 - side; x - 2 >= side && out.right < 0; --x) {
    if (above(x) && above(x - 1) && above(x - 2)) out.right = x;
  }
  if (out.left < 0 || out.right < 0 || out.right <= out.left) return TextureLimbs{};
  const double left_half = 0.5 * (t.floor + v[std::min(out.left + 3, w - 1)]);
  const double right_half = 0.5 * (t.floor + v[std::max(out.right - 3, 0)]);
  out.left_cross = Crossing(v, std::max(out.left - 3, 0), std::min(out.left + 4, w - 1), left_half);
  out.right_cross =
      Crossing(v, std::min(out.right + 3, w - 1), std::max(out.right - 4, 0), right_half);
  return out;
}

// From the side strip inward (step +1: from the left), the first three
// columns of the smoothed texture `v` that stand `ratio` times the
// backdrop's beside them (the median over kBesidePx columns from kGapPx
// outside: the box's spread of a limb's texture clears the gap) and above
// `least`; the limb where the texture crosses half-way from that backdrop's
// to the body's (the median of the five columns from the onset in, which
// a glint among them does not move). NaN where there is none, or where it
// starts at the strip's edge (the body reaches into the strip: its onset
// is not measured).
double TextureOnset(const std::vector<double>& v, int side, int step, double ratio, double least) {
  constexpr int kGapPx = 3;
  constexpr int kBesidePx = 16;
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  const int w = static_cast<int>(v.size());
  if (!(ratio > 0.0) || w < 2 * side + 8) return kNone;
  std::vector<double> near;
  auto median_from = [&](int x, int first, int count) {
    near.clear();
    for (int k = first; k < first + count; ++k) {
      const int at = x + step * k;
      if (at >= 0 && at < w) near.push_back(v[at]);
    }
    return near.empty() ? kNone : Median(near);
  };
  for (int k = side; k + 2 < w - side; ++k) {
    const int x = step > 0 ? k : w - 1 - k;
    const double beside = median_from(x, -kGapPx - kBesidePx + 1, kBesidePx);
    const double level = std::max(ratio * beside, least);
    if (!(v[x] > level && v[x + step] > level && v[x + 2 * step] > level)) continue;
    if (k == side) return kNone;
    const double half = 0.5 * (beside + median_from(x, 0, 5));
    return Crossing(v, std::clamp(x - 3 * step, 0, w - 1), std::clamp(x + 4 * step, 0, w - 1),
                    half);
  }
  return kNone;
}

// A texture onset this many columns ahead of the level's is the limb: the
// level's own onset scatters by a column or two with the noise.
constexpr int kTextureLeadPx = 3;

// The limbs of one band's profile: from each side strip inward, the first
// three columns of the profile smoothed over kBox columns that stand
// `threshold` from the backdrop's level there, `backdrop` (one per column:
// Backdrop over the band's rows). Up: a lit or grey body on a darker
// background; down: a dark cloth on a brighter one. The backdrop's own
// level: a gradient across the frame puts the two strips apart, and
// vignetting lifts the backdrop between them toward the frame's centre, by
// as much as a faint body stands from it (one level for the frame put the
// edges where the backdrop itself rose past the threshold, up to 200 px
// outside the limbs). The model is the strips' over all rows (a band's own
// strip is noisier, and moved the blurred limbs' first estimates by tenths
// of a pixel). `glints_left` and `glints_right`: the lobe's glints may reach
// that limb (see below).
BandLimbs FindBandLimbs(const std::vector<double>& profile, int side, double threshold,
                        int min_separation, bool glints_left, bool glints_right,
                        const std::vector<double>& backdrop, const BandTexture& texture) {
  BandLimbs b;
  const int w = static_cast<int>(profile.size());
  if (w < 2 * side + 8 || static_cast<int>(backdrop.size()) != w) return b;
  // Smoothed over kBox columns, so that a dim limb still stands out of the
  // noise; the sub-pixel position comes from the unsmoothed level below.
  constexpr int kBox = 5;
  std::vector<double> smoothed(w, 0.0);
  {
    // A running sum over the box, truncated at the profile's ends.
    double sum = 0.0;
    for (int k = 0; k < std::min(kBox / 2, w); ++k) sum += profile[k];
    for (int x = 0; x < w; ++x) {
      if (x + kBox / 2 < w) sum += profile[x + kBox / 2];
      if (x - kBox / 2 - 1 >= 0) sum -= profile[x - kBox / 2 - 1];
      const int count = std::min(w - 1, x + kBox / 2) - std::max(0, x - kBox / 2) + 1;
      smoothed[x] = sum / count;
    }
  }
  auto above = [&](int x) {
    return x >= 0 && x < w && std::fabs(smoothed[x] - backdrop[x]) > threshold;
  };
  int left = -1;
  for (int x = side; x + 2 < w - side; ++x) {
    if (above(x) && above(x + 1) && above(x + 2)) {
      left = x;
      break;
    }
  }
  int right = -1;
  for (int x = w - 1 - side; x - 2 >= side; --x) {
    if (above(x) && above(x - 1) && above(x - 2)) {
      right = x;
      break;
    }
  }
  // A limb found at the first column searched lies in (or beyond) the side
  // strip taken as background: its position is not measured, and the
  // band is left out.
  b.at_strip = (left == side || right == w - 1 - side) && left >= 0 && right >= 0;
  const TextureLimbs textured = FindTextureLimbs(texture, side);
  if (left < 0 || right < 0 || right - left < min_separation || b.at_strip) return b;
  // The backdrop beside each limb: its level where the body starts.
  b.left_background = backdrop[std::max(left - 2, 0)];
  b.right_background = backdrop[std::min(right + 2, w - 1)];
  // Sub-pixel limb: where the smoothed profile (a symmetric box keeps a
  // step's half-level crossing in place) crosses half-way between the
  // background and the surface level just inside the limb. The first
  // column above the threshold has the limb pixel (partly covered) at the
  // end of its box, two columns on; the first wholly covered pixel is the
  // third. Its own (unsmoothed) value is the level: any further in may be
  // the lit surface beyond the terminator of an unlit limb. At the limb
  // toward the light, where glints may reach it, a third column standing
  // well above the next three is a glint, and their least is the level: a
  // glint there (1 px inside the limb at α = 140°) made the half level one
  // the smoothed profile never crossed, and the limb was put 4.7 px out.
  auto inside_level = [&](int from, int step, bool glints_may_reach, double background) {
    const double level = profile[std::clamp(from + 3 * step, 0, w - 1)];
    if (!glints_may_reach) return level;
    double least = level;
    for (int k = 4; k <= 6; ++k) least = std::min(least, profile[std::clamp(from + k * step, 0, w - 1)]);
    return level > least + kEdgeRise * std::max(least - background, 0.0) ? least : level;
  };
  const double left_half =
      0.5 * (b.left_background + inside_level(left, +1, glints_left, b.left_background));
  const double right_half =
      0.5 * (b.right_background + inside_level(right, -1, glints_right, b.right_background));
  b.left_cross = Crossing(smoothed, std::max(left - 3, 0), std::min(left + 4, w - 1), left_half);
  b.right_cross =
      Crossing(smoothed, std::min(right + 3, w - 1), std::max(right - 4, 0), right_half);
  // A limb whose body shows first in its texture (TextureLimbs) lies there.
  b.left_textured = textured.left >= 0 && textured.left < left - kTextureLeadPx;
  b.right_textured = textured.right >= 0 && textured.right > right + kTextureLeadPx;
  if (b.left_textured) b.left_cross = textured.left_cross;
  if (b.right_textured) b.right_cross = textured.right_cross;
  b.found = true;
  return b;
}

// The step at column x over h columns, toward `step` (+1: the body at
// larger columns): the mean of profile[x+1 .. x+h] less the least-squares
// line through the 2h columns before them, carried on to their middle.
// NaN when the windows leave the profile. `sigma` is the step's standard
// error in units of one column's noise.
double ExtrapolatedStep(const std::vector<double>& profile, int x, int h, int step,
                        double* sigma) {
  const int n = static_cast<int>(profile.size());
  const int far = x - step * 2 * h;
  const int near = x + step * h;
  if (std::min(far, near) < 0 || std::max(far, near) >= n) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // Positions t = 1..2h counted from the far end toward x; the beyond
  // window's middle at t = 2h + (h + 1)/2.
  double st = 0, sy = 0, stt = 0, sty = 0;
  for (int t = 1; t <= 2 * h; ++t) {
    const double y = profile[far + step * (t - 1)];
    st += t;
    sy += y;
    stt += double(t) * t;
    sty += t * y;
  }
  const double m = 2.0 * h;
  const double tbar = st / m;
  const double sxx = stt - st * st / m;
  const double slope = (sty - st * sy / m) / sxx;
  const double at = 2.0 * h + 0.5 * (h + 1);
  const double predicted = sy / m + slope * (at - tbar);
  double beyond = 0.0;
  for (int k = 1; k <= h; ++k) beyond += profile[x + step * k];
  beyond /= h;
  // Var(prediction) = σ²(1/m + (at − t̄)²/Sxx) (the beyond window's own
  // columns spread about its middle cancel in its mean), plus σ²/h.
  *sigma = std::sqrt(1.0 / m + (at - tbar) * (at - tbar) / sxx + 1.0 / h);
  return beyond - predicted;
}

// Where profile[a..b] breaks from a flat background into a body (a jump and
// a slope): the column boundary e (between pixel centres e − 0.5 and
// e + 0.5 for step +1, the body at larger columns) that leaves the least
// residual of a constant on the background's side and a line on the
// body's. A blurred step and a slow rise from the limb alike break there.
// `jump` (optional) gets the body line's value at the break less the
// background's mean, and `jump_factor` its standard error in units of one
// column's noise.
double BreakPoint(const std::vector<double>& profile, int a, int b, int step,
                  double* jump = nullptr, double* jump_factor = nullptr) {
  double best = std::numeric_limits<double>::infinity();
  double at = std::numeric_limits<double>::quiet_NaN();
  for (int e = a + 2; e <= b - 2; ++e) {
    // Background [a, e − 1] and body [e, b] for step +1; body [a, e] and
    // background [e + 1, b] for step −1.
    const int bg_lo = step > 0 ? a : e + 1;
    const int bg_hi = step > 0 ? e - 1 : b;
    const int body_lo = step > 0 ? e : a;
    const int body_hi = step > 0 ? b : e;
    double sum = 0.0, sum_sq = 0.0;
    for (int x = bg_lo; x <= bg_hi; ++x) {
      sum += profile[x];
      sum_sq += profile[x] * profile[x];
    }
    const int nb = bg_hi - bg_lo + 1;
    double rss = sum_sq - sum * sum / nb;
    double sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    const int n = body_hi - body_lo + 1;
    for (int x = body_lo; x <= body_hi; ++x) {
      sx += x;
      sy += profile[x];
      sxx += double(x) * x;
      sxy += x * profile[x];
      syy += profile[x] * profile[x];
    }
    const double vxx = sxx - sx * sx / n, vxy = sxy - sx * sy / n, vyy = syy - sy * sy / n;
    rss += vxx > 0.0 ? vyy - vxy * vxy / vxx : vyy;
    if (rss < best) {
      best = rss;
      at = step > 0 ? e - 0.5 : e + 0.5;
      const double line_slope = vxx > 0.0 ? vxy / vxx : 0.0;
      const double xbar = sx / n;
      const double d = at - xbar;
      if (jump != nullptr) *jump = sy / n + line_slope * d - sum / nb;
      if (jump_factor != nullptr) {
        *jump_factor = std::sqrt(1.0 / nb + 1.0 / n + (vxx > 0.0 ? d * d / vxx : 0.0));
      }
    }
  }
  return at;
}

// The limbs seen in all the given rows at once: each row's columns shifted
// along the axis's slope (columns per row, about center_row) and summed
// into one profile, whose outermost steps (below, with the noise of that
// many rows) are the limbs at center_row, in region columns. A limb
// whose step is too faint for one band's rows (stray light that leaves the
// body near its limb barely above the background) stands out of all of
// them; a band then finds its first step further in, on the body's rise.
BandLimbs FindShearedLimbs(const Image& luminance, const PixelRegion& region,
                           const std::vector<int>& rows, double slope, double center_row,
                           int side, double noise, int min_separation) {
  // Each column's sums of its values, their squares and their products
  // with the row's offset from center_row (the texture, below).
  std::vector<double> sum(region.width, 0.0), sum_sq(region.width, 0.0), sum_yv(region.width, 0.0);
  std::vector<int> count(region.width, 0);
  double sy = 0.0, syy = 0.0;  // of the rows' offsets
  for (int y : rows) {
    const double dy = y - center_row;
    sy += dy;
    syy += dy * dy;
    // Column x reads between x0 = x + whole and x0 + 1, at t beyond x0.
    const double at = region.x + slope * (y - center_row);
    const int whole = static_cast<int>(std::floor(at));
    const double t = at - whole;
    const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width];
    const int x_lo = std::max(0, region.x - whole);
    const int x_hi = std::min(region.width - 1, region.x + region.width - 2 - whole);
    for (int x = x_lo; x <= x_hi; ++x) {
      const double v = (1.0 - t) * row[x + whole] + t * row[x + whole + 1];
      sum[x] += v;
      sum_sq[x] += v * v;
      sum_yv[x] += dy * v;
      ++count[x];
    }
  }
  // Columns that some rows' shift carried out of the region are left as
  // the nearest full column (the side strips hold only background).
  const int full = static_cast<int>(rows.size());
  std::vector<double> profile(region.width, 0.0);
  int first_full = -1;
  int last_full = -1;
  for (int x = 0; x < region.width; ++x) {
    if (count[x] != full || full == 0) continue;
    if (first_full < 0) first_full = x;
    last_full = x;
  }
  if (first_full < 0) return BandLimbs();
  // Each column's variance down the rows about a line in the row: the
  // backdrop's gradient along the axis is no texture.
  std::vector<double> variance(region.width, 0.0);
  const double vyy = syy - sy * sy / full;
  for (int x = 0; x < region.width; ++x) {
    const int from = std::clamp(x, first_full, last_full);
    profile[x] = sum[from] / full;
    const double vvv = sum_sq[from] - sum[from] * sum[from] / full;
    const double vyv = sum_yv[from] - sy * sum[from] / full;
    variance[x] = std::max(vyy > 0.0 ? vvv - vyv * vyv / vyy : vvv, 0.0) / std::max(full - 2, 1);
  }
  // Steps over 4, 8 and 16 columns: a body that rises slowly from its limb
  // (stray light grazing it) shows over the wider ones first. A step at x is
  // the mean of the h columns beyond x less the line through the 2h columns
  // before it carried on to them: the background's gradient and vignetting
  // are carried with it, which at the noise of all rows would pass for a
  // step (ExtrapolatedStep). The first x from each side where one stands
  // kShearedSigmas above its noise starts a window; the limb is where the
  // window's profile breaks from the background into the body's jump and
  // slope (BreakPoint). kShearedSigmas: a few hundred columns are tried at
  // three widths, and a Gaussian false step of 6σ comes once in 10^9.
  constexpr double kShearedSigmas = 6.0;
  const double column_noise = noise / std::sqrt(static_cast<double>(full));
  // And at least kMinStepShare of the body's typical contrast with the
  // background (the median over the middle half of the columns), as in the
  // bands: a render without noise has none to set the scale.
  constexpr double kMinStepShare = 0.005;
  std::vector<double> middle(profile.begin() + region.width / 4,
                             profile.begin() + 3 * region.width / 4);
  std::vector<double> strips(profile.begin(), profile.begin() + side);
  strips.insert(strips.end(), profile.end() - side, profile.end());
  const double floor = kMinStepShare * std::fabs(Median(middle) - Median(strips));
  BandLimbs limbs;
  auto fires = [&](int x, int h, int step) {
    double sigma = 0.0;
    const double d = ExtrapolatedStep(profile, x, h, step, &sigma);
    return std::fabs(d) > std::max(kShearedSigmas * sigma * column_noise, floor);
  };
  // The limb in the window of a step found at x over h columns, when the
  // profile breaks there with a jump (a limb is a jump out of the
  // background, however small: where the profile only bends, as the
  // shading of a body in shadow at the background's level does, NaN).
  auto limb_at = [&](int x, int h, int step) {
    const int a = step > 0 ? x - h : x - 2 * h;
    const int b = step > 0 ? x + 2 * h : x + h;
    double jump = 0.0;
    double factor = 1.0;
    const double e = BreakPoint(profile, std::max(a, 0), std::min(b, region.width - 1), step,
                                &jump, &factor);
    return std::fabs(jump) > std::max(kShearedSigmas * factor * column_noise, floor)
               ? e
               : std::numeric_limits<double>::quiet_NaN();
  };
  // From each side inward, the first column where a step fires at some
  // width. A wide step fires before the limb it holds (its h columns reach
  // over it): the narrower widths are then tried over those columns, so
  // that the window the limb is placed in is the narrowest that sees it
  // (texture and glints inside the body bend a wide window's break).
  auto first_step = [&](int step, double* fired) {
    for (int k = side; k < region.width - side; ++k) {
      const int x = step > 0 ? k : region.width - 1 - k;
      for (int h : {4, 8, 16}) {
        if (!fires(x, h, step)) continue;
        *fired = x;
        for (int fine : {4, 8}) {
          if (fine >= h) break;
          for (int j = 0; j <= h; ++j) {
            if (!fires(x + step * j, fine, step)) continue;
            const double e = limb_at(x + step * j, fine, step);
            if (std::isfinite(e)) return e;
            break;
          }
        }
        const double e = limb_at(x, h, step);
        if (std::isfinite(e)) return e;
        break;
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  limbs.left_cross = first_step(+1, &limbs.left_fired);
  limbs.right_cross = first_step(-1, &limbs.right_fired);
  // The body's texture over all rows, against the backdrop's just beside
  // it (TextureOnset): kAllRowsTextureRatio of it, or the variance's own
  // scatter's 6 standard errors if more. The backdrop beside a limb shares
  // its vignetting and its photon noise, so that only the scatter and what
  // the few tens of columns between them change set the ratio; against the
  // strips' (TextureLimbs), a vignetting of a quarter lifts a backdrop's
  // variance near the centre by that share.
  constexpr double kAllRowsTextureRatio = 1.25;
  const BandTexture texture = TextureOf(std::move(variance), full, side, kAllRowsTextureRatio);
  const double ratio = texture.floor > 0.0 ? texture.threshold / texture.floor : 0.0;
  // A file's codes spread a smooth backdrop's pixels by up to a code about
  // its level where they step (a JPEG's ringing about each step too): no
  // texture holds less than a code's square.
  const double code = CodeStep(luminance, Median(strips));
  limbs.left_texture = TextureOnset(texture.variance, side, +1, ratio, ratio * code * code);
  limbs.right_texture = TextureOnset(texture.variance, side, -1, ratio, ratio * code * code);
  limbs.found = std::isfinite(limbs.left_cross) && std::isfinite(limbs.right_cross) &&
                limbs.right_cross - limbs.left_cross >= min_separation;
  return limbs;
}

// The bands where both limbs were found: their first limb estimates and
// profiles, and the scatter each limb's first fit gave.
struct BandEdges {
  double row = 0.0;
  double left_cross = 0.0;
  double right_cross = 0.0;
  double radius = 0.0;
  std::vector<double> profile;
  // Columns (of the region) where a pixel of the band's rows clipped: the
  // band's mean there is a lower bound, and the edge fits leave it out.
  std::vector<std::uint8_t> clipped;
  // The background beside each limb: its side strip's level (a gradient
  // across the frame puts the two apart). The limb placer starts from it
  // and then measures its own beside each limb's line (SetLocalBackgrounds):
  // started from the backdrop model's level there (Backdrop), a stray-lit
  // body rolling off to its limb under a gradient came out 0.55 px out.
  double left_background = 0.0;
  double right_background = 0.0;
  int first = 0;  // the band's rows, inclusive
  int last = 0;
  bool left_textured = false;  // BandLimbs
  bool right_textured = false;
};

// At most `max_rows` of the bands' rows (those with `use[i]`, when given),
// evenly spread.
std::vector<int> SpreadRows(const std::vector<BandEdges>& bands, int max_rows,
                            const std::vector<bool>* use = nullptr) {
  int total = 0;
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (use == nullptr || (*use)[i]) total += bands[i].last - bands[i].first + 1;
  }
  const int stride = std::max(1, total / std::max(max_rows, 1));
  std::vector<int> rows;
  int k = 0;
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (use != nullptr && !(*use)[i]) continue;
    for (int y = bands[i].first; y <= bands[i].last; ++y, ++k) {
      if (k % stride == 0) rows.push_back(y);
    }
  }
  return rows;
}

// The share of the columns between the limbs that must show the body.
constexpr double kBodyShare = 0.7;

// One pixel's noise in each side strip over the given rows, from
// differences of pixels kRowApart rows apart. The strips' spread about
// their median, the detector's noise elsewhere, takes in whatever the
// strips hold besides background (a limb, a mount's edge) and a backdrop's
// gradient across them: at three times the pixel noise it hid a limb 38 px
// from the frame's edge, and a body darker than one strip and brighter
// than the other. Rows kRowApart apart lie in different blocks of a JPEG,
// whose pixels within a block share their error.
struct StripNoise {
  double left = 0.0;
  double right = 0.0;
};
StripNoise StripRowNoise(const Image& luminance, const PixelRegion& region, int side,
                         const std::vector<int>& rows) {
  constexpr int kRowApart = 8;
  // At most about kSamples differences per strip: the spread's median is
  // then known to about 2 %.
  constexpr std::size_t kSamples = 4096;
  const std::size_t row_step =
      std::max<std::size_t>(1, rows.size() * std::max(side, 1) / kSamples);
  std::vector<double> left_steps;
  std::vector<double> right_steps;
  const int last_row = region.y + region.height - 1;
  for (std::size_t r = 0; r < rows.size(); r += row_step) {
    const int y = rows[r];
    if (y + kRowApart > last_row) continue;
    for (int i = 0; i < side; ++i) {
      const int xl = region.x + i;
      const int xr = region.x + region.width - 1 - i;
      left_steps.push_back(std::fabs(luminance.At(xl, y + kRowApart) - luminance.At(xl, y)));
      right_steps.push_back(std::fabs(luminance.At(xr, y + kRowApart) - luminance.At(xr, y)));
    }
  }
  // A difference of two pixels holds √2 of one's noise.
  auto one_pixel = [](std::vector<double>& steps) {
    return steps.empty() ? 1e-6 : std::max(1.4826 * Median(steps) / std::sqrt(2.0), 1e-6);
  };
  return {one_pixel(left_steps), one_pixel(right_steps)};
}

// The backdrop's level over the frame, from the side strips: a gradient
// (a + b·u + c·v) under the lens's vignetting, a fall-off with the square
// of the distance from the frame's centre (k·(u² + v²); to first order the
// product of the two), u and v the column and row from the centre over the
// half-diagonal. The strips fix the gradient and, down their rows, the
// fall-off's curvature, which vignetting, being radial, shares across the
// rows: so the level is known between the strips, where a limb stands,
// though no strip pixel lies there.
struct Backdrop {
  double a = 0.0, b = 0.0, c = 0.0, k = 0.0;
  double x0 = 0.0, y0 = 0.0, scale = 1.0;  // the frame's centre and half-diagonal, px
  double At(double x, double y) const {
    const double u = (x - x0) / scale;
    const double v = (y - y0) / scale;
    return a + b * u + c * v + k * (u * u + v * v);
  }
};

// The background beside the cylinder: the side strips' width (at least
// 2 px), their level (both strips', and each side's own, for a gradient
// across the frame), one pixel's noise, and the backdrop between them.
struct SideStrips {
  int side = 0;
  double background = 0.0;
  double left_background = 0.0;
  double right_background = 0.0;
  double noise = 0.0;
  Backdrop backdrop;
};

// How many columns between two edges show a body: a mean over all rows
// that stands apart from the background, or pixels that vary down the
// column (over the bands' rows) beyond the background's noise. The
// background there is on the line between the side strips' levels (a
// backdrop's gradient across the frame), with their own noise
// (StripRowNoise): a body darker than one strip and brighter than the
// other, judged against one level for both and its inflated noise, showed
// in a tenth of its columns. A body in stray light as bright as the
// background still shows the weave's texture down every column (the
// threads cross it at their own period); the background between isolated
// glints shows noise alone. Over n rows a standard deviation is known to
// 1/√(2n) of itself: kTextureSigmas of that above the noise.
// Or, where the body is as bright and as smooth as the background over
// much of its width (a smooth sample in stray light), both edges must step
// into a body: the mean over all rows 3-10 px inside each differs from the
// level 3-10 px outside it. Just inside the outermost line of glints lies
// background again.
struct BodyCoverage {
  int on = 0;
  int total = 0;
  bool limbs_step_into_body = false;
};
BodyCoverage CoverBody(const Image& luminance, const PixelRegion& region,
                       const std::vector<double>& mean_profile, const SideStrips& strips,
                       int mean_rows, double edge_sigmas, const std::vector<BandEdges>& bands,
                       double left_column, double right_column) {
  constexpr double kTextureSigmas = 6.0;
  const std::vector<int> rows = SpreadRows(bands, 256);
  const StripNoise strip_noise = StripRowNoise(luminance, region, strips.side, rows);
  // The background and its noise at column x: on the line between the
  // strips' middles (a backdrop's gradient across the frame).
  const double left_x = region.x + 0.5 * (strips.side - 1);
  const double right_x = region.x + region.width - 1 - 0.5 * (strips.side - 1);
  auto along = [&](double x, double at_left, double at_right) {
    const double t = std::clamp((x - left_x) / std::max(right_x - left_x, 1.0), 0.0, 1.0);
    return at_left + t * (at_right - at_left);
  };
  auto mean_threshold = [&](double x) {
    return edge_sigmas * along(x, strip_noise.left, strip_noise.right) /
           std::sqrt(static_cast<double>(std::max(mean_rows, 1)));
  };
  const double n = static_cast<double>(rows.size());
  BodyCoverage c;
  for (int x = static_cast<int>(std::ceil(left_column)) + 2;
       x <= static_cast<int>(std::floor(right_column)) - 2; ++x) {
    if (x < region.x || x >= region.x + region.width) continue;
    ++c.total;
    if (std::fabs(mean_profile[x - region.x] - along(x, strips.left_background, strips.right_background)) >
        mean_threshold(x)) {
      ++c.on;
      continue;
    }
    if (n < 8) continue;
    double sum = 0.0;
    double sum_sq = 0.0;
    for (int y : rows) {
      const double v = luminance.At(x, y);
      sum += v;
      sum_sq += v * v;
    }
    const double mean = sum / n;
    const double sd = std::sqrt(std::max(0.0, sum_sq / n - mean * mean));
    c.on += sd > along(x, strip_noise.left, strip_noise.right) *
                     (1.0 + kTextureSigmas / std::sqrt(2.0 * n));
  }
  auto steps_in = [&](double edge, int inward) {
    double inside = 0.0;
    double outside = 0.0;
    for (int d = 3; d <= 10; ++d) {
      const int in = static_cast<int>(std::lround(edge + inward * d)) - region.x;
      const int out = static_cast<int>(std::lround(edge - inward * d)) - region.x;
      if (std::min(in, out) < 0 || std::max(in, out) >= region.width) return false;
      inside += mean_profile[in] / 8.0;
      outside += mean_profile[out] / 8.0;
    }
    // Each an 8-column mean: its noise is the column's over √8.
    return std::fabs(inside - outside) > mean_threshold(edge);
  };
  c.limbs_step_into_body = steps_in(left_column, +1) && steps_in(right_column, -1);
  return c;
}

// Where all rows place a limb more than kReseedPx from the line through the
// bands' own first estimates, the bands' estimates of that limb move onto
// the all-rows limb (along the same slope). Outward: a band's noise can
// hide a faint step (a stray-lit body that rises slowly from its limb).
// Inward: the bands find a limb where the level first departs from the
// side strip's, and a background that vignetting or a gradient carries
// away from that level departs without a step; the all-rows search, whose
// steps are measured against the background's own trend (ExtrapolatedStep),
// passed over that column without finding one. The slope is that of the
// limb whose bands agree best (more of them on its line; then the smaller
// scatter).
// Returns which limbs moved, and the lines through the bands' own edges
// (image columns): an edge the bands see where all rows see the body start
// elsewhere may still be the terminator of a body as dark as the
// background beyond it, whose foot all rows found; the dark-limb inference
// starts from the bands' edge.
struct Reseeded {
  bool left = false;
  bool right = false;
  Line left_bands;
  Line right_bands;
  // Where all rows placed each limb at center_row (image columns; NaN: none).
  double all_left = std::numeric_limits<double>::quiet_NaN();
  double all_right = std::numeric_limits<double>::quiet_NaN();
};
Reseeded ReseedFaintLimbs(const Image& luminance, const PixelRegion& region, double center_row,
                          int side, double noise, const CylinderDetectionOptions& options,
                          std::vector<BandEdges>* bands) {
  // The all-rows break lies on the pixel grid (BreakPoint), and the body's
  // texture bends its line: it agrees with the bands' limbs to about 2 px
  // where both see one, so a move takes more.
  constexpr double kReseedPx = 3.0;
  Reseeded moved;
  if (bands->size() < 3) return moved;
  std::vector<LimbPoint> left_first;
  std::vector<LimbPoint> right_first;
  for (const BandEdges& b : *bands) {
    left_first.push_back({b.row, b.left_cross});
    right_first.push_back({b.row, b.right_cross});
  }
  const Line left = FitLimbLine(left_first, center_row);
  const Line right = FitLimbLine(right_first, center_row);
  auto inliers = [](const Line& l) { return std::count(l.inlier.begin(), l.inlier.end(), true); };
  const bool use_left = inliers(left) > inliers(right) ||
                        (inliers(left) == inliers(right) && left.rms < right.rms);
  const double slope = use_left ? left.slope : right.slope;
  // The rows of the bands on both lines.
  std::vector<bool> on_both(bands->size());
  for (std::size_t i = 0; i < bands->size(); ++i) on_both[i] = left.inlier[i] && right.inlier[i];
  const std::vector<int> rows = SpreadRows(*bands, 512, &on_both);
  if (rows.size() < 3) return moved;
  const BandLimbs all = FindShearedLimbs(luminance, region, rows, slope, center_row, side, noise,
                                         static_cast<int>(2 * options.min_radius_px));
  if (!all.found) return moved;
  moved.all_left = region.x + all.left_cross;
  moved.all_right = region.x + all.right_cross;
  // Inward only where no step fired within kReseedPx of the bands' line (a
  // step that fired there but broke further in is the limb's, its break
  // drawn in by glints or texture beside it), and never inward of a limb
  // most of whose bands saw the body's texture there: a stray-lit body at
  // the backdrop's level has no step for all rows to find (a mount wider
  // than the cylinder, its lit limb at the backdrop's level: the limb moved
  // 8 px in, onto where the body's shading rose).
  int left_textured = 0, right_textured = 0;
  for (std::size_t i = 0; i < bands->size(); ++i) {
    left_textured += left.inlier[i] && (*bands)[i].left_textured ? 1 : 0;
    right_textured += right.inlier[i] && (*bands)[i].right_textured ? 1 : 0;
  }
  const bool left_in = 2 * left_textured <= inliers(left);
  const bool right_in = 2 * right_textured <= inliers(right);
  const bool left_out = all.left_cross < left.at_center - kReseedPx ||
                        (left_in && all.left_fired > left.at_center + kReseedPx);
  const bool right_out = all.right_cross > right.at_center + kReseedPx ||
                         (right_in && all.right_fired < right.at_center - kReseedPx);
  // Where the body's texture over all rows starts further out than either
  // reading, the limb lies there: a stray-lit body rolls off to its limb at
  // the backdrop's level, with stripes of the weave's relief beside it that
  // draw the level's break in (4-5 px at 200 px radius), while its texture
  // stands 1.3-2 times the backdrop's variance out to the limb.
  double left_at = left_out ? all.left_cross : left.at_center;
  double right_at = right_out ? all.right_cross : right.at_center;
  const bool left_textured_out = all.left_texture < left_at - kReseedPx;
  const bool right_textured_out = all.right_texture > right_at + kReseedPx;
  if (left_textured_out) left_at = all.left_texture;
  if (right_textured_out) right_at = all.right_texture;
  const bool left_moves = left_out || left_textured_out;
  const bool right_moves = right_out || right_textured_out;
  // Only the bands on the cylinder move: it spans the rows from the first
  // band on either line to the last, and the bands beyond them saw a mount
  // or an end, whose edges must stay off the lines for the stages after
  // this one to leave them out (carried onto the lines, a mount 1.13 radii
  // wide and darker than the backdrop entered the wide window at a lit
  // limb as a dark rim outside it, and the limb moved 7.5 px in). Between
  // them a band off both lines is still the cylinder's, its edges thrown
  // out by the backdrop (strong vignetting) or the noise.
  std::size_t first_on = bands->size(), last_on = 0;
  for (std::size_t i = 0; i < bands->size(); ++i) {
    if (!left.inlier[i] && !right.inlier[i]) continue;
    first_on = std::min(first_on, i);
    last_on = i;
  }
  for (std::size_t i = first_on; i <= last_on && i < bands->size(); ++i) {
    BandEdges& b = (*bands)[i];
    const double along = slope * (b.row - center_row);
    if (left_moves) b.left_cross = left_at + along;
    if (right_moves) b.right_cross = right_at + along;
    b.radius = 0.5 * (b.right_cross - b.left_cross);
  }
  moved.left = left_moves;
  moved.right = right_moves;
  moved.left_bands = left;
  moved.right_bands = right;
  moved.left_bands.at_center += region.x;
  moved.right_bands.at_center += region.x;
  return moved;
}

// A limb's profile over a wide window, the bands' profiles aligned on one
// line and averaged (the model is linear in its levels, so the mean of the
// bands' models is the model of their mean): outside the limb the
// background on a line in the column (a gradient, vignetting); inside it a
// body lit by what DESIGN.md §3 lists, each term a known function of the
// depth d inside the limb: a level B (ambient, the weave's own), stray
// light's shading R·cos φ, a Lambertian direct term, which near a limb is
// a + b·cos φ + c·(1 − d/r) and so adds only L·d, and the grazing scatter
// S/cos φ. The body may stand above, below or at the background's level:
// under stray light alone it meets the limb at its ambient level and rises
// as √d, over tens of pixels, where a step search fires deep inside.
struct WideProfile {
  std::vector<double> v;  // pixel j = 0 .. size−1 at offset j − out inward
  std::vector<bool> use;  // not a glint (a spike over its neighbours) or clipped
  int out = 0;            // pixels outside the line's column
  // The body's terms over the pixel at depths d .. d + 1 inside a limb:
  // 1, cos φ, d + ½ and the grazing scatter, for d = 0 .. size − 1.
  std::vector<Eigen::Vector4d> terms;
  // Sums that make each split's fit a few operations (Prepare): over the
  // used pixels before j, of 1, j, j², v, j·v, v² (outside; a line's
  // residuals do not change with where t = 0 is put); of the terms' outer
  // products over depths before d; and of v² and 1 over the used pixels
  // from j on.
  std::vector<std::array<double, 6>> before;
  std::vector<Eigen::Matrix4d> outer;
  std::vector<double> vv_from;
  std::vector<int> used_from;
  void Prepare();
};

void WideProfile::Prepare() {
  const int n = static_cast<int>(v.size());
  before.assign(n + 1, {0, 0, 0, 0, 0, 0});
  for (int j = 0; j < n; ++j) {
    before[j + 1] = before[j];
    if (!use[j]) continue;
    const double t = j;
    const double x = v[j];
    const std::array<double, 6> add = {1.0, t, t * t, x, t * x, x * x};
    for (int k = 0; k < 6; ++k) before[j + 1][k] += add[k];
  }
  outer.assign(n + 1, Eigen::Matrix4d::Zero());
  for (int d = 0; d < n; ++d) outer[d + 1] = outer[d] + terms[d] * terms[d].transpose();
  vv_from.assign(n + 1, 0.0);
  used_from.assign(n + 1, 0);
  for (int j = n - 1; j >= 0; --j) {
    vv_from[j] = vv_from[j + 1] + (use[j] ? v[j] * v[j] : 0.0);
    used_from[j] = used_from[j + 1] + (use[j] ? 1 : 0);
  }
}

// How well the wide model explains the window with the limb before pixel
// j = out + delta (delta > 0: inward of the line): −2 ln L of its
// residuals, Gaussian with each side its own variance (the body's texture
// is the background's noise and more), n·ln(RSS/n) per side, up to a
// constant. Every split has the same parameters, so a difference of two is
// a difference of BIC. With `shading`, the stray light's R there, where it
// stands kShadingSigmas of its least-squares error from zero (else 0).
// `w` Prepared.
double WideCost(const WideProfile& w, int delta, double* shading = nullptr) {
  constexpr double kShadingSigmas = 4.0;  // as LimbPlacer::RollOff
  const int split = w.out + delta;
  const int n = static_cast<int>(w.v.size());
  const std::array<double, 6>& o = w.before[split];
  const double s1 = o[0];
  const int inside = w.used_from[split];
  if (s1 < 3 || inside < 8) return std::numeric_limits<double>::infinity();
  const double vtt = o[2] - o[1] * o[1] / s1, vtv = o[4] - o[1] * o[3] / s1;
  const double vvv = o[5] - o[3] * o[3] / s1;
  const double sse_out = vtt > 0.0 ? vvv - vtv * vtv / vtt : vvv;
  // All depths' outer products, less the unused pixels'.
  Eigen::Matrix4d a = w.outer[n - split];
  Eigen::Vector4d b = Eigen::Vector4d::Zero();
  for (int j = split; j < n; ++j) {
    const Eigen::Vector4d& f = w.terms[j - split];
    if (w.use[j]) {
      b += f * w.v[j];
    } else {
      a -= f * f.transpose();
    }
  }
  const Eigen::Vector4d beta = a.ldlt().solve(b);
  const double sse_in = std::max(w.vv_from[split] - b.dot(beta), 1e-300);
  if (shading != nullptr) {
    const double var = sse_in / std::max(inside - 4, 1) * a.inverse()(1, 1);
    *shading = var > 0.0 && std::fabs(beta(1)) > kShadingSigmas * std::sqrt(var) ? beta(1) : 0.0;
  }
  return s1 * std::log(std::max(sse_out, 1e-300) / s1) + inside * std::log(sse_in / inside);
}

// Where the wide model places a limb (inward +1: the left) against the
// bands' first estimates: the move inward of their line, px, when it is
// at least kMinMovePx and the model explains the window decisively better
// there than at the line (by BIC); 0 otherwise, and wherever the window
// cannot hold the model: the edge away from the light from 90° on (it may
// be a terminator), a strip inside the limb too short for cos φ's curve
// before the terminator or the lobe.
struct WideLimb {
  double move = 0.0;     // px inward of the line
  double shading = 0.0;  // the stray light's R at the limb so placed, away from the light
  // Half the move the model preferred, but not decisively, where the limb
  // stays on its line: that limb's allowance (px).
  double doubt_px = 0.0;
};
WideLimb WideLimbMove(const std::vector<BandEdges>& bands, const Line& line,
                      const std::vector<bool>& on_cylinder, int inward, double center_row,
                      int side, double phase_angle_rad) {
  constexpr int kSearchOutPx = 96;  // how far outside the line a limb is sought
  constexpr int kSearchInPx = 8;
  constexpr int kBackgroundPx = 16;  // the least background seen outside it
  constexpr int kMinBodyPx = 20;     // cos φ's curvature needs a few tens of px
  constexpr double kMinMovePx = 3.0;  // as ReseedFaintLimbs: the texture bends lines by ~2 px
  if (!std::isfinite(phase_angle_rad) || bands.size() < 3) return WideLimb();
  const double alpha = std::fabs(phase_angle_rad);
  const bool toward_light = (inward > 0) == (phase_angle_rad < 0);
  if (!toward_light && alpha >= 0.5 * M_PI) return WideLimb();
  std::vector<double> radii;
  for (const BandEdges& b : bands) radii.push_back(b.radius);
  const double r = Median(radii);
  // The body's depth the window may reach: a third of the radius, short of
  // the terminator (by a fifth, as RollOff: the model has no kink for the
  // direct light's start) unless that lies within kSliverPx of the limb,
  // where the blur hides the kink; or, at the lit limb, short of the lobe
  // at α/2 (by two fifths: its caustics spread about it).
  constexpr double kSliverPx = 2.0;
  double depth = r / 3.0;
  const double terminator_depth = r * (1.0 - std::cos(alpha));
  if (!toward_light && terminator_depth > kSliverPx) {
    depth = std::min(depth, 0.8 * terminator_depth);
  }
  if (toward_light) depth = std::min(depth, 0.6 * r * (1.0 - std::sin(0.5 * alpha)));
  const int in = static_cast<int>(depth);
  if (in < kSearchInPx + kMinBodyPx) return WideLimb();
  const int width = static_cast<int>(bands.front().profile.size());
  // The window outside reaches to the side strip.
  double least_room = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (!on_cylinder[i]) continue;
    const double p = line.at_center + line.slope * (bands[i].row - center_row);
    least_room = std::min(least_room, inward > 0 ? p - side : width - 1 - side - p);
  }
  const int out = std::min(kSearchOutPx + kBackgroundPx, static_cast<int>(least_room));
  if (out < kBackgroundPx + static_cast<int>(kMinMovePx) + 1) return WideLimb();
  WideProfile w;
  w.out = out;
  for (int d = 0; d < out + in; ++d) {
    w.terms.emplace_back(1.0, CosFromLimb(r, d + 1) - CosFromLimb(r, d), d + 0.5,
                         GrazingFromLimb(r, d + 1) - GrazingFromLimb(r, d));
  }
  w.v.assign(out + in, 0.0);
  std::vector<int> count(out + in, 0);
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (!on_cylinder[i]) continue;
    const BandEdges& band = bands[i];
    const long x0 = std::lround(line.at_center + line.slope * (band.row - center_row));
    for (int j = 0; j < out + in; ++j) {
      const long x = x0 + inward * (j - out);
      if (x < 0 || x >= width) continue;
      if (!band.clipped.empty() && band.clipped[x] != 0) continue;
      w.v[j] += band.profile[x];
      ++count[j];
    }
  }
  const auto bands_on = std::count(on_cylinder.begin(), on_cylinder.end(), true);
  w.use.assign(out + in, false);
  for (int j = 0; j < out + in; ++j) {
    if (2 * count[j] < bands_on) continue;
    w.v[j] /= count[j];
    w.use[j] = true;
  }
  // A glint: a pixel above the median of the 11 about it by more than 4
  // times their spread (MAD): the model has no term for it.
  constexpr int kHalf = 5;
  std::vector<bool> glint(out + in, false);
  std::array<double, 2 * kHalf + 1> near;
  // The median of near's first m values (the upper one for an even count).
  auto median_of = [&near](int m) {
    std::nth_element(near.begin(), near.begin() + m / 2, near.begin() + m);
    return near[m / 2];
  };
  for (int j = 0; j < out + in; ++j) {
    if (!w.use[j]) continue;
    int m = 0;
    for (int k = std::max(0, j - kHalf); k <= std::min(out + in - 1, j + kHalf); ++k) {
      if (w.use[k]) near[m++] = w.v[k];
    }
    if (m < 5) continue;
    const double med = median_of(m);
    for (int k = 0; k < m; ++k) near[k] = std::fabs(near[k] - med);
    glint[j] = w.v[j] - med > 4.0 * 1.4826 * median_of(m);
  }
  for (int j = 0; j < out + in; ++j) w.use[j] = w.use[j] && !glint[j];
  w.Prepare();
  const int from = -(out - kBackgroundPx);
  double best_cost = std::numeric_limits<double>::infinity();
  int best = 0;
  for (int delta = from; delta <= kSearchInPx; ++delta) {
    const double cost = WideCost(w, delta);
    if (cost < best_cost) {
      best_cost = cost;
      best = delta;
    }
  }
  // Decisive as FindShadowOnset's: above 10, odds beyond 150:1. The
  // shading only at the limb away from the light: at the lit one the cos φ
  // term also carries the direct light and the lobe's flank, and held in
  // the edge model it drew a smooth body's lit limb 0.6 px in.
  WideLimb limb;
  double* shading = toward_light ? nullptr : &limb.shading;
  const double delta_bic = WideCost(w, 0, shading) - best_cost;
  if (std::abs(best) < kMinMovePx) return limb;
  if (!(delta_bic > 10.0)) {
    // The window's best limb lies off the line, by odds short of decisive:
    // the limb stays, and its error counts half the move (a faint limb
    // rolling off at the backdrop's level, 7.5 px outside the line by
    // ΔBIC 9.96, was placed either side of that mark by changes elsewhere
    // that moved its line by a pixel, with a stated error of 0.1 px).
    if (delta_bic > 0.0) limb.doubt_px = 0.5 * std::fabs(best - 0.5);
    return limb;
  }
  // The limb lies between pixels best − 1 and best: half a pixel before
  // the latter's centre.
  WideCost(w, best, shading);
  limb.move = best - 0.5;
  return limb;
}

// Each limb's first estimates moved where the wide model places it
// (WideLimbMove), all onto its line; what it found at each limb, left and
// right.
std::array<WideLimb, 2> PlaceLimbsWide(double center_row, int side, double phase_angle_rad,
                                       std::vector<BandEdges>* bands) {
  std::vector<LimbPoint> left_first;
  std::vector<LimbPoint> right_first;
  for (const BandEdges& b : *bands) {
    left_first.push_back({b.row, b.left_cross});
    right_first.push_back({b.row, b.right_cross});
  }
  if (bands->size() < 3) return {};
  const Line left = FitLimbLine(left_first, center_row);
  const Line right = FitLimbLine(right_first, center_row);
  // The cylinder's rows: the bands on both lines (a mount's or an end's
  // edges stand off them, and a mount's step outweighs a faint limb's).
  std::vector<bool> on_both(bands->size());
  for (std::size_t i = 0; i < bands->size(); ++i) on_both[i] = left.inlier[i] && right.inlier[i];
  if (std::count(on_both.begin(), on_both.end(), true) < 3) return {};
  const WideLimb left_limb =
      WideLimbMove(*bands, left, on_both, +1, center_row, side, phase_angle_rad);
  const WideLimb right_limb =
      WideLimbMove(*bands, right, on_both, -1, center_row, side, phase_angle_rad);
  const double left_move = left_limb.move;
  const double right_move = right_limb.move;
  for (BandEdges& b : *bands) {
    if (left_move != 0.0) {
      b.left_cross = std::round(left.at_center + left.slope * (b.row - center_row)) + left_move;
    }
    if (right_move != 0.0) {
      b.right_cross =
          std::round(right.at_center + right.slope * (b.row - center_row)) - right_move;
    }
    b.radius = 0.5 * (b.right_cross - b.left_cross);
  }
  return {left_limb, right_limb};
}

// The first and last columns of [from, to] more than half-way from the
// median to the maximum: the ends of the specular lobe (for a split lobe, its
// two caustics, whichever of them is the brighter). NaN when none is.
std::pair<double, double> BrightExtent(const std::vector<double>& mean_profile, int x0,
                                       double from, double to) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int lo = std::max(0, static_cast<int>(std::ceil(from)) - x0);
  const int hi = std::min(static_cast<int>(mean_profile.size()) - 1, static_cast<int>(std::floor(to)) - x0);
  if (hi <= lo) return {nan, nan};
  std::vector<double> values(mean_profile.begin() + lo, mean_profile.begin() + hi + 1);
  const double median = Median(values);
  const double top = *std::max_element(values.begin(), values.end());
  const double level = median + 0.5 * (top - median);
  int first = -1;
  int last = -1;
  for (int x = lo; x <= hi; ++x) {
    if (!(mean_profile[x] > level)) continue;
    if (first < 0) first = x;
    last = x;
  }
  if (first < 0) return {nan, nan};
  return {first + x0, last + x0};
}

// A small linear least-squares fit (OpenCV's QR): the residual sum of
// squares and the coefficients of y ≈ Σ c_k·basis[k]. Infinite RSS when the
// basis is degenerate.
double LeastSquaresRss(const std::vector<std::vector<double>>& basis,
                       const std::vector<double>& y, std::vector<double>* coefficients) {
  const int k = static_cast<int>(basis.size());
  const int n = static_cast<int>(y.size());
  cv::Mat a(n, k, CV_64F);
  for (int c = 0; c < k; ++c) {
    for (int t = 0; t < n; ++t) a.at<double>(t, c) = basis[c][t];
  }
  const cv::Mat b(n, 1, CV_64F, const_cast<double*>(y.data()));
  cv::Mat x;
  if (n < k || !cv::solve(a, b, x, cv::DECOMP_QR)) return std::numeric_limits<double>::infinity();
  cv::SVD svd(a, cv::SVD::NO_UV);
  const double* w = svd.w.ptr<double>();
  if (!(w[k - 1] > 1e-12 * w[0])) return std::numeric_limits<double>::infinity();
  coefficients->assign(x.ptr<double>(), x.ptr<double>() + k);
  const cv::Mat residual = a * x - b;
  return residual.dot(residual);
}

}  // namespace

ShadowOnset FindShadowOnset(const std::vector<double>& profile, int lo, int hi,
                            double center, double half_width, int light_side,
                            const Projection& projection, double min_rise) {
  ShadowOnset result;
  lo = std::max(lo, 0);
  hi = std::min(hi, static_cast<int>(profile.size()) - 1);
  // Non-overlapping kBlock-column means: the weave's texture is correlated
  // over a thread's few pixels, so single columns would overcount the evidence.
  constexpr int kBlock = 5;
  const int blocks = (hi - lo + 1) / kBlock;
  if (blocks < 8 || !(half_width > 0.0)) return result;
  result.judged = true;
  auto azimuth = [&](double x) {
    return AzimuthFromOffset(std::clamp((x - center) / half_width, -1.0, 1.0), projection);
  };
  std::vector<double> y(blocks, 0.0);
  std::vector<std::vector<double>> m0(4, std::vector<double>(blocks, 0.0));
  for (int b = 0; b < blocks; ++b) {
    for (int k = 0; k < kBlock; ++k) {
      const int x = lo + b * kBlock + k;
      const double u = std::clamp((x - center) / half_width, -1.0, 1.0);
      y[b] += profile[x] / kBlock;
      m0[0][b] += 1.0 / kBlock;
      m0[1][b] += u / kBlock;
      m0[2][b] += std::cos(azimuth(x)) / kBlock;
      m0[3][b] += u * u / kBlock;
    }
  }
  std::vector<double> c0;
  const double rss0 = LeastSquaresRss(m0, y, &c0);
  if (!std::isfinite(rss0)) return result;
  result.level = Median(y);
  // M1: an onset of direct light at φ0 inside the region, growing toward the
  // light as at a terminator: the Lambertian ramp max(0, sin(s·(φ − φ0))),
  // or the axial threads' grazing scatter, a step ∝ 1/cos φ. At least two
  // blocks on each side of it, so that its amplitude is measured.
  // M1 is M0 and one column v more: its fit adds to M0's the part w of v
  // that M0 cannot explain (v less its projection on M0's columns), times
  // (w·e0)/(w·w), and takes (w·e0)²/(w·w) off the residual sum of squares,
  // with e0 M0's residuals (Frisch–Waugh–Lovell). So each onset costs a
  // projection, not a least-squares solve.
  std::vector<std::vector<double>> basis = m0;  // M0's columns, orthonormalised
  for (std::size_t a = 0; a < basis.size(); ++a) {
    for (std::size_t p = 0; p < a; ++p) {
      double dot = 0.0;
      for (int b = 0; b < blocks; ++b) dot += basis[a][b] * basis[p][b];
      for (int b = 0; b < blocks; ++b) basis[a][b] -= dot * basis[p][b];
    }
    double norm = 0.0;
    for (int b = 0; b < blocks; ++b) norm += basis[a][b] * basis[a][b];
    norm = std::sqrt(norm);
    for (int b = 0; b < blocks; ++b) basis[a][b] /= norm;  // M0 has full rank (above)
  }
  std::vector<double> e0(blocks);
  for (int b = 0; b < blocks; ++b) {
    double f0 = 0.0;
    for (int k = 0; k < 4; ++k) f0 += c0[k] * m0[k][b];
    e0[b] = y[b] - f0;
  }
  const double n = blocks;
  // Each column's azimuth and grazing term, once for all onsets.
  std::vector<double> column_phi(blocks * kBlock);
  std::vector<double> column_grazing(blocks * kBlock);
  for (int i = 0; i < blocks * kBlock; ++i) {
    column_phi[i] = azimuth(lo + i);
    column_grazing[i] = 1.0 / std::max(std::cos(column_phi[i]), 0.1);
  }
  std::vector<double> v(blocks);
  for (int onset = lo + 2 * kBlock; onset <= lo + (blocks - 2) * kBlock; ++onset) {
    const double phi0 = azimuth(onset - 0.5);
    for (int kind = 0; kind < 2; ++kind) {
      std::fill(v.begin(), v.end(), 0.0);
      for (int b = 0; b < blocks; ++b) {
        for (int k = 0; k < kBlock; ++k) {
          const double phi = column_phi[b * kBlock + k];
          const double beyond = light_side * (phi - phi0);
          if (beyond <= 0.0) continue;
          v[b] += (kind == 0 ? std::sin(beyond) : column_grazing[b * kBlock + k]) / kBlock;
        }
      }
      double vv = 0.0;
      for (double x : v) vv += x * x;
      for (const std::vector<double>& q : basis) {
        double dot = 0.0;
        for (int b = 0; b < blocks; ++b) dot += q[b] * v[b];
        for (int b = 0; b < blocks; ++b) v[b] -= dot * q[b];
      }
      double ww = 0.0, we = 0.0;
      for (int b = 0; b < blocks; ++b) {
        ww += v[b] * v[b];
        we += v[b] * e0[b];
      }
      // v within M0's span (a rank-deficient M1): no onset there.
      if (!(ww > 1e-20 * vv)) continue;
      const double amplitude = we / ww;
      if (!(amplitude > 0.0)) continue;  // direct light only adds
      const double rss1 = std::max(rss0 - we * we / ww, 0.0);
      // BIC difference: n·ln(RSS0/RSS1) less ln n for each of the two new
      // parameters (the onset and its amplitude).
      const double delta_bic = n * std::log(rss0 / std::max(rss1, 1e-300)) - 2.0 * std::log(n);
      if (delta_bic <= result.delta_bic) continue;
      // The light the onset shows beyond what stray light could: the
      // largest difference of the two fits, amplitude·w (the onset's own
      // term trades with M0's slope, so its value alone may be none of it).
      double shown = 0.0;
      for (int b = 0; b < blocks; ++b) shown = std::max(shown, std::fabs(amplitude * v[b]));
      result.delta_bic = delta_bic;
      result.onset_column = onset;
      result.rise = shown;
      result.sigma = std::sqrt(rss1 / std::max(1.0, n - 6.0));
    }
  }
  // Decisive: a BIC difference above 10 ("very strong" evidence, odds
  // beyond 150:1), and the two fits apart somewhere by at least
  // kOnsetSigmas of the blocks' scatter about M1 (the texture and the noise)
  // and by min_rise (the caller's noise floor). The texture alone, or a
  // gradient of stray light, fits M0 and gives neither.
  constexpr double kDecisiveBic = 10.0;
  constexpr double kOnsetSigmas = 4.0;
  result.lit = result.delta_bic > kDecisiveBic && result.rise > kOnsetSigmas * result.sigma &&
               result.rise > min_rise;
  return result;
}

// Whether direct light begins where the phase angle puts the terminator in
// cylinder `c`: FindShadowOnset over the columns from the unlit limb to
// kBeyondRad past the terminator finds an onset within kAtRad of it (in
// azimuth; plus the tilt's smear of the all-rows mean). Stray light alone,
// or a surface lit all through, fits without one.
bool TerminatorSeen(const std::vector<double>& mean_profile, const PixelRegion& region,
                    const CylinderGeometry& c, const CylinderDetectionOptions& options,
                    double noise, int mean_rows) {
  constexpr double kBeyondRad = 10.0 * M_PI / 180.0;
  constexpr double kAtRad = 5.0 * M_PI / 180.0;
  const int side = options.phase_angle_rad > 0 ? 1 : -1;
  const double phi_t = options.phase_angle_rad - side * M_PI / 2.0;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  const double smear = 3.0 + std::fabs(std::tan(c.axis_angle_rad)) * region.height / 2.0;
  auto column = [&](double phi) {
    return c.center_x_px +
           OffsetFromAzimuth(std::clamp(phi, -M_PI / 2.0, M_PI / 2.0), options.projection) * half;
  };
  const double x_dark = c.center_x_px - side * half;
  const double x_beyond = column(phi_t + side * kBeyondRad);
  const int lo = static_cast<int>(std::ceil(std::min(x_dark, x_beyond) + smear)) - region.x;
  const int hi = static_cast<int>(std::floor(std::max(x_dark, x_beyond) - smear)) - region.x;
  if (hi - lo < 8) return false;
  const double column_noise = noise / std::sqrt(5.0 * std::max(mean_rows, 1));
  const ShadowOnset onset =
      FindShadowOnset(mean_profile, lo, hi, c.center_x_px - region.x, half, side,
                      options.projection, 6.0 * column_noise);
  if (!onset.lit) return false;
  const double x_term = column(phi_t);
  const double tolerance = std::fabs(column(phi_t + side * kAtRad) - x_term) + smear;
  return std::fabs(onset.onset_column + region.x - x_term) <= tolerance;
}

absl::Status CylinderDetectionOptions::Validate() const {
  if (num_bands < 3) return absl::InvalidArgumentError("num_bands must be >= 3");
  if (!(background_fraction > 0 && background_fraction < 0.25)) {
    return absl::InvalidArgumentError("background_fraction must be in (0, 0.25)");
  }
  if (!(edge_sigmas > 0)) return absl::InvalidArgumentError("edge_sigmas must be > 0");
  if (region.width < 0 || region.height < 0 || region.x < 0 || region.y < 0) {
    return absl::InvalidArgumentError("region must have non-negative x, y, width, height");
  }
  return absl::OkStatus();
}

namespace {

constexpr char kTooFewLimbs[] = "no cylinder found: only ";

// Whether a side strip holds a step over the given rows: the mean of each
// strip column over them, and a difference of three columns' means beside
// three others beyond kStripStepSigmas of its noise (StripRowNoise). A limb
// there (a cylinder that fills the frame) makes the body beyond it the
// strip's level, and the body then departs from it only at its terminator.
// (Over the bands' rows only: a mount's edges may stand in the strips
// beside the cylinder's ends.)
bool StripHoldsAStep(const Image& luminance, const PixelRegion& region, int side,
                     const std::vector<int>& rows) {
  constexpr double kStripStepSigmas = 8.0;
  if (side < 8 || rows.empty()) return false;
  std::vector<double> left(side, 0.0);
  std::vector<double> right(side, 0.0);
  for (int y : rows) {
    for (int i = 0; i < side; ++i) {
      left[i] += luminance.At(region.x + i, y);
      right[i] += luminance.At(region.x + region.width - 1 - i, y);
    }
  }
  const StripNoise noise = StripRowNoise(luminance, region, side, rows);
  const double n = static_cast<double>(rows.size());
  for (int s = 0; s < 2; ++s) {
    const std::vector<double>& p = s == 0 ? left : right;
    // At least one code value of the file at the strip's level: a file
    // that holds less noise than a code value (8-bit, a JPEG's smoothing)
    // shows a smooth backdrop's gradient as a staircase of whole codes,
    // whose column means step by up to a code where a limb steps by many.
    double level = 0.0;
    for (double v : p) level += v;
    level /= n * side;
    const double threshold =
        std::max(kStripStepSigmas * (s == 0 ? noise.left : noise.right) * std::sqrt(2.0 / (3.0 * n)),
                 CodeStep(luminance, level));
    for (int x = 3; x + 3 < side; ++x) {
      const double d = (p[x + 1] + p[x + 2] + p[x + 3] - p[x - 1] - p[x - 2] - p[x - 3]) / (3.0 * n);
      if (std::fabs(d) > threshold) return true;
    }
  }
  return false;
}

// What the phase checks read of the photograph.
struct SeenPhotograph {
  const Image& luminance;
  PixelRegion region;
  const std::vector<double>& mean_profile;  // the cylinder's rows' column means
  double background = 0.0;
  double noise = 0.0;
  int mean_rows = 0;
  int side = 0;  // the side strips' width, px
  const CylinderDetectionOptions& options;
  // The body inside the unlit edge rises as a limb's stray-light shading,
  // not as a terminator's ramp (Shading::ExplainsSoftEdge).
  bool unlit_shading_rise = false;
};

// Where the lobe stands on cylinder `c`: the mean azimuth of its two ends.
// A split lobe's caustics lie symmetric about the mirror azimuth, whichever
// is the brighter. (The centroid of the brightest columns, used before, took
// a seen limb for a dark one under a wide lobe:
// DetectionCasesTest.WideSplitLobeKeepsBothSeenLimbs.) α/2 when no column
// stands out.
double LobeAzimuth(const SeenPhotograph& seen, const CylinderGeometry& c) {
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  const auto [first, last] = BrightExtent(seen.mean_profile, seen.region.x,
                                          c.center_x_px - 0.9 * half, c.center_x_px + 0.9 * half);
  if (!std::isfinite(first)) return seen.options.phase_angle_rad / 2.0;
  auto azimuth = [&](double x) {
    return AzimuthFromOffset(std::clamp((x - c.center_x_px) / half, -1.0, 1.0),
                             seen.options.projection);
  };
  return 0.5 * (azimuth(first) + azimuth(last));
}

// The background just beside the unlit limb, kBesidePx out, over the
// cylinder's usable rows (the ends' mount may stand beside the others). A
// gradient across the frame (a lit backdrop) and vignetting move the
// background's level between a side strip and the limb by as much as a
// dim body stands from it. Two models of it:
//  - the trend beyond the edge: a quadratic (gradient and vignetting)
//    through the mean levels kTrendFromPx..kTrendToPx outside it along
//    each row, carried in to kBesidePx. It holds only where those columns
//    are background: when the edge is not the limb they hold the body
//    (its texture, its roll-off, the limb's step), whose residuals stand
//    out of the means' noise: their mean square more than kPlainChi2Sigmas
//    standard deviations of χ²/dof above 1, with kNoiseAllowance for the
//    noise estimate's own error (a few per cent from the strip's MAD)
//    and mildly correlated noise;
//  - otherwise the line through the two side strips' medians.
// NaN when a side strip has no rows.
constexpr int kBesidePx = 7;
double UnlitBackground(const SeenPhotograph& seen, const CylinderGeometry& c) {
  constexpr int kTrendFromPx = 12, kTrendToPx = 200;
  constexpr double kPlainChi2Sigmas = 4.0, kNoiseAllowance = 1.1;
  const Image& luminance = seen.luminance;
  const PixelRegion& region = seen.region;
  const int strip = seen.side;
  const int unlit = seen.options.phase_angle_rad > 0 ? -1 : 1;
  const int row_step = std::max(1, (c.bottom_row - c.top_row + 1) / 128);
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  std::vector<double> sum(kTrendToPx + 1, 0.0);
  std::vector<int> count(kTrendToPx + 1, 0);
  int rows = 0;
  for (int y = c.top_row; y <= c.bottom_row; y += row_step, ++rows) {
    const double limb = c.AxisColumn(y) + unlit * half;
    for (int d = kTrendFromPx; d <= kTrendToPx; ++d) {
      const int x = static_cast<int>(std::lround(limb + unlit * d));
      if (x < region.x || x >= region.x + region.width) break;
      sum[d] += luminance.At(x, y);
      ++count[d];
    }
  }
  std::vector<std::vector<double>> basis(3);
  std::vector<double> level;
  for (int d = kTrendFromPx; d <= kTrendToPx; ++d) {
    if (count[d] < rows || rows == 0) continue;
    const double u = (d - kBesidePx) / static_cast<double>(kTrendToPx);
    basis[0].push_back(1.0);
    basis[1].push_back(u);
    basis[2].push_back(u * u);
    level.push_back(sum[d] / count[d]);
  }
  auto strip_values = [&](int from) {
    std::vector<double> values;
    for (int y = c.top_row; y <= c.bottom_row; y += row_step) {
      for (int x = from; x < from + strip; ++x) values.push_back(luminance.At(x, y));
    }
    return values;
  };
  const std::vector<double> lefts = strip_values(region.x);
  const std::vector<double> rights = strip_values(region.x + region.width - strip);
  if (lefts.empty() || rights.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double left = Median(lefts);
  const double right = Median(rights);
  // The noise of one pixel from the unlit side's strip about its own
  // median (the detector's `noise` pools both strips about one level,
  // which a gradient inflates).
  std::vector<double> deviations;
  for (double v : unlit < 0 ? lefts : rights) {
    deviations.push_back(std::fabs(v - (unlit < 0 ? left : right)));
  }
  const double pixel_noise = 1.4826 * Median(deviations);
  std::vector<double> coefficients;
  const double rss = level.size() >= 16 ? LeastSquaresRss(basis, level, &coefficients)
                                        : std::numeric_limits<double>::infinity();
  const double mean_noise = pixel_noise / std::sqrt(std::max(rows, 1));
  const double dof = static_cast<double>(level.size()) - 3.0;
  if (std::isfinite(rss) &&
      rss / dof <= kNoiseAllowance * kNoiseAllowance * mean_noise * mean_noise *
                       (1.0 + kPlainChi2Sigmas * std::sqrt(2.0 / dof))) {
    return coefficients[0];  // u = 0 at kBesidePx
  }
  const double x_left = region.x + 0.5 * (strip - 1);
  const double x_right = region.x + region.width - 0.5 * (strip + 1);
  const double x = c.center_x_px + unlit * (half + kBesidePx);
  return left + (right - left) * (x - x_left) / std::max(1.0, x_right - x_left);
}

// The part of the disc in shadow, from the unlit limb to the terminator
// φ_T = α − sign(α)·90° (with a margin for blur and the tilt's smear of
// the column means), can only show the body's stray light: no Lambertian,
// scatter or glint reaches it (DESIGN.md §3). A rise there means the edge
// taken for the unlit limb is the terminator or beyond. `seen_in_shadow`:
// the shadow is flat and stands clearly apart from the background beside
// the unlit limb (UnlitBackground): a body seen in its own shadow, whose
// edge is its limb (a terminator is taken for a limb only where the body
// beyond it is as dark as the background); `level` is its median.
struct ShadowView {
  bool flat = true;
  bool seen_in_shadow = false;
  double level = std::numeric_limits<double>::quiet_NaN();
  ShadowOnset onset;
};
ShadowView JudgeShadow(const SeenPhotograph& seen, const CylinderGeometry& c) {
  const PixelRegion& region = seen.region;
  const std::vector<double>& mean_profile = seen.mean_profile;
  const CylinderDetectionOptions& options = seen.options;
  ShadowView view;
  const int side = options.phase_angle_rad > 0 ? 1 : -1;
  const double phi_t = options.phase_angle_rad - side * M_PI / 2.0;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  const double smear = 3.0 + std::fabs(std::tan(c.axis_angle_rad)) * region.height / 2.0;
  const double margin = 3.0 * M_PI / 180.0;
  const double x_dark = c.center_x_px - side * half;
  const double x_term = c.center_x_px + OffsetFromAzimuth(phi_t - side * margin, options.projection) * half;
  const int lo = static_cast<int>(std::ceil(std::min(x_dark, x_term) + smear)) - region.x;
  const int hi = static_cast<int>(std::floor(std::max(x_dark, x_term) - smear)) - region.x;
  if (hi - lo < 4) return view;
  std::vector<double> values;
  for (int x = std::max(lo, 2); x <= std::min(hi, region.width - 3); ++x) {
    double v = 0.0;
    for (int k = -2; k <= 2; ++k) v += mean_profile[x + k];
    values.push_back(v / 5.0);
  }
  if (values.size() < 4) return view;
  std::sort(values.begin(), values.end());
  // The scale: the surface's typical level over the disc (a maximum
  // would be a clipped glint's).
  std::vector<double> disc;
  for (int x = static_cast<int>(std::ceil(c.center_x_px - half)) - region.x;
       x <= static_cast<int>(std::floor(c.center_x_px + half)) - region.x; ++x) {
    if (x >= 0 && x < region.width) disc.push_back(std::fabs(mean_profile[x] - seen.background));
  }
  const double typical = disc.empty() ? 0.0 : Median(disc);
  const double column_noise = seen.noise / std::sqrt(5.0 * std::max(seen.mean_rows, 1));
  view.onset = FindShadowOnset(mean_profile, lo, hi, c.center_x_px - region.x, half, side,
                               options.projection, 6.0 * column_noise);
  view.flat = !view.onset.lit;
  view.level = values[values.size() / 2];
  const double beside = UnlitBackground(seen, c);
  const double level = view.level - (std::isfinite(beside) ? beside : seen.background);
  view.seen_in_shadow = view.flat && std::fabs(level) > std::max(kSeenShadowSigmas * column_noise,
                                                                 kSeenShadowShare * typical);
  return view;
}

// Just inside the unlit limb the surface is in shadow (|α| ≥ 20°): its
// pixels vary across rows by the noise and the cloth's texture, not by
// the comb of glints an edge of the specular lobe shows.
bool UnlitEdgeIsSmooth(const SeenPhotograph& seen, const CylinderGeometry& c) {
  const Image& luminance = seen.luminance;
  const CylinderDetectionOptions& options = seen.options;
  const double background = seen.background;
  const double noise = seen.noise;
  if (std::fabs(options.phase_angle_rad) < 20.0 * M_PI / 180.0) return true;
  const int side = options.phase_angle_rad > 0 ? 1 : -1;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  std::vector<double> spreads;
  std::vector<double> levels;
  for (int k = 1; k <= 5; ++k) {
    double sum = 0.0;
    double sum_sq = 0.0;
    int n = 0;
    for (int y = c.top_row; y <= c.bottom_row; ++y) {
      const int x = static_cast<int>(std::lround(c.AxisColumn(y) - side * (half - k)));
      if (x < 0 || x >= luminance.width) continue;
      const double v = luminance.At(x, y);
      sum += v;
      sum_sq += v * v;
      ++n;
    }
    if (n < 3) continue;
    const double mean = sum / n;
    spreads.push_back(std::sqrt(std::max(0.0, sum_sq / n - mean * mean)));
    levels.push_back(std::fabs(mean - background));
  }
  if (spreads.empty()) return true;
  return Median(spreads) < 4.0 * noise + 0.3 * Median(levels);
}

// A limb is where the body meets the background: just beyond the edge
// taken for the unlit limb (4-10 px out, past a lens blur of a pixel or
// two, whose tail there is a few per cent of the step) the level must
// lie within kLimbOutsideShare of the way from the background beside it
// (UnlitBackground) to the body seen in shadow (`shadow_level`). Under
// stray light the body darkens toward its limb gradually (the diffuse light
// falls off as the surface turns away), and an edge found on that roll-off,
// the body continuing beyond it, is not the limb.
bool UnlitEdgeMeetsBackground(const SeenPhotograph& seen, const CylinderGeometry& c,
                              double shadow_level) {
  const Image& luminance = seen.luminance;
  const PixelRegion& region = seen.region;
  if (!std::isfinite(shadow_level)) return true;
  const int unlit = seen.options.phase_angle_rad > 0 ? -1 : 1;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  const int row_step = std::max(1, (c.bottom_row - c.top_row + 1) / 128);
  const double local_background = UnlitBackground(seen, c);
  if (!std::isfinite(local_background)) return true;
  double sum = 0.0;
  int n = 0;
  for (int y = c.top_row; y <= c.bottom_row; y += row_step) {
    for (int d = kBesidePx - 3; d <= kBesidePx + 3; ++d) {
      const int x = static_cast<int>(std::lround(c.AxisColumn(y) + unlit * (half + d)));
      if (x < region.x || x >= region.x + region.width) continue;
      sum += luminance.At(x, y);
      ++n;
    }
  }
  if (n == 0) return true;
  // A shadow less than a code of the file from the background (an 8-bit
  // file, a dark body on a dark backdrop) is not told from it: the means
  // of pixels on few codes are biased by up to half a code, and the test
  // below would judge that bias.
  if (std::fabs(shadow_level - local_background) < CodeStep(luminance, local_background)) {
    return true;
  }
  return !(std::fabs(sum / n - local_background) >
           kLimbOutsideShare * std::fabs(shadow_level - local_background));
}

// The 20-80 % rise of an edge, px, from the mean over the usable rows
// of each row's pixels at a distance d inside it (along the row, the
// axis's tilt followed): a limb is a step blurred by the lens, a
// terminator taken for one a ramp (the Lambertian term grows from zero
// there). NaN when the edge has too little contrast to measure.
double EdgeRisePx(const SeenPhotograph& seen, const CylinderGeometry& c, int side) {
  const Image& luminance = seen.luminance;
  const double noise = seen.noise;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  const int row_step = std::max(1, (c.bottom_row - c.top_row + 1) / 128);
  constexpr int kOut = 4, kIn = 14;
  std::vector<double> level(kOut + kIn + 1, 0.0);
  int rows = 0;
  for (int y = c.top_row; y <= c.bottom_row; y += row_step) {
    const double edge = c.AxisColumn(y) + side * half;  // side −1: left
    const double x_lo = edge - side * kIn, x_hi = edge + side * kOut;
    if (std::min(x_lo, x_hi) < 0 || std::max(x_lo, x_hi) > luminance.width - 2) continue;
    for (int d = -kOut; d <= kIn; ++d) {
      const double x = edge - side * d;
      const int x0 = static_cast<int>(std::floor(x));
      const double t = x - x0;
      level[d + kOut] += (1.0 - t) * luminance.At(x0, y) + t * luminance.At(x0 + 1, y);
    }
    ++rows;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (rows < 3) return nan;
  for (double& v : level) v /= rows;
  const double outside = 0.5 * (level[0] + level[1]);
  const double inside = 0.5 * (level[kOut + kIn] + level[kOut + kIn - 1]);
  const double step = inside - outside;
  if (!(std::fabs(step) > 8.0 * noise / std::sqrt(static_cast<double>(rows)))) return nan;
  auto crossing = [&](double share) {
    const double at = outside + share * step;
    for (std::size_t i = 1; i < level.size(); ++i) {
      if ((level[i - 1] - at) * (level[i] - at) <= 0.0 && level[i] != level[i - 1]) {
        return (i - 1) + (at - level[i - 1]) / (level[i] - level[i - 1]);
      }
    }
    return nan;
  };
  return crossing(0.8) - crossing(0.2);
}

// A cylinder whose inferred limb (the one away from the light) lies in
// the region at the cylinder's first and last rows; an error otherwise.
// The detector reads the side strips as background: beyond the frame's
// edge, the limb would leave the body in shadow in the strip, read as
// background, and nothing in the photograph places it (a limb inferred
// 1,300 px outside an 800 px frame made a lobe at one caustic "fit").
absl::StatusOr<CylinderGeometry> InferredLimbInFrame(const CylinderGeometry& c,
                                                     const PixelRegion& region,
                                                     double phase_angle_rad) {
  const double toward_unlit = phase_angle_rad > 0 ? -1.0 : 1.0;
  const double half = c.radius_px / std::cos(c.axis_angle_rad);
  for (const int row : {c.top_row, c.bottom_row}) {
    const double limb = c.AxisColumn(row) + toward_unlit * half;
    if (limb < region.x || limb > region.x + region.width - 1) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "the limb inferred from the terminator would lie outside the frame (column %.0f "
          "at row %d)",
          limb, row));
    }
  }
  return c;
}

// With the phase angle known, the lobe must stand near the mirror azimuth
// α/2. When it does not, the edge on the side away from the light may be
// the terminator, the limb beyond it lost in darkness: infer that limb
// (terminator.h) and keep the cylinder whose lobe stands at α/2. `g` is
// the cylinder of both limbs seen, through the limb lines final_left and
// final_right; `reseeded` says which limbs all rows placed. The cylinders
// tried, with the figures that judged them, go to `trace` when given.
absl::StatusOr<CylinderGeometry> CheckAgainstPhase(const SeenPhotograph& seen,
                                                   const CylinderGeometry& g,
                                                   const Line& final_left,
                                                   const Line& final_right,
                                                   const Reseeded& reseeded,
                                                   DetectionTrace* trace) {
  const Image& luminance = seen.luminance;
  const PixelRegion& region = seen.region;
  const std::vector<double>& mean_profile = seen.mean_profile;
  const double background = seen.background;
  const double noise = seen.noise;
  const int mean_rows = seen.mean_rows;
  const CylinderDetectionOptions& options = seen.options;
  const double half_alpha = options.phase_angle_rad / 2.0;
  auto lobe_azimuth = [&](const CylinderGeometry& c) { return LobeAzimuth(seen, c); };
  auto edge_rise_px = [&](const CylinderGeometry& c, int side) { return EdgeRisePx(seen, c, side); };
  const double phi = lobe_azimuth(g);
  const double miss = std::fabs(phi - half_alpha);
  const ShadowView shadow = JudgeShadow(seen, g);
  bool shadow_seen = shadow.seen_in_shadow;
  const bool shadow_flat = shadow.flat;
  // Only a body seen in shadow has a level to stand apart from.
  const bool edge_is_limb = !shadow_seen || UnlitEdgeMeetsBackground(seen, g, shadow.level);
  if (!edge_is_limb) shadow_seen = false;
  const bool smooth = UnlitEdgeIsSmooth(seen, g);
  const bool flat = shadow_flat && smooth && edge_is_limb;
  const ShadowOnset& both_limbs_onset = shadow.onset;
  // With the unlit limb in shadow, an edge there that rises far more
  // slowly than the lit limb is a terminator: at α = −16° (640×480, a
  // Lambertian body as dark as the background) it stood 12 px inside the
  // limb, which put the lobe 1° off and called a sawtooth a sinusoid.
  // Unless the terminator is seen where the phase angle puts it inside
  // this cylinder: direct light beginning there (TerminatorSeen) makes the
  // edge beyond the body in shadow its limb, however soft that limb's
  // rise (a stray-lit body darkens toward its limb as the surface turns
  // from the diffuse light); or unless the strip inside the edge rises as
  // that shading does rather than as a terminator's ramp
  // (SeenPhotograph::unlit_shading_rise).
  bool soft_unlit = false;
  double lit_rise = std::numeric_limits<double>::quiet_NaN();
  double unlit_rise = std::numeric_limits<double>::quiet_NaN();
  if (std::fabs(options.phase_angle_rad) >= kShadowedLimbRad) {
    const int light_side = options.phase_angle_rad > 0 ? 1 : -1;
    lit_rise = edge_rise_px(g, light_side);
    unlit_rise = edge_rise_px(g, -light_side);
    soft_unlit = std::isfinite(unlit_rise) &&
                 unlit_rise > kSoftEdgePx + (std::isfinite(lit_rise) ? lit_rise : 0.0) &&
                 !seen.unlit_shading_rise &&
                 !TerminatorSeen(mean_profile, region, g, options, noise, mean_rows);
  }
  std::string why_not_inferred;
  auto degrees = [](double rad) { return absl::StrFormat("%.1f", rad * 180.0 / M_PI); };
  // The figures that judge the cylinder of both edges taken for limbs.
  std::string both_verdict = absl::StrCat(
      "lobe at ", degrees(phi), " deg (half the phase angle ", degrees(half_alpha), ")");
  if (both_limbs_onset.judged) {
    absl::StrAppend(&both_verdict, both_limbs_onset.lit ? "; direct light in the shadow"
                                                        : "; the shadow shows stray light only",
                    absl::StrFormat(" (onset model better by %.0f in BIC, rise %.1f noise)",
                                    both_limbs_onset.delta_bic,
                                    both_limbs_onset.sigma > 0.0
                                        ? both_limbs_onset.rise / both_limbs_onset.sigma
                                        : 0.0));
  }
  if (!smooth) absl::StrAppend(&both_verdict, "; glints just inside the unlit edge");
  if (!edge_is_limb) absl::StrAppend(&both_verdict, "; the body continues beyond the unlit edge");
  if (std::isfinite(unlit_rise)) {
    absl::StrAppend(&both_verdict, absl::StrFormat("; unlit edge rises over %.1f px, lit over %.1f px",
                                                   unlit_rise, lit_rise));
  }
  if (soft_unlit) absl::StrAppend(&both_verdict, " (a terminator's ramp)");
  if (std::isfinite(unlit_rise) && seen.unlit_shading_rise) {
    absl::StrAppend(&both_verdict, " (the unlit limb's shading)");
  }
  auto note = [&](const std::string& name, const CylinderGeometry& c, bool kept,
                  const std::string& verdict) {
    if (trace != nullptr) trace->hypotheses.push_back({name, c, kept, verdict});
  };
  const std::string kBoth = "both edges are limbs";
  const std::string kInferred = "unlit edge is the terminator, its limb inferred";
  // Noted as rejected; set kept below when it is.
  note(kBoth, g, false, both_verdict);
  // A lobe off α/2 alone does not make the unlit edge a terminator when
  // the body is seen in shadow inside it: a sawtooth m = 0.47 at −95°, its
  // outer caustic 6 px inside the lit limb (beyond the columns the lobe is
  // looked for in), stood 25° off by its inner caustic alone, and a dark
  // limb inferred 300 px out made the lobe "fit".
  const bool off_lobe = miss > options.min_lobe_offset_to_infer_rad && !shadow_seen;
  if (off_lobe || !flat || soft_unlit) {
    // The edge away from the light may be a soft terminator: the tilt is
    // the lit limb's alone.
    const Line& lit = options.phase_angle_rad > 0 ? final_right : final_left;
    const bool unlit_moved = options.phase_angle_rad > 0 ? reseeded.left : reseeded.right;
    const Line& other =
        unlit_moved ? (options.phase_angle_rad > 0 ? reseeded.left_bands : reseeded.right_bands)
                    : (options.phase_angle_rad > 0 ? final_left : final_right);
    CylinderGeometry edges = g;
    edges.axis_angle_rad = std::atan(-lit.slope);
    edges.center_x_px = 0.5 * (lit.at_center + other.at_center);
    edges.radius_px = 0.5 * std::fabs(lit.at_center - other.at_center) * std::cos(edges.axis_angle_rad);
    absl::StatusOr<CylinderGeometry> inferred = InferDarkLimb(
        luminance, edges, options.phase_angle_rad, options.projection, {background, noise});
    if (inferred.ok()) inferred = InferredLimbInFrame(*inferred, region, options.phase_angle_rad);
    if (inferred.ok()) {
      const double inferred_miss = std::fabs(lobe_azimuth(*inferred) - half_alpha);
      // A soft unlit edge is the shading of a stray-lit limb as well as a
      // terminator's ramp: it makes the terminator the answer only where
      // the lobe does not stand nearer α/2 on the cylinder of both limbs
      // (within kLobeAgreeRad the lobe's ends do not tell them apart).
      constexpr double kLobeAgreeRad = 1.0 * M_PI / 180.0;
      const bool soft_and_lobe_agrees =
          soft_unlit && inferred_miss <= std::max(miss, kLobeAgreeRad);
      if ((!flat || soft_and_lobe_agrees || inferred_miss < 0.5 * miss) &&
          inferred_miss <= options.min_lobe_offset_to_infer_rad) {
        const bool right_lit = options.phase_angle_rad > 0;
        SetRadiusStderr(final_left, right_lit ? kInferredLimbPx : kLimbSystematicPx,
                        final_right, right_lit ? kLimbSystematicPx : kInferredLimbPx,
                        &*inferred);
        note(kInferred, *inferred, true,
             absl::StrCat("lobe at ", degrees(lobe_azimuth(*inferred)), " deg"));
        return *inferred;
      }
      why_not_inferred = absl::StrCat(
          "; with the unlit edge taken as the terminator the lobe lies at ",
          std::lround(lobe_azimuth(*inferred) * 180.0 / M_PI), " deg");
      note(kInferred, *inferred, false,
           absl::StrCat("lobe at ", degrees(lobe_azimuth(*inferred)), " deg, not within ",
                        degrees(options.min_lobe_offset_to_infer_rad), " deg of ",
                        degrees(half_alpha), (!flat || soft_unlit) ? "" : ", nor nearer than before"));
    } else {
      why_not_inferred = absl::StrCat("; no dark limb could be inferred: ",
                                      inferred.status().message());
      note(kInferred, CylinderGeometry(), false, std::string(inferred.status().message()));
    }
  }
  if (!flat) {
    // What the surface in shadow showed, the first failed check's words.
    const std::string what =
        !shadow_flat ? "shows direct light, not stray light alone"
        : !smooth    ? "shows glints just inside that edge, as the lobe does, not a body in shadow"
                     : "goes on beyond that edge at the level it has in shadow (stray light "
                       "falling off toward the limb, not the limb)";
    return absl::InvalidArgumentError(absl::StrCat(
        "no cylinder found consistent with the phase angle: the surface between the edge "
        "away from the light and the terminator (", std::lround(options.phase_angle_rad * 180.0 / M_PI),
        " deg light) ", what, ", so that edge is not a limb "
        "(check the phase angle and its sign; a background as bright as the body's unlit "
        "side hides its limb: darken or lighten the background, or give the cylinder)",
        why_not_inferred));
  }
  if (miss > options.max_lobe_offset_rad) {
    return absl::InvalidArgumentError(absl::StrCat(
        "no cylinder found consistent with the phase angle: the brightest part of "
        "what was found lies at azimuth ", std::lround(phi * 180.0 / M_PI),
        " deg, not near half the phase angle (", std::lround(half_alpha * 180.0 / M_PI),
        " deg); check the phase angle and its sign (positive = light on the image's "
        "right)", why_not_inferred));
  }
  if (trace != nullptr) {
    for (DetectionTrace::Hypothesis& h : trace->hypotheses) h.kept = h.name == kBoth;
  }
  return g;
}

struct LimbFit {
  double scatter = std::numeric_limits<double>::quiet_NaN();
  Blur blur;
  Line line;  // the first pass's line moved by the fitted δ
  double delta = 0.0;
  // No glints cut a window: a fit that chose its blur proposed one.
  bool whole = false;
  // S's standard error, cluster-robust over the bands (CR2).
  double scatter_stderr = 0.0;
};

// The stray-light shading inside the limb away from the light
// (LimbPlacer::RollOff): R, and the BIC by which the strip's rise is that
// shading's rather than a terminator's ramp.
struct Shading {
  bool measured = false;  // in at least three bands
  double rolloff = 0.0;
  double delta_bic = 0.0;
  // Decisive as FindShadowOnset's: above 10, odds beyond 150:1.
  bool ExplainsSoftEdge() const { return delta_bic > 10.0; }
};

// The limbs placed in every band to a fraction of a pixel, with what their
// errors need: the stages of DetectWithSideStrips between the bands' first
// estimates and the limb lines.
struct PlacedLimbs {
  Shading unlit_shading;
  std::vector<LimbPoint> left_points;
  std::vector<LimbPoint> right_points;
  // The held scatter's common shift of each limb (HeldShift), px.
  double left_held_px = 0.0;
  double right_held_px = 0.0;
  // Each limb's allowance for the edge model (SetRadiusStderr).
  double left_systematic_px = kLimbSystematicPx;
  double right_systematic_px = kLimbSystematicPx;
  // Each limb's move when the blur moves by its error (ThroughBlur), px.
  double left_through_blur_px = 0.0;
  double right_through_blur_px = 0.0;
  double sigma = 0.0;           // the lens blur both limbs were seen through
  double unused_blur_px = 0.0;  // a proposal not used (CylinderGeometry)
};

// What one band's profile shows of the background beside a limb at `edge`:
// the sums of its level v over t = kGapPx .. kGapPx + kSpanPx − 1 px
// outside it. kGapPx clears a lens blur's tail (3σ at the first fit's cap).
struct BesideLimb {
  int n = 0;
  double st = 0.0, sv = 0.0, stt = 0.0, stv = 0.0;
};
BesideLimb MeasureBesideLimb(const std::vector<double>& profile, double edge, int inward) {
  constexpr int kGapPx = 5;
  constexpr int kSpanPx = 24;
  BesideLimb b;
  const int n_columns = static_cast<int>(profile.size());
  for (int k = kGapPx; k < kGapPx + kSpanPx; ++k) {
    const int x = static_cast<int>(std::floor(edge)) - inward * k;
    if (x < 0 || x >= n_columns) return BesideLimb();  // the frame cuts it
    b.st += k;
    b.sv += profile[x];
    b.stt += static_cast<double>(k) * k;
    b.stv += k * profile[x];
    ++b.n;
  }
  return b;
}

// Each limb to a fraction of a pixel (RefineEdge) in every band, twice: the
// grazing scatter's strength S is the same along a limb, so the second pass
// holds it at one value for all bands; and through one lens blur for both
// limbs, with the errors the blur and the held S carry into each limb.
class LimbPlacer {
 public:
  // `shading`: each limb's stray-light R from the wide window
  // (PlaceLimbsWide), left and right, 0 at the lit one; RollOff's replaces
  // it where it measures one (a strip short of the terminator and the
  // blur: not at small phase angles, where the direct light starts within
  // a pixel or two of the limb).
  LimbPlacer(const std::vector<BandEdges>& bands_seen, const PixelRegion& region,
             double center_row, const CylinderDetectionOptions& options,
             const std::array<double, 2>& shading)
      : bands_seen_(bands_seen), region_(region), center_row_(center_row), options_(options) {
    rolloff_[0] = shading[0];
    rolloff_[1] = shading[1];
    for (const BandEdges& band : bands_seen) {
      background_[0].push_back(band.left_background);
      background_[1].push_back(band.right_background);
    }
    light_ = std::isfinite(options.phase_angle_rad) ? (options.phase_angle_rad > 0 ? 1 : -1) : 0;
    glints_reach_limb_ = light_ != 0 && std::fabs(options.phase_angle_rad) >= kGlintsReachLimbRad;
    shadowed_limb_ = light_ != 0 && std::fabs(options.phase_angle_rad) >= kShadowedLimbRad;
  }

  // Both limbs in every band. With `shadow_is_limb`, the edge away from the
  // light is known to be a limb (DetectWithSideStrips).
  PlacedLimbs Place(bool shadow_is_limb);

 private:
  // Below kShadowedLimbRad the limb away from the light is lit only from
  // the terminator on, R·(1 − cos α) inside it (2 px at R = 128 px and 10°):
  // its grazing scatter starts there. Modelled from the limb, the scatter's
  // rise at the terminator drew that limb inward (the coarse gauze at 10°,
  // noise-free: radius 0.015 px short).
  double LitFrom(bool toward_light, double radius) const;
  // The pad of a limb's edge windows (pad_, or glint_pad_ where glints may
  // reach it).
  int LimbPad(bool toward_light) const;
  // One limb (inward +1: left) in every band, with S held at `scatter`
  // (NaN: fitted per band), through `blur`, around `around` when given.
  std::vector<LimbPoint> RefineLimb(int inward, double scatter, const Blur& blur = Blur(),
                                    const Line* around = nullptr) const;
  // The held S, and the lens blur, from all the limb's bands at once: their
  // edges on the first pass's line moved together by δ (every 0.05 px within
  // a pixel, then every 0.005 px), each band its own body level,
  // one S ≥ 0 for all, by least squares (S enters linearly: closed form at
  // each δ).
  // - S: fitted band by band (edge, body and S each), it comes out biased
  //   upward by noise, in proportion to it: at the coarse gauze's lit limb at
  //   60° the median of the bands' fits read 0.00014-0.00025 where the
  //   noise-free value is 0.00013, pulling that limb 0.02 px inward; with the
  //   joint S the radius is short by 0.006 px instead of 0.012 (48 noise
  //   draws; 0.014 instead of 0.022 at 10°, 0.007 instead of 0.012 at -110°).
  // - The blur: a lens PSF smears the scatter's bright rim at the limb
  //   outward, and a sharp model follows it out: on noise-free renders of the
  //   coarse gauze the radius came out 0.04, 0.27 and 0.87 px long at a lens
  //   blur of 0.4, 0.8 and 1.2 px (60°). The model is seen through a
  //   Gaussian of σ chosen by the least residual over 0-1.5 px (a grid, then
  //   golden-section search between the best point's neighbours).
  // `warm_delta`: δ of the same fit through the blur before it moved by
  // its error (NearWarmStart).
  LimbFit JointLimb(int inward, const std::vector<LimbPoint>& first,
                    const Blur* fixed_blur = nullptr,
                    const std::vector<bool>* use_band = nullptr,
                    double warm_delta = std::numeric_limits<double>::quiet_NaN()) const;
  // The held S is one number for the whole limb, so its own noise moves every
  // band's edge alike, which the line's scatter over the bands does not show:
  // over 64 noise draws of the coarse gauze at 10° the limbs spread 1.3 times
  // their line's stated scatter (1.8 times with dark axial threads), and
  // 1.1 times with the first pass's edges. HeldShift is that common shift's
  // standard error: S's (the joint fit's, LimbFit::scatter_stderr) times the
  // line's move per unit S, from two more passes at S ± that error.
  double HeldShift(int inward, const LimbFit& fit) const;
  // How far a limb moves when the blur moves by its error: half the move
  // between blur ± error, signed, of the joint fit's line through each (S
  // refitted with the blur, or held at zero at a limb in shadow). The
  // bands' own placement about that line moves with it: refitting them
  // too changed no stated radius error on the shared photographs by more
  // than 0.009 px.
  double ThroughBlur(int inward, const std::vector<LimbPoint>& first, const LimbFit& fit,
                     double blur_stderr_px) const;
  // The shading R of a body in stray light at the limb away from the light,
  // from a wide strip inside the line through `points` (0: none seen).
  Shading RollOff(int inward, const std::vector<LimbPoint>& points, double from_px) const;
  // The background under each band's limbs at the lines through `left` and
  // `right`, for the bands on them (MeasureBesideLimb).
  void SetLocalBackgrounds(const std::vector<LimbPoint>& left,
                           const std::vector<LimbPoint>& right);

  const std::vector<BandEdges>& bands_seen_;
  const PixelRegion& region_;
  const double center_row_;
  const CylinderDetectionOptions& options_;
  int light_ = 0;  // +1: light on the right, -1: on the left, 0: unknown
  // With the phase angle known and at least kGlintsReachLimbRad, the
  // lobe's glints may reach the limb toward the light.
  bool glints_reach_limb_ = false;
  // The limb away from the light lies in the cylinder's own shadow.
  bool shadowed_limb_ = false;
  // Pixels added to each end of the edge windows (WidePad): 0 until the
  // lens blur is found at the first fit's cap.
  int pad_ = 0;
  // Each limb's held stray-light shading R (RollOff), left and right.
  double rolloff_[2] = {0.0, 0.0};
  // The background under each band's limbs, left and right: the side
  // strips' levels, then the local ones at the first pass's lines
  // (SetLocalBackgrounds).
  std::vector<double> background_[2];
  // ... but not at a limb the glints may reach, whose window they cut short
  // (a wide window took them in and drew that limb inward): it is seen
  // through the blur the other limb proposes.
  int glint_pad_ = 0;
};

double LimbPlacer::LitFrom(bool toward_light, double radius) const {
  if (light_ == 0 || toward_light || shadowed_limb_) return 0.0;
  return radius * (1.0 - std::cos(options_.phase_angle_rad));
}

int LimbPlacer::LimbPad(bool toward_light) const {
  return glints_reach_limb_ && toward_light ? glint_pad_ : pad_;
}

std::vector<LimbPoint> LimbPlacer::RefineLimb(int inward, double scatter, const Blur& blur,
                                              const Line* around) const {
  const bool toward_light = inward > 0 ? light_ < 0 : light_ > 0;
  std::vector<LimbPoint> points;
  for (std::size_t i = 0; i < bands_seen_.size(); ++i) {
    const BandEdges& band = bands_seen_[i];
    // Around the joint line for the bands on it (a band on a mount or an
    // end, off the line, keeps its own first estimate).
    const double e0 = inward > 0 ? band.left_cross : band.right_cross;
    double center = std::numeric_limits<double>::quiet_NaN();
    if (around != nullptr && i < around->inlier.size() && around->inlier[i]) {
      center = around->at_center + around->slope * (band.row - center_row_) - region_.x;
    }
    points.push_back(
        {band.row, region_.x + RefineEdge(band.profile,
                                         background_[inward > 0 ? 0 : 1][i],
                                         e0, inward, band.radius,
                                         glints_reach_limb_ && toward_light,
                                         !shadowed_limb_ || toward_light, scatter, nullptr, blur,
                                         center, LitFrom(toward_light, band.radius),
                                         LimbPad(toward_light), &band.clipped,
                                         rolloff_[inward > 0 ? 0 : 1])});
  }
  return points;
}

LimbFit LimbPlacer::JointLimb(int inward, const std::vector<LimbPoint>& first,
                              const Blur* fixed_blur, const std::vector<bool>* use_band,
                              double warm_delta) const {
  const bool toward_light = inward > 0 ? light_ < 0 : light_ > 0;
  const bool lit = !shadowed_limb_ || toward_light;
  const Line line = FitLimbLine(first, center_row_);
  std::vector<EdgeWindow> windows;
  std::vector<double> edges;  // the first line at each band, region columns
  for (std::size_t i = 0; i < bands_seen_.size(); ++i) {
    if (!line.inlier[i] || (use_band != nullptr && !(*use_band)[i])) continue;
    const BandEdges& band = bands_seen_[i];
    EdgeWindow w = MakeEdgeWindow(
        band.profile, background_[inward > 0 ? 0 : 1][i],
        inward > 0 ? band.left_cross : band.right_cross, inward,
        band.radius, glints_reach_limb_ && toward_light, LitFrom(toward_light, band.radius),
        LimbPad(toward_light), fixed_blur != nullptr ? RampPx(*fixed_blur) : 0.0,
        &band.clipped);
    if (w.xs.empty()) continue;
    w.rolloff = rolloff_[inward > 0 ? 0 : 1];
    windows.push_back(std::move(w));
    edges.push_back(line.at_center + line.slope * (band.row - center_row_) - region_.x);
  }
  bool extend = true;
  for (const EdgeWindow& w : windows) {
    extend = extend && w.xs.size() == static_cast<std::size_t>(9 + 2 * w.pad);
  }
  // The scan's reach beyond a pixel: 2.5 px, and the pad's width more
  // through the wide windows; through a blur found at the other limb as
  // well, whose rise starts far out however the glints cut the window.
  const bool reach_out = extend || (fixed_blur != nullptr && fixed_blur->sigma >= 0.5);
  struct Scan {
    double sse = std::numeric_limits<double>::infinity();
    double delta = 0.0;
    double scatter = std::numeric_limits<double>::quiet_NaN();
  };
  // The best δ (and its S) through one blur: every 0.05 px, then every
  // 0.005 px around the best, over all bands (`fine`), or for choosing the
  // blur, every 0.1 px over every third band.
  auto scan = [&](const Blur& blur, bool fine) {
    const std::size_t band_step = fine ? 1 : 3;
    for (std::size_t k = 0; k < windows.size(); k += band_step) {
      SetBlur(&windows[k], blur);
    }
    Scan best;
    auto consider = [&](double delta) {
      HeldFit sum;
      for (std::size_t k = 0; k < windows.size(); k += band_step) {
        const HeldFit h = Held(SumsAt(windows[k], edges[k] + delta));
        sum.at_zero += h.at_zero;
        sum.num += h.num;
        sum.den += h.den;
      }
      if (!(sum.den > 0.0)) return std::numeric_limits<double>::infinity();
      const double s = lit ? std::max(0.0, sum.num / sum.den) : 0.0;
      const double sse = sum.at_zero - 2.0 * s * sum.num + s * s * sum.den;
      if (sse < best.sse) best = {sse, delta, s};
      return sse;
    };
    if (fine && NearWarmStart(consider, warm_delta)) {
      // Only near the unmoved fit's δ.
    } else if (fine) {
      for (int k = -20; k <= 20; ++k) consider(0.05 * k);
      // A best at the end of the range: the first estimates are off by
      // more than a pixel (a wide blur's rise starts far out), so on,
      // unless glints cut a window short (they would draw the edge in).
      for (int k = 21; k <= 50 + 20 * pad_ && reach_out && std::fabs(best.delta) >= 0.95; ++k) {
        consider(std::copysign(0.05 * k, best.delta));
      }
      FineStepsAround(consider, best.delta);
    } else {
      for (int k = -10; k <= 10; ++k) consider(0.1 * k);
      for (int k = 11; k <= 25 + 10 * pad_ && reach_out && std::fabs(best.delta) >= 0.95; ++k) {
        consider(std::copysign(0.1 * k, best.delta));
      }
    }
    return best;
  };
  LimbFit fit;
  if (windows.empty()) return fit;
  if (fixed_blur != nullptr) {
    fit.blur = *fixed_blur;
  } else {
    // Glints that cut a window short would pass for blur: no proposal then.
    // Through the wide windows, from the first cap on.
    const std::vector<double> grid =
        !extend   ? std::vector<double>{0.0}
        : pad_ > 0 ? std::vector<double>{1.0, kMaxBlurPx, 2.0, 2.5, 3.0, kWideMaxBlurPx}
                  : std::vector<double>{0.0, 0.35, 0.7, 1.0, kMaxBlurPx};
    std::size_t best_k = 0;
    double best_sse = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < grid.size(); ++k) {
      const double sse = scan(MakeBlur(grid[k]), false).sse;
      if (sse < best_sse) {
        best_sse = sse;
        best_k = k;
      }
    }
    double sigma = grid[best_k];
    if (best_k > 0) {
      const double lo = grid[best_k - 1];
      const double hi = grid[std::min(best_k + 1, grid.size() - 1)];
      sigma = GoldenSectionMinimum([&](double sg) { return scan(MakeBlur(sg), false).sse; },
                                   lo, hi, 0.05);
    }
    fit.blur = MakeBlur(sigma < kMinBlurPx ? 0.0 : sigma);
  }
  const Scan final_scan = scan(fit.blur, true);
  fit.whole = extend;
  fit.scatter = final_scan.scatter;
  {
    // S's error from the bands' own scores at the joint fit, each scaled
    // for the share of S's information its band holds: the bias-reduced
    // cluster-robust form (as stats/cluster_covariance.h, for one
    // parameter). S was taken before as the bootstrap error of the median
    // of the bands' separate fits, which the joint fit replaced: over 16
    // noise draws of six fixtures the radius then spread 0.21-1.03 times
    // its stated statistical error (0.24-1.31 so).
    double den = 0.0;
    std::vector<HeldFit> per_band;
    for (std::size_t k = 0; k < windows.size(); ++k) {
      per_band.push_back(Held(SumsAt(windows[k], edges[k] + final_scan.delta)));
      den += per_band.back().den;
    }
    double meat = 0.0;
    for (const HeldFit& h : per_band) {
      const double score = h.num - final_scan.scatter * h.den;
      const double rest = std::max(1.0 - h.den / den, 1e-3);
      meat += score * score / rest;
    }
    if (den > 0.0 && std::isfinite(final_scan.scatter)) fit.scatter_stderr = std::sqrt(meat) / den;
  }
  fit.line = line;
  fit.line.at_center += final_scan.delta;
  fit.delta = final_scan.delta;
  // Where glints cut a window short, the bands search around their own
  // first estimates rather than this line, which the glints draw in (0.5 px
  // at α = 140°, R = 256 px, the glints 1.4 px inside the limb): no band is
  // marked as on it.
  if (!extend) std::fill(fit.line.inlier.begin(), fit.line.inlier.end(), false);
  return fit;
}

double LimbPlacer::HeldShift(int inward, const LimbFit& fit) const {
  const double ds = fit.scatter_stderr;
  if (!(ds > 0.0)) return 0.0;
  const Line plus = FitLimbLine(
      RefineLimb(inward, fit.scatter + ds, fit.blur, &fit.line), center_row_);
  const Line minus = FitLimbLine(
      RefineLimb(inward, fit.scatter - ds, fit.blur, &fit.line), center_row_);
  return 0.5 * std::fabs(plus.at_center - minus.at_center);
}

double LimbPlacer::ThroughBlur(int inward, const std::vector<LimbPoint>& first,
                               const LimbFit& fit, double blur_stderr_px) const {
  if (!(blur_stderr_px > 0.0)) return 0.0;
  const double sigma = fit.blur.sigma;
  auto at = [&](double blur_px) {
    const Blur b = MakeBlur(std::max(0.0, blur_px));
    const LimbFit f = JointLimb(inward, first, &b, nullptr, fit.delta);
    if (!std::isfinite(f.scatter)) return std::numeric_limits<double>::quiet_NaN();
    return f.line.at_center;
  };
  const double move = 0.5 * (at(sigma + blur_stderr_px) - at(sigma - blur_stderr_px));
  return std::isfinite(move) ? move : 0.0;
}

// The BIC by which the bands' mean strip inside a limb (strip_sum[k] /
// strip_count[k] at depth k px, over the depths all `bands` reach) is
// B + R·cos φ rather than a terminator's B + k·d, in kBlock-column means.
double ShadingOverRamp(const std::vector<double>& strip_sum, const std::vector<int>& strip_count,
                       double radius, int bands) {
  constexpr int kBlock = 5;
  std::vector<double> c, d, v;  // block means
  double block_c = 0.0, block_d = 0.0, block_v = 0.0;
  int in_block = 0;
  for (std::size_t k = 0; k < strip_sum.size(); ++k) {
    if (strip_count[k] < bands) continue;
    const double u = 1.0 - k / radius;
    block_c += std::sqrt(std::max(0.0, 1.0 - u * u));
    block_d += k;
    block_v += strip_sum[k] / strip_count[k];
    if (++in_block < kBlock) continue;
    c.push_back(block_c / kBlock);
    d.push_back(block_d / kBlock);
    v.push_back(block_v / kBlock);
    block_c = block_d = block_v = 0.0;
    in_block = 0;
  }
  const int n = static_cast<int>(v.size());
  if (n < 4) return 0.0;
  // The residual sum of squares of v on a line in x.
  auto rss = [&](const std::vector<double>& x) {
    double sx = 0, sv = 0, sxx = 0, sxv = 0, svv = 0;
    for (int i = 0; i < n; ++i) {
      sx += x[i];
      sv += v[i];
      sxx += x[i] * x[i];
      sxv += x[i] * v[i];
      svv += v[i] * v[i];
    }
    const double vxx = sxx - sx * sx / n, vxv = sxv - sx * sv / n, vvv = svv - sv * sv / n;
    return std::max(vxx > 0.0 ? vvv - vxv * vxv / vxx : vvv, 1e-300);
  };
  return n * std::log(rss(d) / rss(c));
}

// A body in stray light is shaded like any diffuse surface under a broad
// source, a + R·cos φ (DESIGN.md §3: stray light reaches the whole body; a
// source on the camera's side lights the middle fully and the limb at
// grazing incidence). Near the limb cos φ ≈ √(2d/r) rises steeply, and a
// flat body level meets it only some pixels in: the edge model follows it
// there. R is measured where nothing else lights the body: inside the limb
// away from the light, from `from_px` (past the edge's blur) to half the
// radius, and short of the terminator (by a fifth of its depth: the weave's
// relief and the source's size soften it), about a line most bands agree
// on (where they do not, the first estimates are still far off: a mount,
// vignetting). Each band gives the least-squares R of v = B + R·cos φ
// about its edge on the line; R is their mean, kept when it stands
// kSigmas of its standard error (the bands' scatter) from zero.
// The same strip also tells a limb from a terminator taken for one: past
// a terminator the direct light grows linearly with the depth, v = B + k·d
// (the Lambertian term from zero); the shading's √d rises at once and
// levels off. Both are fitted to the bands' mean strip in kBlock-column
// means (the weave's texture is correlated over a thread's few pixels), and
// compared by BIC (the same number of parameters: n·ln(RSS_ramp/RSS_cos)).
Shading LimbPlacer::RollOff(int inward, const std::vector<LimbPoint>& points,
                            double from_px) const {
  constexpr double kMinStripPx = 24.0;  // cos φ's curvature needs a few tens of px
  constexpr double kSigmas = 4.0;
  Shading shading;
  const bool toward_light = inward > 0 ? light_ < 0 : light_ > 0;
  if (light_ == 0 || toward_light || points.size() < 3) return shading;
  const Line line = FitLimbLine(points, center_row_);
  const auto on_line = std::count(line.inlier.begin(), line.inlier.end(), true);
  if (2 * on_line < static_cast<long>(points.size())) return shading;
  const double alpha = std::fabs(options_.phase_angle_rad);
  std::vector<double> per_band;
  std::vector<double> strip_sum;  // the bands' levels at depth k px, summed
  std::vector<int> strip_count;
  double strip_radius = 0.0;      // the least of the bands' radii
  for (std::size_t i = 0; i < bands_seen_.size() && i < points.size(); ++i) {
    if (!line.inlier[i]) continue;
    const BandEdges& band = bands_seen_[i];
    const double r = band.radius;
    double depth = 0.5 * r;
    if (alpha < 0.5 * M_PI) depth = std::min(depth, 0.8 * r * (1.0 - std::cos(alpha)));
    if (!(depth - from_px >= kMinStripPx)) continue;
    const double e = line.at_center + line.slope * (band.row - center_row_) - region_.x;
    const int n_columns = static_cast<int>(band.profile.size());
    double sc = 0.0, sv = 0.0, scc = 0.0, scv = 0.0;  // v on cos φ (c)
    int n = 0;
    for (int k = static_cast<int>(std::ceil(from_px)); k <= static_cast<int>(depth); ++k) {
      const int x = static_cast<int>(std::lround(e + inward * k));
      if (x < 0 || x >= n_columns) break;
      if (!band.clipped.empty() && band.clipped[x] != 0) continue;
      const double d = inward * (x - e);
      const double u = 1.0 - d / r;
      const double c = std::sqrt(std::max(0.0, 1.0 - u * u));
      const double v = band.profile[x];
      if (strip_sum.size() <= static_cast<std::size_t>(k)) {
        strip_sum.resize(k + 1, 0.0);
        strip_count.resize(k + 1, 0);
      }
      strip_sum[k] += v;
      ++strip_count[k];
      sc += c;
      sv += v;
      scc += c * c;
      scv += c * v;
      ++n;
    }
    if (n < kMinStripPx) continue;
    const double vcc = scc - sc * sc / n, vcv = scv - sc * sv / n;
    if (!(vcc > 0.0)) continue;
    per_band.push_back(vcv / vcc);
    strip_radius = per_band.size() == 1 ? r : std::min(strip_radius, r);
  }
  if (per_band.size() < 3) return shading;
  shading.measured = true;
  shading.delta_bic = ShadingOverRamp(strip_sum, strip_count, strip_radius,
                                      static_cast<int>(per_band.size()));
  double mean = 0.0;
  for (double v : per_band) mean += v;
  mean /= per_band.size();
  double var = 0.0;
  for (double v : per_band) var += (v - mean) * (v - mean);
  const double stderr_r = std::sqrt(var / (per_band.size() - 1) / per_band.size());
  if (std::fabs(mean) > kSigmas * stderr_r) shading.rolloff = mean;
  return shading;
}

// The backdrop's gradient and vignetting move the background at a limb
// away from the side strip's level, by as much as a stray-lit body stands
// from it, and an edge model on the strip's level takes the difference for
// body. The background beside each band's limb (MeasureBesideLimb) is
// carried on to the limb along one slope for the whole limb, and the
// levels so found follow a quadratic along the limb (vignetting, 1 − k·ρ²,
// is one along a line; a gradient, a straight line): one band's own would
// carry its noise into its edge. Bands off the line (a mount, an end, not
// yet placed) and limbs with fewer than kMinBands keep the strip's level.
void LimbPlacer::SetLocalBackgrounds(const std::vector<LimbPoint>& left,
                                     const std::vector<LimbPoint>& right) {
  constexpr int kMinBands = 5;
  for (int side = 0; side < 2; ++side) {
    const int inward = side == 0 ? +1 : -1;
    const Line line = FitLimbLine(side == 0 ? left : right, center_row_);
    std::vector<std::size_t> used;
    std::vector<BesideLimb> beside;
    double vtt = 0.0, vtv = 0.0;
    for (std::size_t i = 0; i < bands_seen_.size() && i < line.inlier.size(); ++i) {
      if (!line.inlier[i]) continue;
      const double edge =
          line.at_center + line.slope * (bands_seen_[i].row - center_row_) - region_.x;
      const BesideLimb b = MeasureBesideLimb(bands_seen_[i].profile, edge, inward);
      if (b.n == 0) continue;
      used.push_back(i);
      beside.push_back(b);
      vtt += b.stt - b.st * b.st / b.n;
      vtv += b.stv - b.st * b.sv / b.n;
    }
    if (static_cast<int>(used.size()) < kMinBands || !(vtt > 0.0)) continue;
    const double slope = vtv / vtt;
    // Each band's level at its limb (t = 0), then a quadratic in the row.
    cv::Mat a(static_cast<int>(used.size()), 3, CV_64F);
    cv::Mat y(static_cast<int>(used.size()), 1, CV_64F);
    const double scale = std::max(1.0, 0.5 * region_.height);
    for (std::size_t k = 0; k < used.size(); ++k) {
      const double u = (bands_seen_[used[k]].row - center_row_) / scale;
      a.at<double>(static_cast<int>(k), 0) = 1.0;
      a.at<double>(static_cast<int>(k), 1) = u;
      a.at<double>(static_cast<int>(k), 2) = u * u;
      y.at<double>(static_cast<int>(k), 0) = (beside[k].sv - slope * beside[k].st) / beside[k].n;
    }
    cv::Mat c;
    if (!cv::solve(a, y, c, cv::DECOMP_SVD)) continue;
    for (std::size_t k = 0; k < used.size(); ++k) {
      const double u = (bands_seen_[used[k]].row - center_row_) / scale;
      background_[side][used[k]] =
          c.at<double>(0, 0) + c.at<double>(1, 0) * u + c.at<double>(2, 0) * u * u;
    }
  }
}

// An unblurred step fitted to a blurred limb comes out too far out by at
// most about this many of the blur's σ: 0.2, 1.1 and 3.4 px at a blur of
// 1, 1.3 and 2 px with glints by the limb at 100° (640×480, noise-free).
constexpr double kMaxInwardPerBlur = 1.75;

// The lit limb placed through the limb in shadow's blur `sigma`, from 90°
// on, where the outer caustic nears it: within 0.1 px at 95-100° (2 and
// 3 px, 640×480, noise-free) but 1.6 px in at 120° and 3 px, where the
// glints are blurred into the limb's rise, and 2.9 px out at 120° and 2 px,
// where they cut its window short. Returns its allowance (px): 0.5 px per
// px of blur, or as for an unused blur when the window was cut. An
// unblurred step fitted to a blurred limb (`unblurred`) comes out too far
// out by less than kMaxInwardPerBlur of its σ; a through-blur line (`fit`)
// further in than that has slid onto the outer caustic's flank (5 px in at
// 99° through a 2 px blur, the caustic 5 px inside the limb). Then neither
// reading stands alone: `fit`'s line is put between them, half their
// difference the allowance, and `between` set.
double LitLimbThroughOtherBlur(const LimbFit& unblurred, double sigma, int inward, LimbFit* fit,
                               bool* between) {
  double allowance =
      fit->whole ? kThroughOtherBlurPxPerPx * sigma : kUnusedBlurPxPerPx2 * sigma * sigma;
  const double moved = (fit->line.at_center - unblurred.line.at_center) * inward;
  if (std::isfinite(unblurred.scatter) && moved > kMaxInwardPerBlur * sigma) {
    fit->line.at_center -= 0.5 * moved * inward;
    allowance = std::max(allowance, 0.5 * moved);
    *between = true;
  }
  return allowance;
}

PlacedLimbs LimbPlacer::Place(bool shadow_is_limb) {
  PlacedLimbs placed;
  std::vector<LimbPoint>& left_points = placed.left_points;
  std::vector<LimbPoint>& right_points = placed.right_points;
  ForBothLimbs([&] { left_points = RefineLimb(+1, std::numeric_limits<double>::quiet_NaN()); },
               [&] { right_points = RefineLimb(-1, std::numeric_limits<double>::quiet_NaN()); });
  // Placed again on the background at each limb's line, and the limb away
  // from the light, where it is one (below 90° it is; from 90° on when
  // DetectWithSideStrips says so), in the body's stray-light shading
  // (RollOff; measured again below, once the lens blur is known).
  SetLocalBackgrounds(left_points, right_points);
  const bool away_is_limb = shadow_is_limb || std::fabs(options_.phase_angle_rad) < 0.5 * M_PI;
  const bool shaded = light_ != 0 && away_is_limb;
  const int away = light_ > 0 ? +1 : -1;
  std::vector<LimbPoint>& away_points = away > 0 ? left_points : right_points;
  double& away_rolloff = rolloff_[away > 0 ? 0 : 1];
  if (shaded) {
    placed.unlit_shading = RollOff(away, away_points, 2.0);
    if (placed.unlit_shading.measured) away_rolloff = placed.unlit_shading.rolloff;
  }
  ForBothLimbs([&] { left_points = RefineLimb(+1, std::numeric_limits<double>::quiet_NaN()); },
               [&] { right_points = RefineLimb(-1, std::numeric_limits<double>::quiet_NaN()); });
  double& left_held_px = placed.left_held_px;
  double& right_held_px = placed.right_held_px;
  // One lens blurs both limbs alike, so each limb's fit proposes a blur and
  // the smaller is taken for both (or the one proposal, below): what looks
  // like blur at one limb only is something else there (a rim of clipped
  // scatter, glints at the lit limb, a terminator's ramp taken for the limb
  // in shadow), and over-correcting it moved limbs by up to a pixel. Through
  // no blur, a blurred limb comes out too far out (above); a limb in shadow
  // too, as a plain step whose blurred light inside the window's end pulls
  // the fitted body level down: 0.26 and 0.37 px at a lens blur of 0.8 and
  // 1.2 px.
  LimbFit left_try;
  LimbFit right_try;
  ForBothLimbs([&] { left_try = JointLimb(+1, left_points); },
               [&] { right_try = JointLimb(-1, right_points); });
  auto lens_sigma = [&](bool proposers_only) {
    if (!std::isfinite(left_try.scatter) || !std::isfinite(right_try.scatter)) return 0.0;
    if (proposers_only && !left_try.whole) return right_try.blur.sigma;
    if (proposers_only && !right_try.whole) return left_try.blur.sigma;
    return std::min(left_try.blur.sigma, right_try.blur.sigma);
  };
  // Where the glints cut the lit limb's windows, the limb in shadow proposes
  // alone, as long as it is a limb: below 90° the terminator lies beyond it.
  // (From 90° on the edge away from the light may be the terminator, a wide
  // ramp that would pass for blur: at −120°, taken for it, the lit limb came
  // out a pixel in.)
  const bool alone = away_is_limb;
  double& sigma = placed.sigma;
  sigma = lens_sigma(alone);
  if (sigma >= kMaxBlurPx - kAtCapPx) {
    // The blur at the cap: refitted through wider windows, over wider blurs
    // (the narrow windows' fit is kept where a wide one fails).
    pad_ = WidePad(kWideMaxBlurPx);
    LimbFit left_wide;
    LimbFit right_wide;
    ForBothLimbs([&] { left_wide = JointLimb(+1, left_points); },
                 [&] { right_wide = JointLimb(-1, right_points); });
    if (std::isfinite(left_wide.scatter) && std::isfinite(right_wide.scatter)) {
      left_try = std::move(left_wide);
      right_try = std::move(right_wide);
      sigma = lens_sigma(alone);
      glint_pad_ = WidePad(sigma);
    } else {
      pad_ = 0;
    }
  }
  // The shading measured again beyond the lens blur's reach, where the
  // strip still holds enough of it: a blurred step's tail inside the limb
  // passes for it (at σ = 3 px it put the radius 0.3 px out). The limb is
  // placed again where it changed.
  if (shaded) {
    const Shading beyond_blur = RollOff(away, away_points, 2.0 + 3.0 * sigma);
    if (beyond_blur.measured) {
      placed.unlit_shading = beyond_blur;
      if (beyond_blur.rolloff != away_rolloff) {
        away_rolloff = beyond_blur.rolloff;
        away_points = RefineLimb(away, std::numeric_limits<double>::quiet_NaN());
      }
    }
  }
  // From 90° on, a blur the limb in shadow alone proposes is not used (above),
  // and a blurred lit limb then comes out too far out: 0.2, 1.1 and 3.4 px at
  // a lens blur of 1, 1.3 and 2 px (100°, 640×480, noise-free; the proposal
  // 1.03 px, then at the cap). That limb's allowance says so: 1.5 px per px²
  // of the proposal.
  double& left_systematic_px = placed.left_systematic_px;  // kLimbSystematicPx unless below
  double& right_systematic_px = placed.right_systematic_px;
  double& unused_blur_px = placed.unused_blur_px;
  if (!alone && std::isfinite(left_try.scatter) && std::isfinite(right_try.scatter) &&
      left_try.whole != right_try.whole) {
    const double proposal = left_try.whole ? left_try.blur.sigma : right_try.blur.sigma;
    if (proposal > sigma + kMinBlurPx) {
      unused_blur_px = proposal;
      (left_try.whole ? right_systematic_px : left_systematic_px) =
          std::hypot(kLimbSystematicPx, kUnusedBlurPxPerPx2 * proposal * proposal);
    }
  }
  const Blur lens = MakeBlur(sigma);
  // The blur's own error: half the difference of the blurs the limb that
  // set it proposes from the top and from the bottom half of the bands
  // apart. Each limb then moves by its share (ThroughBlur): both
  // outward or inward together, so the radius, and the wavelength with it,
  // take it whole. On the fixture with a lens blur of 0.8 px, the radius
  // spread 2.7 times its stated statistical error over 16 noise draws
  // without it (the blur read 0.58-0.64 px).
  double blur_stderr_px = 0.0;
  if (sigma >= kMinBlurPx) {
    // The limb whose proposal lens_sigma took.
    bool from_left = left_try.blur.sigma <= right_try.blur.sigma;
    if (alone && !left_try.whole) from_left = false;
    else if (alone && !right_try.whole) from_left = true;
    std::vector<bool> top(bands_seen_.size());
    std::vector<bool> bottom(bands_seen_.size());
    for (std::size_t i = 0; i < top.size(); ++i) {
      top[i] = 2 * i < top.size();
      bottom[i] = !top[i];
    }
    const int inward = from_left ? +1 : -1;
    const std::vector<LimbPoint>& points = from_left ? left_points : right_points;
    LimbFit upper;
    LimbFit lower;
    ForBothLimbs([&] { upper = JointLimb(inward, points, nullptr, &top); },
                 [&] { lower = JointLimb(inward, points, nullptr, &bottom); });
    if (std::isfinite(upper.scatter) && std::isfinite(lower.scatter)) {
      blur_stderr_px = 0.5 * std::fabs(upper.blur.sigma - lower.blur.sigma);
    }
  }
  double& left_through_blur_px = placed.left_through_blur_px;
  double& right_through_blur_px = placed.right_through_blur_px;
  auto place_limb = [&](int inward) {
    std::vector<LimbPoint>& points = inward > 0 ? left_points : right_points;
    LimbFit fit = JointLimb(inward, points, &lens);
    if (!std::isfinite(fit.scatter)) return;
    bool between = false;  // put between two readings (below): on the line
    const bool toward_light = inward > 0 ? light_ < 0 : light_ > 0;
    const LimbFit& unblurred = inward > 0 ? left_try : right_try;
    if (shadow_is_limb && toward_light && !unblurred.whole) {
      (inward > 0 ? left_systematic_px : right_systematic_px) = std::hypot(
          kLimbSystematicPx, LitLimbThroughOtherBlur(unblurred, sigma, inward, &fit, &between));
    }
    (inward > 0 ? left_through_blur_px : right_through_blur_px) =
        ThroughBlur(inward, points, fit, blur_stderr_px);
    if (shadowed_limb_ && !toward_light) {
      // S held at zero in both passes: only the blur and the line are new.
      points = RefineLimb(inward, 0.0, lens, &fit.line);
      return;
    }
    if (between) {
      // Each band refined again would slide back onto the caustic's flank.
      for (LimbPoint& p : points) {
        p.column = fit.line.at_center + fit.line.slope * (p.row - center_row_);
      }
      return;
    }
    points = RefineLimb(inward, fit.scatter, lens, &fit.line);
    (inward > 0 ? left_held_px : right_held_px) =
        HeldShift(inward, fit);
  };
  ForBothLimbs([&] { place_limb(+1); }, [&] { place_limb(-1); });
  return placed;
}

// The mean of the middle half of `values` (sorted here).
double InterquartileMean(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t lo = values.size() / 4;
  const std::size_t hi = std::max(values.size() - values.size() / 4, lo + 1);
  return std::accumulate(values.begin() + lo, values.begin() + hi, 0.0) / (hi - lo);
}

// The backdrop (Backdrop) fitted by least squares to the interquartile
// means of blocks of each strip's rows: a glint or a speck in a strip moves
// them by little, and unlike a median they are not held to the file's
// codes (in an 8-bit photograph the blocks' medians took three codes, their
// spread about their own median came out 0, and every block off it was
// left out as an outlier, and with them the vignetting's fall-off). Too
// few blocks for the fall-off's curvature: a level per strip, joined by
// the line between them.
Backdrop FitBackdrop(const Image& luminance, const PixelRegion& region, int side, double left_level,
                     double right_level) {
  constexpr int kBlocks = 16;
  constexpr double kOutlierSigmas = 4.0;
  Backdrop d;
  d.x0 = 0.5 * (luminance.width - 1);
  d.y0 = 0.5 * (luminance.height - 1);
  d.scale = std::max(1.0, 0.5 * std::hypot(luminance.width, luminance.height));
  const double left_x = region.x + 0.5 * (side - 1);
  const double right_x = region.x + region.width - 1 - 0.5 * (side - 1);
  // The fallback: the line between the strips, flat down the rows.
  d.b = (right_level - left_level) / std::max((right_x - left_x) / d.scale, 1e-9);
  d.a = left_level - d.b * (left_x - d.x0) / d.scale;
  const int blocks = std::min(kBlocks, region.height / 8);
  if (blocks < 6 || side < 2) return d;
  struct Sample {
    double x, y, level;
  };
  std::vector<Sample> samples;
  const int column_step = std::max(1, side / 16);
  for (int s = 0; s < 2; ++s) {
    for (int i = 0; i < blocks; ++i) {
      const int y0 = region.y + i * region.height / blocks;
      const int y1 = region.y + (i + 1) * region.height / blocks;
      const int row_step = std::max(1, (y1 - y0) / 16);
      std::vector<double> values;
      for (int y = y0; y < y1; y += row_step) {
        for (int j = 0; j < side; j += column_step) {
          values.push_back(
              luminance.At(s == 0 ? region.x + j : region.x + region.width - 1 - j, y));
        }
      }
      samples.push_back(
          {s == 0 ? left_x : right_x, 0.5 * (y0 + y1 - 1), InterquartileMean(std::move(values))});
    }
  }
  // Blocks far from their strip's median level are not backdrop (a mount
  // beyond the cylinder's ends, wider than it, reaches the strips): the
  // backdrop's own variation down a strip is smooth and small beside them.
  std::vector<bool> used(samples.size(), true);
  for (int s = 0; s < 2; ++s) {
    std::vector<double> levels;
    for (int i = 0; i < blocks; ++i) levels.push_back(samples[s * blocks + i].level);
    const double median = Median(levels);
    std::vector<double> deviation;
    for (double l : levels) deviation.push_back(std::fabs(l - median));
    const double spread = std::max(1.4826 * Median(deviation), 1e-12);
    for (int i = 0; i < blocks; ++i) {
      used[s * blocks + i] = deviation[i] <= kOutlierSigmas * spread;
    }
  }
  // Vignetting only darkens the frame away from its centre (k ≤ 0); a
  // rise toward the strips' ends is something else, and the fall-off is
  // left out (below).
  bool fall_off = true;
  double fall_off_stderr = 0.0;
  auto fit = [&](Backdrop* out) {
    cv::Mat a(0, 4, CV_64F);
    cv::Mat y(0, 1, CV_64F);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!used[i]) continue;
      const double u = (samples[i].x - d.x0) / d.scale;
      const double v = (samples[i].y - d.y0) / d.scale;
      const double row[4] = {1.0, u, v, fall_off ? u * u + v * v : 0.0};
      a.push_back(cv::Mat(1, 4, CV_64F, const_cast<double*>(row)));
      y.push_back(samples[i].level);
    }
    cv::Mat x;
    if (a.rows < 8 || !cv::solve(a, y, x, cv::DECOMP_SVD)) return false;
    out->a = x.at<double>(0);
    out->b = x.at<double>(1);
    out->c = x.at<double>(2);
    out->k = x.at<double>(3);
    if (fall_off) {
      // The fall-off's standard error: the residuals' variance times the
      // diagonal of (AᵀA)⁻¹.
      const cv::Mat residual = a * x - y;
      const double variance = residual.dot(residual) / std::max(a.rows - 4, 1);
      const cv::Mat inverse = (a.t() * a).inv(cv::DECOMP_SVD);
      fall_off_stderr = std::sqrt(std::max(variance * inverse.at<double>(3, 3), 0.0));
    }
    return true;
  };
  Backdrop first = d;
  if (!fit(&first)) return d;
  // The fall-off is kept only where the strips show it (beyond 3 of its
  // errors): fitted to noise, its curvature lifts or lowers the backdrop
  // between the strips by a share of the noise that a faint limb or a
  // terminator's shallow ramp is placed against.
  if (first.k > 0.0 || std::fabs(first.k) < 3.0 * fall_off_stderr) {
    fall_off = false;
    first = d;
    if (!fit(&first)) return d;
  }
  return first;
}

// SideStrips, measured: `side_fraction` of the region's width at each side.
SideStrips MeasureSideStrips(const Image& luminance, const PixelRegion& region,
                             double side_fraction) {
  SideStrips strips;
  const int side = std::max(2, static_cast<int>(std::lround(side_fraction * region.width)));
  strips.side = side;
  const int row_step = std::max(1, region.height / 256);
  std::vector<double> samples;
  std::vector<double> left_samples;
  std::vector<double> right_samples;
  // At most about 32 columns per side and row (every one on small images).
  const int column_step = std::max(1, side / 32);
  for (int y = region.y; y < region.y + region.height; y += row_step) {
    for (int i = 0; i < side; i += column_step) {
      left_samples.push_back(luminance.At(region.x + i, y));
      right_samples.push_back(luminance.At(region.x + region.width - 1 - i, y));
    }
  }
  samples = left_samples;
  samples.insert(samples.end(), right_samples.begin(), right_samples.end());
  const double background = Median(samples);
  strips.background = background;
  strips.left_background = Median(left_samples);
  strips.right_background = Median(right_samples);
  for (double& s : samples) s = std::fabs(s - background);
  strips.noise = std::max(1.4826 * Median(samples), 1e-6);
  strips.backdrop =
      FitBackdrop(luminance, region, side, strips.left_background, strips.right_background);
  return strips;
}

// The column means over rows top..bottom (at most about 32·24 of them, evenly
// spread, as the bands read), and how many rows they hold.
std::vector<double> ColumnMeans(const Image& luminance, const PixelRegion& region, int top,
                                int bottom, int* rows) {
  constexpr int kRows = 32 * 24;
  const int stride = std::max(1, (bottom - top + kRows) / kRows);
  std::vector<double> sums(region.width, 0.0);
  *rows = 0;
  for (int y = top; y <= bottom; y += stride, ++*rows) {
    const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width + region.x];
    cv::accumulate(cv::Mat(1, region.width, CV_32F, const_cast<float*>(row)),
                   cv::Mat(1, region.width, CV_64F, sums.data()));
  }
  for (double& v : sums) v /= std::max(*rows, 1);
  return sums;
}

// A band's texture (BandTexture) from its column means and sums of squares
// over `rows` rows.
BandTexture MeasureBandTexture(const std::vector<double>& mean, const std::vector<double>& sum_sq,
                               int rows, int side) {
  BandTexture t;
  const int w = static_cast<int>(mean.size());
  if (rows < 4 || w < 2 * side + 8) return t;
  std::vector<double> variance(w);
  for (int x = 0; x < w; ++x) {
    variance[x] = std::max(sum_sq[x] / rows - mean[x] * mean[x], 0.0) * rows / (rows - 1);
  }
  return TextureOf(std::move(variance), rows, side, 2.0);
}

BandTexture TextureOf(std::vector<double> variance, int rows, int side, double min_ratio) {
  BandTexture t;
  const int w = static_cast<int>(variance.size());
  if (rows < 4 || w < 2 * side + 8) return t;
  constexpr int kBox = 5;
  // Summed directly, not as a running sum: a running sum's rounding leaves
  // a residue where the variance is exactly 0 (a JPEG's flat backdrop),
  // and a floor of that residue made every column textured.
  t.variance.assign(w, 0.0);
  for (int x = 0; x < w; ++x) {
    const int lo = std::max(0, x - kBox / 2), hi = std::min(w - 1, x + kBox / 2);
    for (int k = lo; k <= hi; ++k) t.variance[x] += variance[k];
    t.variance[x] /= hi - lo + 1;
  }
  std::vector<double> strips;
  for (int x = 0; x < side; ++x) {
    strips.push_back(t.variance[x]);
    strips.push_back(t.variance[w - 1 - x]);
  }
  t.floor = Median(strips);
  // A variance over n rows scatters by √(2/(n − 1)) of itself; over kBox
  // columns by √kBox less.
  const double scatter = std::sqrt(2.0 / (kBox * (rows - 1.0)));
  t.threshold = t.floor * std::max(min_ratio, 1.0 + 6.0 * scatter);
  return t;
}

// Each band of rows' column means and first limb estimates (FindBandLimbs),
// and the column means of all the bands' rows.
struct BandScan {
  std::vector<BandEdges> bands_seen;  // the bands that found both limbs
  std::vector<int> band_first;        // every band's rows, inclusive
  std::vector<int> band_last;
  std::vector<double> mean_profile;   // sums over mean_rows rows
  int mean_rows = 0;
  int at_strip = 0;  // bands left out for a limb in a side strip
};
BandScan ScanBands(const Image& luminance, const PixelRegion& region, int bands,
                   const SideStrips& strips, const CylinderDetectionOptions& options) {
  const int side = strips.side;
  const double background = strips.background;
  const double noise = strips.noise;
  BandScan scan;
  std::vector<BandEdges>& bands_seen = scan.bands_seen;
  std::vector<int>& band_first = scan.band_first;
  std::vector<int>& band_last = scan.band_last;
  std::vector<double>& mean_profile = scan.mean_profile;
  int& mean_rows = scan.mean_rows;
  band_first.resize(bands);
  band_last.resize(bands);
  mean_profile.assign(region.width, 0.0);
  // Limbs per band of rows. With the phase angle known and at least
  // kGlintsReachLimbRad, the lobe's glints may reach the limb toward the light.
  const int light = std::isfinite(options.phase_angle_rad)
                        ? (options.phase_angle_rad > 0 ? 1 : -1)
                        : 0;
  const bool glints_reach_limb =
      light != 0 && std::fabs(options.phase_angle_rad) >= kGlintsReachLimbRad;
  std::vector<double> profile(region.width), squares(region.width);
  std::vector<double> backdrop(region.width);
  for (int b = 0; b < bands; ++b) {
    const int y0 = region.y + static_cast<int>(
                                  static_cast<long long>(b) * region.height / bands);
    const int y1 = region.y + static_cast<int>(static_cast<long long>(b + 1) *
                                                region.height / bands);
    band_first[b] = y0;
    band_last[b] = y1 - 1;
    // Column sums of the band, over at most kBandRows rows evenly spread: a
    // limb stands out of the noise of that many rows by far on any image
    // large enough to have more (and it keeps 12 Mpx images cheap).
    constexpr int kBandRows = 32;
    const int stride = std::max(1, (y1 - y0 + kBandRows - 1) / kBandRows);
    std::fill(profile.begin(), profile.end(), 0.0);
    std::fill(squares.begin(), squares.end(), 0.0);
    int band_rows = 0;
    std::vector<std::uint8_t> clipped;
    for (int y = y0; y < y1; y += stride) {
      const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width + region.x];
      if (const std::uint8_t* flags = luminance.saturated.Row(y); flags != nullptr) {
        clipped.resize(region.width, 0);
        for (int x = 0; x < region.width; ++x) clipped[x] |= flags[region.x + x];
      }
      // OpenCV's vectorised float-into-double accumulation.
      const cv::Mat pixels(1, region.width, CV_32F, const_cast<float*>(row));
      cv::accumulate(pixels, cv::Mat(1, region.width, CV_64F, profile.data()));
      cv::accumulateSquare(pixels, cv::Mat(1, region.width, CV_64F, squares.data()));
      ++band_rows;
    }
    for (int x = 0; x < region.width; ++x) mean_profile[x] += profile[x];
    mean_rows += band_rows;
    double peak = background;
    for (double& p : profile) {
      p /= band_rows;
      peak = std::max(peak, p);
    }
    const BandTexture texture = MeasureBandTexture(profile, squares, band_rows, side);
    // A band mean's noise, over the smoothing box's five columns.
    constexpr int kBox = 5;
    const double threshold =
        std::max(options.edge_sigmas * noise / std::sqrt(band_rows * kBox),
                 0.005 * (peak - background));
    const double row = 0.5 * (y0 + y1 - 1);
    for (int x = 0; x < region.width; ++x) backdrop[x] = strips.backdrop.At(region.x + x, row);
    const BandLimbs limbs = FindBandLimbs(
        profile, side, threshold, static_cast<int>(2 * options.min_radius_px),
        glints_reach_limb && light < 0, glints_reach_limb && light > 0, backdrop, texture);
    if (!limbs.found) {
      scan.at_strip += limbs.at_strip ? 1 : 0;
      continue;
    }
    const double band_radius = 0.5 * (limbs.right_cross - limbs.left_cross);
    bands_seen.push_back({row, limbs.left_cross, limbs.right_cross, band_radius, profile,
                          std::move(clipped), strips.left_background, strips.right_background, y0,
                          y1 - 1, limbs.left_textured, limbs.right_textured});
  }
  return scan;
}

// The cylinder's usable rows (first, last), refined row by row from the
// first band on both limb lines (rows top_from..top_to) and the last
// (bottom_from..bottom_to).
std::pair<int, int> UsableRows(const Image& luminance, const PixelRegion& region, int side,
                               double background, double noise, double edge_sigmas,
                               const CylinderGeometry& g, int top_from, int top_to,
                               int bottom_from, int bottom_to) {
  // Refine the ends row by row: a row belongs to the cylinder when the
  // surface just inside its limbs (offsets 0.75–0.95) stands nearer the
  // body's level there than the background's, judged over most of that
  // stretch (its median) on each side whose body the cylinder's middle rows
  // show clearly apart from the background (a body as dark as the
  // background on its unlit side shows only the other). A mount or an end
  // narrower than the cylinder leaves most of the stretch at the
  // background's level, where a mean over both sides counted its rows (a
  // mount 0.8 radii wide: 34 and 44 rows beyond the ends of a 2000×1500
  // photograph, whose step across the shadow read as direct light). Bands
  // that straddle an end would otherwise count whole. Each level is taken
  // from the row's own background, its side strips' median: a mount or an
  // end beyond the cylinder fills whole rows at a level of its own, which
  // the whole photograph's background would count as surface.
  struct RowLevels {
    std::array<double, 2> side = {0.0, 0.0};  // the stretch's median less the background
    std::array<double, 2> resolution = {0.0, 0.0};  // what a row's median resolves
    bool mean_apart = false;  // both stretches' mean, beyond the noise
  };
  auto levels_in = [&](int y) {
    std::vector<double> strips;
    std::array<std::vector<double>, 2> inside;
    for (int x = region.x; x < region.x + region.width; ++x) {
      if (x < region.x + side || x >= region.x + region.width - side) {
        strips.push_back(luminance.At(x, y));
      }
      const double o = g.NormalisedOffset(x, y);
      if (std::fabs(o) < 0.75 || std::fabs(o) > 0.95) continue;
      inside[o < 0.0 ? 0 : 1].push_back(luminance.At(x, y));
    }
    const double row_background = strips.empty() ? background : Median(strips);
    RowLevels r;
    double sum = 0.0;
    std::size_t n = 0;
    for (int k = 0; k < 2; ++k) {
      std::vector<double>& v = inside[k];
      if (v.empty()) continue;
      for (double p : v) sum += p;
      n += v.size();
      r.side[k] = Median(v) - row_background;
      // The median of n pixels scatters by about 1.25·noise/√n.
      r.resolution[k] = edge_sigmas * 1.25 * noise / std::sqrt(static_cast<double>(v.size()));
    }
    r.mean_apart = n > 0 && std::fabs(sum / n - row_background) >
                                edge_sigmas * noise / std::sqrt(static_cast<double>(n)) * 0.75;
    return r;
  };
  // The body's level on each side from nine of the middle rows, and whether
  // it tells the body from the background: apart from it by twice what a
  // row resolves and the rows' own spread (the lobe's glints, where they
  // reach the stretch, move its median from row to row by more than that).
  std::array<double, 2> body = {0.0, 0.0};
  std::array<bool, 2> telling = {false, false};
  constexpr int kMiddleRows = 9;
  std::vector<RowLevels> middle_rows;
  for (int i = 0; i < kMiddleRows; ++i) {
    middle_rows.push_back(
        levels_in(top_to + (bottom_from - top_to) * (2 * i + 1) / (2 * kMiddleRows)));
  }
  for (int k = 0; k < 2; ++k) {
    std::vector<double> level;
    double resolution = 0.0;
    for (const RowLevels& r : middle_rows) {
      level.push_back(r.side[k]);
      resolution = r.resolution[k];
    }
    body[k] = Median(level);
    std::vector<double> deviation;
    for (double l : level) deviation.push_back(std::fabs(l - body[k]));
    const double spread = 1.4826 * Median(deviation);
    telling[k] = resolution > 0.0 && std::fabs(body[k]) > 2.0 * (resolution + spread);
  }
  auto row_on_cylinder = [&](int y) {
    const RowLevels r = levels_in(y);
    if (!telling[0] && !telling[1]) return r.mean_apart;
    for (int k = 0; k < 2; ++k) {
      // Nearer the background's level than the body's.
      if (telling[k] && !(r.side[k] * body[k] > 0.5 * body[k] * body[k])) return false;
    }
    return true;
  };
  // The end may lie beyond the first (last) band whose limbs agreed with
  // the lines: a mount nearly as wide as the cylinder puts its edges within
  // a few pixels of the limbs. Where a side tells, the search goes on
  // toward the middle.
  const int middle_row = (top_to + bottom_from) / 2;
  const bool tells = telling[0] || telling[1];
  int top = top_from;
  while (top < (tells ? middle_row : top_to) &&
         !(row_on_cylinder(top) && row_on_cylinder(top + 1))) {
    ++top;
  }
  int bottom = bottom_to;
  while (bottom > (tells ? middle_row : bottom_from) &&
         !(row_on_cylinder(bottom) && row_on_cylinder(bottom - 1))) {
    --bottom;
  }
  return {top, bottom};
}

// The cylinder between two limb lines (image columns at the reference row
// g->center_row_px): axis, tilt, radius, the lines' scatter and the
// radius's error with `placed`'s allowances.
void SetFromLines(const Line& left, const Line& right, const PlacedLimbs& placed,
                  CylinderGeometry* g) {
  g->center_x_px = 0.5 * (left.at_center + right.at_center);
  const double slope = 0.5 * (left.slope + right.slope);
  g->axis_angle_rad = std::atan(-slope);
  g->radius_px = 0.5 * (right.at_center - left.at_center) * std::cos(g->axis_angle_rad);
  g->limb_rms_px = std::sqrt(0.5 * (left.rms * left.rms + right.rms * right.rms));
  SetRadiusStderr(left, placed.left_systematic_px, right, placed.right_systematic_px, g,
                  placed.left_through_blur_px, placed.right_through_blur_px);
}

// DetectCylinder with `side_fraction` of the region's width at each side
// taken as background. With `shadow_is_limb`, the edge away from the light is
// known to be a limb (a first pass saw both): its lens blur proposal counts
// alone at any phase angle.
absl::StatusOr<CylinderGeometry> DetectWithSideStrips(const Image& luminance,
                                                      const CylinderDetectionOptions& options,
                                                      double side_fraction, bool shadow_is_limb,
                                                      DetectionTrace* trace,
                                                      bool* body_in_strips = nullptr) {
  if (luminance.channels != 1) {
    return absl::InvalidArgumentError("DetectCylinder needs a one-channel image");
  }
  PixelRegion region = options.region;
  if (region.IsEmpty()) region = {0, 0, luminance.width, luminance.height};
  // In 64 bits, so that no two int fields can wrap round to pass (the
  // pipeline's CheckRegion refuses such a region first; this is the guard
  // of every other caller).
  if (region.x < 0 || region.y < 0 ||
      std::int64_t{region.x} + region.width > luminance.width ||
      std::int64_t{region.y} + region.height > luminance.height) {
    return absl::InvalidArgumentError(absl::StrCat(
        "region of interest ", region.x, ",", region.y, " ", region.width, "x",
        region.height, " extends beyond the ", luminance.width, "x",
        luminance.height, " image"));
  }
  const int bands = std::min(options.num_bands, region.height);
  if (region.width < 4 * options.min_radius_px || bands < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image region ", region.width, "x", region.height,
        " is too small to hold a cylinder"));
  }

  const SideStrips strips = MeasureSideStrips(luminance, region, side_fraction);
  const int side = strips.side;
  const double background = strips.background;
  const double noise = strips.noise;
  BandScan scan = ScanBands(luminance, region, bands, strips, options);
  // More bands saw the body reach into a side strip than found both its
  // limbs: the strips are not background over most of the cylinder's rows.
  if (body_in_strips != nullptr) {
    *body_in_strips = scan.at_strip > static_cast<int>(scan.bands_seen.size());
  }
  std::vector<BandEdges>& bands_seen = scan.bands_seen;
  const std::vector<int>& band_first = scan.band_first;
  const std::vector<int>& band_last = scan.band_last;
  std::vector<double>& mean_profile = scan.mean_profile;
  const int mean_rows = scan.mean_rows;
  const double center_row = region.y + (region.height - 1) / 2.0;
  if (trace != nullptr) {
    *trace = DetectionTrace();
    trace->region = region;
    trace->side_px = side;
    trace->column_means = mean_profile;
    for (double& v : trace->column_means) v /= std::max(mean_rows, 1);
    trace->left_background = strips.left_background;
    trace->right_background = strips.right_background;
    trace->noise = noise;
    trace->phase_angle_rad = options.phase_angle_rad;
    for (const BandEdges& b : bands_seen) {
      trace->band_edges.push_back({b.row, region.x + b.left_cross, region.x + b.right_cross});
    }
  }
  if (StripHoldsAStep(luminance, region, side, SpreadRows(bands_seen, 512))) {
    return absl::InvalidArgumentError(absl::StrCat(
        kTooFewLimbs, "part of the side strips (", side,
        " px) is plain background: a limb lies in one"));
  }
  const Reseeded reseeded =
      ReseedFaintLimbs(luminance, region, center_row, side, noise, options, &bands_seen);
  if (trace != nullptr) {
    trace->all_rows_left_x = reseeded.all_left;
    trace->all_rows_right_x = reseeded.all_right;
  }
  const std::array<WideLimb, 2> wide =
      PlaceLimbsWide(center_row, side, options.phase_angle_rad, &bands_seen);
  LimbPlacer placer(bands_seen, region, center_row, options, {wide[0].shading, wide[1].shading});
  PlacedLimbs placed = placer.Place(shadow_is_limb);
  placed.left_systematic_px = std::hypot(placed.left_systematic_px, wide[0].doubt_px);
  placed.right_systematic_px = std::hypot(placed.right_systematic_px, wide[1].doubt_px);
  std::vector<LimbPoint>& left_points = placed.left_points;
  std::vector<LimbPoint>& right_points = placed.right_points;
  const double left_held_px = placed.left_held_px;
  const double right_held_px = placed.right_held_px;
  const double sigma = placed.sigma;
  const double unused_blur_px = placed.unused_blur_px;
  // A limb's line with that shift's error added to its own.
  auto fit_limb = [&](const std::vector<LimbPoint>& points, double held_px) {
    Line line = FitLimbLine(points, center_row);
    line.at_center_stderr = std::hypot(line.at_center_stderr, held_px);
    return line;
  };
  if (left_points.size() < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        kTooFewLimbs, left_points.size(), " of ", bands,
        " row bands show two limbs against the background (level ", background,
        ", noise ", noise, ")"));
  }

  const Line left = fit_limb(left_points, left_held_px);
  const Line right = fit_limb(right_points, right_held_px);
  // The lines the geometry was last computed from.
  Line final_left = left;
  Line final_right = right;
  CylinderGeometry g;
  g.center_row_px = center_row;
  SetFromLines(left, right, placed, &g);
  g.lens_blur_px = sigma;
  g.unused_blur_px = unused_blur_px;
  g.left_observed = true;
  g.right_observed = true;
  // The cylinder of both edges taken for limbs, in the trace: its verdict is
  // the first check it fails (CheckAgainstPhase adds its own).
  auto refuse = [&](const std::string& why) {
    if (trace != nullptr) {
      trace->hypotheses.push_back({"both edges are limbs", g, false, why});
    }
    return absl::InvalidArgumentError(why);
  };
  if (g.radius_px < options.min_radius_px) {
    return refuse("no cylinder found: limbs too close together");
  }
  for (double& v : mean_profile) v /= std::max(mean_rows, 1);
  // The surface between the two edges must be continuous: edges found on
  // isolated glints (a body as dark as the background, no lit terminator)
  // would place a cylinder that is not there.
  if (const BodyCoverage body = CoverBody(luminance, region, mean_profile, strips, mean_rows,
                                          options.edge_sigmas, bands_seen,
                                          left.at_center, right.at_center);
      body.total == 0 || (body.on < kBodyShare * body.total && !body.limbs_step_into_body)) {
    return refuse(absl::StrCat(
        "no cylinder found: only ", body.on, " of ", body.total, " columns between the two "
        "edges differ from the background in level or texture; a body as dark and as "
        "smooth as the background shows only its glints (light it, or darken the "
        "background)"));
  }
  // Usable rows: from the first to the last band whose limbs agree with the
  // fitted lines (ends of the cylinder and the mount are excluded).
  int first = -1;
  int last = -1;
  for (std::size_t i = 0; i < left_points.size(); ++i) {
    if (!left.inlier[i] || !right.inlier[i]) continue;
    const int band = static_cast<int>(
        std::lround((left_points[i].row - region.y) * bands / region.height - 0.5));
    const int b = std::clamp(band, 0, bands - 1);
    if (first < 0 || b < first) first = b;
    if (last < 0 || b > last) last = b;
  }
  if (first < 0) return refuse("no cylinder found: limbs inconsistent");
  const auto [top, bottom] =
      UsableRows(luminance, region, side, background, noise, options.edge_sigmas, g,
                 band_first[first], band_last[first], band_first[last], band_last[last]);
  g.top_row = top;
  g.bottom_row = std::max(bottom, top);
  // Refit the limbs on the bands wholly inside the usable rows: a band that
  // straddles an end holds a partial limb that tilts the lines.
  const double half_band = 0.5 * region.height / bands;
  std::vector<LimbPoint> inner_left;
  std::vector<LimbPoint> inner_right;
  for (std::size_t i = 0; i < left_points.size(); ++i) {
    if (left_points[i].row - half_band >= g.top_row - 0.5 &&
        left_points[i].row + half_band <= g.bottom_row + 0.5) {
      inner_left.push_back(left_points[i]);
      inner_right.push_back(right_points[i]);
    }
  }
  if (inner_left.size() >= 3 && inner_left.size() < left_points.size()) {
    const Line l = fit_limb(inner_left, left_held_px);
    const Line r = fit_limb(inner_right, right_held_px);
    final_left = l;
    final_right = r;
    SetFromLines(l, r, placed, &g);
  }
  if (std::isfinite(options.phase_angle_rad)) {
    // The phase checks read the cylinder's rows alone: a mount or an end in
    // the others puts its own steps into the column means (a mount 0.8
    // radii wide, across the shadow, read as direct light there).
    int rows_on = mean_rows;
    const std::vector<double> on_cylinder =
        g.top_row > region.y || g.bottom_row < region.y + region.height - 1
            ? ColumnMeans(luminance, region, g.top_row, g.bottom_row, &rows_on)
            : mean_profile;
    return CheckAgainstPhase({luminance, region, on_cylinder, background, noise, rows_on, side,
                              options, placed.unlit_shading.ExplainsSoftEdge()},
                             g, final_left, final_right, reseeded, trace);
  }
  if (trace != nullptr) {
    trace->hypotheses.push_back({"both edges are limbs", g, true, "no phase angle to check"});
  }
  return g;
}

}  // namespace

absl::StatusOr<CylinderGeometry> DetectCylinder(const Image& luminance,
                                                const CylinderDetectionOptions& options,
                                                DetectionTrace* trace) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  // From 90° on, the blur the limb in shadow alone proposes is not used, for
  // that edge may be the terminator. When both limbs came out seen, it was a
  // limb: the lit limb is placed again through that blur. (A sinusoid at
  // 100°, lens blur 2 px, 640×480, noise-free: its lit limb 3.4 px out,
  // then within 0.1 px.)
  // Each attempt's trace, when asked for one; the returned result's is kept.
  auto detect = [&](double side_fraction, DetectionTrace* seen, bool* body_in_strips) {
    absl::StatusOr<CylinderGeometry> first =
        DetectWithSideStrips(luminance, options, side_fraction, false, seen, body_in_strips);
    if (first.ok() && first->unused_blur_px > 0.0 && first->left_observed &&
        first->right_observed) {
      DetectionTrace again_seen;
      absl::StatusOr<CylinderGeometry> again = DetectWithSideStrips(
          luminance, options, side_fraction, true, seen != nullptr ? &again_seen : nullptr);
      if (again.ok() && again->left_observed && again->right_observed) {
        if (seen != nullptr) *seen = std::move(again_seen);
        return again;
      }
    }
    return first;
  };
  bool body_in_strips = false;
  absl::StatusOr<CylinderGeometry> found =
      detect(options.background_fraction, trace, &body_in_strips);
  // A cylinder that fills the frame has a limb inside the side strips: the
  // bands are searched from the strips inward and skip it (limbs 11.5 px
  // from the edge of a 320 px image, 21 px of a 640 px one, were "no
  // cylinder"). Then the strips are narrowed to kNarrowSideFraction, at
  // least kNarrowSidePx. So they are too where a refusal rests on the
  // minority of the bands, the rest having seen the body reach into a strip
  // (a limb at a strip's inner edge left every band of the cylinder's rows
  // out, and a mount narrower than the cylinder, above and below it, gave
  // the only edges).
  constexpr double kNarrowSideFraction = 0.01;
  constexpr int kNarrowSidePx = 3;
  const int width = options.region.IsEmpty() ? luminance.width : options.region.width;
  const double narrow =
      std::max(kNarrowSideFraction, kNarrowSidePx / std::max(1.0, static_cast<double>(width)));
  if (found.ok() || narrow >= options.background_fraction ||
      !(absl::StartsWith(found.status().message(), kTooFewLimbs) || body_in_strips)) {
    return found;
  }
  DetectionTrace narrowed_seen;
  absl::StatusOr<CylinderGeometry> narrowed =
      detect(narrow, trace != nullptr ? &narrowed_seen : nullptr, nullptr);
  if (narrowed.ok() && trace != nullptr) *trace = std::move(narrowed_seen);
  return narrowed.ok() ? narrowed : found;
}

}  // namespace weavefit
