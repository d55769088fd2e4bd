// One sample photographed several times (the paper: phase angles 10°, 60°,
// 110°): the thread parameters are shared, everything else (cylinder, lobe
// position, blur, exposure) is each photograph's own.
#ifndef WEAVEFIT_ESTIMATOR_PIPELINE_JOINT_H_
#define WEAVEFIT_ESTIMATOR_PIPELINE_JOINT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/optics/radiance.h"
#include "estimator/pipeline/estimate.h"

namespace weavefit {

// What the joint estimate needs of one photograph's estimate.
struct PhotographEstimate {
  std::string name;
  ProfileModel model = ProfileModel::kSmooth;
  Quantity max_slope;
  Quantity wavelength_mm;
};

PhotographEstimate PhotographFrom(const Estimate& estimate, const std::string& name);

struct JointEstimate {
  ProfileModel model = ProfileModel::kSmooth;
  Quantity peak_spacing_rad;
  Quantity max_slope;
  Quantity max_inclination_rad;  // MaxInclinationFromSlope(max_slope)
  Quantity wavelength_mm;
  Quantity amplitude_mm;
  // Photographs that entered each quantity, and the reduced chi-square of
  // their values about the joint one (1 when they agree as their errors say;
  // the joint error is scaled up by its square root when above 1).
  int slope_photographs = 0;
  int wavelength_photographs = 0;
  double slope_chi2 = 0.0;
  double wavelength_chi2 = 0.0;
  std::vector<std::string> warnings;
};

// The joint estimate: the model most photographs chose (a photograph whose
// split hides in its blur reads SMOOTH and does not vote against one that
// resolves the split; its upper bound is checked against the joint slope
// instead, with a warning when exceeded); the max slope and
// the wavelength as inverse-variance weighted means over the photographs
// that resolved them (with the model chosen), which is the maximum-
// likelihood joint value when each photograph's nuisance parameters are its
// own and its errors are Gaussian; the spacing and amplitude derived from
// them (DESIGN.md §2–3). Errors are scaled by sqrt(reduced chi-square) when
// the photographs disagree beyond their errors, and a warning says so.
// INVALID_ARGUMENT for fewer than two photographs.
absl::StatusOr<JointEstimate> CombineEstimates(const std::vector<PhotographEstimate>& photographs);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PIPELINE_JOINT_H_
