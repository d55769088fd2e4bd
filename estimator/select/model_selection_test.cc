// Unit tests of select/model_selection: which model the profile shows, from
// peak picking's verdict and the lobe fits' BICs and residual correlation.
#include "estimator/select/model_selection.h"

#include <gtest/gtest.h>

#include <cmath>

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

ModelFit Fit(ProfileModel model, double bic, double correlation_bins = 1.0,
             bool converged = true) {
  ModelFit f;
  f.model = model;
  // Caustics 20° apart (the split models), read to 0.1°.
  if (model != ProfileModel::kSmooth) {
    f.max_slope = std::tan(10.0 * kDeg);
    f.max_slope_stderr = 0.05 * kDeg * (1.0 + f.max_slope * f.max_slope);
  }
  f.bic = bic;
  f.correlation_bins = correlation_bins;
  f.converged = converged;
  return f;
}

// Peak picking's reading: `model` split 20° ± 1° apart, or one peak.
PeakReading Read(ProfileModel model) {
  if (model == ProfileModel::kSmooth) return {false, model, 0.0, 0.0, 0.0, 0.0, 0.0};
  return {true, model, 20.0 * kDeg, 1.0 * kDeg, 0.25 * kDeg, 0.0, 0.0};
}

// SMOOTH, SINUSOID, SAWTOOTH, as FitProfileModels returns them, best set.
ProfileFitResult Fits(double smooth, double sinusoid, double sawtooth, double tau = 1.0) {
  ProfileFitResult r;
  r.fits = {Fit(ProfileModel::kSmooth, smooth, tau), Fit(ProfileModel::kSinusoid, sinusoid, tau),
            Fit(ProfileModel::kSawtooth, sawtooth, tau)};
  for (std::size_t i = 0; i < r.fits.size(); ++i) {
    if (r.best < 0 || r.fits[i].bic < r.fits[r.best].bic) r.best = static_cast<int>(i);
  }
  return r;
}

TEST(ChooseProfileModelTest, AgreeingFitGivesTheNumbers) {
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSawtooth), Fits(1100, 700, 45));
  EXPECT_EQ(c.model, ProfileModel::kSawtooth);
  EXPECT_EQ(c.fit, 2);
  EXPECT_GT(c.evidence, 10.0);
  EXPECT_TRUE(c.reason.empty());
}

TEST(ChooseProfileModelTest, DecisiveFitsOverturnPeakPickingsSplitModel) {
  // A sinusoid read as a sawtooth: the sinusoid explains the lobe by 2,100
  // BIC over residuals correlated across 30 bins, 70 per independent bin.
  const ModelChoice c =
      ChooseProfileModel(Read(ProfileModel::kSawtooth), Fits(10200, 1470, 3580, 30.0));
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, 1);
  EXPECT_NEAR(c.evidence, (3580.0 - 1470.0) / 30.0, 1e-9);
  EXPECT_NE(c.reason.find("SINUSOID, not the SAWTOOTH"), std::string::npos) << c.reason;
}

TEST(ChooseProfileModelTest, AFitWhoseCausticsMissThePeaksDoesNotOverturn) {
  // A sinusoid's lobe that a blurred sawtooth explains better, its caustics
  // 13° apart where peak picking found the peaks 20° ± 1° apart.
  ProfileFitResult r = Fits(1900, 930, 550, 4.0);
  r.fits[2].max_slope = std::tan(6.5 * kDeg);
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, -1);
  EXPECT_NE(c.reason.find("caustics stand 13.00 deg apart"), std::string::npos) << c.reason;
  // Where they stand at the peaks, the same evidence overturns it.
  r.fits[2].max_slope = std::tan(10.5 * kDeg);
  EXPECT_EQ(ChooseProfileModel(Read(ProfileModel::kSinusoid), r).model, ProfileModel::kSawtooth);
}

