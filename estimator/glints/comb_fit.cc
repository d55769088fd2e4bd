#include "estimator/glints/comb_fit.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/stats/cluster_covariance.h"
#include "estimator/stats/median.h"
#include "estimator/stats/normal_table.h"

namespace weavefit {
namespace {

// Parameters: (m, λ mm, δ rad: the mirror's offset from (α + v)/2), (ln σ
// of the source, rad), (ℓ: lens PSF σ = 0.1 + ln(1 + e^ℓ) px, which keeps
// it above its floor without a bound: PsfPx) shared by all rows; each row's
// own (c mm, level A, baseline b0, baseline slope b1 per rad).
constexpr int kShared = 5;
constexpr int kOwn = 4;
constexpr double kPsfFloorPx = 0.1;
// The lens blur (σ, px) the limbs must show for the PSF to place each glint
// within its pixel (InPixelPsfKernel).
constexpr double kInPixelFromBlurPx = 1.0;
// Sub-intervals per bin at most (BinMean's node arrays).
constexpr int kMaxPieces = 32;
// Sub-intervals per bin of the main solve at most (the polish takes all).
constexpr int kMainPieces = 4;
// The most the facet tilt m·cos θ may turn across one sub-interval, m times
// the weave phase it spans (rad). The miss is taken as linear along a
// sub-interval; 8 per 1 px bin at 11 px per period and m = 0.24 (the
// fixtures) turn it by 0.017. A steep, fine weave on a large photograph
// (m = 0.6, 11 px per period, bins of 2.6 px: 0.11) read the spacing 0.48°
// long, 9 stated errors, noise-free; at 0.054 (16 pieces) 0.03°.
constexpr double kMaxTiltTurnPerPiece = 0.03;

// One bin of a row: its footprint along the arc is cut into `pieces`
// sub-intervals (its own count: PiecesPerBin) whose end nodes are stored in
// the row.
struct Bin {
  double value = 0.0;
  bool valid = true;       // false where a pixel clipped: no residual
  double from_mid = 0.0;   // φ − the window's middle, for the baseline
  double weight = 0.0;     // sec φ / footprint: the geometry over the bin mean
  double piece = 0.0;      // width of one sub-interval (rad)
  int pieces = 1;
  int first_node = 0;
  // Bins the image of a point moves by per mm of relief height at the bin
  // (AddParallaxGeometry): tan(φ − v)/R times the bins per rad of azimuth.
  double bins_per_mm = 0.0;
  double tan_view = 0.0;  // tan(φ − v) at the bin
};

// How finely the bins are integrated: two sub-intervals each (the rough
// solve and the start), kMainPieces at most (the main solve), or all of a
// bin's pieces (the polish, and every share and scale reported).
enum class Quadrature { kRough, kMain, kFull };

// The step between the nodes a quadrature takes of a bin's pieces. Odd
// counts (subintervals odd, never doubled) are always taken whole.
int StrideFor(int pieces, Quadrature quadrature) {
  if (quadrature == Quadrature::kFull || pieces % 2 != 0) return 1;
  return quadrature == Quadrature::kRough ? pieces / 2 : std::max(2, pieces / kMainPieces);
}

struct Row {
  double phase_mm = 0.0;         // start of c
  std::vector<Bin> bins;         // contiguous, in column order
  std::vector<double> node_s;    // R·(φ − φ_mid) (mm)
  std::vector<double> node_lhs;  // φ − (α + v(φ))/2 (rad)
};

// One part of a bin's mean: the share of its sub-intervals (or, after the
// extrapolation below, of a pair of them) and its gradient, placed at their
// middle: what the lens PSF needs to blur a glint from where it lies in its
// pixel (RowShape).
struct BinPart {
  double value = 0.0;
  double grad[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
  // Where the relief parallax moves it (bins), and that move's gradient by
  // m, λ and c (CombAt::parallax; 0 where it is not modelled).
  double shift = 0.0;
  double shift_grad[3] = {0.0, 0.0, 0.0};
};

// Whether BinMean extrapolates its sum from pairs of sub-intervals: at full
// resolution, over an even number of them (below).
bool ExtrapolatesPairs(int pieces, int stride) {
  const int segments = pieces / stride;
  return stride == 1 && segments % 2 == 0 && segments > 1;
}

// The number of parts BinMean gives a bin: its sub-intervals, or their pairs
// where it extrapolates.
int PartsPerBin(int pieces, int stride) {
  const int segments = pieces / stride;
  return ExtrapolatesPairs(pieces, stride) ? segments / 2 : segments;
}

// The comb's shared parameters at one evaluation, with what every bin
// needs of them.
struct CombAt {
  double m = 0.0, lambda = 0.0, delta = 0.0, sigma = 0.0;
  double k = 0.0;        // 2π/λ
  double reach = 0.0;    // arctan|m| + 8σ: no miss at a bin's ends beyond it is lit
  bool gradient = true;  // whether the derivatives are wanted
  // Where axial threads float over the circumferential thread (Hidden):
  // the weave phase of the floats' middles and their half-width (rad of
  // θ); half-width 0 where they are not modelled.
  double float_centre = 0.0, float_half = 0.0;
  // Thread relief parallax (DESIGN.md §3): 1 where the glints are seen
  // where their facets stand, z = (m/k)·sin θ off the mean cylinder, moved
  // by z·Bin::bins_per_mm; 0 where every glint is placed on the mean
  // cylinder.
  double parallax = 0.0;
};

// The share of a circumferential thread hidden at weave phase θ = k·(s + c)
// and its derivative by θ. In a plain weave each axial thread passes over
// a circumferential one at its trough, once a period (DESIGN.md §3: the
// axial threads glint where they pass over the circumferential threads),
// and there hides it: a glint of the comb that falls within such a float is
// not seen. A box of half-width `half` about `centre`, its edges smoothed
// over kFloatEdge (the floats' round edges; a hard edge would make the cost
// jump as a glint crosses it).
constexpr double kFloatEdge = 0.05 * M_PI;
double Hidden(double theta, const CombAt& at, double* by_theta) {
  const double x = std::remainder(theta - at.float_centre, 2.0 * M_PI);
  const double t = std::tanh((at.float_half - std::fabs(x)) / kFloatEdge);
  *by_theta = -0.5 * (1.0 - t * t) / kFloatEdge * (x < 0.0 ? -1.0 : 1.0);
  return 0.5 * (1.0 + t);
}

CombAt MakeCombAt(double m, double lambda, double delta, double sigma, bool gradient) {
  return {m, lambda, delta, sigma, 2.0 * M_PI / lambda, std::atan(std::fabs(m)) + 8.0 * sigma,
          gradient};
}

constexpr int kMaxNodes = kMaxPieces + 1;

// One bin's nodes (every `stride`-th): the slope h = m·cos θ and the miss
// g = lhs − δ − arctan h at each, the Gaussian's density and half-integral
// where |g| < 8σ, and the derivatives of g and h by m, λ and c where a
// sub-interval that may hold light ends.
struct BinNodes {
  int count = 0;
  double g[kMaxNodes], h[kMaxNodes], pdf[kMaxNodes], cdf[kMaxNodes];
  double dg[kMaxNodes][3], dh[kMaxNodes][3];  // by m, λ, c
  int side[kMaxNodes];                         // Beyond(g, σ)
  double theta[kMaxNodes];                     // the weave phase k·(s + c)
  double cos_t[kMaxNodes], sin_t[kMaxNodes];   // its cosine and sine
  double cos_half = 1.0, sin_half = 0.0;       // of half the step between nodes
};

// A node more than 8σ beyond the mirror: +1 past it, −1 short of it, 0 near.
int Beyond(double g, double sigma) { return g > 8.0 * sigma ? 1 : (g < -8.0 * sigma ? -1 : 0); }

// Fills `out` for one bin; false where every node lies more than 8σ beyond
// the mirror on one side (the bin is dark: most bins, the glints being far
// narrower than a pixel).
bool ReadBinNodes(const Row& row, const Bin& bin, int stride, const CombAt& at, double c,
                  BinNodes* out) {
  const int nodes = bin.pieces / stride + 1;
  out->count = nodes;
  // |arctan(m·cos θ)| ≤ arctan|m|: a bin whose mirror offset lies beyond
  // that and 8σ more at both ends (lhs is monotonic across a bin) is dark
  // before any trigonometry.
  const int last = bin.first_node + (nodes - 1) * stride;
  const double lhs_lo = std::min(row.node_lhs[bin.first_node], row.node_lhs[last]) - at.delta;
  const double lhs_hi = std::max(row.node_lhs[bin.first_node], row.node_lhs[last]) - at.delta;
  if (lhs_lo > at.reach || lhs_hi < -at.reach) return false;
  // The nodes are evenly spaced in s, so cos θ and sin θ follow by rotation
  // from the first node's.
  const double theta0 = at.k * (row.node_s[bin.first_node] + c);
  const double step =
      nodes > 1 ? at.k * (row.node_s[bin.first_node + stride] - row.node_s[bin.first_node]) : 0.0;
  const double cos_step = std::cos(step), sin_step = std::sin(step);
  if (at.parallax != 0.0) {
    out->cos_half = std::cos(0.5 * step);
    out->sin_half = std::sin(0.5 * step);
  }
  double* cos_t = out->cos_t;
  double* sin_t = out->sin_t;
  cos_t[0] = std::cos(theta0);
  sin_t[0] = std::sin(theta0);
  double h_lo = at.m * cos_t[0], h_hi = h_lo;
  for (int n = 0; n < nodes; ++n) out->theta[n] = theta0 + n * step;
  for (int n = 1; n < nodes; ++n) {
    cos_t[n] = cos_t[n - 1] * cos_step - sin_t[n - 1] * sin_step;
    sin_t[n] = sin_t[n - 1] * cos_step + cos_t[n - 1] * sin_step;
    h_lo = std::min(h_lo, at.m * cos_t[n]);
    h_hi = std::max(h_hi, at.m * cos_t[n]);
  }
  // Every node more than 8σ from the mirror on one side (the test below,
  // node by node) follows already from the range of h over the nodes and of
  // lhs across the bin, since arctan is monotonic: g > 8σ at every node
  // where even the largest h turns less than the smallest lhs − δ − 8σ, and
  // the other way round. Most bins of a lobe lie between two glints, and
  // this spares their arctangents.
  const double past = lhs_lo - 8.0 * at.sigma;   // tilts below this leave g > 8σ
  const double short_of = lhs_hi + 8.0 * at.sigma;  // tilts above this leave g < −8σ
  if (past >= 0.5 * M_PI || (past > -0.5 * M_PI && h_hi < std::tan(past))) return false;
  if (short_of <= -0.5 * M_PI || (short_of < 0.5 * M_PI && h_lo > std::tan(short_of))) {
    return false;
  }
  int* side = out->side;
  bool above = true, below = true;
  for (int n = 0; n < nodes; ++n) {
    out->h[n] = at.m * cos_t[n];
    out->g[n] = row.node_lhs[bin.first_node + n * stride] - at.delta - std::atan(out->h[n]);
    side[n] = Beyond(out->g[n], at.sigma);
    above = above && side[n] > 0;
    below = below && side[n] < 0;
  }
  if (above || below) return false;
  const double inv_sigma = 1.0 / at.sigma;
  for (int n = 0; n < nodes; ++n) {
    // Beyond 8σ the Gaussian is below 1e-14 of its peak and its integral
    // ±1/2 to 1e-15 (BinMean drops the sub-intervals between such nodes).
    if (side[n] != 0) {
      out->pdf[n] = 0.0;
      out->cdf[n] = side[n] > 0 ? 0.5 : -0.5;
      continue;
    }
    const NormalAt normal = StandardNormal(out->g[n] * inv_sigma);
    out->pdf[n] = normal.pdf * inv_sigma;
    out->cdf[n] = normal.cdf - 0.5;
  }
  if (!at.gradient) return true;
  for (int n = 0; n < nodes; ++n) {
    // A sub-interval (of one node or, extrapolating, two) adds light unless
    // both its ends lie beyond on one side: only such ends need derivatives.
    bool needed = side[n] == 0;
    for (int j = std::max(n - 2, 0); j <= std::min(n + 2, nodes - 1) && !needed; ++j) {
      needed = side[j] != side[n];
    }
    if (!needed) continue;
    const double arc = row.node_s[bin.first_node + n * stride] + c;
    const double inv = 1.0 / (1.0 + out->h[n] * out->h[n]);
    const double dtheta_dlambda = -arc * at.k / at.lambda;
    // dg/dm = −cos θ/(1+h²), dg/dθ = m·sin θ/(1+h²); dh/dm = cos θ, dh/dθ = −m·sin θ.
    out->dg[n][0] = -cos_t[n] * inv;
    out->dg[n][1] = at.m * sin_t[n] * inv * dtheta_dlambda;
    out->dg[n][2] = at.m * sin_t[n] * inv * at.k;
    out->dh[n][0] = cos_t[n];
    out->dh[n][1] = -at.m * sin_t[n] * dtheta_dlambda;
    out->dh[n][2] = -at.m * sin_t[n] * at.k;
  }
  return true;
}

// One sub-interval of a bin from node a to node b, `span` wide: the
// Gaussian over the miss taken as linear between the two nodes, times sec β
// at its middle, into *total and (with at.gradient) its gradient by m, λ,
// ln σ, c and δ into g5, and into `part` when non-null.
void AddSegment(const BinNodes& nd, const CombAt& at, int a, int b, double span, double* total,
                double g5[5], BinPart* part) {
  const double sigma = at.sigma;
  if (nd.side[a] != 0 && nd.side[a] == nd.side[b]) return;
  const double h_mid = 0.5 * (nd.h[a] + nd.h[b]);
  const double sec = std::sqrt(1.0 + h_mid * h_mid);
  const double delta = nd.g[b] - nd.g[a];
  double piece, d_ga, d_gb, d_log_sigma;
  if (std::fabs(delta) > 1e-2 * sigma) {
    const double diff = nd.cdf[b] - nd.cdf[a];
    piece = diff * span / delta;
    d_gb = span * (nd.pdf[b] / delta - diff / (delta * delta));
    d_ga = span * (-nd.pdf[a] / delta + diff / (delta * delta));
    d_log_sigma = span * (-nd.pdf[b] * nd.g[b] + nd.pdf[a] * nd.g[a]) / delta;
  } else {
    const double z = 0.5 * (nd.g[a] + nd.g[b]) / sigma;
    const double norm = 1.0 / (sigma * std::sqrt(2.0 * M_PI));
    const double f = norm * std::exp(-0.5 * z * z);
    piece = f * span;
    d_ga = d_gb = -0.5 * f * z / sigma * span;
    d_log_sigma = f * (z * z - 1.0) * span;
  }
  // The share of the thread seen there (1 where no floats are modelled).
  double seen = 1.0, seen_by_theta = 0.0;
  const double theta_mid = 0.5 * (nd.theta[a] + nd.theta[b]);
  if (at.float_half > 0.0) {
    seen = 1.0 - Hidden(theta_mid, at, &seen_by_theta);
    seen_by_theta = -seen_by_theta;
  }
  *total += seen * sec * piece;
  if (part != nullptr) part->value += seen * sec * piece;
  if (!at.gradient) return;
  const double dsec = h_mid / sec;
  double d5[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
  for (int p = 0; p < 3; ++p) {
    const double d_hmid = 0.5 * (nd.dh[a][p] + nd.dh[b][p]);
    d5[p == 2 ? 3 : p] = sec * (d_ga * nd.dg[a][p] + d_gb * nd.dg[b][p]) + piece * dsec * d_hmid;
  }
  d5[2] = sec * d_log_sigma;
  d5[4] = -sec * (d_ga + d_gb);  // dg/dδ = −1 at every node
  if (at.float_half > 0.0) {
    for (int p = 0; p < 5; ++p) d5[p] *= seen;
    // dθ/dλ = −θ/λ, dθ/dc = k.
    d5[1] += sec * piece * seen_by_theta * (-theta_mid / at.lambda);
    d5[3] += sec * piece * seen_by_theta * at.k;
  }
  for (int p = 0; p < 5; ++p) g5[p] += d5[p];
  if (part != nullptr) {
    for (int p = 0; p < 5; ++p) part->grad[p] += d5[p];
  }
}

// The share of the thread seen at weave phase θ where the relief folds
// over itself: measured in phase, the surface at θ is seen at θ + e·sin θ,
// e = m·tan(φ − v), which turns back where e > 1 (|e| > 1 on the other
// side of the line of sight). There the nearer crest hides what it turns
// back over: on the far side of the line of sight, every point short of the
// last turning point θ' (cos θ' = −1/e, the latest at or before θ) that is
// seen short of it; on the near side the same with the next one. A hard
// edge would make the cost jump as a glint crosses it: the edge is smoothed
// over kFloatEdge, as the floats' (Hidden).
double Unhidden(double theta, double e) {
  if (std::fabs(e) <= 1.0) return 1.0;
  const double turn = std::acos(-1.0 / e);
  const double cycles = (theta - turn) / (2.0 * M_PI);
  const double at = turn + 2.0 * M_PI * (e > 0.0 ? std::floor(cycles) : std::ceil(cycles));
  const double ahead = (theta + e * std::sin(theta)) - (at + e * std::sin(at));
  return 0.5 * (1.0 + std::tanh((e > 0.0 ? ahead : -ahead) / kFloatEdge));
}

// The relief parallax's move of a part of `bin` centred at weave phase θ
// (`theta`, with its cosine and sine; CombAt::parallax): its facets stand
// z = (m/k)·sin θ off the mean cylinder (h = m·cos θ is dz/ds), and are
// seen z·Bin::bins_per_mm away; where the relief folds, the part keeps the
// share of it seen (Unhidden).
void SetPartShift(const Bin& bin, const CombAt& at, double theta, double cos_t, double sin_t,
                  BinPart* part) {
  if (at.parallax == 0.0) return;
  // A part the relief hides keeps its share only; the share's own
  // derivatives are left out (its edge is narrow, and rarely on a glint).
  const double seen = Unhidden(theta, at.m * bin.tan_view);
  if (seen < 1.0) {
    part->value *= seen;
    for (double& g : part->grad) g *= seen;
  }
  const double per_mm = at.parallax * bin.bins_per_mm;
  const double z = at.m / at.k * sin_t;
  part->shift = per_mm * z;
  part->shift_grad[0] = per_mm * sin_t / at.k;  // by m
  // By λ: z ∝ λ at a fixed θ, and dθ/dλ = −θ/λ.
  part->shift_grad[1] = per_mm * (z - at.m / at.k * cos_t * theta) / at.lambda;
  part->shift_grad[2] = per_mm * at.m * cos_t;  // by c
}

// Mean over one bin's footprint of sec β · G(miss; σ), G the unit-area
// Gaussian, miss g = lhs − δ − arctan(m·cos(k(s + c))), and (with
// at.gradient) its gradient by m, λ, ln σ, c and δ. Along each sub-interval
// the miss is taken as linear, so the Gaussian integrates to a difference of
// error functions. A dark bin (ReadBinNodes) adds nothing. Every
// `stride`-th node only (stride divides the bin's pieces) gives a coarser,
// cheaper sum. With `parts` non-null (PartsPerBin of them, zeroed), also
// the mean in parts, in column order.
double BinMean(const Row& row, const Bin& bin, int stride, const CombAt& at, double c,
               double grad[5], BinPart* parts = nullptr) {
  grad[0] = grad[1] = grad[2] = grad[3] = grad[4] = 0.0;
  BinNodes nd;
  if (!ReadBinNodes(row, bin, stride, at, c, &nd)) return 0.0;
  const int nodes = nd.count;
  const double width = bin.piece * stride;
  // Each sub-interval's share, for the parts (the pairs' shares combined
  // below when the sum is extrapolated).
  BinPart fine[kMaxPieces];
  double sum = 0.0;
  for (int n = 1; n < nodes; ++n) {
    AddSegment(nd, at, n - 1, n, width, &sum, grad, parts != nullptr ? &fine[n - 1] : nullptr);
  }
  // The linear miss falls short where it bends most, at the caustics (the
  // glints' turning points, which set m): the sum's error goes as the
  // square of the sub-interval, so the sum over pairs of sub-intervals,
  // from the same nodes, extrapolates it away (Richardson): on noise-free
  // renders of m = 0.3 at α = −60° (11 px per period) the max slope came out
  // 0.079 % long with 8 sub-intervals, 0.011 % with 64. Only at full
  // resolution (the polish): the main solve on every other node stays as
  // it was, so that a polish that slides off it still shows (FitGlintComb).
  if (ExtrapolatesPairs(bin.pieces, stride)) {
    double coarse = 0.0;
    double coarse_grad[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
    for (int n = 2; n < nodes; n += 2) {
      BinPart pair;
      AddSegment(nd, at, n - 2, n, 2.0 * width, &coarse, coarse_grad,
                 parts != nullptr ? &pair : nullptr);
      if (parts == nullptr) continue;
      BinPart& out = parts[n / 2 - 1];
      out.value = bin.weight * (4.0 * (fine[n - 2].value + fine[n - 1].value) - pair.value) / 3.0;
      for (int p = 0; p < 5; ++p) {
        out.grad[p] =
            bin.weight * (4.0 * (fine[n - 2].grad[p] + fine[n - 1].grad[p]) - pair.grad[p]) / 3.0;
      }
      SetPartShift(bin, at, nd.theta[n - 1], nd.cos_t[n - 1], nd.sin_t[n - 1], &out);
    }
    sum = (4.0 * sum - coarse) / 3.0;
    for (int p = 0; p < 5; ++p) grad[p] = (4.0 * grad[p] - coarse_grad[p]) / 3.0;
  } else if (parts != nullptr) {
    for (int n = 0; n + 1 < nodes; ++n) {
      parts[n].value = bin.weight * fine[n].value;
      for (int p = 0; p < 5; ++p) parts[n].grad[p] = bin.weight * fine[n].grad[p];
      // The middle of nodes n and n + 1: node n's turned by half the step.
      SetPartShift(bin, at, 0.5 * (nd.theta[n] + nd.theta[n + 1]),
                   nd.cos_t[n] * nd.cos_half - nd.sin_t[n] * nd.sin_half,
                   nd.sin_t[n] * nd.cos_half + nd.cos_t[n] * nd.sin_half, &parts[n]);
    }
  }
  for (int p = 0; p < 5; ++p) grad[p] *= bin.weight;
  return sum * bin.weight;
}

// The lens PSF over a row's bins, two ways. Sampled: a Gaussian of σ_bins
// at whole bins, normalised, each bin's light taken from its middle. In
// pixel: a bin's value is its footprint's mean of the image blurred by a
// Gaussian of σ_bins, so light at u bins from the middle of a bin gives it
// K(u) = Φ((½ − u)/σ) − Φ((−½ − u)/σ), tabulated for the parts of a bin t
// bins away (t + the part's middle: index (t + reach)·parts + part). Both
// with the derivative by ln σ_bins.
//
// Sampled, a blur of a bin or more placed every glint at its pixel's middle:
// through a 1-2 px lens blur the spacing read 0.2-0.65° short at 4-10
// stated errors (640×480, m = 0.31). In pixel, the sub-pixel PSF
// trades with the source blur: where the limbs see 0.8 px (the cylinder-ends
// fixture, 320×240) 4 of 12 noise draws slid to no source blur and fell back
// to peak picking, one read 7 errors short, where sampled all 12 were
// right; from a 1 px blur both kernels mostly leave that scene's comb
// unfitted (peak picking answers, within its errors). So the glints are
// placed in their pixels only where the limbs show a blur of a pixel or
// more (FitGlintComb): between 0.8 and 1 px the sampled kernel still reads
// the default scene's spacing 2.6-5 errors short.
struct Kernel {
  int reach = 0;
  int parts = 1;
  std::vector<double> w, dw;
};

Kernel SampledPsfKernel(double sigma_bins) {
  Kernel k;
  k.reach = std::clamp(static_cast<int>(std::ceil(4.0 * sigma_bins)), 1, 24);
  const int n = 2 * k.reach + 1;
  k.w.resize(n);
  k.dw.resize(n);
  double z = 0.0, second = 0.0;
  for (int t = -k.reach; t <= k.reach; ++t) {
    const double u = t / sigma_bins;
    k.w[t + k.reach] = std::exp(-0.5 * u * u);
    z += k.w[t + k.reach];
  }
  for (int t = -k.reach; t <= k.reach; ++t) {
    k.w[t + k.reach] /= z;
    second += k.w[t + k.reach] * t * t;
  }
  const double inv2 = 1.0 / (sigma_bins * sigma_bins);
  for (int t = -k.reach; t <= k.reach; ++t) {
    k.dw[t + k.reach] = k.w[t + k.reach] * (t * t - second) * inv2;
  }
  return k;
}

Kernel InPixelPsfKernel(double sigma_bins, int parts) {
  Kernel k;
  k.reach = std::clamp(static_cast<int>(std::ceil(4.0 * sigma_bins + 0.5)), 1, 25);
  k.parts = parts;
  const int n = (2 * k.reach + 1) * parts;
  k.w.resize(n);
  k.dw.resize(n);
  const double s = sigma_bins;
  auto pdf = [](double z) { return 0.3989422804014327 * std::exp(-0.5 * z * z); };
  auto cdf = [](double z) { return 0.5 * std::erfc(-z * M_SQRT1_2); };
  for (int t = -k.reach; t <= k.reach; ++t) {
    for (int q = 0; q < parts; ++q) {
      const double u = t + (q + 0.5) / parts - 0.5;
      const double a = (0.5 - u) / s;
      const double b = (-0.5 - u) / s;
      const int i = (t + k.reach) * parts + q;
      k.w[i] = cdf(a) - cdf(b);
      k.dw[i] = -a * pdf(a) + b * pdf(b);
    }
  }
  return k;
}

// The kernel for one PSF width and parts count, kept per thread: every row
// of one evaluation, and of the polish's tail, blurs by the same PSF, with
// one kernel per parts count its bins use (at most four: PiecesPerBin
// doubles up to kMaxPieces). A reference stays valid until
// kKeptKernels further kernels have been made. The kernels live on the
// heap: a thread's static TLS comes out of its stack, and the daemon's
// metrics threads (civetweb's) have little to spare.
constexpr int kKeptKernels = 8;
const Kernel& PsfKernel(bool in_pixel, double sigma_bins, int parts) {
  struct Kept {
    Kernel kernel;
    bool in_pixel = false;
    double sigma = std::numeric_limits<double>::quiet_NaN();
    int parts = 0;
  };
  thread_local std::unique_ptr<std::array<Kept, kKeptKernels>> kept_slots;
  thread_local int next = 0;
  if (kept_slots == nullptr) kept_slots = std::make_unique<std::array<Kept, kKeptKernels>>();
  std::array<Kept, kKeptKernels>& kept = *kept_slots;
  for (const Kept& k : kept) {
    if (k.sigma == sigma_bins && k.in_pixel == in_pixel && k.parts == parts) return k.kernel;
  }
  Kept& slot = kept[next];
  next = (next + 1) % kKeptKernels;
  slot.kernel = in_pixel ? InPixelPsfKernel(sigma_bins, parts) : SampledPsfKernel(sigma_bins);
  slot.sigma = sigma_bins;
  slot.in_pixel = in_pixel;
  slot.parts = parts;
  return slot.kernel;
}

// Calls f(i) for every row i < n, rows in parallel (OpenCV's pool). Each
// row's model is its own (its bins, its phase): a caller that writes row
// i's result to slot i and sums the slots in order afterwards gets the same
// answer, to the bit, on any number of threads.
template <class F>
void ForEachRow(std::size_t n, const F& f) {
  cv::parallel_for_(cv::Range(0, static_cast<int>(n)), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) f(static_cast<std::size_t>(i));
  });
}

// The sum over rows i < n of f(i), computed in parallel and added in row
// order (ForEachRow).
template <class F>
double SumOverRows(std::size_t n, const F& f) {
  std::vector<double> each(n, 0.0);
  ForEachRow(n, [&](std::size_t i) { each[i] = f(i); });
  double sum = 0.0;
  for (double v : each) sum += v;
  return sum;
}

// Everything the model needs but the row's level and baseline.
struct Shared {
  double m = 0.0, lambda = 0.0, delta = 0.0, log_sigma = 0.0, psf_l = 0.0;
  // The axial threads' floats that hide the comb (CombAt, Hidden): held
  // through a fit at the start's choice.
  double float_centre = 0.0, float_half = 0.0;
  double parallax = 0.0;  // CombAt::parallax, held
  // The softplus: σ grows as ℓ for large ℓ and nears the floor as e^ℓ. A
  // comb sharper than a pixel has its optimum at the floor. A form with no
  // slope there (σ = hypot(q, 0.1)) makes the Gauss-Newton step in q grow
  // as 1/q near it: the solvers spent 5-20 iterations on rejected steps
  // that flung the PSF out to many pixels, and stopped at their caps
  // wherever that left them (CombFitTest.ASharpCombIsPolishedToConvergence).
  // Here a step toward the floor cannot overshoot it.
  double PsfPx() const { return kPsfFloorPx + SoftPlus(psf_l); }
  static double SoftPlus(double x) {
    return x > 0.0 ? x + std::log1p(std::exp(-x)) : std::log1p(std::exp(x));
  }
};

// One part of a bin, `from` bins from the first bin's middle before the
// relief parallax moves it by part.shift, spread over the bins by the PSF
// in pixel (InPixelPsfKernel's K, here at any offset), into `out` and, with
// `grad`, its gradient: the PSF's width by ln σ_bins (times dlog_dl, the
// width's derivative by ℓ) and the move's by m, λ and c.
void SpreadMovedPart(const BinPart& part, double from, double sigma_bins, double dlog_dl,
                     std::vector<double>* out, std::vector<std::array<double, 6>>* grad) {
  const int n = static_cast<int>(out->size());
  const double at = from + part.shift;
  const double reach = 4.0 * sigma_bins + 0.5;
  const int lo = std::max(0, static_cast<int>(std::floor(at - reach)));
  const int hi = std::min(n - 1, static_cast<int>(std::ceil(at + reach)));
  const double inv = 1.0 / sigma_bins;
  // Bin j spans the edges j ∓ ½, in σ from the part: (j ∓ ½ − at)/σ. Each
  // edge is shared by two bins, and its Φ and φ are taken once.
  double b = (lo - 0.5 - at) * inv;
  const NormalAt at_b = StandardNormal(b);
  double cdf_b = at_b.cdf, pdf_b = at_b.pdf;
  for (int j = lo; j <= hi; ++j) {
    const double a = (j + 0.5 - at) * inv;
    const NormalAt at_a = StandardNormal(a);
    const double cdf_a = at_a.cdf;
    const double w = cdf_a - cdf_b;
    (*out)[j] += w * part.value;
    if (grad != nullptr) {
      const double pdf_a = at_a.pdf;
      const double by_u = (pdf_b - pdf_a) * inv;  // dK/du, u = at − j
      std::array<double, 6>& g = (*grad)[j];
      for (int k = 0; k < 5; ++k) g[k] += w * part.grad[k];
      g[0] += part.value * by_u * part.shift_grad[0];
      g[1] += part.value * by_u * part.shift_grad[1];
      g[3] += part.value * by_u * part.shift_grad[2];
      g[5] += (-a * pdf_a + b * pdf_b) * dlog_dl * part.value;
      pdf_b = pdf_a;
    }
    b = a;
    cdf_b = cdf_a;
  }
}

// The row's modelled glint shape per bin (before level and baseline): bin
// means blurred by the PSF (in pixel wherever the relief parallax moves the
// glints off their bins); with `grad` non-null, also the derivatives by
// m, λ, ln σ, c, δ and ℓ (six per bin).
std::vector<double> RowShape(const Row& row, Quadrature quadrature, int bin_px, bool in_pixel,
                             const Shared& p, double c,
                             std::vector<std::array<double, 6>>* grad) {
  const int n = static_cast<int>(row.bins.size());
  const double sigma = std::exp(p.log_sigma);
  const double psf_px = p.PsfPx();
  const double dlog_dl =  // ∂ ln σ / ∂ℓ: the logistic of ℓ over σ
      1.0 / ((1.0 + std::exp(-p.psf_l)) * psf_px);
  CombAt comb = MakeCombAt(p.m, p.lambda, p.delta, sigma, grad != nullptr);
  comb.float_centre = p.float_centre;
  comb.float_half = p.float_half;
  comb.parallax = p.parallax;
  std::vector<double> out(n, 0.0);
  if (grad != nullptr) grad->assign(n, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0});
  if (!in_pixel && p.parallax == 0.0) {
    std::vector<double> raw(n);
    std::vector<std::array<double, 5>> raw_grad(n);
    for (int j = 0; j < n; ++j) {
      raw[j] = BinMean(row, row.bins[j], StrideFor(row.bins[j].pieces, quadrature), comb, c,
                       raw_grad[j].data());
    }
    const Kernel& kernel = PsfKernel(false, psf_px / bin_px, 1);
    for (int j = 0; j < n; ++j) {
      for (int t = -kernel.reach; t <= kernel.reach; ++t) {
        const int at = std::clamp(j + t, 0, n - 1);
        const double w = kernel.w[t + kernel.reach];
        out[j] += w * raw[at];
        if (grad != nullptr) {
          for (int q = 0; q < 5; ++q) (*grad)[j][q] += w * raw_grad[at][q];
          (*grad)[j][5] += kernel.dw[t + kernel.reach] * dlog_dl * raw[at];
        }
      }
    }
    return out;
  }
  // Each bin's parts from first_part[j] on (their count is the bin's own).
  std::vector<int> first_part(n + 1, 0);
  for (int j = 0; j < n; ++j) {
    const Bin& b = row.bins[j];
    first_part[j + 1] = first_part[j] + PartsPerBin(b.pieces, StrideFor(b.pieces, quadrature));
  }
  std::vector<BinPart> parts(first_part[n]);
  std::vector<char> lit(n, 0);
  double unused[5];
  for (int j = 0; j < n; ++j) {
    const Bin& b = row.bins[j];
    lit[j] = BinMean(row, b, StrideFor(b.pieces, quadrature), comb, c, unused,
                     &parts[first_part[j]]) != 0.0;
  }
  // Each lit bin's parts spread to the bins around it (light beyond the
  // row's ends is lost: the rows reach well past the lobe).
  for (int i = 0; i < n; ++i) {
    if (!lit[i]) continue;
    const int per_bin = first_part[i + 1] - first_part[i];
    if (p.parallax != 0.0) {
      for (int q = 0; q < per_bin; ++q) {
        const BinPart& part = parts[first_part[i] + q];
        if (part.value == 0.0) continue;
        SpreadMovedPart(part, i + (q + 0.5) / per_bin - 0.5, psf_px / bin_px, dlog_dl, &out, grad);
      }
      continue;
    }
    const Kernel& kernel = PsfKernel(true, psf_px / bin_px, per_bin);
    for (int q = 0; q < per_bin; ++q) {
      const BinPart& part = parts[first_part[i] + q];
      for (int t = -kernel.reach; t <= kernel.reach; ++t) {
        const int j = i - t;
        if (j < 0 || j >= n) continue;
        const int at = (t + kernel.reach) * per_bin + q;
        const double w = kernel.w[at];
        out[j] += w * part.value;
        if (grad != nullptr) {
          for (int k = 0; k < 5; ++k) (*grad)[j][k] += w * part.grad[k];
          (*grad)[j][5] += kernel.dw[at] * dlog_dl * part.value;
        }
      }
    }
  }
  return out;
}

// Level and baseline of a row for a given shape, by linear least squares
// over its valid bins (level held at zero when it comes out negative).
// Returns the residual sum of squares.
double SolveLinear(const Row& row, const std::vector<double>& shape, double own[kOwn]) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d y = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < row.bins.size(); ++j) {
    if (!row.bins[j].valid) continue;
    const Eigen::Vector3d x(shape[j], 1.0, row.bins[j].from_mid);
    a += x * x.transpose();
    y += x * row.bins[j].value;
  }
  Eigen::Vector3d sol = a.ldlt().solve(y);
  if (!(sol[0] >= 0.0) || !sol.allFinite()) {
    const Eigen::Vector2d two = a.bottomRightCorner<2, 2>().ldlt().solve(y.tail<2>());
    sol = Eigen::Vector3d(0.0, two[0], two[1]);
    if (!sol.allFinite()) sol.setZero();
  }
  own[1] = sol[0];
  own[2] = sol[1];
  own[3] = sol[2];
  double rss = 0.0;
  for (std::size_t j = 0; j < row.bins.size(); ++j) {
    if (!row.bins[j].valid) continue;
    const double r = sol[0] * shape[j] + sol[1] + sol[2] * row.bins[j].from_mid - row.bins[j].value;
    rss += r * r;
  }
  return rss;
}

}  // namespace

