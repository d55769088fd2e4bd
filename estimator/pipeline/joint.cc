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

// Weighted mean of the resolved values with a positive error. The shares of
// the errors (Quantity) combine by what they are: the statistical shares,
// and the systematic ones that move with the geometry (peaks on the bins),
// as independent errors, shrinking with more photographs; the common shares
// (the models' floors, the limb's allowance) as fully correlated, their
// weighted mean, which no number of photographs reduces. A share every
// photograph has alike moves them all alike and says nothing about which
// is better, so the weights are the inverse independent variances (the
// generalised least-squares mean under that covariance), and the
// photographs' agreement is judged against their independent errors: above
// a reduced chi-square of 1 the independent share is scaled by its root.
Combined WeightedMean(const std::vector<Quantity>& values) {
  Combined out;
  struct Term {
    double value, statistical, moving, common;
    double Independent2() const { return statistical * statistical + moving * moving; }
  };
  std::vector<Term> terms;
  for (const Quantity& q : values) {
    if (!q.resolved || !(q.stderr_value > 0.0)) continue;
    const double systematic = std::min(q.systematic, q.stderr_value);
    const double common = std::min(q.common, systematic);
    Term t{q.value, q.Statistical(), std::sqrt(systematic * systematic - common * common), common};
    // At least 1 % of the stated error counts as independent, so that a
    // photograph whose error is nearly all floor cannot take all the
    // weight. (A tenth, before the comb fit's mismatch joined its common
    // share, then set every gauze photograph's weight alike: their
    // independent errors are 0.004-0.013° of 0.13°, and the joint came out
    // 0.0062° rms off against 0.0050° at 10° alone, 32 draws.)
    if (t.Independent2() < 1e-4 * q.stderr_value * q.stderr_value) {
      t.statistical = 0.01 * q.stderr_value;
    }
    terms.push_back(t);
  }
  out.count = static_cast<int>(terms.size());
  if (out.count == 0) return out;
  double sum_w = 0.0, sum_wx = 0.0, sum_w_common = 0.0, sum_w2_stat2 = 0.0, sum_w2_moving2 = 0.0;
  for (const Term& t : terms) {
    const double w = 1.0 / t.Independent2();
    sum_w += w;
    sum_wx += w * t.value;
    sum_w_common += w * t.common;
    sum_w2_stat2 += w * w * t.statistical * t.statistical;
    sum_w2_moving2 += w * w * t.moving * t.moving;
  }
  const double mean = sum_wx / sum_w;
  double chi2 = 0.0;
  for (const Term& t : terms) chi2 += (t.value - mean) * (t.value - mean) / t.Independent2();
  out.chi2 = out.count > 1 ? chi2 / (out.count - 1) : 0.0;
  const double statistical = std::sqrt(sum_w2_stat2) / sum_w * std::sqrt(std::max(1.0, out.chi2));
  const double common = sum_w_common / sum_w;
  const double systematic = std::hypot(std::sqrt(sum_w2_moving2) / sum_w, common);
  out.quantity = {mean, std::hypot(statistical, systematic), true, 0.0, systematic, common};
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
      joint.peak_spacing_rad = SpacingFromSlope(m.quantity);
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
  joint.amplitude_mm = AmplitudeFrom(joint.model, joint.max_slope, joint.wavelength_mm);
  joint.max_inclination_rad = MaxInclinationFromSlope(joint.max_slope);
  return joint;
}

}  // namespace weavefit