TEST(ChooseProfileModelTest, AFitOnAnotherLobeGivesNoNumbers) {
  // Peak picking's own model, fitted with its caustics 29° apart where the
  // peaks stand 20° ± 1° apart: the model stays, the numbers are peak
  // picking's.
  ProfileFitResult r = Fits(5000, 900, 950, 4.0);
  r.fits[1].max_slope = std::tan(14.5 * kDeg);
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, -1);
  EXPECT_NE(c.reason.find("29.00 deg apart"), std::string::npos) << c.reason;
}

TEST(ChooseProfileModelTest, ASawtoothWhoseCornersFillTheLobeIsNoSawtooth) {
  // The sawtooth explains a sinusoid's comb-filled lobe better only with
  // its corners at the most the model allows: no overturn.
  ProfileFitResult r = Fits(77700, 17950, 11100, 5.0);
  r.fits[2].corner_share = kMaxCornerShare;
  ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, -1);
  // With corners of a tenth of its arc, it does.
  r.fits[2].corner_share = 0.1;
  c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSawtooth);
  EXPECT_EQ(c.fit, 2);
}

TEST(ChooseProfileModelTest, ABlurredOrCoarseCombedLobeDoesNotDecide) {
  ProfileFitResult r = Fits(5000, 900, 300, 4.0);
  PeakReading peaks = Read(ProfileModel::kSinusoid);
  ASSERT_EQ(ChooseProfileModel(peaks, r).model, ProfileModel::kSawtooth);
  // The sawtooth's caustics 20° apart through a blur of 2.5°: 8 blurs.
  r.fits[2].blur_rad = 2.45 * kDeg;
  EXPECT_EQ(ChooseProfileModel(peaks, r).model, ProfileModel::kSinusoid);
  // A comb of glints 3° apart: under 7 teeth between the caustics.
  r.fits[2].blur_rad = 0.0;
  peaks.comb_gap_rad = 3.0 * kDeg;
  const ModelChoice c = ChooseProfileModel(peaks, r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_NE(c.reason.find("comb of glints too coarse"), std::string::npos) << c.reason;
  peaks.comb_gap_rad = 2.0 * kDeg;
  EXPECT_EQ(ChooseProfileModel(peaks, r).model, ProfileModel::kSawtooth);
}

TEST(ChooseProfileModelTest, AFitOffTheMirrorAzimuthDoesNotRead) {
  // The sinusoid explains a sawtooth's lobe better by standing 3.7° off
  // where the acquisition puts the mirror (error 0.33°).
  ProfileFitResult r = Fits(3700, 300, 1000, 3.5);
  r.fits[1].mirror_rad = 3.7 * kDeg;
  r.fits[1].mirror_stderr_rad = 0.33 * kDeg;
  ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSawtooth), r);
  EXPECT_EQ(c.model, ProfileModel::kSawtooth);
  EXPECT_EQ(c.fit, -1);
  // 1.5° off is within 3 errors and a degree.
  r.fits[1].mirror_rad = 1.5 * kDeg;
  c = ChooseProfileModel(Read(ProfileModel::kSawtooth), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, 1);
}

TEST(ChooseProfileModelTest, CorrelatedResidualsWeakenTheEvidence) {
  // The same BIC difference over residuals correlated across 100 bins is 3
  // per independent bin: peak picking's model and its numbers stand.
  const ModelChoice c =
      ChooseProfileModel(Read(ProfileModel::kSawtooth), Fits(5000, 1000, 1300, 100.0));
  EXPECT_EQ(c.model, ProfileModel::kSawtooth);
  EXPECT_EQ(c.fit, -1);
  EXPECT_LT(c.evidence, 0.0);
  EXPECT_NE(c.reason.find("short of"), std::string::npos) << c.reason;
}

