#include "estimator/select/model_selection.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

// The index of `model`'s fit where it converged, else -1.
int ConvergedFit(const ProfileFitResult& fits, ProfileModel model) {
  for (std::size_t i = 0; i < fits.fits.size(); ++i) {
    if (fits.fits[i].model == model && fits.fits[i].converged) return static_cast<int>(i);
  }
  return -1;
}

// How far the better of two fits leaves its residuals above the noise
// model: its reduced chi-square, at least 1. Where neither model explains
// the profile (a lobe cut by the limb, a shape neither has), their BIC
// difference measures which misfit is smaller, not which model is there, and
// counts that much less (quasi-likelihood, as in QAIC).
double Overdispersion(const ModelFit& a, const ModelFit& b) {
  auto reduced = [](const ModelFit& f) {
    return f.chi2 / std::max(f.num_residuals - f.num_params, 1);
  };
  return std::max(1.0, std::min(reduced(a), reduced(b)));
}

// Whether a split fit's caustics stand where peak picking found the peaks:
// their spacings within 3 of their combined errors. A fit that converged on
// another lobe (a heavily blurred sawtooth mimicking a sinusoid's, a
// sinusoid's caustics at a comb's inner teeth) explains the profile
// differently from the peaks seen.
bool AtThePeaks(const ModelFit& fit, const PeakReading& peaks) {
  const double spacing = PeakSpacingRad(fit.max_slope);
  const double stderr_rad = 2.0 * fit.max_slope_stderr / (1.0 + fit.max_slope * fit.max_slope);
  return std::fabs(spacing - peaks.spacing_rad) <=
         3.0 * std::hypot(stderr_rad, peaks.spacing_stderr_rad);
}

// Whether a fit's mirror azimuth stands where the stated geometry puts it:
// within 3 of its errors and a degree (a smooth cylinder's brightest column
// sits a little off α/2), the allowance peak picking's mirror has too
// (EstimateFromLuminance). A fit that shifted the lobe to explain the
// profile (a sinusoid 3.7° off α/2 explaining a sawtooth whose outer
// caustic met the limb) is not reading the lobe the acquisition makes.
bool AtTheMirror(const ModelFit& fit, const PeakReading& peaks) {
  return std::fabs(fit.mirror_rad - peaks.geometry_mirror_rad) <=
         3.0 * fit.mirror_stderr_rad + kDegree;
}

// A sawtooth fit whose rounded corners take the most the model allows
// (kMaxCornerShare): the level between the peaks is fuller than a
// sawtooth's, and its numbers are not a sawtooth's reading.
bool CornersFillTheLobe(const ModelFit& fit) {
  return fit.model == ProfileModel::kSawtooth && fit.corner_share >= 0.99 * kMaxCornerShare;
}

// Whether a split fit's lobe can tell a sinusoid from a sawtooth: its
// caustics far enough apart against its blur and against a comb's teeth.
bool TellsTheModelsApart(const ModelFit& fit, const PeakReading& peaks,
                         const ModelSelectionOptions& options) {
  const double spacing = PeakSpacingRad(fit.max_slope);
  const double blur = std::hypot(fit.blur_rad, peaks.smoothing_rad);
  return spacing >= options.min_split_per_blur * blur &&
         spacing >= options.min_teeth_between_caustics * peaks.comb_gap_rad;
}

}  // namespace

ModelChoice ChooseProfileModel(const PeakReading& peaks, const ProfileFitResult& fits,
                               const ModelSelectionOptions& options) {
  ModelChoice choice;
  const ProfileModel picked = peaks.model;
  const int smooth = ConvergedFit(fits, ProfileModel::kSmooth);
  if (!peaks.split || picked == ProfileModel::kSmooth) {
    choice.model = ProfileModel::kSmooth;
    if (smooth >= 0 && fits.best == smooth) {
      choice.fit = smooth;
    } else if (fits.best >= 0) {
      choice.reason = absl::StrFormat(
          "the least-squares fits prefer %s to the one peak peak picking read; on a profile "
          "this is not strong enough evidence, so one peak is kept",
          ProfileModelName(fits.fits[fits.best].model));
    }
    return choice;
  }
  choice.model = picked;
  const int sinusoid = ConvergedFit(fits, ProfileModel::kSinusoid);
  const int sawtooth = ConvergedFit(fits, ProfileModel::kSawtooth);
  int named = picked == ProfileModel::kSinusoid ? sinusoid : sawtooth;
  // A fit reads the split only where it explains the profile better than
  // one peak, and with its caustics where peak picking found the peaks.
  auto reads_the_split = [&](int i) {
    return i >= 0 && (smooth < 0 || fits.fits[i].bic < fits.fits[smooth].bic) &&
           AtThePeaks(fits.fits[i], peaks) && !CornersFillTheLobe(fits.fits[i]) &&
           AtTheMirror(fits.fits[i], peaks);
  };
  if (sinusoid >= 0 && sawtooth >= 0) {
    const int other = named == sinusoid ? sawtooth : sinusoid;
    const ModelFit& a = fits.fits[named];
    const ModelFit& b = fits.fits[other];
    const double tau = std::max({a.correlation_bins, b.correlation_bins, 1.0});
    const double for_other = (a.bic - b.bic) / (tau * Overdispersion(a, b));
    choice.evidence = -for_other;
    if (for_other >= options.min_split_evidence && reads_the_split(other) &&
        TellsTheModelsApart(b, peaks, options)) {
      choice.model = b.model;
      choice.evidence = for_other;
      choice.fit = other;
      choice.reason = absl::StrFormat(
          "%s, not the %s peak picking read from the level between the peaks: fitted to the "
          "whole lobe, it explains the profile with a BIC lower by %.0f per independent bin",
          ProfileModelName(b.model), ProfileModelName(picked), for_other);
      return choice;
    }
    if (for_other > 0.0) {
      // The other model explains the lobe better, not decisively (or not
      // with its caustics at the peaks): neither fit's numbers stand, peak
      // picking's (with its allowances) do.
      choice.reason = absl::StrFormat(
          "the fits prefer %s to peak picking's %s by %.1f BIC per independent bin%s; peak "
          "picking's reading is kept",
          ProfileModelName(b.model), ProfileModelName(picked), for_other,
          for_other < options.min_split_evidence
              ? absl::StrFormat(", short of the %.0f that decides", options.min_split_evidence)
              : std::string(", but its caustics do not stand where peak picking found the "
                            "peaks or the mirror azimuth, its corners fill the lobe, or the "
                            "lobe is too blurred or its comb too coarse to tell the two "
                            "apart"));
      return choice;
    }
  }
  if (reads_the_split(named)) {
    choice.fit = named;
  } else if (named >= 0) {
    choice.reason = absl::StrFormat(
        "the %s fit explains the profile less well than one peak, fills it with its corners, "
        "stands off the mirror azimuth the acquisition makes, or puts its caustics %.2f deg "
        "apart where peak picking found the peaks %.2f deg apart; peak picking's split is kept",
        ProfileModelName(choice.model), PeakSpacingRad(fits.fits[named].max_slope) / kDegree,
        peaks.spacing_rad / kDegree);
  }
  return choice;
}

}  // namespace weavefit
