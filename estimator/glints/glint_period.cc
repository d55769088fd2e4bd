#include "estimator/glints/glint_period.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "estimator/stats/median.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

// One row's glints: arc position s = R·φ (mm) and the left-hand side of the
// mirror equation, φ − (α + v(φ))/2 (rad).
struct RowGlints {
  std::vector<double> s_mm;
  std::vector<double> lhs;
  std::vector<double> tan_lhs;  // tan of lhs, for RowScore
};

// The longest run of masked samples taken for one clipped glint (8 px at
// the arc signals' half-pixel step); a longer run is a clipped patch.
constexpr int kMaxClippedRun = 16;

// Local maxima of a row standing glint_sigmas of pixel noise (and a share of
// the row's range) above its median, refined to sub-sample positions, and
// clipped glints; maxima closer than 3 samples keep the higher.
std::vector<double> FindGlints(const float* v, const std::uint8_t* ok, int n,
                               double noise, const GlintPeriodOptions& options) {
  std::vector<double> row(v, v + n);
  const double median = Median(row);
  double top = median;
  for (int k = 0; k < n; ++k) top = std::max(top, static_cast<double>(v[k]));
  const double threshold = median + std::max(options.glint_sigmas * noise, 0.15 * (top - median));
  std::vector<double> at;
  std::vector<double> height;
  for (int k = 1; k + 1 < n; ++k) {
    double x = k;
    double peak = v[k];
    if (!ok[k]) {
      // A short run of masked samples is a glint clipped at the sensor's
      // maximum (samples are masked only beside saturated pixels): one glint
      // at the run's middle, higher than anything unclipped. Without it a
      // photograph whose glints clip shows almost none.
      const int start = k;
      int end = k;
      while (end < n && !ok[end]) ++end;
      const int length = end - start;
      x = start + 0.5 * (length - 1);
      k = end - 1;
      // A run cut by the row's ends has no middle.
      if (length > kMaxClippedRun || end >= n || !ok[start - 1]) continue;
      peak = std::numeric_limits<double>::infinity();
    } else {
      if (v[k] <= threshold || v[k] < v[k - 1] || v[k] <= v[k + 1]) continue;
      const double d = v[k - 1] - 2.0 * v[k] + v[k + 1];
      if (d < 0) x += std::clamp(0.5 * (v[k - 1] - v[k + 1]) / d, -0.5, 0.5);
    }
    if (!at.empty() && x - at.back() < 3.0) {
      if (peak > height.back()) {
        at.back() = x;
        height.back() = peak;
      }
      continue;
    }
    at.push_back(x);
    height.push_back(peak);
  }
  return at;
}

// exp(−x) for 0 ≤ x < 8 from a table (step 1/256, linear interpolation:
// relative error below 2e-6), the scoring kernel's hot path.
double ExpNeg(double x) {
  constexpr int kPerUnit = 256;
  constexpr int kSize = 8 * kPerUnit + 2;
  static const std::vector<double> table = [] {
    std::vector<double> t(kSize);
    for (int i = 0; i < kSize; ++i) t[i] = std::exp(-static_cast<double>(i) / kPerUnit);
    return t;
  }();
  const double u = x * kPerUnit;
  const int i = static_cast<int>(u);
  if (i >= kSize - 1) return std::exp(-x);
  return table[i] + (u - i) * (table[i + 1] - table[i]);
}