absl::Status CombFitOptions::Validate() const {
  if (max_rows < 4) return absl::InvalidArgumentError("max_rows must be >= 4");
  if (max_samples_per_row < 16) return absl::InvalidArgumentError("max_samples_per_row must be >= 16");
  if (subintervals < 1 || subintervals > 16) {
    return absl::InvalidArgumentError("subintervals must be in [1, 16]");
  }
  if (max_iterations < 1 || polish_iterations < 1) {
    return absl::InvalidArgumentError("max_iterations and polish_iterations must be >= 1");
  }
  if (!(polish_settled_share >= 0.0)) {
    return absl::InvalidArgumentError("polish_settled_share must be >= 0");
  }
  if (!(min_explained > 0.0 && min_explained <= min_explained_alone && min_explained_alone < 1.0)) {
    return absl::InvalidArgumentError(
        "need 0 < min_explained <= min_explained_alone < 1");
  }
  if (!(min_explained_to_polish >= 0.0 && min_explained_to_polish < min_explained)) {
    return absl::InvalidArgumentError("need 0 <= min_explained_to_polish < min_explained");
  }
  if (!(slope_floor >= 0.0) || !(wavelength_floor >= 0.0) || !(mirror_floor_rad >= 0.0) ||
      !(slope_mismatch >= 0.0) || !(wavelength_mismatch >= 0.0) ||
      !(mirror_tolerance_rad >= 0.0)) {
    return absl::InvalidArgumentError(
        "slope_floor, wavelength_floor, slope_mismatch, wavelength_mismatch, mirror_floor_rad "
        "and mirror_tolerance_rad must be >= 0");
  }
  return absl::OkStatus();
}

