// A bank of model lobe shapes searched with FLANN: where the least-squares
// fits start, and a quick answer of its own (issue 5, initialisation).
//
// Each entry is the blurred facet-tilt density p_σ(β) of one model (DESIGN.md
// §3: SMOOTH, SINUSOID, SAWTOOTH) for one max slope and blur, sampled on a
// fixed grid of tilts β around the mirror point and scaled to unit length. A
// measured profile is brought to the same form: its lobe around the mirror
// azimuth, a straight baseline through the window's ends taken off (ambient,
// scatter and diffuse vary slowly there), the geometric factor
// cos(α/2)/(cos φ·cos β) divided out, negatives cleared, unit length. The
// nearest entries (Euclidean, i.e. the best-correlated shapes) are found with
// FLANN's exact linear index (deterministic; the bank is small).
#ifndef WEAVEFIT_ESTIMATOR_INIT_PROFILE_BANK_H_
#define WEAVEFIT_ESTIMATOR_INIT_PROFILE_BANK_H_

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/optics/radiance.h"
#include "estimator/profile/profile_extraction.h"

namespace weavefit {

struct ProfileBankOptions {
  double window_rad = 40.0 * 3.14159265358979323846 / 180.0;  // |β| sampled
  int samples = 96;
  // Max slopes: geometric steps from min to max; blurs (σ in tilt, rad) the same.
  double min_slope = 0.02;
  double max_slope = 0.8;
  int num_slopes = 48;
  double min_blur_rad = 0.15 * 3.14159265358979323846 / 180.0;
  double max_blur_rad = 3.0 * 3.14159265358979323846 / 180.0;
  int num_blurs = 10;

  absl::Status Validate() const;
};

struct BankEntry {
  ProfileModel model = ProfileModel::kSmooth;
  double max_slope = 0.0;  // 0 for SMOOTH
  double blur_rad = 0.0;
};

struct BankMatch {
  BankEntry entry;
  double distance = 0.0;  // Euclidean between unit vectors: 0 same, √2 unrelated
};

class ProfileBank {
 public:
  // Builds the bank (about 10^3 entries: a fraction of a second).
  static absl::StatusOr<std::unique_ptr<ProfileBank>> Build(const ProfileBankOptions& options);
  // The bank with default options, built on first use, shared, thread-safe.
  static const ProfileBank& Default();

  // The k nearest entries to the lobe of `profile` whose mirror point is at
  // azimuth mirror_rad (phase angle phase_angle_rad), nearest first.
  // INVALID_ARGUMENT when the profile holds no lobe there.
  absl::StatusOr<std::vector<BankMatch>> Nearest(const Profile& profile, double mirror_rad,
                                                 double phase_angle_rad, int k) const;
  // The nearest entry of each model, in the order SMOOTH, SINUSOID, SAWTOOTH
  // (searching the k nearest; a model absent there is left out).
  absl::StatusOr<std::vector<BankMatch>> NearestPerModel(const Profile& profile, double mirror_rad,
                                                         double phase_angle_rad, int k = 48) const;

  int size() const { return static_cast<int>(entries_.size()); }
  const ProfileBankOptions& options() const { return options_; }
  ~ProfileBank();

 private:
  struct Index;
  ProfileBank() = default;
  ProfileBankOptions options_;
  std::vector<BankEntry> entries_;
  std::vector<float> features_;  // entries × samples, row-major
  std::unique_ptr<Index> index_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_INIT_PROFILE_BANK_H_
