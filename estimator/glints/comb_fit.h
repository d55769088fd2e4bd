// The comb of glints, fitted row by row (DESIGN.md §3: "smooth over half a
// thread period or model the comb"). A photograph holds only as many weave
// phases as it has threads in view, so its column average is a comb around
// the analytic lobe and the outermost glints of a sinusoid stand up to half a
// period inside the caustics: read from the column average, the split comes
// out short. Along one row of one thread, though, the radiance is exactly
//     L(φ) ∝ G(φ − (α + v(φ))/2 − arctan(m·cos(k·(R·φ + c))); σ) · sec β / cos φ,
// a Gaussian G of the source's angular width σ in the mirror miss, averaged
// over each pixel's footprint. Fitted over a few dozen rows with the max
// slope m, the period λ = 2π/k and σ shared and each row's weave phase c,
// level and baseline its own, every glint's position (not only the last one
// before the caustic) tells m. Sinusoidal profiles only: a sawtooth's glints
// stand at the caustics themselves.
#ifndef WEAVEFIT_ESTIMATOR_GLINTS_COMB_FIT_H_
#define WEAVEFIT_ESTIMATOR_GLINTS_COMB_FIT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/glints/glint_period.h"
#include "estimator/profile/arc_signals.h"

namespace weavefit {

struct CombFitOptions {
  // Rows fitted (those with a weave phase, evenly spread), and pixel bins
  // per row (the pipeline bins neighbouring columns down to it).
  int max_rows = 32;
  int max_samples_per_row = 128;
  // Sub-intervals per bin over which the Gaussian is integrated along the
  // locally linear miss, the sum extrapolated from them and from half as
  // many (BinMean). Without the extrapolation the max slope of noise-free
  // 320×240 renders (11 px per period, α = −60°) came out 0.31 / 0.079 /
  // 0.030 % long with 4 / 8 / 16; with it and 8, within 0.009 % on three
  // seeds of four (0.033 % on the fourth), the radius's error taken out.
  int subintervals = 8;
  // Iterations of the main solve. A tilted axis couples the row phases to
  // the period and the solve crawls: the 2° tilt fixture needed more than
  // 100 from a start 0.5 % away from the one that converged within 100.
  int max_iterations = 300;
  // Iterations of the polish on every sub-interval (its cap only ends a
  // refinement of a converged solve).
  int polish_iterations = 30;
  // The polish ends sooner once its answer has settled: once the largest
  // step of the max slope, the period or the mirror offset over each of the
  // last three, in that quantity's statistical error at the main solve,
  // times the iterations left to the cap, is below this share (0: to the
  // cap or the tolerances). Were every step to the cap as long, the answer
  // would stay within this share of its error of the capped polish's. On
  // the independently rendered photographs the polish's cost fell by about
  // 0.01 % a step to the cap, a crawl of the row phases that moved the max
  // slope by 0.05 of its error in all, and took half the comb fit's time.
  double polish_settled_share = 0.1;
  // The polish is skipped, and the fit not taken, when the main solve
  // leaves the glints explaining less than this share of the rows'
  // variance, where its pieces per bin are at least half of what the tilt's
  // turn needs (kMainPieces): there the polish only refines each bin's
  // integral, and it raised the share by at most 0.02 on the fixtures and
  // the independently rendered photographs. (Where the main solve has a
  // quarter or less of the pieces needed, the polish does the real work: a
  // steep fine weave went from 0.02 to 0.88.) No caller takes a fit below
  // 0.7 (the lattice's period-only fits, pipeline/estimate.cc), so 0.6
  // leaves five times that gain as margin; a sawtooth's caustics, which are
  // no comb, explain 0.01-0.13 and so cost no polish. At 0.45 a sawtooth's
  // fit that reached 0.43 crawled on for 268 iterations (SolveComb), over
  // half of its photograph's estimate, to be refused all the same.
  double min_explained_to_polish = 0.6;
  // The fit is taken when the glints explain at least this share of the
  // rows' variance about their baselines: 0.85 to 0.998 on the fixtures'
  // sinusoids; at most 0.21 started from half or twice the period, but 0.75
  // from a period 25 % off when the lens blur and the source blur are free
  // to smear the glints. So a period the glint count confirmed needs
  // min_explained, one it found too weak to call needs min_explained_alone.
  // min_explained_alone stays at 0.9: at 0.85 grazing renders (α = 120°,
  // the bench sweep's scene) passed with 86 % explained and spacings up to
  // 4.6 stated errors off.
  double min_explained = 0.8;
  double min_explained_alone = 0.9;
  // Relative errors always counted for what the model leaves out (a real
  // thread is no exact sinusoid; pixels are not exact boxes). The radius's
  // error, which scales both, is counted apart (ApplyCombFit). They are
  // the systematic share of the errors, common to every photograph of a
  // sample (Quantity::common). Measured on noise-free renders, the radius's
  // error taken out (a radius short by ε makes m long by about ε): the max
  // slope comes out within 0.001 % at 10° and mostly within 0.01-0.02 % at
  // −60° and 90°, the wavelength within 0.005 %. Over 8 noise draws of each
  // fixture scene (scripts/noise_draws.py) the max slope's mean error on
  // the comb fixtures runs from −0.23 % (the cylinder's ends in view) to
  // +0.12 % (clipped glints), most within ±0.03 %: with a 0.1 % floor every
  // draw lies within 3 stated errors, rms z at most 1.8 per fixture. (Before
  // the quadrature's extrapolation the means reached +0.32 % and the floor
  // was 0.2 %.)
  double slope_floor = 0.001;
  double wavelength_floor = 0.0003;
  // Relative errors for the glint model's mismatch with threads of another
  // make, measured on photographs from a renderer that shares no code with
  // weavefit (scripts/independent_scenes.py: round threads, rounded glint
  // bands, threads along the axis glinting between them): over 10 comb fits
  // the max slope came out 0.1-1.2 % off (2.3 % at 5 px per period), either
  // sign, and the wavelength 0.08-0.33 % off (0.5 %), at up to 9.7 stated
  // errors with the floors alone. Common to a sample's photographs, as the
  // floors (ApplyCombFit).
  double slope_mismatch = 0.005;
  double wavelength_mismatch = 0.0015;
  // The same for the mirror azimuth (rad), and the offset from half the
  // stated phase angle beyond 3 standard errors that is reported as an
  // inconsistent phase angle.
  double mirror_floor_rad = 0.03 * 3.14159265358979323846 / 180.0;
  double mirror_tolerance_rad = 0.25 * 3.14159265358979323846 / 180.0;
  // Where the comb alone converges but falls short (explaining less than
  // min_explained, or needing a lens PSF the limbs do not show), a second
  // fit models the axial threads' floats, which hide the circumferential
  // thread and its glints once a period (FitGlintComb). Where a period
  // spans many pixels the comb alone smears its PSF over the glints it
  // predicts there: on weavefit's renders of a plain weave at 43-139 px
  // per period it explained 47-78 % of the rows, or 93 % with a PSF of
  // 2.9 px where the limbs showed none, and was refused.
  bool model_floats = true;
  // Where the glints are placed (FitGlintComb): on the mean cylinder, or
  // where their facets stand off it (the threads' relief parallax,
  // DESIGN.md §3, which moves each by up to h0·sin(φ − v)), or both fitted
  // and the one that explains more kept.
  enum class Relief { kCompare, kMeanCylinder, kOnFacets };
  Relief relief = Relief::kCompare;