absl::StatusOr<CombRows> ChooseCombRows(const ArcSignals& signals, const GlintModel& model,
                                        double wavelength_mm, int max_rows) {
  if (!(wavelength_mm > 0.0) || !(model.max_slope > 0.0) || !(model.mm_per_px > 0.0)) {
    return absl::InvalidArgumentError("comb rows need a wavelength, a max slope and mm_per_px > 0");
  }
  if (max_rows < 4) return absl::InvalidArgumentError("max_rows must be >= 4");
  // Rows with a weave phase, in image order, grouped into threads: a run of
  // neighbouring rows (at most two apart) whose phases agree within a tenth
  // of a period. One row per thread first (the middle one), then more.
  const std::vector<double> phases = RowPhasesMm(signals, model, wavelength_mm, GlintPeriodOptions());
  std::vector<int> order;
  for (std::size_t r = 0; r < phases.size(); ++r) {
    if (std::isfinite(phases[r])) order.push_back(static_cast<int>(r));
  }
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return signals.rows[a] < signals.rows[b]; });
  if (order.size() < 4) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "only %zu rows hold enough glints for the comb fit", order.size()));
  }
  auto phase_gap = [&](int a, int b) {
    return std::fabs(std::remainder(phases[a] - phases[b], wavelength_mm)) / wavelength_mm;
  };
  std::vector<std::vector<int>> threads;
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || signals.rows[order[i]] - signals.rows[order[i - 1]] > 2 ||
        phase_gap(order[i], order[i - 1]) > 0.1) {
      threads.emplace_back();
    }
    threads.back().push_back(order[i]);
  }
  CombRows out;
  const std::size_t count = threads.size();
  for (std::size_t round = 0; out.rows.size() < static_cast<std::size_t>(max_rows); ++round) {
    bool any = false;
    // Threads evenly spread when there are more than rows to fill.
    const std::size_t want = std::min<std::size_t>(count, max_rows - out.rows.size());
    for (std::size_t t = 0; t < want; ++t) {
      const std::size_t thread = t * count / want;
      const std::vector<int>& members = threads[thread];
      // Middle outward: round 0 the middle row, then its neighbours.
      const std::ptrdiff_t mid = static_cast<std::ptrdiff_t>(members.size() / 2);
      const std::ptrdiff_t step = static_cast<std::ptrdiff_t>((round + 1) / 2);
      const std::ptrdiff_t at = round % 2 == 1 ? mid + step : mid - step;
      if (at < 0 || at >= static_cast<std::ptrdiff_t>(members.size())) continue;
      out.rows.push_back(signals.rows[members[at]]);
      out.phase_mm.push_back(phases[members[at]]);
      out.thread.push_back(static_cast<int>(thread));
      any = true;
    }
    if (!any) break;
  }
  return out;
}

