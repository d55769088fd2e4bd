#include "estimator/init/profile_bank.h"

#include <flann/flann.hpp>

#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace weavefit {

struct ProfileBank::Index {
  flann::Matrix<float> data;
  flann::Index<flann::L2<float>> index;
  // Exact (linear) search: the bank is small (about 10^3 × 96), a scan
  // takes microseconds, and FLANN's randomised k-d trees would make answers
  // differ from run to run (their shuffling is seeded from random_device).
  Index(float* features, std::size_t rows, std::size_t cols)
      : data(features, rows, cols), index(data, flann::LinearIndexParams()) {}
};

namespace {

double TiltAt(const ProfileBankOptions& o, int j) {
  return -o.window_rad + (j + 0.5) * 2.0 * o.window_rad / o.samples;
}

// Scales v to unit length; false when it is all zero.
bool Normalise(std::vector<float>& v) {
  double sum = 0.0;
  for (float x : v) sum += static_cast<double>(x) * x;
  if (!(sum > 0.0)) return false;
  const double inv = 1.0 / std::sqrt(sum);
  for (float& x : v) x = static_cast<float>(x * inv);
  return true;
}

}  // namespace

absl::Status ProfileBankOptions::Validate() const {
  if (!(window_rad > 0.0 && window_rad < 1.2)) return absl::InvalidArgumentError("window_rad must be in (0, 1.2)");
  if (samples < 8) return absl::InvalidArgumentError("samples must be >= 8");
  if (!(min_slope > 0.0 && max_slope > min_slope) || num_slopes < 2) {
    return absl::InvalidArgumentError("need 0 < min_slope < max_slope and num_slopes >= 2");
  }
  if (!(min_blur_rad > 0.0 && max_blur_rad > min_blur_rad) || num_blurs < 2) {
    return absl::InvalidArgumentError("need 0 < min_blur_rad < max_blur_rad and num_blurs >= 2");
  }
  return absl::OkStatus();
}

ProfileBank::~ProfileBank() = default;

absl::StatusOr<std::unique_ptr<ProfileBank>> ProfileBank::Build(const ProfileBankOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  std::unique_ptr<ProfileBank> bank(new ProfileBank());
  bank->options_ = options;
  const int n = options.samples;
  auto add = [&](ProfileModel model, double slope, double blur) {
    std::vector<float> f(n);
    for (int j = 0; j < n; ++j) {
      f[j] = static_cast<float>(TiltDensity(model, TiltAt(options, j), slope, blur));
    }
    if (!Normalise(f)) return;
    bank->entries_.push_back({model, slope, blur});
    bank->features_.insert(bank->features_.end(), f.begin(), f.end());
  };
  for (int b = 0; b < options.num_blurs; ++b) {
    const double blur = options.min_blur_rad *
                        std::pow(options.max_blur_rad / options.min_blur_rad,
                                 static_cast<double>(b) / (options.num_blurs - 1));
    add(ProfileModel::kSmooth, 0.0, blur);
    for (int i = 0; i < options.num_slopes; ++i) {
      const double slope = options.min_slope *
                           std::pow(options.max_slope / options.min_slope,
                                    static_cast<double>(i) / (options.num_slopes - 1));
      add(ProfileModel::kSinusoid, slope, blur);
      add(ProfileModel::kSawtooth, slope, blur);
    }
  }
  bank->index_ = std::make_unique<Index>(bank->features_.data(), bank->entries_.size(),
                                         static_cast<std::size_t>(n));
  bank->index_->index.buildIndex();
  return bank;
}

const ProfileBank& ProfileBank::Default() {
  static const ProfileBank* bank = [] {
    absl::StatusOr<std::unique_ptr<ProfileBank>> built = Build(ProfileBankOptions());
    return built.ok() ? built->release() : nullptr;
  }();
  return *bank;  // the default options are valid: Build cannot fail
}