// How well one period explains one row: the best, over the row's phase c,
// of Σ exp(−r²/2σ²) with r = lhs − arctan(m·cos(k(s + c))). With a = tan lhs
// and y = m·cos(…), r = arctan((a − y)/(1 + a·y)); only |r| < 4σ (a few
// hundredths of a radian) counts, where arctan(x) = x to within x³/3, so the
// arctangent is dropped (a relative error below 1e-3 in r).
double RowScore(const RowGlints& row, double k, double m, double sigma, int phases,
                int* best_phase = nullptr) {
  const double inv = 1.0 / (2.0 * sigma * sigma);
  const double reach = 16.0 * sigma * sigma;  // beyond 4σ a glint adds < 4e-4
  const std::size_t n = row.s_mm.size();
  // cos(k·s + p) = cos(k·s)·cos p − sin(k·s)·sin p: one cosine per glint.
  thread_local std::vector<double> c;
  thread_local std::vector<double> sn;
  c.resize(n);
  sn.resize(n);
  const std::size_t used = n;
  for (std::size_t j = 0; j < used; ++j) {
    c[j] = std::cos(k * row.s_mm[j]);
    sn[j] = std::sin(k * row.s_mm[j]);
  }
  // cos and sin of the trial phases, kept per thread for the last count.
  thread_local std::vector<double> phase_cos;
  thread_local std::vector<double> phase_sin;
  if (static_cast<int>(phase_cos.size()) != phases) {
    phase_cos.resize(phases);
    phase_sin.resize(phases);
    for (int p = 0; p < phases; ++p) {
      phase_cos[p] = std::cos(2.0 * M_PI * p / phases);
      phase_sin[p] = std::sin(2.0 * M_PI * p / phases);
    }
  }
  double best = 0.0;
  for (int p = 0; p < phases; ++p) {
    const double cp = phase_cos[p];
    const double sp = phase_sin[p];
    double score = 0.0;
    for (std::size_t j = 0; j < used; ++j) {
      const double a = row.tan_lhs[j];
      const double y = m * (c[j] * cp - sn[j] * sp);
      const double den = 1.0 + a * y;
      const double num = a - y;
      // r = num / den; test r² < reach without dividing (den > 0: |r| < π/2).
      if (den > 0.0 && num * num < reach * den * den) {
        const double r = num / den;
        score += ExpNeg(r * r * inv);
      }
    }
    if (score > best) {
      best = score;
      if (best_phase != nullptr) *best_phase = p;
    }
  }
  return best;
}

// One row's glints in the form RowScore takes (empty when it has fewer than
// three).
RowGlints RowGlintsOf(const ArcSignals& signals, int r, const GlintModel& model,
                      const GlintPeriodOptions& options) {
  const int n = signals.num_samples;
  const std::vector<double> at =
      FindGlints(signals.Row(r), &signals.valid[static_cast<std::size_t>(r) * n], n,
                 std::max(model.pixel_noise, 1e-6), options);
  RowGlints row;
  if (at.size() < 3) return row;
  for (double x : at) {
    const double phi = signals.first_azimuth_rad + x * signals.step_rad;
    row.s_mm.push_back(signals.radius_mm * phi);
    row.lhs.push_back(phi - 0.5 * (model.phase_angle_rad + ViewAngleRad(phi, model.projection)));
    row.tan_lhs.push_back(std::tan(row.lhs.back()));
  }
  return row;
}

}  // namespace

std::vector<double> RowPhasesMm(const ArcSignals& signals, const GlintModel& model,
                                double wavelength_mm, const GlintPeriodOptions& options) {
  constexpr int kPhases = 96;
  const double k = 2.0 * M_PI / wavelength_mm;
  const double pixel_rad = model.mm_per_px / signals.radius_mm;
  const double tolerance = std::max(1.5 * pixel_rad, 0.5 * model.max_slope * M_PI / kPhases);
  std::vector<double> phases(signals.rows.size(), std::nan(""));
  for (std::size_t r = 0; r < signals.rows.size(); ++r) {
    const RowGlints row = RowGlintsOf(signals, static_cast<int>(r), model, options);
    if (row.s_mm.empty()) continue;
    int best = 0;
    if (RowScore(row, k, model.max_slope, tolerance, kPhases, &best) <= 0.0) continue;
    phases[r] = (2.0 * M_PI * best / kPhases) / k;
  }
  return phases;
}

absl::Status GlintPeriodOptions::Validate() const {
  if (!(min_px_per_period >= 2.0)) return absl::InvalidArgumentError("min_px_per_period must be >= 2");
  if (!(min_periods >= 1.0)) return absl::InvalidArgumentError("min_periods must be >= 1");
  if (!(glint_sigmas > 0.0)) return absl::InvalidArgumentError("glint_sigmas must be > 0");
  if (!(min_explained > 0.0 && min_explained <= 1.0)) {
    return absl::InvalidArgumentError("min_explained must be in (0, 1]");
  }
  if (!(min_ratio >= 1.0)) return absl::InvalidArgumentError("min_ratio must be >= 1");
  if (!(min_periods_found >= min_periods)) {
    return absl::InvalidArgumentError("min_periods_found must be >= min_periods");
  }
  if (bootstrap_samples < 0) return absl::InvalidArgumentError("bootstrap_samples must be >= 0");
  return absl::OkStatus();
}

