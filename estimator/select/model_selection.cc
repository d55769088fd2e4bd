#include "estimator/select/model_selection.h"

#include <algorithm>
#include <cmath>
#include <string>

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

// The evidence, in BIC per independent bin, for `better` over `worse`: their
// BIC difference divided by the better fit's residual correlation
// (ModelFit::correlation_bins: its n bins carry about n/τ independent
// pieces of information) and by its reduced chi-square where that exceeds
// 1. Both are read off the better fit because the worse fit's residuals
// hold its misfit, which is the signal being weighed, not noise: a split
// fit that leaves a lone specular peak unexplained has residuals correlated
// over the peak's whole width. Where even the better fit leaves structure
// the noise does not explain (a lobe cut by the limb, a ripple of axial
// glint lines, a shape neither model has), the difference measures which
// misfit is smaller and counts that much less (quasi-likelihood, as in
// QAIC, whose overdispersion comes from the best-approximating model).
double Evidence(const ModelFit& better, const ModelFit& worse) {
  const double reduced = better.chi2 / std::max(better.num_residuals - better.num_params, 1);
  return (worse.bic - better.bic) /
         (std::max(better.correlation_bins, 1.0) * std::max(reduced, 1.0));
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

// The converged split fit with the lowest BIC, else -1.
int BestSplitFit(const ProfileFitResult& fits) {
  int best = -1;
  for (std::size_t i = 0; i < fits.fits.size(); ++i) {
    const ModelFit& f = fits.fits[i];
    if (f.model == ProfileModel::kSmooth || !f.converged) continue;
    if (best < 0 || f.bic < fits.fits[best].bic) best = static_cast<int>(i);
  }
  return best;
}

// Whether one peak explains a lobe peak picking read as split: the one-peak
// fit beats the better split fit by min_split_evidence, stands at the
// mirror azimuth, and is narrow against the split read (its blur, with the
// smoothing, under 1/min_split_per_blur of the spacing). Two caustics that
// far apart are two peaks no single blurred peak can mimic, so a narrow
// peak that explains the lobe decisively better says the maxima taken for
// caustics are something else: the glint lines of axial threads, which
// stand at one pitch across the whole lit surface, or the relief of stray
// light. Where the split is closer to the blur, one blurred peak and a
// split lobe look alike and peak picking's reading stands.
bool OnePeakExplainsTheSplit(const ModelFit& smooth, const ModelFit& split,
                             const PeakReading& peaks, const ModelSelectionOptions& options) {
  if (!(smooth.bic < split.bic)) return false;
  const double blur = std::hypot(smooth.blur_rad, peaks.smoothing_rad);
  return Evidence(smooth, split) >= options.min_split_evidence &&
         peaks.spacing_rad >= options.min_split_per_blur * blur && AtTheMirror(smooth, peaks);
}

// Two Gaussian peaks of width σ closer than 2σ show one maximum: a split
// fit whose caustics stand under this many of its blurs (with the
// smoothing) apart draws one peak.
constexpr double kMergedCausticsPerBlur = 2.0;

// Whether the fits read one peak where peak picking read a split: every
// converged split fit, started at peak picking's split, left it for caustics
// merged into one maximum (kMergedCausticsPerBlur) at the mirror azimuth,
// more than 3 of peak picking's errors short of its split (a fit's own
// error on a split it merged can be any size: it is not a reading of one),
// and the one-peak fit stands at the mirror too. The maxima read as
// caustics are then something the models do not hold (a ripple of axial
// glint lines or of stray light's relief beside a lone specular peak): the
// lobe's own shape, fitted whole, says no split.
bool FitsMergeTheCaustics(const ProfileFitResult& fits, int smooth, const PeakReading& peaks) {
  if (smooth < 0 || !AtTheMirror(fits.fits[smooth], peaks)) return false;
  int split_fits = 0;
  for (const ModelFit& f : fits.fits) {
    if (f.model == ProfileModel::kSmooth || !f.converged) continue;
    ++split_fits;
    const double blur = std::hypot(f.blur_rad, peaks.smoothing_rad);
    const double spacing = PeakSpacingRad(f.max_slope);
    if (spacing >= kMergedCausticsPerBlur * blur ||
        peaks.spacing_rad - spacing <= 3.0 * peaks.spacing_stderr_rad || !AtTheMirror(f, peaks)) {
      return false;
    }
  }
  return split_fits > 0;
}

// Why a split fit does not read the split (or, with `deciding`, cannot
// tell the two split models apart), in a user's words; empty where it does.
std::string WhyNotRead(const ModelFit& fit, const ModelFit* smooth, const PeakReading& peaks,
                       const ModelSelectionOptions& options, bool deciding) {
  const double spacing = PeakSpacingRad(fit.max_slope);
  if (smooth != nullptr && !(fit.bic < smooth->bic)) {
    return "it explains the profile less well than one peak";
  }
  if (!AtThePeaks(fit, peaks)) {
    return absl::StrFormat("its caustics stand %.2f deg apart where peak picking found the "
                           "peaks %.2f deg apart",
                           spacing / kDegree, peaks.spacing_rad / kDegree);
  }
  if (!AtTheMirror(fit, peaks)) {
    return absl::StrFormat("its mirror azimuth stands %.2f deg from where the acquisition puts "
                           "it (%.2f deg)",
                           std::fabs(fit.mirror_rad - peaks.geometry_mirror_rad) / kDegree,
                           peaks.geometry_mirror_rad / kDegree);
  }
  if (CornersFillTheLobe(fit)) {
    return "its rounded corners fill a quarter of its arc, more than a sawtooth has";
  }
  if (deciding && !TellsTheModelsApart(fit, peaks, options)) {
    return "the lobe is too blurred, or its comb of glints too coarse, to tell a sinusoid from a "
           "sawtooth";
  }
  return std::string();
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
  const int best_split = BestSplitFit(fits);
  if (smooth >= 0 && best_split >= 0 &&
      OnePeakExplainsTheSplit(fits.fits[smooth], fits.fits[best_split], peaks, options)) {
    choice.model = ProfileModel::kSmooth;
    choice.fit = smooth;
    choice.evidence = Evidence(fits.fits[smooth], fits.fits[best_split]);
    choice.reason = absl::StrFormat(
        "SMOOTH, not the %s peak picking read from maxima %.2f deg apart: one narrow peak at the "
        "mirror azimuth explains the lobe with a BIC lower by %.0f per independent bin than the "
        "best split fit, so those maxima are not caustics (glint lines of axial threads, or "
        "stray light's relief, stand across the whole lit surface)",
        ProfileModelName(picked), peaks.spacing_rad / kDegree, choice.evidence);
    return choice;
  }
  if (FitsMergeTheCaustics(fits, smooth, peaks)) {
    choice.model = ProfileModel::kSmooth;
    choice.fit = smooth;
    choice.reason = absl::StrFormat(
        "SMOOTH, not the %s peak picking read from maxima %.2f deg apart: fitted to the whole "
        "lobe from that split, every split model closed its caustics into one peak at the mirror "
        "azimuth, so those maxima are not caustics",
        ProfileModelName(picked), peaks.spacing_rad / kDegree);
    return choice;
  }
  choice.model = picked;
  const int sinusoid = ConvergedFit(fits, ProfileModel::kSinusoid);
  const int sawtooth = ConvergedFit(fits, ProfileModel::kSawtooth);
  const int named = picked == ProfileModel::kSinusoid ? sinusoid : sawtooth;
  const ModelFit* one_peak = smooth >= 0 ? &fits.fits[smooth] : nullptr;
  if (sinusoid >= 0 && sawtooth >= 0) {
    const int other = named == sinusoid ? sawtooth : sinusoid;
    const ModelFit& a = fits.fits[named];
    const ModelFit& b = fits.fits[other];
    const double for_other = b.bic < a.bic ? Evidence(b, a) : -Evidence(a, b);
    choice.evidence = -for_other;
    if (for_other > 0.0) {
      const std::string why_not =
          for_other < options.min_split_evidence
              ? absl::StrFormat("short of the %.0f that decides", options.min_split_evidence)
              : WhyNotRead(b, one_peak, peaks, options, /*deciding=*/true);
      if (why_not.empty()) {
        choice.model = b.model;
        choice.evidence = for_other;
        choice.fit = other;
        choice.reason = absl::StrFormat(
            "%s, not the %s peak picking read from the level between the peaks: fitted to the "
            "whole lobe, it explains the profile with a BIC lower by %.0f per independent bin",
            ProfileModelName(b.model), ProfileModelName(picked), for_other);
        return choice;
      }
      // The other model explains the lobe better, but not decisively or not
      // as a reading of this lobe: neither fit's numbers stand, peak
      // picking's (with its allowances) do.
      choice.reason = absl::StrFormat(
          "the fits prefer %s to peak picking's %s by %.1f BIC per independent bin, but %s; "
          "peak picking's reading is kept",
          ProfileModelName(b.model), ProfileModelName(picked), for_other, why_not);
      return choice;
    }
  }
  if (named < 0) return choice;
  const std::string why_not = WhyNotRead(fits.fits[named], one_peak, peaks, options, false);
  if (why_not.empty()) {
    choice.fit = named;
  } else {
    choice.reason = absl::StrFormat("the %s fit does not give the split: %s; peak picking's is "
                                    "kept",
                                    ProfileModelName(choice.model), why_not);
  }
  return choice;
}

ProfileModel ChooseModelOffTheGeometry(ProfileModel named, const ProfileFitResult& fits) {
  if (named == ProfileModel::kSmooth) return named;
  const int smooth = ConvergedFit(fits, ProfileModel::kSmooth);
  const int split = BestSplitFit(fits);
  if (smooth < 0 || split < 0 || !(fits.fits[smooth].bic > 0.0)) return named;
  return fits.fits[split].bic >= kOffGeometryBicRatio * fits.fits[smooth].bic
             ? ProfileModel::kSmooth
             : named;
}

ProfileModel ModelWithConfirmedComb(ProfileModel named, double evidence,
                                    const ModelSelectionOptions& options) {
  if (named == ProfileModel::kSawtooth && evidence >= options.min_split_evidence) return named;
  return ProfileModel::kSinusoid;
}

}  // namespace weavefit