absl::StatusOr<std::vector<BankMatch>> ProfileBank::Nearest(const Profile& profile,
                                                            double mirror_rad,
                                                            double phase_angle_rad,
                                                            int k) const {
  const int n = options_.samples;
  if (profile.NumBins() < 2 || k < 1) {
    return absl::InvalidArgumentError("the bank needs a profile of two or more bins and k >= 1");
  }
  // The lobe on the bank's tilt grid: φ = mirror − β, linear interpolation
  // between bins; samples off the profile stay empty (0 after the baseline).
  std::vector<double> value(n, 0.0);
  std::vector<bool> have(n, false);
  const std::vector<double>& az = profile.azimuth_rad;
  for (int j = 0; j < n; ++j) {
    const double phi = mirror_rad - TiltAt(options_, j);
    if (phi <= az.front() || phi >= az.back()) continue;
    const std::size_t hi = std::upper_bound(az.begin(), az.end(), phi) - az.begin();
    const std::size_t lo = hi - 1;
    if (profile.count[lo] <= 0.0 || profile.count[hi] <= 0.0) continue;
    const double t = (phi - az[lo]) / (az[hi] - az[lo]);
    value[j] = (1.0 - t) * profile.mean[lo] + t * profile.mean[hi];
    have[j] = true;
  }
  // Baseline: the line through the medians of the first and last eighths
  // that the profile covers.
  std::vector<int> covered;
  for (int j = 0; j < n; ++j) {
    if (have[j]) covered.push_back(j);
  }
  if (covered.size() < static_cast<std::size_t>(n / 2)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the profile covers only ", covered.size(), " of the bank's ", n,
        " tilt samples around the mirror azimuth"));
  }
  const std::size_t edge = std::max<std::size_t>(2, covered.size() / 8);
  auto median_of = [&](std::size_t from, std::size_t to, double* at) {
    std::vector<double> v;
    double sum_j = 0.0;
    for (std::size_t i = from; i < to; ++i) {
      v.push_back(value[covered[i]]);
      sum_j += covered[i];
    }
    *at = sum_j / (to - from);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  double j0 = 0.0;
  double j1 = 0.0;
  const double v0 = median_of(0, edge, &j0);
  const double v1 = median_of(covered.size() - edge, covered.size(), &j1);
  // A lobe must stand above the baseline by more than the profile's noise.
  double peak = 0.0;
  for (int j : covered) peak = std::max(peak, value[j] - (v0 + (v1 - v0) * (j - j0) / (j1 - j0)));
  std::vector<double> errors;
  for (std::size_t i = 0; i < profile.stderr_mean.size(); ++i) {
    if (profile.count[i] > 0.0) errors.push_back(profile.stderr_mean[i]);
  }
  double noise = 0.0;
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    noise = errors[errors.size() / 2];
  }
  if (!(peak > std::max(5.0 * noise, 1e-6 * std::max(std::fabs(v0), std::fabs(v1))))) {
    return absl::InvalidArgumentError("no lobe above the baseline around the mirror azimuth");
  }
  std::vector<float> query(n, 0.0f);
  const double half_alpha = 0.5 * phase_angle_rad;
  for (int j : covered) {
    const double base = v0 + (v1 - v0) * (j - j0) / (j1 - j0);
    const double beta = TiltAt(options_, j);
    const double phi = mirror_rad - beta;
    // Divide out cos(α/2)/(cos φ·cos β) (DESIGN.md §3).
    const double geometry = std::cos(phi) * std::cos(beta) / std::max(std::cos(half_alpha), 0.05);
    query[j] = static_cast<float>(std::max(0.0, value[j] - base) * geometry);
  }
  if (!Normalise(query)) {
    return absl::InvalidArgumentError("no lobe above the baseline around the mirror azimuth");
  }
  const int kk = std::min(k, size());
  std::vector<int> indices(kk);
  std::vector<float> distances(kk);
  flann::Matrix<float> q(query.data(), 1, n);
  flann::Matrix<int> idx(indices.data(), 1, kk);
  flann::Matrix<float> dist(distances.data(), 1, kk);
  index_->index.knnSearch(q, idx, dist, kk, flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  std::vector<BankMatch> out;
  for (int i = 0; i < kk; ++i) {
    if (indices[i] < 0) continue;
    out.push_back({entries_[indices[i]], std::sqrt(std::max(0.0f, distances[i]))});
  }
  return out;
}

absl::StatusOr<std::vector<BankMatch>> ProfileBank::NearestPerModel(const Profile& profile,
                                                                    double mirror_rad,
                                                                    double phase_angle_rad,
                                                                    int k) const {
  absl::StatusOr<std::vector<BankMatch>> near = Nearest(profile, mirror_rad, phase_angle_rad, k);
  if (!near.ok()) return near.status();
  std::vector<BankMatch> out;
  for (ProfileModel model : {ProfileModel::kSmooth, ProfileModel::kSinusoid, ProfileModel::kSawtooth}) {
    for (const BankMatch& m : *near) {
      if (m.entry.model == model) {
        out.push_back(m);
        break;
      }
    }
  }
  return out;
}

}  // namespace weavefit