absl::StatusOr<GlintPeriodResult> EstimateGlintPeriod(const ArcSignals& signals,
                                                      const GlintModel& model,
                                                      const GlintPeriodOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (!(model.mm_per_px > 0.0) || !(model.max_slope > 0.0)) {
    return absl::InvalidArgumentError("glint model needs mm_per_px > 0 and max_slope > 0");
  }
  GlintPeriodResult result;
  const int n = signals.num_samples;
  const double window_mm = (n - 1) * signals.StepMm();
  const double shortest_mm = options.min_px_per_period * model.mm_per_px;
  const double longest_mm = window_mm / options.min_periods;
  if (!(longest_mm > shortest_mm)) {
    result.reason = absl::StrFormat(
        "the lobe spans only %.2f mm of arc, too short for %.0f periods of at "
        "least %.0f px",
        window_mm, options.min_periods, options.min_px_per_period);
    return result;
  }

  // The glints of every row.
  std::vector<RowGlints> rows;
  int total = 0;
  for (std::size_t r = 0; r < signals.rows.size(); ++r) {
    RowGlints row = RowGlintsOf(signals, static_cast<int>(r), model, options);
    if (row.s_mm.empty()) continue;
    total += static_cast<int>(row.s_mm.size());
    rows.push_back(std::move(row));
  }
  // At most 96 rows, evenly spread, and no more than hold about 640 glints
  // (at least 32 rows): the cost stays bounded on large images, whose rows
  // hold many glints each, while small ones keep every glint they have.
  const double glints_per_row = rows.empty() ? 1.0 : static_cast<double>(total) / rows.size();
  const std::size_t cap = static_cast<std::size_t>(
      std::clamp(std::ceil(640.0 / glints_per_row), 32.0, 96.0));
  if (rows.size() > cap) {
    std::vector<RowGlints> kept;
    total = 0;
    for (std::size_t i = 0; i < cap; ++i) {
      kept.push_back(rows[i * rows.size() / cap]);
      total += static_cast<int>(kept.back().s_mm.size());
    }
    rows.swap(kept);
  }
  result.rows_used = static_cast<int>(rows.size());
  result.glints_used = total;
  if (rows.size() < 4) {
    result.reason = absl::StrFormat(
        "only %zu rows show three or more glints above the noise: the thread "
        "period is not resolved",
        rows.size());
    return result;
  }

  // Position tolerance: a pixel and a half at the axis, in azimuth.
  const double pixel_rad = model.mm_per_px / signals.radius_mm;
  // The tolerance is also at least half the miss a phase grid of `phases`
  // steps allows (m·π/phases): on large images a pixel is far finer than
  // the phase grid, and a tolerance of pixels would count a glint only when
  // a grid phase happens to hit it.
  auto tolerance = [&](double pixels, int phases) {
    return std::max(pixels * pixel_rad, 0.5 * model.max_slope * M_PI / phases);
  };
  const double m = model.max_slope;
  auto total_score = [&](double lambda, double sigma, int phases) {
    double sum = 0.0;
    for (const RowGlints& row : rows) sum += RowScore(row, 2.0 * M_PI / lambda, m, sigma, phases);
    return sum / total;
  };
  // Coarse: periods 2 % apart over the whole range (at most max_periods in
  // the arc), on every other row and 32 phases; the fine stage uses all.
  double best_lambda = 0.0;
  double best_score = -1.0;
  const double coarse_from = std::max(shortest_mm, window_mm / options.max_periods);
  std::vector<std::pair<double, double>> scan;  // (period, score)
  for (double lambda = coarse_from; lambda <= longest_mm; lambda *= 1.02) {
    double sum = 0.0;
    int count = 0;
    for (std::size_t r = 0; r < rows.size(); r += 2) {
      sum += RowScore(rows[r], 2.0 * M_PI / lambda, m, tolerance(2.0, 32), 32);
      count += static_cast<int>(rows[r].s_mm.size());
    }
    const double score = sum / std::max(count, 1);
    scan.push_back({lambda, score});
    if (score > best_score) {
      best_score = score;
      best_lambda = lambda;
    }
  }
  // The scan's local maxima, best first, for a stronger test to choose
  // from when the best is too weak to call.
  {
    std::vector<std::pair<double, double>> peaks;
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const bool left = i == 0 || scan[i].second > scan[i - 1].second;
      const bool right = i + 1 == scan.size() || scan[i].second >= scan[i + 1].second;
      if (left && right) peaks.push_back({scan[i].second, scan[i].first});
    }
    std::sort(peaks.rbegin(), peaks.rend());
    for (std::size_t i = 0; i < peaks.size() && i < 4; ++i) {
      result.candidates_mm.push_back(peaks[i].second);
    }
  }
  // Fine: 0.2 % steps within ±4 % of it, finer phases, per-row scores kept
  // for the bootstrap.
  std::vector<double> fine;
  for (int i = -20; i <= 20; ++i) fine.push_back(best_lambda * (1.0 + 0.002 * i));
  std::vector<std::vector<double>> per_row(rows.size(), std::vector<double>(fine.size()));
  std::vector<double> fine_total(fine.size(), 0.0);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (std::size_t i = 0; i < fine.size(); ++i) {
      per_row[r][i] = RowScore(rows[r], 2.0 * M_PI / fine[i], m, tolerance(1.5, 96), 96);
      fine_total[i] += per_row[r][i];
    }
  }
  const std::size_t best_i =
      std::max_element(fine_total.begin(), fine_total.end()) - fine_total.begin();
  const double lambda = fine[best_i];
  result.explained = fine_total[best_i] / total;
  result.candidate_mm = lambda;
  const double half = total_score(0.5 * lambda, tolerance(1.5, 96), 96);
  const double twice = 2.0 * lambda <= longest_mm * 1.5 ? total_score(2.0 * lambda, tolerance(1.5, 96), 96) : 0.0;
  if (total < options.min_glints || result.explained < options.min_explained ||
      result.explained < options.min_ratio * std::max(half, twice) ||
      lambda > window_mm / options.min_periods_found) {
    result.reason = absl::StrFormat(
        "the glints do not follow one thread period (best %.2f mm explains "
        "%.0f%% of %d glints; half of it %.0f%%, twice %.0f%%)",
        lambda, 100.0 * result.explained, total, 100.0 * half, 100.0 * twice);
    return result;
  }
  result.wavelength_mm = lambda;
  result.px_per_period = lambda / model.mm_per_px;
  // Standard error: resample rows; the fine grid's best for each resample.
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<std::size_t> pick(0, rows.size() - 1);
  std::vector<double> lambdas;
  for (int b = 0; b < options.bootstrap_samples; ++b) {
    std::vector<double> sum(fine.size(), 0.0);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const std::size_t r = pick(rng);
      for (std::size_t i = 0; i < fine.size(); ++i) sum[i] += per_row[r][i];
    }
    lambdas.push_back(fine[std::max_element(sum.begin(), sum.end()) - sum.begin()]);
  }
  double mean = 0.0;
  for (double x : lambdas) mean += x;
  mean /= std::max<std::size_t>(lambdas.size(), 1);
  double ss = 0.0;
  for (double x : lambdas) ss += (x - mean) * (x - mean);
  const double spread = lambdas.size() > 1 ? std::sqrt(ss / (lambdas.size() - 1)) : 0.0;
  // The period found leans on the max slope taken from the profile: redo the
  // search with m one standard error either side and count half the shift.
  double lean = 0.0;
  if (model.max_slope_stderr > 0.0) {
    auto best_near = [&](double slope) {
      double best = -1.0;
      double at = lambda;
      for (double f = 0.975; f <= 1.025 + 1e-9; f += 0.0025) {
        double sum = 0.0;
        for (const RowGlints& row : rows) {
          sum += RowScore(row, 2.0 * M_PI / (lambda * f), slope, tolerance(1.5, 48), 48);
        }
        if (sum > best) {
          best = sum;
          at = lambda * f;
        }
      }
      return at;
    };
    lean = 0.5 * std::fabs(best_near(m + model.max_slope_stderr) -
                           best_near(std::max(m - model.max_slope_stderr, 0.5 * m)));
  }
  // Plus the grid step as a uniform error, and a floor for what the model
  // leaves out (glints located on a pixel grid, a profile that is not an
  // exact sinusoid, the blur's pull on glints beside the caustics): see
  // GlintPeriodOptions::model_floor.
  result.wavelength_systematic_mm = 0.0025 * lambda / std::sqrt(12.0);
  result.wavelength_stderr_mm =
      std::sqrt(spread * spread + lean * lean + std::pow(result.wavelength_systematic_mm, 2) +
                std::pow(options.model_floor * lambda, 2));
  result.resolved = true;
  return result;
}

}  // namespace weavefit
