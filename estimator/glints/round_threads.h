// The axial threads' pitch from where their glint lines stand (DESIGN.md §3).
// An axial thread is round: it glints where its own normal bisects the light
// and the view, at the mirror azimuth μ, which on a thread lying at azimuth φ
// is ρ·sin(μ − φ) of arc from its top (ρ the radius of curvature of the
// thread's top). Across the cylinder φ changes and the glint slides over
// its thread, so the lines stand closer than the threads:
//     local pitch = p·(1 − κ·cos(μ − φ)),   κ = ρ / R,
// 1-3 % on a woven surface (ρ a quarter of a pitch or more, pitches of
// 0.5-2 mm, R = 23 mm),
// and a photograph's lines are read mostly 20-80° from μ, where the cosine
// is 0.2-0.95. κ is fitted to the local pitches along the arc
// (AxialPitch::local, beside the lobe) with a prior on ρ from a plain
// weave's threads, which decides it where the stretches' azimuths span too
// little to show the slope; the threads' pitch is then the lattice's
// times 1 + κ·(the lattice's mean cosine).
#ifndef WEAVEFIT_ESTIMATOR_GLINTS_ROUND_THREADS_H_
#define WEAVEFIT_ESTIMATOR_GLINTS_ROUND_THREADS_H_

#include <vector>

#include "absl/status/status.h"
#include "estimator/glints/weave_lattice.h"
#include "estimator/profile/arc_signals.h"

namespace weavefit {

struct RoundThreadOptions {
  // Prior on ρ, in axial pitches: the middle of the range a lattice can
  // show, 0 to 1/2 (ThreadPitchFromGlints), with its ends 1.7 sigmas out.
  // A plain weave's round threads, covering half to nine tenths of the
  // pitch, glint with ρ = 0.25-0.45; under stray light the threads' own
  // texture, which does not slide, mixes lines at the threads' places into
  // the lattice, and it shows less.
  double radius_pitches = 0.25;
  double radius_pitches_sd = 0.15;
  // How far one stretch's pitch scatters about the model, relative, beyond
  // its jackknife error: the threads' spacing wanders along the arc the
  // same way in every row, which a jackknife over rows does not see.
  double local_scatter = 0.002;

  absl::Status Validate() const;
};

struct ThreadPitch {
  double pitch_mm = 0.0;          // between the threads' tops
  double pitch_stderr_mm = 0.0;
  // The part of pitch_stderr_mm that is ρ's: photographs of one sample
  // share it.
  double model_stderr_mm = 0.0;
  double glint_radius_mm = 0.0;   // ρ, fitted (or the prior's)
  double glint_radius_stderr_mm = 0.0;
  // The lattice's mean cos(μ − φ): the apparent pitch is short by κ times it.
  double mean_cos = 0.0;
  int stretches = 0;              // local pitches fitted
};

// `apparent` is EstimateAxialPitch's reading of `arcs` (found), `mirror_rad`
// the mirror azimuth μ.
ThreadPitch ThreadPitchFromGlints(const AxialPitch& apparent, const std::vector<ArcSignals>& arcs,
                                  double mirror_rad, const RoundThreadOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_GLINTS_ROUND_THREADS_H_