  absl::Status Validate() const;
};

struct CombFitResult {
  bool converged = false;
  double max_slope = 0.0;
  double max_slope_stderr = 0.0;
  double wavelength_mm = 0.0;
  double wavelength_stderr_mm = 0.0;
  double blur_rad = 0.0;        // σ of the source in the mirror miss
  double psf_px = 0.0;          // σ of the lens PSF along the arc, px
  // The mirror's offset from (α + v)/2: 0 when the stated phase angle is
  // right (the fit leaves it free and so measures the phase angle: α + 2δ).
  double mirror_offset_rad = 0.0;
  double mirror_offset_stderr_rad = 0.0;
  double reduced_chi2 = 0.0;    // against the noise scale of the residuals
  // Share of the rows' variance about their baselines the glints explain.
  double explained = 0.0;
  int rows_used = 0;
  int threads_used = 0;         // distinct threads among the rows
  int iterations = 0;
  // The share of each period where axial threads' floats hide the comb
  // (0 where they were not modelled).
  double hidden_share = 0.0;
  // Whether the glints were placed where their facets stand off the mean
  // cylinder (the threads' relief parallax: FitGlintComb).
  bool relief_parallax = false;
  std::string message;          // why it is not converged
};

// The most a comb fit's lens PSF (σ, px) may exceed the limbs' own blur.
inline constexpr double kCombMaxExtraPsfPx = 1.5;

// Whether a comb fit's lens PSF is one the limbs could show: at most twice
// their blur or kCombMaxExtraPsfPx more. A sawtooth's two columns of
// caustic glints (independently rendered, under a smooth grazing scatter)
// were explained to 92 % by a "sinusoid" of twice the period smeared by a
// 4.7 px PSF, its limbs sharp, and reported a SINUSOID with λ 7.42 ± 0.03 mm
// for 4.0. On the fixtures' confirmed fits the PSF is 0.10-0.52 px with
// sharp limbs, 0.80 px with limbs blurred by 0.79 px.
bool CombPsfPlausible(double psf_px, double lens_blur_px);

// The rows to fit and each one's weave phase c (mm, from the glint
// positions), grouped into threads: neighbouring rows whose phases agree.
// One row per thread first (up to max_rows), then further rows of each.
struct CombRows {
  std::vector<int> rows;         // image rows (anchors on the axis)
  std::vector<double> phase_mm;  // c in arc length s = R·φ
  std::vector<int> thread;       // thread index of each row
};
absl::StatusOr<CombRows> ChooseCombRows(const ArcSignals& signals, const GlintModel& model,
                                        double wavelength_mm, int max_rows);
// The same rows with their phases read again at `wavelength_mm` (a row
// whose glints give none there keeps its phase): a second fit on the rows
// of a first, from its answer.
absl::StatusOr<CombRows> RephaseCombRows(const ArcSignals& signals, const GlintModel& model,
                                         double wavelength_mm, const CombRows& rows);

// Fits the comb to the chosen rows' pixels (covering the whole lobe and a
// margin), starting from model.max_slope and `wavelength_mm` (the glint
// period's). Each bin is modelled as the exact average over its footprint.
// The standard errors are cluster-robust over threads (rows of one thread
// share its phase and their residuals are correlated): the bias-reduced CR2
// form (stats/cluster_covariance.h), not the plain covariance.
// INVALID_ARGUMENT when too few rows hold pixels.
absl::StatusOr<CombFitResult> FitGlintComb(const ArcPixels& pixels, const CombRows& rows,
                                           const GlintModel& model, double wavelength_mm,
                                           const CombFitOptions& options);

// Two readings of one period: a comb fit's and a lattice's of glint lines
// (the threads' pitch `pitch_mm` ± `pitch_stderr_mm`; the period is twice
// it, or the pitch itself for a lattice that is not lines along the axis:
// the one nearer the comb's is compared). Where they differ by more than
// twice their own errors combined (the comb's fitted error with its floor,
// scaled by the misfit; not the limbs' scale, which both share),
// `counted_mm` is the difference, which a period from such a comb must
// count in its error; 0 where they agree. A comb that explains only part of
// the rows can be pulled by the lines it does not model, the more so the
// fewer pixels a period spans (the shared photographs at 0.3 of their size,
// 6 px per period: the comb read 1.2 % short with an error of 0.2 %, the
// lines 0.5 % short).
struct PeriodReadings {
  double lattice_mm = 0.0;
  double counted_mm = 0.0;
};
PeriodReadings ComparePeriods(const CombFitResult& comb, const CombFitOptions& options,
                              double pitch_mm, double pitch_stderr_mm);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_GLINTS_COMB_FIT_H_
