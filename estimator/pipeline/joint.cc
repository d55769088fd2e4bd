#include "estimator/pipeline/joint.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

// Above this reduced chi-square the photographs disagree enough to say so.
constexpr double kDisagreeChi2 = 4.0;

struct Combined {
  Quantity quantity;
  int count = 0;
  double chi2 = 0.0;
};

// Inverse-variance weighted mean of the resolved values with a positive
// error; the error scaled by sqrt(reduced chi-square) when that exceeds 1.
Combined WeightedMean(const std::vector<Quantity>& values) {
  Combined out;
  double sum_w = 0.0;
  double sum_wx = 0.0;
  for (const Quantity& q : values) {
    if (!q.resolved || !(q.stderr_value > 0.0)) continue;
    const double w = 1.0 / (q.stderr_value * q.stderr_value);
    sum_w += w;
    sum_wx += w * q.value;
    ++out.count;
  }
  if (out.count == 0) return out;
  const double mean = sum_wx / sum_w;
  double chi2 = 0.0;
  for (const Quantity& q : values) {
    if (!q.resolved || !(q.stderr_value > 0.0)) continue;
    const double d = (q.value - mean) / q.stderr_value;
    chi2 += d * d;
  }
  out.chi2 = out.count > 1 ? chi2 / (out.count - 1) : 0.0;
  out.quantity = {mean, std::sqrt(1.0 / sum_w) * std::sqrt(std::max(1.0, out.chi2)), true};
  return out;
}

}  // namespace

PhotographEstimate PhotographFrom(const Estimate& estimate, const std::string& name) {
  return {name, estimate.model, estimate.max_slope, estimate.wavelength_mm};
}

absl::StatusOr<JointEstimate> CombineEstimates(const std::vector<PhotographEstimate>& photographs) {
  if (photographs.size() < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a joint estimate needs two or more photographs of the sample, got ", photographs.size()));
  }
  JointEstimate joint;
  // The model: the one most photographs chose; a tie goes to the model whose
  // photographs measured the slope most precisely.
  // A photograph whose split hides in its blur reads SMOOTH: SMOOTH wins
  // only when no photograph resolved a split.
  bool any_split = false;
  for (const PhotographEstimate& p : photographs) {
    any_split = any_split || (p.model != ProfileModel::kSmooth && p.max_slope.resolved);
  }
  std::map<ProfileModel, std::pair<int, double>> votes;  // count, best relative error
  for (const PhotographEstimate& p : photographs) {
    if (any_split && p.model == ProfileModel::kSmooth) continue;
    auto& v = votes.try_emplace(p.model, 0, 1e300).first->second;
    ++v.first;
    if (p.max_slope.resolved && p.max_slope.value > 0.0) {
      v.second = std::min(v.second, p.max_slope.stderr_value / p.max_slope.value);
    }
  }
  auto best = votes.begin();
  for (auto it = votes.begin(); it != votes.end(); ++it) {
    if (it->second.first > best->second.first ||
        (it->second.first == best->second.first && it->second.second < best->second.second)) {
      best = it;
    }
  }
  joint.model = best->first;
  std::set<ProfileModel> seen;
  for (const PhotographEstimate& p : photographs) seen.insert(p.model);
  if (seen.size() > 1) {
    std::string list;
    for (const PhotographEstimate& p : photographs) {
      absl::StrAppend(&list, list.empty() ? "" : ", ", p.name, " ", ProfileModelName(p.model));
    }
    joint.warnings.push_back(absl::StrCat(
        "the photographs disagree on the thread profile (", list, "); the joint estimate uses ",
        ProfileModelName(joint.model), " and only the photographs that read it",
        any_split ? " (a SMOOTH reading is a split hidden in that photograph's blur)" : ""));
  }
  std::vector<Quantity> slopes;
  std::vector<Quantity> wavelengths;
  for (const PhotographEstimate& p : photographs) {
    if (p.model != joint.model) continue;
    slopes.push_back(p.max_slope);
    wavelengths.push_back(p.wavelength_mm);
  }
  if (joint.model != ProfileModel::kSmooth) {
    const Combined m = WeightedMean(slopes);
    joint.slope_photographs = m.count;
    joint.slope_chi2 = m.chi2;
    if (m.count > 0) {
      joint.max_slope = m.quantity;
      const double s = m.quantity.value;
      joint.peak_spacing_rad = {2.0 * std::atan(s), 2.0 * m.quantity.stderr_value / (1.0 + s * s),
                                true};
      for (const PhotographEstimate& p : photographs) {
        if (!p.max_slope.resolved && p.max_slope.upper_bound > 0.0 &&
            s > p.max_slope.upper_bound + 2.0 * m.quantity.stderr_value) {
          joint.warnings.push_back(absl::StrFormat(
              "the joint max slope %.3f exceeds the bound %.3f that %s's unresolved split sets",
              s, p.max_slope.upper_bound, p.name));
        }
      }
      if (m.chi2 > kDisagreeChi2) {
        joint.warnings.push_back(absl::StrFormat(
            "the photographs' max slopes scatter %.1f times more than their errors allow "
            "(reduced chi-square %.1f): the joint error is scaled up accordingly; check that "
            "they show one sample",
            std::sqrt(m.chi2), m.chi2));
      }
    } else {
      joint.warnings.push_back("no photograph resolved the split: max slope unresolved");
    }
  }
  const Combined lambda = WeightedMean(wavelengths);
  joint.wavelength_photographs = lambda.count;
  joint.wavelength_chi2 = lambda.chi2;
  if (lambda.count > 0) {
    joint.wavelength_mm = lambda.quantity;
    if (lambda.chi2 > kDisagreeChi2) {
      joint.warnings.push_back(absl::StrFormat(
          "the photographs' wavelengths scatter %.1f times more than their errors allow "
          "(reduced chi-square %.1f): the joint error is scaled up accordingly",
          std::sqrt(lambda.chi2), lambda.chi2));
    }
  }
  // Amplitude (DESIGN.md §2): m·λ/(2π) for the sinusoid, m·λ/4 for the
  // sawtooth; relative errors added in quadrature.
  if (joint.max_slope.resolved && joint.wavelength_mm.resolved) {
    const double factor = joint.model == ProfileModel::kSinusoid ? 1.0 / (2.0 * M_PI) : 0.25;
    const double h0 = factor * joint.max_slope.value * joint.wavelength_mm.value;
    const double rel = std::hypot(joint.max_slope.stderr_value / joint.max_slope.value,
                                  joint.wavelength_mm.stderr_value / joint.wavelength_mm.value);
    joint.amplitude_mm = {h0, h0 * rel, true};
  }
  joint.max_inclination_rad = MaxInclinationFromSlope(joint.max_slope);
  return joint;
}

}  // namespace weavefit