TEST(ChooseProfileModelTest, FitsThatExplainNeitherModelDoNotDecide) {
  // Both split fits leave residuals 15 times the noise model (a lobe cut by
  // the limb): 22 BIC per correlated bin between them is 1.5 once that is
  // counted, and peak picking's reading stands.
  ProfileFitResult r = Fits(4514, 3633, 3768, 6.2);
  for (ModelFit& f : r.fits) {
    f.num_residuals = 249;
    f.num_params = 7;
    f.chi2 = 15.0 * 242;
  }
  r.fits[1].chi2 = 14.8 * 242;
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSawtooth), r);
  EXPECT_EQ(c.model, ProfileModel::kSawtooth);
  EXPECT_EQ(c.fit, -1);
  EXPECT_NEAR(-c.evidence, (3768.0 - 3633.0) / (6.2 * 14.8), 1e-9);
}

TEST(ChooseProfileModelTest, OnePeakReadStaysOnePeak) {
  // Peak picking saw one peak: a split fit does not overturn it.
  ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSmooth), Fits(900, 400, 500));
  EXPECT_EQ(c.model, ProfileModel::kSmooth);
  EXPECT_EQ(c.fit, -1);
  EXPECT_NE(c.reason.find("one peak is kept"), std::string::npos) << c.reason;
  // Where the smooth fit is best it gives the mirror azimuth.
  c = ChooseProfileModel(Read(ProfileModel::kSmooth), Fits(300, 400, 500));
  EXPECT_EQ(c.model, ProfileModel::kSmooth);
  EXPECT_EQ(c.fit, 0);
}

TEST(ChooseProfileModelTest, SplitFitWorseThanOnePeakGivesNoNumbers) {
  // One peak blurred over 3°: the split read, 20° wide, is under 10 of its
  // blurs, where one blurred peak mimics two caustics; peak picking's split
  // stands, without the fit's numbers.
  ProfileFitResult r = Fits(300, 400, 900);
  r.fits[0].blur_rad = 3.0 * kDeg;
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, -1);
  EXPECT_NE(c.reason.find("less well than one peak"), std::string::npos) << c.reason;
}

TEST(ChooseProfileModelTest, ANarrowPeakThatExplainsTheLobeOverturnsAWideSplit) {
  // Maxima 20° apart that one peak 0.7° wide explains by 1,500 BIC over
  // residuals correlated across 3 bins and 9 times the noise: 56 per
  // independent bin, and 27 of its blurs between the maxima. The maxima
  // were not caustics: one peak, and its fit's mirror azimuth.
  ProfileFitResult r = Fits(2000, 3500, 3600, 12.0);
  r.fits[0].correlation_bins = 3.0;
  r.fits[0].blur_rad = 0.7 * kDeg;
  r.fits[0].num_residuals = 250;
  r.fits[0].num_params = 6;
  r.fits[0].chi2 = 9.0 * 244;
  ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSmooth);
  EXPECT_EQ(c.fit, 0);
  EXPECT_NEAR(c.evidence, 1500.0 / (3.0 * 9.0), 1e-9);
  EXPECT_NE(c.reason.find("SMOOTH, not the SINUSOID"), std::string::npos) << c.reason;
  // Short of the evidence (60 BIC, 2.2 per independent bin), the split
  // stands.
  r.fits[1].bic = 2060;
  c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  // Decisive, but the one peak off the mirror azimuth: not the specular
  // lobe, and the split stands.
  r.fits[1].bic = 3500;
  r.fits[0].mirror_rad = 5.0 * kDeg;
  c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
}

