// Which profile model a photograph shows, decided in one place from the
// candidates' scores (DESIGN.md §1, STYLE.md `select/`): peak picking's
// reading of the lobe and the least-squares fits of each model to it.
#ifndef WEAVEFIT_ESTIMATOR_SELECT_MODEL_SELECTION_H_
#define WEAVEFIT_ESTIMATOR_SELECT_MODEL_SELECTION_H_

#include <string>

#include "estimator/fit/profile_fit.h"
#include "estimator/optics/radiance.h"

namespace weavefit {

struct ModelSelectionOptions {
  // The evidence, in BIC per independent bin, one model's fit needs over
  // another's to overturn peak picking's reading (one split model over the
  // other, or one peak over a split): the BIC difference divided by the
  // better fit's residual correlation (ModelFit::correlation_bins; the bins
  // are not independent) and by its reduced chi-square where that exceeds 1
  // (then neither model explains the profile). 10 is "very strong" on Kass
  // and Raftery's scale (2·ln of the Bayes factor). Between two fits this
  // close the lobe does not tell the models apart, and peak picking's
  // reading, which sees the glints and the level between the peaks, stands.
  double min_split_evidence = 10.0;
  // The two split models differ in how the level falls from each caustic
  // toward the middle (a sinusoid's inner shoulder, a sawtooth's flank and
  // corners). They are told apart only where the caustics stand this many
  // blurs (the fit's, with the smoothing) apart: a sinusoid of m = 0.04
  // whose caustics stood 5 blurs apart was fitted better by a sawtooth
  // with rounded corners (stability sweep), where the overturns needed on
  // photographs stood 17-34 apart. Likewise one peak overturns a split only
  // where the split read spans this many of the one-peak fit's blurs:
  // closer, one blurred peak mimics two caustics (on the sweep, one peak
  // preferred at m = 0.04 came out 0.6-1.9° off).
  double min_split_per_blur = 10.0;
  // ... and where a comb of glints puts this many teeth between them: a
  // coarse comb is the glints of a few weave phases, not the density the
  // models describe (a sinusoid of 32 px per period, 4.5 teeth between its
  // caustics, was fitted better by a sawtooth 9° short; the overturns
  // needed stood 17-34 teeth apart).
  double min_teeth_between_caustics = 8.0;
};

// Peak picking's verdict on the lobe (PeakPickingResult's, in short).
struct PeakReading {
  bool split = false;
  ProfileModel model = ProfileModel::kSmooth;
  double spacing_rad = 0.0;
  double spacing_stderr_rad = 0.0;
  double smoothing_rad = 0.0;  // the profile's smoothing (σ), which the fits share
  double comb_gap_rad = 0.0;   // a comb of glints' tooth spacing; 0 = none
  // Where the stated acquisition puts the mirror azimuth, (α + v)/2.
  double geometry_mirror_rad = 0.0;
};

// What the profile shows, and whose numbers to report.
struct ModelChoice {
  ProfileModel model = ProfileModel::kSmooth;
  // The fit (an index into ProfileFitResult::fits) whose split and mirror
  // azimuth are reported; -1 keeps peak picking's.
  int fit = -1;
  // The BIC per independent bin by which the named split model's fit beats
  // the other split model's (negative: it loses, kept on peak picking's
  // word), or by which one peak beats the better split fit where it
  // overturned a split; 0 where no two split fits converged.
  double evidence = 0.0;
  // In a user's words, why: empty where peak picking's reading stands
  // unchallenged.
  std::string reason;
};

// Peak picking decides whether the lobe splits, but for two cases: a split
// the fits find where it saw one peak, or one peak they prefer where it saw
// two caustics a few blurs apart, came out 0.6-1.9° off with errors of
// 0.1-0.35° on the stability sweep (grazing light, α = 140°; m = 0.04).
// The cases: a split read from maxima many blurs apart (min_split_per_blur)
// that one narrow peak at the mirror azimuth explains decisively better
// (min_split_evidence) is one peak; so is one whose every split fit,
// started there, closed its caustics into one maximum at the mirror
// azimuth (under two of its blurs apart, beyond peak picking's errors of
// the split read). The maxima were not caustics. Between
// the two split models the fits decide on min_split_evidence, where their
// lobe can tell the two apart (min_split_per_blur,
// min_teeth_between_caustics).
//
// A split is reported from the chosen model's fit only where that fit
// explains the profile better than one peak does; its caustics stand where
// peak picking found the peaks (their spacings within 3 of their combined
// errors: a heavily blurred sawtooth can mimic a sinusoid's lobe with its
// caustics far inside the peaks, and a fit can settle on a comb's inner
// teeth); its mirror azimuth stands where the stated geometry puts it
// (within 3 of its errors and a degree, as peak picking's must); and, for a
// sawtooth, its corners stay under kMaxCornerShare. Otherwise the model is
// named and peak picking's numbers stand, and `reason` says which check
// failed. `fits` may hold no converged fit (then peak picking's reading
// stands).
ModelChoice ChooseProfileModel(const PeakReading& peaks, const ProfileFitResult& fits,
                               const ModelSelectionOptions& options = {});

// One peak overturns a split read where the geometry cannot place the lobe
// (several degrees off (α + v)/2, its split left unresolved) only when the
// one-peak fit's BIC is this many times lower than the better split fit's.
inline constexpr double kOffGeometryBicRatio = 3.0;

// The model named for a split read whose lobe stands where the stated
// geometry puts no specular lobe: `named` (peak picking's or the fits'),
// or SMOOTH where the least-squares fits ran and one peak explains the
// profile kOffGeometryBicRatio times better (lower BIC) than either split:
// a smooth lobe at −114° on a Lambertian ramp (diffuse 0.16, 1 px lens
// blur) was read as a sawtooth 9° off α/2, its fits' BICs 402 for one peak
// and 5,216 and 5,258 for the splits. `fits` may be empty (fast mode) or
// hold no converged fit: then `named` stands.
ProfileModel ChooseModelOffTheGeometry(ProfileModel named, const ProfileFitResult& fits);

// The model named once a comb of glints is confirmed along the arc (the
// comb fit takes a period): a sawtooth mirrors only at its two caustics,
// so glints that repeat along the arc are a sinusoid's, and a SAWTOOTH
// read from a nearly empty valley (a steep sinusoid's, m = 0.79: 0.04-0.06
// of the peaks' height) becomes a SINUSOID. Not where the lobe's own shape
// decides the sawtooth, its fit beating the sinusoid's by
// min_split_evidence or more (`evidence`, ModelChoice's): a sinusoid's
// comb laid over a sawtooth's lit facets, which repeat along the arc
// beside each caustic, explained 94 % of a noisy render's rows. Then
// `named` stands and the comb's period is not the weave's.
ProfileModel ModelWithConfirmedComb(ProfileModel named, double evidence,
                                    const ModelSelectionOptions& options = {});

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_SELECT_MODEL_SELECTION_H_