absl::StatusOr<CombRows> RephaseCombRows(const ArcSignals& signals, const GlintModel& model,
                                         double wavelength_mm, const CombRows& rows) {
  if (!(wavelength_mm > 0.0) || !(model.max_slope > 0.0) || !(model.mm_per_px > 0.0)) {
    return absl::InvalidArgumentError("comb rows need a wavelength, a max slope and mm_per_px > 0");
  }
  const std::vector<double> phases =
      RowPhasesMm(signals, model, wavelength_mm, GlintPeriodOptions());
  CombRows out = rows;
  for (std::size_t i = 0; i < out.rows.size(); ++i) {
    const auto at = std::find(signals.rows.begin(), signals.rows.end(), out.rows[i]);
    if (at == signals.rows.end()) continue;
    const double phase = phases[at - signals.rows.begin()];
    if (std::isfinite(phase)) out.phase_mm[i] = phase;
  }
  return out;
}

namespace {

// The comb's rows in the fit's terms: every bin's footprint cut into its
// own number of sub-intervals, arc lengths counted from the window's middle.
struct CombProblemData {
  std::vector<Row> rows;
  std::vector<int> thread_of_row;
  std::vector<int> distinct;  // the threads, sorted
  int pieces = 1;             // the most any bin has
  int bin_px = 1;
  bool in_pixel = false;
  int num_residuals = 0;  // valid bins
  double phi_mid = 0.0;   // the window's middle (rad), which arc lengths count from
  double px_per_bin = 1.0;  // perpendicular to the axis, as the offsets
  double radius_px = 0.0;   // the limbs' half-width, perpendicular to the axis
};

// Sub-intervals of one bin spanning `width_rad` in azimuth:
// options.subintervals, doubled (up to kMaxPieces) until the tilt's turn
// across one is within kMaxTiltTurnPerPiece. Each bin has its own: a bin
// spans 1/cos φ in azimuth, so toward the limb a bin needs up to four times
// the pieces of one near the mirror; giving every bin the widest one's
// count cost the independently rendered photographs' glint stage a tenth
// of its time in all (bench ../shared/photographs). The main solve
// keeps kMainPieces per bin: on 12 the steep weave above slid to m = 0.84
// for 0.60.
int PiecesPerBin(double width_rad, const GlintModel& model, double wavelength_mm,
                 int subintervals) {
  const double turn =
      model.max_slope * 2.0 * M_PI * model.projection.radius_mm * width_rad / wavelength_mm;
  const int needed = static_cast<int>(std::ceil(turn / kMaxTiltTurnPerPiece));
  int pieces = subintervals;
  while (pieces < needed && 2 * pieces <= kMaxPieces) pieces *= 2;
  return pieces;
}

absl::StatusOr<CombProblemData> BuildCombProblem(const ArcPixels& pixels, const CombRows& chosen,
                                                 const GlintModel& model, double wavelength_mm,
                                                 const CombFitOptions& options) {
  CombProblemData data;
  data.bin_px = pixels.bin_px;
  // Glints placed within their pixels only where the limbs show a lens blur
  // of a pixel or more (the kernels, above).
  data.in_pixel = model.lens_blur_px >= kInPixelFromBlurPx;
  const double radius_mm = model.projection.radius_mm;
  const double radius_px = pixels.radius_px;
  auto azimuth = [&](double offset_px) {
    return AzimuthFromOffset(std::clamp(offset_px / radius_px, -0.999999, 0.999999),
                             model.projection);
  };
  // The middle of the window, which arc lengths are counted from (so that
  // the period and the phases are not correlated through a large offset:
  // the phase becomes c + R·φ_mid).
  double phi_mid = 0.0;
  {
    double lo = 1e9, hi = -1e9;
    for (const std::vector<double>& o : pixels.offset_px) {
      if (o.empty()) continue;
      lo = std::min(lo, o.front());
      hi = std::max(hi, o.back());
    }
    if (!(hi > lo)) return absl::InvalidArgumentError("comb fit: the rows hold no pixels");
    phi_mid = 0.5 * (azimuth(lo) + azimuth(hi));
  }
  data.phi_mid = phi_mid;
  data.px_per_bin = pixels.bin_width_px;
  data.radius_px = radius_px;
  for (std::size_t r = 0; r < pixels.rows.size(); ++r) {
    Row row;
    row.phase_mm = chosen.phase_mm[r] + radius_mm * phi_mid;
    int valid = 0;
    for (std::size_t j = 0; j < pixels.values[r].size(); ++j) {
      const double p = pixels.offset_px[r][j];
      const double lo = azimuth(p - 0.5 * pixels.bin_width_px);
      const double hi = azimuth(p + 0.5 * pixels.bin_width_px);
      const double phi = azimuth(p);
      Bin b;
      b.value = pixels.values[r][j];
      b.valid = pixels.valid[r][j] != 0 && std::isfinite(b.value);
      if (!b.valid) b.value = 0.0;
      valid += b.valid;
      b.from_mid = phi - phi_mid;
      b.weight = 1.0 / (std::max(std::cos(phi), 0.05) * (hi - lo));
      b.pieces = PiecesPerBin(hi - lo, model, wavelength_mm, options.subintervals);
      data.pieces = std::max(data.pieces, b.pieces);
      b.piece = (hi - lo) / b.pieces;
      b.first_node = static_cast<int>(row.node_s.size());
      for (int q = 0; q <= b.pieces; ++q) {
        const double at = lo + q * b.piece;
        row.node_s.push_back(radius_mm * (at - phi_mid));
        row.node_lhs.push_back(
            at - 0.5 * (model.phase_angle_rad + ViewAngleRad(at, model.projection)));
      }
      row.bins.push_back(b);
    }
    if (valid >= 16) {
      data.num_residuals += valid;
      data.rows.push_back(std::move(row));
      data.thread_of_row.push_back(chosen.thread[r]);
    }
  }
  if (data.rows.size() < 4) return absl::InvalidArgumentError("too few rows left for the comb fit");
  data.distinct = data.thread_of_row;
  std::sort(data.distinct.begin(), data.distinct.end());
  data.distinct.erase(std::unique(data.distinct.begin(), data.distinct.end()),
                      data.distinct.end());
  return data;
}

// Each bin's Bin::bins_per_mm (the relief parallax, CombAt::parallax): a
// point z mm off the mean cylinder at azimuth φ is seen where the mean
// cylinder's φ + z·tan(φ − v)/R is, and the offset moves OffsetPerRadian
// half-widths per radian there. Returns the most a glint of relief h0_mm
// then moves, in pixels.
double AddParallaxGeometry(const GlintModel& model, double h0_mm, CombProblemData* data) {
  double most = 0.0;
  for (Row& row : data->rows) {
    for (Bin& b : row.bins) {
      const double phi = data->phi_mid + b.from_mid;
      b.tan_view = std::tan(phi - ViewAngleRad(phi, model.projection));
      const double rad_per_mm = b.tan_view / model.projection.radius_mm;
      const double px_per_rad = data->radius_px * OffsetPerRadian(phi, model.projection);
      b.bins_per_mm = rad_per_mm * px_per_rad / data->px_per_bin;
      most = std::max(most, std::fabs(h0_mm * rad_per_mm * px_per_rad));
    }
  }
  return most;
}

using OwnParams = std::vector<std::array<double, kOwn>>;

// The start, in plain arithmetic with each row's level and baseline solved
// linearly and two pieces per bin: the source blur and the lens PSF from a
// few trial widths, each row's phase refined on a grid of ±4 half-steps of
// the phase search, the max slope scanned (a comb pulls the profile's
// peaks inward, so the start may be off by several per cent), and the
// phases once more. The solver then starts close.
Shared StartComb(const CombProblemData& data, const GlintModel& model, double wavelength_mm,
                 double parallax, OwnParams* own_out) {
  const std::vector<Row>& rows = data.rows;
  const int bin_px = data.bin_px;
  const bool in_pixel = data.in_pixel;
  const Quadrature coarse = Quadrature::kRough;
  Shared p;
  p.m = model.max_slope;
  p.lambda = wavelength_mm;
  p.parallax = parallax;
  OwnParams& own = *own_out;
  own.assign(rows.size(), {0.0, 0.0, 0.0, 0.0});
  for (std::size_t i = 0; i < rows.size(); ++i) own[i][0] = rows[i].phase_mm;
  auto total_rss = [&](const Shared& trial, OwnParams* out) {
    return SumOverRows(rows.size(), [&](std::size_t i) {
      return SolveLinear(rows[i],
                         RowShape(rows[i], coarse, bin_px, in_pixel, trial, (*out)[i][0], nullptr),
                         (*out)[i].data());
    });
  };
  auto refine_phases = [&]() {
    const double step = wavelength_mm / 192.0;
    ForEachRow(rows.size(), [&](std::size_t i) {
      double best = -1.0;
      std::array<double, kOwn> keep = own[i];
      for (int d = -4; d <= 4; ++d) {
        std::array<double, kOwn> trial = own[i];
        trial[0] = own[i][0] + d * step;
        const double rss = SolveLinear(
            rows[i], RowShape(rows[i], coarse, bin_px, in_pixel, p, trial[0], nullptr), trial.data());
        if (best < 0.0 || rss < best) {
          best = rss;
          keep = trial;
        }
      }
      own[i] = keep;
    });
  };
  double best = -1.0;
  Shared start = p;
  for (double sigma_deg : {0.15, 0.4, 1.0}) {
    for (double psf_px : {0.3, 1.0}) {
      Shared trial = p;
      trial.log_sigma = std::log(sigma_deg * M_PI / 180.0);
      trial.psf_l = std::log(std::expm1(psf_px - kPsfFloorPx));
      OwnParams scratch = own;
      const double rss = total_rss(trial, &scratch);
      if (best < 0.0 || rss < best) {
        best = rss;
        start = trial;
      }
    }
  }
  p = start;
  refine_phases();
  best = -1.0;
  double best_m = p.m;
  for (double f = 0.92; f <= 1.121; f += 0.02) {
    Shared trial = p;
    trial.m = model.max_slope * f;
    OwnParams scratch = own;
    const double rss = total_rss(trial, &scratch);
    if (best < 0.0 || rss < best) {
      best = rss;
      best_m = trial.m;
    }
  }
  p.m = best_m;
  refine_phases();
  return p;
}

// A comb's parameters and each row's own, as fitted or to start from.
struct CombSolution {
  Shared p;
  OwnParams own;
};

// The floats that hide the comb (Hidden) which explain the rows best at a
// fitted comb, each row's level and baseline solved anew: their middle at
// either extreme of the undulation (which of them is the trough depends on
// which face of the cloth is out), their width from a thirtieth to a fifth
// of the period (a float spans the axial thread's width, under half the
// threads' pitch, λ/2). Kept only where they leave less than
// kFloatsResidualShare of the comb's residual sum of squares: a mask over
// glints that the photograph does show raises it, and noise alone moves it
// by far less.
constexpr double kFloatsResidualShare = 0.9;
std::optional<CombSolution> BestFloats(const CombProblemData& data, const CombSolution& fitted) {
  auto rss_at = [&](const Shared& trial, OwnParams* own) {
    return SumOverRows(data.rows.size(), [&](std::size_t i) {
      const std::vector<double> shape = RowShape(data.rows[i], Quadrature::kRough, data.bin_px,
                                                 data.in_pixel, trial, (*own)[i][0], nullptr);
      return SolveLinear(data.rows[i], shape, (*own)[i].data());
    });
  };
  OwnParams own = fitted.own;
  const double plain = rss_at(fitted.p, &own);
  std::optional<CombSolution> best;
  double best_rss = kFloatsResidualShare * plain;
  for (double centre : {-0.5 * M_PI, 0.5 * M_PI}) {
    for (double half : {0.1, 0.2, 0.3, 0.4, 0.5, 0.6}) {
      CombSolution trial = fitted;
      trial.p.float_centre = centre;
      trial.p.float_half = half;
      const double rss = rss_at(trial.p, &trial.own);
      if (rss < best_rss) {
        best_rss = rss;
        best = std::move(trial);
      }
    }
  }
  return best;
}

// Every row's shape at `p` with all pieces, rows in parallel.
std::vector<std::vector<double>> FullShapes(const CombProblemData& data, const Shared& p,
                                            const OwnParams& own) {
  std::vector<std::vector<double>> shapes(data.rows.size());
  ForEachRow(data.rows.size(), [&](std::size_t i) {
    shapes[i] = RowShape(data.rows[i], Quadrature::kFull, data.bin_px, data.in_pixel, p, own[i][0],
                         nullptr);
  });
  return shapes;
}

// Noise scale: the median absolute residual at the start, as a σ, but no
// smaller than the pixel noise averaged over a bin.
double NoiseScale(const CombProblemData& data, const Shared& p, const OwnParams& own,
                  double pixel_noise) {
  const std::vector<std::vector<double>> shapes = FullShapes(data, p, own);
  std::vector<double> abs_res;
  for (std::size_t i = 0; i < data.rows.size(); ++i) {
    const Row& row = data.rows[i];
    const std::vector<double>& shape = shapes[i];
    for (std::size_t j = 0; j < row.bins.size(); ++j) {
      const Bin& b = row.bins[j];
      if (!b.valid) continue;
      abs_res.push_back(std::fabs(own[i][1] * shape[j] + own[i][2] + own[i][3] * b.from_mid - b.value));
    }
  }
  return std::max(1.4826 * Median(abs_res), pixel_noise / std::sqrt(data.bin_px));
}

// The share of the rows' variance about their own baselines that the comb
// explains at `p` with all pieces (each row's level and baseline as
// fitted); `rss` gets the residual sum of squares.
double ExplainedShare(const CombProblemData& data, const Shared& p, const OwnParams& own,
                      double* rss_out) {
  const std::vector<std::vector<double>> shapes = FullShapes(data, p, own);
  double rss = 0.0, base = 0.0;
  for (std::size_t i = 0; i < data.rows.size(); ++i) {
    const Row& row = data.rows[i];
    const std::vector<double>& shape = shapes[i];
    std::array<double, kOwn> flat = own[i];
    base += SolveLinear(row, std::vector<double>(shape.size(), 0.0), flat.data());
    for (std::size_t j = 0; j < row.bins.size(); ++j) {
      const Bin& b = row.bins[j];
      if (!b.valid) continue;
      const double r = own[i][1] * shape[j] + own[i][2] + own[i][3] * b.from_mid - b.value;
      rss += r * r;
    }
  }
  *rss_out = rss;
  return base > 0.0 ? 1.0 - rss / base : 0.0;
}

// The comb's parameters as Ceres holds them: (m, λ, δ), ln σ, ℓ and each
// row's own.
struct CombParams {
  double shared[3] = {0.0, 0.0, 0.0};
  double log_sigma = 0.0;
  double psf_l = 0.0;
  OwnParams own;
  double float_centre = 0.0, float_half = 0.0;
  double parallax = 0.0;
  Shared AsShared() const {
    Shared p;
    p.float_centre = float_centre;
    p.float_half = float_half;
    p.parallax = parallax;
    p.m = shared[0];
    p.lambda = shared[1];
    p.delta = shared[2];
    p.log_sigma = log_sigma;
    p.psf_l = psf_l;
    return p;
  }
};

// Every row's modelled shape (RowShape) at the solver's current point,
// computed for all rows at once, in parallel (ForEachRow), before Ceres
// asks the rows' costs for their residuals: the rows' shapes are nearly
// all of a solve's time, and Ceres's own threads would sum the rows' costs
// in an order that varies from run to run.
class RowShapes : public ceres::EvaluationCallback {
 public:
  RowShapes(const CombProblemData& data, const CombParams& params, const Quadrature& quadrature)
      : data_(data), params_(params), quadrature_(quadrature), rows_(data.rows.size()) {}