TEST(ChooseProfileModelTest, SplitFitsThatMergeTheirCausticsReadOnePeak) {
  // Maxima 20° ± 1° apart, read beside a lone specular peak: both split
  // fits, started there, closed their caustics to under two of their blurs
  // (0.96° and 0.69° apart through 0.55° blurs, with the 0.25° smoothing
  // 0.6°), at the mirror azimuth. The sinusoid beats one peak by its extra
  // freedom, and the sawtooth's error on its slope is as large as the
  // slope: neither reads a split.
  ProfileFitResult r = Fits(866.8, 847.8, 959.5, 4.7);
  r.fits[1].max_slope = std::tan(0.48 * kDeg);
  r.fits[2].max_slope = std::tan(0.345 * kDeg);
  r.fits[2].max_slope_stderr = 0.53;
  for (ModelFit& f : r.fits) f.blur_rad = 0.55 * kDeg;
  ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSmooth);
  EXPECT_EQ(c.fit, 0);
  EXPECT_NE(c.reason.find("closed its caustics into one peak"), std::string::npos) << c.reason;
  // One split fit whose caustics stay apart (3 of its blurs) keeps the
  // split read.
  r.fits[2].max_slope = std::tan(0.9 * kDeg);
  c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  // Merged, but off the mirror azimuth: not the specular lobe's reading.
  r.fits[2].max_slope = std::tan(0.345 * kDeg);
  r.fits[1].mirror_rad = 5.0 * kDeg;
  c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
}

TEST(ChooseProfileModelTest, UnconvergedFitsLeavePeakPickingAlone) {
  ProfileFitResult r = Fits(300, 200, 100);
  for (ModelFit& f : r.fits) f.converged = false;
  r.best = -1;
  const ModelChoice c = ChooseProfileModel(Read(ProfileModel::kSinusoid), r);
  EXPECT_EQ(c.model, ProfileModel::kSinusoid);
  EXPECT_EQ(c.fit, -1);
  // Only the picked model's fit converged: it gives the numbers.
  r.fits[1].converged = true;
  r.best = 1;
  EXPECT_EQ(ChooseProfileModel(Read(ProfileModel::kSinusoid), r).fit, 1);
}

TEST(ChooseModelOffTheGeometryTest, OnePeakFarBetterThanEitherSplitIsSmooth) {
  // The fits' BICs of a smooth lobe on a Lambertian ramp read as a sawtooth
  // off α/2: 402 for one peak, 5,216 and 5,258 for the splits.
  EXPECT_EQ(ChooseModelOffTheGeometry(ProfileModel::kSawtooth, Fits(402, 5216, 5258)),
            ProfileModel::kSmooth);
  // Under kOffGeometryBicRatio times better, the split model named stands.
  EXPECT_EQ(ChooseModelOffTheGeometry(ProfileModel::kSawtooth, Fits(402, 1000, 5258)),
            ProfileModel::kSawtooth);
  // Without fits (fast mode), or none converged, too.
  EXPECT_EQ(ChooseModelOffTheGeometry(ProfileModel::kSinusoid, ProfileFitResult()),
            ProfileModel::kSinusoid);
  ProfileFitResult r = Fits(402, 5216, 5258);
  r.fits[0].converged = false;
  EXPECT_EQ(ChooseModelOffTheGeometry(ProfileModel::kSinusoid, r), ProfileModel::kSinusoid);
}

// A comb of glints confirmed along the arc makes a sawtooth read from the
// level between the peaks a sinusoid, unless the lobe's shape decides the
// sawtooth by min_split_evidence or more.
TEST(ModelWithConfirmedCombTest, OverturnsASawtoothOnlyWhereTheLobeDoesNotDecideIt) {
  const ModelSelectionOptions options;
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSawtooth, 0.0, options), ProfileModel::kSinusoid);
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSawtooth, -4.0, options),
            ProfileModel::kSinusoid);
  EXPECT_EQ(
      ModelWithConfirmedComb(ProfileModel::kSawtooth, 0.9 * options.min_split_evidence, options),
      ProfileModel::kSinusoid);
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSawtooth, options.min_split_evidence, options),
            ProfileModel::kSawtooth);
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSawtooth, 603.0, options),
            ProfileModel::kSawtooth);
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSinusoid, 603.0, options),
            ProfileModel::kSinusoid);
  ModelSelectionOptions strict = options;
  strict.min_split_evidence = 700.0;
  EXPECT_EQ(ModelWithConfirmedComb(ProfileModel::kSawtooth, 603.0, strict),
            ProfileModel::kSinusoid);
}

}  // namespace
}  // namespace weavefit