  // Each point with its gradient, even where Ceres asks for the cost alone:
  // it asks for a step's cost first and, where it takes the step (most
  // steps), for the Jacobian at the same point, which then costs nothing
  // more (the shape's value is the same either way). On the shared
  // photographs' sinusoids the estimate took 10-13 % less CPU time.
  void PrepareForEvaluation(bool /*jacobians*/, bool /*new_point*/) override {
    const Shared p = params_.AsShared();
    if (!Valid(p)) return;
    ForEachRow(rows_.size(), [&](std::size_t i) {
      if (!rows_[i].Holds(p, params_.own[i][0], quadrature_, true)) {
        Compute(i, p, params_.own[i][0], true);
      }
    });
  }

  static bool Valid(const Shared& p) {
    return p.lambda > 0.0 && std::isfinite(p.m) && std::isfinite(p.log_sigma) &&
           std::isfinite(p.PsfPx());
  }

  // Row i's shape at (p, c), with its gradient if `jacobians`: as prepared,
  // or computed here where Ceres evaluates a point it did not announce.
  // Not thread-safe: the solves run on one thread (SolveComb).
  const std::vector<double>& Shape(std::size_t i, const Shared& p, double c, bool jacobians,
                                   const std::vector<std::array<double, 6>>** grad) {
    Entry& e = rows_[i];
    if (!e.Holds(p, c, quadrature_, jacobians)) Compute(i, p, c, jacobians);
    *grad = &e.grad;
    return e.shape;
  }

 private:
  struct Entry {
    bool filled = false, with_grad = false;
    Quadrature quadrature = Quadrature::kFull;
    double key[9] = {};
    std::vector<double> shape;
    std::vector<std::array<double, 6>> grad;
    static void Key(const Shared& p, double c, double out[9]) {
      const double k[9] = {p.m, p.lambda,       p.delta,      p.log_sigma, p.psf_l,
                           c,   p.float_centre, p.float_half, p.parallax};
      std::copy(k, k + 9, out);
    }
    bool Holds(const Shared& p, double c, Quadrature q, bool jacobians) const {
      double k[9];
      Key(p, c, k);
      return filled && quadrature == q && (with_grad || !jacobians) && std::equal(k, k + 9, key);
    }
  };

  void Compute(std::size_t i, const Shared& p, double c, bool jacobians) {
    Entry& e = rows_[i];
    e.shape = RowShape(data_.rows[i], quadrature_, data_.bin_px, data_.in_pixel, p, c,
                       jacobians ? &e.grad : nullptr);
    e.filled = true;
    e.with_grad = jacobians;
    e.quadrature = quadrature_;
    Entry::Key(p, c, e.key);
  }

  const CombProblemData& data_;
  const CombParams& params_;
  const Quadrature& quadrature_;
  std::vector<Entry> rows_;
};

// One row's residuals, in units of the noise scale: parameter blocks
// (m, λ, δ), (ln σ), (q) and the row's (c, A, b0, b1). Clipped bins give 0.
// The row's shape comes from `shapes`.
class RowCost : public ceres::CostFunction {
 public:
  RowCost(const Row* row, std::size_t index, double inv_scale, RowShapes* shapes,
          double float_centre, double float_half, double parallax)
      : row_(row),
        index_(index),
        inv_scale_(inv_scale),
        shapes_(shapes),
        float_centre_(float_centre),
        float_half_(float_half),
        parallax_(parallax) {
    set_num_residuals(static_cast<int>(row->bins.size()));
    mutable_parameter_block_sizes()->assign({3, 1, 1, kOwn});
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Shared p;
    p.m = parameters[0][0];
    p.lambda = parameters[0][1];
    p.delta = parameters[0][2];
    p.log_sigma = parameters[1][0];
    p.psf_l = parameters[2][0];
    p.float_centre = float_centre_;
    p.float_half = float_half_;
    p.parallax = parallax_;
    const double* own = parameters[3];
    if (!RowShapes::Valid(p)) return false;
    const std::vector<std::array<double, 6>>* grad_ptr = nullptr;
    const std::vector<double>& shape =
        shapes_->Shape(index_, p, own[0], jacobians != nullptr, &grad_ptr);
    const std::vector<std::array<double, 6>>& grad = *grad_ptr;
    const int n = static_cast<int>(shape.size());
    for (int j = 0; j < n; ++j) {
      const Bin& b = row_->bins[j];
      residuals[j] =
          b.valid ? (own[1] * shape[j] + own[2] + own[3] * b.from_mid - b.value) * inv_scale_ : 0.0;
    }
    if (jacobians == nullptr) return true;
    for (int j = 0; j < n; ++j) {
      const Bin& b = row_->bins[j];
      const double a = b.valid ? own[1] * inv_scale_ : 0.0;
      const double one = b.valid ? inv_scale_ : 0.0;
      if (jacobians[0] != nullptr) {
        jacobians[0][3 * j] = a * grad[j][0];
        jacobians[0][3 * j + 1] = a * grad[j][1];
        jacobians[0][3 * j + 2] = a * grad[j][4];
      }
      if (jacobians[1] != nullptr) jacobians[1][j] = a * grad[j][2];
      if (jacobians[2] != nullptr) jacobians[2][j] = a * grad[j][5];
      if (jacobians[3] != nullptr) {
        jacobians[3][kOwn * j] = a * grad[j][3];
        jacobians[3][kOwn * j + 1] = one * shape[j];
        jacobians[3][kOwn * j + 2] = one;
        jacobians[3][kOwn * j + 3] = one * b.from_mid;
      }
    }
    return true;
  }

 private:
  const Row* row_;
  std::size_t index_;
  double inv_scale_;
  RowShapes* shapes_;
  double float_centre_, float_half_;  // the floats that hide the comb (held)
  double parallax_;                   // CombAt::parallax (held)
};

// One residual block per row, over (m, λ, δ), ln σ, ℓ and its own; each
// reads its shape from `shapes` (the problem's evaluation callback).
void AddRowCosts(const CombProblemData& data, double scale, RowShapes* shapes, CombParams* params,
                 ceres::Problem* problem) {
  for (std::size_t i = 0; i < data.rows.size(); ++i) {
    problem->AddResidualBlock(
        new RowCost(&data.rows[i], i, 1.0 / scale, shapes, params->float_centre, params->float_half,
                    params->parallax),
        nullptr, params->shared, &params->log_sigma, &params->psf_l, params->own[i].data());
  }
}

// Continuation: the glints are far narrower than a pixel, which makes the
// cost rugged in the period and the phases; a wide blur smooths it (a start
// 2 % off in the period otherwise ends in a false minimum), so the first
// solve holds the source blur at three times its start (and the PSF at its
// start) on two pieces per bin, for a rough optimum. Returns its iterations.
int SolveRough(const ceres::Solver::Options& solver, ceres::Problem* problem,
               Quadrature* quadrature, CombParams* params) {
  const double keep = params->log_sigma;
  params->log_sigma = std::max(keep + std::log(3.0), std::log(0.5 * M_PI / 180.0));
  problem->SetParameterBlockConstant(&params->log_sigma);
  problem->SetParameterBlockConstant(&params->psf_l);
  ceres::Solver::Options rough = solver;
  rough.max_num_iterations = 15;
  rough.function_tolerance = 1e-3;
  *quadrature = Quadrature::kRough;
  ceres::Solver::Summary summary;
  ceres::Solve(rough, problem, &summary);
  params->log_sigma = keep;
  problem->SetParameterBlockVariable(&params->log_sigma);
  problem->SetParameterBlockVariable(&params->psf_l);
  return static_cast<int>(summary.iterations.size());
}

// Ends the polish once the answer has settled: once the largest move of
// the max slope, the period or the mirror offset, in its statistical error
// (`errors`: the main solve's, ClusterErrors), over each of the last
// kSettledSteps steps, times the iterations left to the cap, is below
// `share` (CombFitOptions::polish_settled_share).
class SettledAnswer : public ceres::IterationCallback {
 public:
  SettledAnswer(const double* shared, const double errors[3], int cap, double share)
      : shared_(shared), cap_(cap), share_(share) {
    for (int p = 0; p < 3; ++p) {
      errors_[p] = errors[p];
      last_[p] = shared[p];
    }
  }
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (summary.iteration == 0 || !summary.step_is_successful) return ceres::SOLVER_CONTINUE;
    double move = 0.0;
    for (int p = 0; p < 3; ++p) {
      move = std::max(move, std::fabs(shared_[p] - last_[p]) / errors_[p]);
      last_[p] = shared_[p];
    }
    moves_[steps_++ % kSettledSteps] = move;
    if (steps_ < kSettledSteps) return ceres::SOLVER_CONTINUE;
    const double largest = *std::max_element(moves_, moves_ + kSettledSteps);
    const int left = cap_ - summary.iteration;
    return largest * left < share_ ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

  static constexpr int kSettledSteps = 3;

 private:
  const double* shared_;
  const int cap_;
  const double share_;
  double errors_[3];
  double last_[3];
  double moves_[kSettledSteps] = {};
  int steps_ = 0;
};

// The polish on all the pieces, after a main solve on fewer (kMain) that
// ended at main_cost. It runs to a tight tolerance: stopped at a relative
// cost change of 1e-5 (which noise alone makes the cost's scale) the max
// slope still crawled. Over 8 noise draws of each fixture scene
// (scripts/noise_draws.py) its spread fell 2-30 fold to the
// size the cluster-robust errors give (sin_m020_p60: 1.0 % to 0.03 %), and
// a fixture whose answer hung on its start (silk_m10_srgb) came in (+0.18
// to +0.06 deg). It ends sooner once the answer has settled (SettledAnswer,
// given the main solve's errors in `errors`, all finite and positive).
// Returns its iterations; marks `summary` unsettled where the polish slid
// rather than refined (below).
int Polish(const ceres::Solver::Options& solver, const CombFitOptions& options, double main_cost,
           const double* errors, ceres::Problem* problem, Quadrature* quadrature,
           CombParams* params, ceres::Solver::Summary* summary) {
  *quadrature = Quadrature::kFull;
  ceres::Solver::Options polish = solver;
  polish.max_num_iterations = options.polish_iterations;
  polish.function_tolerance = 1e-8;
  polish.parameter_tolerance = 1e-10;
  std::unique_ptr<SettledAnswer> settled;
  if (errors != nullptr && options.polish_settled_share > 0.0) {
    settled = std::make_unique<SettledAnswer>(params->shared, errors, options.polish_iterations,
                                              options.polish_settled_share);
    polish.callbacks.push_back(settled.get());
    polish.update_state_every_iteration = true;
  }
  ceres::Solver::Summary last;
  const double log_sigma_before = params->log_sigma;
  ceres::Solve(polish, problem, &last);
  // The polish may stop at its iteration cap: it only refines a converged
  // solution, whose verdict stands.
  if (!last.IsSolutionUsable()) *summary = last;
  // The polish refines the integration over each bin: on the fixtures it
  // moves the max slope by 0.06-0.7 % and the source blur by at most 15 %.
  // One that changes the blur by half or more has slid along a valley of
  // narrow glints to a false optimum (α = 89°, 800×600: blur 0.18° to
  // 0.06°, the max slope 4 % long, 8 stated errors), not refined one.
  // Unless the main solve itself was the one stuck: a polished solution
  // that the main solve's quadrature also prefers is a better optimum the
  // main solve missed, not a slide (coarse gauze at 60°, one seed in 64:
  // the main solve held the source blur at 0.80° where the truth is 0.30°,
  // the polish found 0.31°, and peak picking's answer in its place was
  // 1.25° off).
  const bool blur_moved = std::fabs(params->log_sigma - log_sigma_before) > std::log(1.5);
  double polished_main_cost = std::numeric_limits<double>::infinity();
  if (blur_moved) {
    *quadrature = Quadrature::kMain;
    if (!problem->Evaluate(ceres::Problem::EvaluateOptions(), &polished_main_cost, nullptr,
                           nullptr, nullptr)) {
      polished_main_cost = std::numeric_limits<double>::infinity();
    }
    *quadrature = Quadrature::kFull;
  }
  if (blur_moved && !(polished_main_cost < main_cost)) {
    summary->termination_type = ceres::NO_CONVERGENCE;
    summary->message = absl::StrFormat(
        "the fit did not settle: its polish moved the source blur from %.2f to %.2f deg",
        std::exp(log_sigma_before) * 180.0 / M_PI, std::exp(params->log_sigma) * 180.0 / M_PI);
  }
  return static_cast<int>(last.iterations.size());
}

bool ClusterErrors(const CombProblemData& data, ceres::Problem* problem, CombParams* params,
                   CombFitResult* result);

// The rough solve, then to convergence on half the pieces (kMainPieces at
// most), and a polish on all of them unless the main solve explains too
// little (CombFitOptions::min_explained_to_polish). Returns the main solve's
// summary (the polish's where it failed or slid, marked unconverged where
// the polish was skipped); `iterations` gets all three's.
ceres::Solver::Summary SolveComb(const CombProblemData& data, const CombFitOptions& options,
                                 ceres::Problem* problem, Quadrature* quadrature,
                                 CombParams* params, int* iterations, bool rough = true) {
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_SCHUR;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  // The max slope is wanted to a few parts in 10⁴, far coarser than the
  // solver's defaults.
  solver.function_tolerance = 1e-5;
  solver.parameter_tolerance = 1e-5;
  *iterations = rough ? SolveRough(solver, problem, quadrature, params) : 0;
  *quadrature = Quadrature::kMain;
  // Where a polish follows (even piece counts, below), the main solve only
  // brings it close: it ends once a step gains under kMainTolerance of the
  // cost. The glints' cost is far from quadratic (narrower than a pixel):
  // near its optimum the steps gain 0.3-0.6 of what the Gauss-Newton model
  // predicts, and at 1e-5 the main solve crawled up to 100 more iterations
  // for 0.2 % of the cost, which the polish gains as well. On the shared
  // photographs its iterations fell from 1327 to 662 and the polish's rose
  // from 462 to 487; the answers moved by at most 0.35 of their errors.
  constexpr double kMainTolerance = 1e-4;
  ceres::Solver::Options main_solve = solver;
  if (data.pieces % 2 == 0) main_solve.function_tolerance = kMainTolerance;
  ceres::Solver::Summary summary;
  ceres::Solve(main_solve, problem, &summary);
  *iterations += static_cast<int>(summary.iterations.size());
  if (summary.IsSolutionUsable() && data.pieces <= 2 * kMainPieces) {
    double rss = 0.0;
    double share = ExplainedShare(data, params->AsShared(), params->own, &rss);
    // The share that earns a polish was set for a main solve run to the
    // full tolerance: one stopped early for the polish, and within
    // kCrawlShare of that share, is carried on to it before it is judged
    // to explain too little (a 4096×3072 comb of clipped glints explained
    // 44 % at the early stop, over 45 % at the full one). Over 155 such fits
    // (the shared photographs; random lab, ×2.5 and lens-blurred scenes)
    // carrying on added at most 0.044 to the share.
    constexpr double kCrawlShare = 0.05;
    if (share < options.min_explained_to_polish &&
        share >= options.min_explained_to_polish - kCrawlShare &&
        main_solve.function_tolerance > solver.function_tolerance) {
      ceres::Solve(solver, problem, &summary);
      *iterations += static_cast<int>(summary.iterations.size());
      share = summary.IsSolutionUsable()
                  ? ExplainedShare(data, params->AsShared(), params->own, &rss)
                  : 0.0;
    }
    if (share < options.min_explained_to_polish) {
      summary.termination_type = ceres::NO_CONVERGENCE;
      summary.message = absl::StrFormat(
          "it explains %.0f%% of the rows' variance at %.3f mm before its polish, too little "
          "for the polish to make it a fit",
          100.0 * share, params->shared[1]);
      return summary;
    }
  }
  // Odd piece counts are never split (StrideFor): the main solve had them
  // all.
  if (data.pieces % 2 == 0) {
    CombFitResult at_main;
    const bool evaluated = ClusterErrors(data, problem, params, &at_main);
    const double errors[3] = {at_main.max_slope_stderr, at_main.wavelength_stderr_mm,
                              at_main.mirror_offset_stderr_rad};
    const bool usable = evaluated && std::all_of(errors, errors + 3, [](double e) {
                          return std::isfinite(e) && e > 0.0;
                        });
    *iterations += Polish(solver, options, summary.final_cost, usable ? errors : nullptr, problem,
                          quadrature, params, &summary);
  }
  return summary;
}

// Standard errors: cluster-robust over threads (CR2, below). The residuals
// of one row are correlated (the glints' shapes are not exactly the
// model's) and the rows of one thread share its phase, so the plain
// covariance, even scaled by the reduced chi-square, is far too small.
// Each row's own parameters are profiled out of its Jacobian; the threads'
// own scores then measure the error the data actually show. Over 16 noise
// draws of each of the 21 comb-fitted fixtures the spacing spread 0.69-1.64
// times its statistical error so stated (20 within a factor 1.5; with
// session 15's limb errors too), against 0.47-1.36 times with the
// delete-one-thread jackknife used before (17 within; its error ranged over
// 9 times from draw to draw of one scene). False where the Jacobian could
// not be evaluated.
bool ClusterErrors(const CombProblemData& data, ceres::Problem* problem, CombParams* params,
                   CombFitResult* result) {
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = {params->shared, &params->log_sigma, &params->psf_l};
  for (auto& o : params->own) eval.parameter_blocks.push_back(o.data());
  std::vector<double> residuals;
  ceres::CRSMatrix jacobian;
  if (!problem->Evaluate(eval, nullptr, &residuals, nullptr, &jacobian)) return false;
  using Mat = Eigen::Matrix<double, kShared, kShared>;
  using Vec = Eigen::Matrix<double, kShared, 1>;
  Mat hessian = Mat::Zero();
  std::vector<Vec> score(data.distinct.size(), Vec::Zero());
  std::vector<Mat> cluster_hessian(data.distinct.size(), Mat::Zero());
  int at = 0;
  for (std::size_t i = 0; i < data.rows.size(); ++i) {
    const int count = static_cast<int>(data.rows[i].bins.size());
    const int own_col = kShared + kOwn * static_cast<int>(i);
    Eigen::MatrixXd js = Eigen::MatrixXd::Zero(count, kShared);
    Eigen::MatrixXd jo = Eigen::MatrixXd::Zero(count, kOwn);
    for (int r = 0; r < count; ++r) {
      for (int e = jacobian.rows[at + r]; e < jacobian.rows[at + r + 1]; ++e) {
        const int col = jacobian.cols[e];
        if (col < kShared) {
          js(r, col) = jacobian.values[e];
        } else if (col >= own_col && col < own_col + kOwn) {
          jo(r, col - own_col) = jacobian.values[e];
        }
      }
    }
    // Project the own columns out: J̃ = Js − Jo (JoᵀJo)⁺ JoᵀJs.
    const Eigen::MatrixXd proj =
        (jo.transpose() * jo).completeOrthogonalDecomposition().solve(jo.transpose() * js);
    const Eigen::MatrixXd jt = js - jo * proj;
    const Eigen::VectorXd res = Eigen::Map<const Eigen::VectorXd>(&residuals[at], count);
    const std::size_t t = std::lower_bound(data.distinct.begin(), data.distinct.end(),
                                           data.thread_of_row[i]) -
                          data.distinct.begin();
    score[t] += jt.transpose() * res;
    cluster_hessian[t] += jt.transpose() * jt;
    hessian += jt.transpose() * jt;
    at += count;
  }
  // Their covariance from the threads' scores, each scaled by how much of
  // the information its own thread carries (ClusterRobustCovariance).
  const Mat cov = ClusterRobustCovariance(hessian, cluster_hessian, score);
  result->max_slope_stderr = std::sqrt(std::max(cov(0, 0), 0.0));
  result->wavelength_stderr_mm = std::sqrt(std::max(cov(1, 1), 0.0));
  result->mirror_offset_stderr_rad = std::sqrt(std::max(cov(2, 2), 0.0));
  return true;
}

// One fit of the comb, from StartComb's start or from `from`; its answer
// into `out` when non-null.
absl::StatusOr<CombFitResult> FitComb(const CombProblemData& data, const GlintModel& model,
                                      double wavelength_mm, const CombFitOptions& options,
                                      const CombSolution* from, CombSolution* out,
                                      double parallax = 0.0) {
  CombParams params;
  Shared p;
  if (from != nullptr) {
    p = from->p;
    params.own = from->own;
  } else {
    p = StartComb(data, model, wavelength_mm, parallax, &params.own);
  }
  const double scale = NoiseScale(data, p, params.own, model.pixel_noise);
  if (!(scale > 0.0)) return absl::InvalidArgumentError("comb fit: the rows hold no signal");
  params.shared[0] = p.m;
  params.shared[1] = p.lambda;
  params.shared[2] = p.delta;
  params.log_sigma = p.log_sigma;
  params.psf_l = p.psf_l;
  params.float_centre = p.float_centre;
  params.float_half = p.float_half;
  params.parallax = p.parallax;
  Quadrature quadrature = Quadrature::kFull;
  RowShapes shapes(data, params, quadrature);
  ceres::Problem::Options problem_options;
  problem_options.evaluation_callback = &shapes;
  ceres::Problem problem(problem_options);
  AddRowCosts(data, scale, &shapes, &params, &problem);
  CombFitResult result;
  const ceres::Solver::Summary summary =
      SolveComb(data, options, &problem, &quadrature, &params, &result.iterations, from == nullptr);

  const Shared fit = params.AsShared();
  if (out != nullptr) *out = {fit, params.own};
  result.rows_used = static_cast<int>(data.rows.size());
  result.threads_used = static_cast<int>(data.distinct.size());
  result.max_slope = fit.m;
  result.wavelength_mm = fit.lambda;
  result.blur_rad = std::exp(fit.log_sigma);
  result.mirror_offset_rad = fit.delta;
  result.psf_px = fit.PsfPx();
  result.hidden_share = fit.float_half / M_PI;
  result.relief_parallax = fit.parallax != 0.0;
  // No bounds in the solver (they cost it a line search per step); a result
  // outside them is not a fit of this comb.
  result.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
  if (result.converged &&
      !(fit.m > 0.5 * model.max_slope && fit.m < std::min(2.0 * model.max_slope, 3.0) &&
        std::fabs(fit.lambda / wavelength_mm - 1.0) < 0.1 && result.blur_rad < 5.0 * M_PI / 180.0 &&
        std::fabs(fit.delta) < 10.0 * M_PI / 180.0 && result.psf_px < 8.0)) {
    result.converged = false;
    result.message = absl::StrFormat(
        "the fit left its range (max slope %.4f from %.4f, period %.3f mm from %.3f mm)",
        fit.m, model.max_slope, fit.lambda, wavelength_mm);
  }
  if (!result.converged) {
    if (result.message.empty()) result.message = summary.message;
    return result;
  }
  // The share of the rows' variance about their baselines that the glints
  // explain (near 1 for a comb the model reproduces, low for a wrong
  // period), and the chi-square against the scale.
  double rss = 0.0;
  result.explained = ExplainedShare(data, fit, params.own, &rss);
  const int dof =
      std::max(data.num_residuals - kShared - kOwn * static_cast<int>(data.rows.size()), 1);
  result.reduced_chi2 = rss / (scale * scale) / dof;
  if (!ClusterErrors(data, &problem, &params, &result)) {
    result.converged = false;
    result.message = "the Jacobian could not be evaluated";
  }
  return result;
}

// Whether a converged comb fit leaves the rows short of its model:
// explaining less than CombFitOptions::min_explained of them, or needing a
// lens PSF the limbs do not show.
bool FallsShort(const CombFitResult& fit, const GlintModel& model, const CombFitOptions& options) {
  return fit.explained < options.min_explained ||
         !CombPsfPlausible(fit.psf_px, model.lens_blur_px);
}

// The comb with its glints placed where their facets stand, beside `comb`
// (and its answer `fitted`) with them on the mean cylinder: the one that
// explains more kept in their place.
//
// The comb places its glints on the mean cylinder; a glint stands where its
// facet lies, up to h0 off it, and is seen up to h0·sin(φ − v) from there
// (DESIGN.md §3: the relief's parallax), toward the limb pixels. Where that
// could move a glint by kMinParallaxPx (a quarter pixel: the comb's own PSF
// hides less), the fit with the glints so placed, from its own start and,
// where that falls short too, from the comb's answer, is kept if it
// converges to a PSF the limbs could show and explains more of the rows. On
// the independently rendered photographs the comb alone explained 51-84 %
// at phase angles of 79-107° and read the spacing up to 0.57° off; placed,
// 84-98 % (a steep weave at 107°: 69 % from its own start, 86 % from the
// comb's), and the spacing's median error fell from 0.088° to 0.037°, its
// largest to 0.14°. On renders without the parallax it was the better fit
// in 7 of 560 random scenes (by chance; all still within three stated
// errors) and on none of the fixtures. A comb that explains under
// kMinCombShare of the rows is no comb of these glints (a sawtooth's
// caustics explain 0.01-0.13), which placing them by a pixel or two does
// not change.
void PlaceOnFacets(const GlintModel& model, double wavelength_mm, const CombFitOptions& options,
                   CombProblemData* data, CombFitResult* comb, CombSolution* fitted) {
  constexpr double kMinCombShare = 0.2;
  constexpr double kMinParallaxPx = 0.25;
  if (!comb->converged || comb->explained < kMinCombShare) return;
  const double h0_mm = comb->max_slope * comb->wavelength_mm / (2.0 * M_PI);
  if (AddParallaxGeometry(model, h0_mm, data) < kMinParallaxPx) return;
  const CombSolution plain = *fitted;
  const int plain_iterations = comb->iterations;
  for (const bool from_plain : {false, true}) {
    CombSolution from = plain, placed;
    from.p.parallax = 1.0;
    absl::StatusOr<CombFitResult> moved =
        FitComb(*data, model, wavelength_mm, options, from_plain ? &from : nullptr, &placed, 1.0);
    if (moved.ok() && moved->converged && CombPsfPlausible(moved->psf_px, model.lens_blur_px) &&
        moved->explained > comb->explained) {
      moved->iterations += plain_iterations;
      *comb = *std::move(moved);
      *fitted = placed;
    }
    if (comb->relief_parallax && !FallsShort(*comb, model, options)) return;
  }
}

}  // namespace

bool CombPsfPlausible(double psf_px, double lens_blur_px) {
  return psf_px <= std::max(2.0 * lens_blur_px, lens_blur_px + kCombMaxExtraPsfPx);
}

absl::StatusOr<CombFitResult> FitGlintComb(const ArcPixels& pixels, const CombRows& chosen,
                                           const GlintModel& model, double wavelength_mm,
                                           const CombFitOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (!(wavelength_mm > 0.0) || !(model.max_slope > 0.0) || !(model.mm_per_px > 0.0)) {
    return absl::InvalidArgumentError("comb fit needs a wavelength, a max slope and mm_per_px > 0");
  }
  if (pixels.rows.size() != chosen.rows.size() || pixels.rows.empty()) {
    return absl::InvalidArgumentError("comb fit: one pixel signal per chosen row is needed");
  }
  absl::StatusOr<CombProblemData> built =
      BuildCombProblem(pixels, chosen, model, wavelength_mm, options);
  if (!built.ok()) return built.status();
  CombSolution fitted;
  absl::StatusOr<CombFitResult> comb;
  if (options.relief == CombFitOptions::Relief::kOnFacets) {
    AddParallaxGeometry(model, model.max_slope * wavelength_mm / (2.0 * M_PI), &*built);
    comb = FitComb(*built, model, wavelength_mm, options, nullptr, &fitted, 1.0);
  } else {
    comb = FitComb(*built, model, wavelength_mm, options, nullptr, &fitted);
    if (options.relief == CombFitOptions::Relief::kCompare && comb.ok()) {
      PlaceOnFacets(model, wavelength_mm, options, &*built, &*comb, &fitted);
    }
  }
  if (!comb.ok() || !comb->converged || !options.model_floats ||
      !FallsShort(*comb, model, options)) {
    return comb;
  }
  // The comb alone leaves the rows short: where the axial threads float
  // over the circumferential ones they hide the glints the comb predicts
  // there (Hidden), which it may have smeared its PSF or its slope to
  // explain. Where floats would explain its residuals (BestFloats), the fit
  // with them, from its answer, is kept if it converges to a PSF the limbs
  // could show and explains more of the rows.
  const std::optional<CombSolution> masked = BestFloats(*built, fitted);
  if (!masked) return comb;
  absl::StatusOr<CombFitResult> hidden =
      FitComb(*built, model, wavelength_mm, options, &*masked, nullptr);
  if (hidden.ok() && hidden->converged && CombPsfPlausible(hidden->psf_px, model.lens_blur_px) &&
      (!CombPsfPlausible(comb->psf_px, model.lens_blur_px) ||
       hidden->explained > comb->explained)) {
    hidden->iterations += comb->iterations;
    return hidden;
  }
  return comb;
}

PeriodReadings ComparePeriods(const CombFitResult& comb, const CombFitOptions& options,
                              double pitch_mm, double pitch_stderr_mm) {
  PeriodReadings r;
  const double lambda = comb.wavelength_mm;
  if (!(pitch_mm > 0.0) || !(lambda > 0.0)) return r;
  const double twice = 2.0 * pitch_mm;
  r.lattice_mm = std::fabs(twice - lambda) < std::fabs(pitch_mm - lambda) ? twice : pitch_mm;
  const double lattice_se = pitch_stderr_mm * r.lattice_mm / pitch_mm;
  const double comb_se = std::sqrt(std::max(1.0, comb.reduced_chi2)) *
                         std::hypot(comb.wavelength_stderr_mm, options.wavelength_floor * lambda);
  const double difference = std::fabs(lambda - r.lattice_mm);
  if (difference > 2.0 * std::hypot(lattice_se, comb_se)) r.counted_mm = difference;
  return r;
}

}  // namespace weavefit
