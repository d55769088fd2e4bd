// The axial threads' pitch from the lattice of their glints over the whole
// lit surface (DESIGN.md §3). Threads running along the axis glint as short
// lines wherever they pass over the circumferential threads, one every
// axial pitch of arc, from limb to terminator, not only inside the lobe; in a
// plain weave the undulation period λ is twice that pitch. One row holds
// dozens of them where the lobe holds a period or two, so the pitch is the
// robust first word on the period: the comb fit (glints/comb_fit.h), started
// from twice it, says the last.
//
// The estimate is the art conservators' thread count from X-radiographs
// (Johnson, Johnson and Erdmann 2013, DESIGN.md §3) on the rectified
// surface: each row along the arc, its smooth shading taken out and clamped
// to a few noise sigmas so that a lobe's bright glints weigh no more than the
// faint lines, is windowed, and the rows' power spectra are summed (the weave
// phase wanders from row to row, so their spectra add where their signals
// would cancel). The lattice's fundamental is the shortest pitch whose
// harmonics hold most of it (narrow lines have harmonics as strong as their
// fundamental), refined from every harmonic that stands out; its standard
// error is the jackknife's over groups of rows. Whether the lattice is lines
// along the axis at all, and not a plain weave's relief repeating with λ
// itself, is measured across the rows (AxialPitch::aligned, ::checker).
#ifndef WEAVEFIT_ESTIMATOR_GLINTS_WEAVE_LATTICE_H_
#define WEAVEFIT_ESTIMATOR_GLINTS_WEAVE_LATTICE_H_

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "estimator/profile/arc_signals.h"

namespace weavefit {

struct AxialPitchOptions {
  // Shortest pitch looked for, in pixels at the axis: half the 4 px per
  // period below which the period is unresolved (DESIGN.md §3).
  double min_px_per_pitch = 2.0;
  // The analysed arc must hold at least this many pitches. A lattice's
  // half frequency (the weave's period, when every other line differs) must
  // stand clear of a Hann window's zero-frequency lobe, which reaches 2
  // cycles per arc and carries the body's shading: with 6 lines in view it
  // lies a cycle beyond it; with 4, inside it, where shading and the
  // lattice's half cannot be told apart. A relief repeating with λ itself
  // needs as many: its fundamental's own lobe, 2 cycles either side, must
  // clear the shading's too (on a lab render a relief read over 4.3
  // periods, allowed for a test, came out 25 % short at 6 stated errors).
  double min_pitches = 6.0;
  // Each row's deviation from its shading is clamped to this many noise
  // sigmas: a glint line stands far above it, so lines of any brightness
  // weigh alike and a clipped lobe does not drown them, while noise keeps
  // its flat spectrum.
  double clamp_sigmas = 5.0;
  // The lattice's fundamental must stand this many times above the band's
  // median power. Summed over N rows, noise's power scatters by about 1/√N
  // of its mean, so a factor of 2 is already beyond noise; a lobe's glints
  // leaking beside it or the texture of stray light make weak structure, up
  // to 9 times the floor where too few lines were in view to be counted,
  // while a woven surface's lines over a few dozen rows stand 40 to 600
  // times above it.
  double min_contrast = 20.0;
  // A pattern whose rows alternate from one circumferential thread to the
  // next (`alternating`) need stand only this many times above the floor.
  // What min_contrast guards against, weak structure that is not the
  // weave's lattice, does not alternate at its own pitch: only the weave,
  // its neighbouring threads half a period out of step, does (its relief
  // under stray light, its circumferential glints), and then the pitch is
  // λ itself. What is left to exclude is noise, whose power summed over N
  // rows scatters by 1/√N of its floor (a quarter over 16 rows), so that
  // its strongest bin in the band stands about twice above it.
  double min_alternating_contrast = 4.0;
  // Below min_contrast the rows must alternate with at least this share
  // of the lattice's power (`checker`, above min_checker_share): at a low
  // contrast the noise's power, spread evenly over the rows, dilutes a true
  // checkerboard's share and lends a chance concentration to a pattern that
  // is not one. Alternating reliefs standing above min_contrast kept 0.63
  // to 0.90 on renders of lab scenes; a structure at a quarter of the
  // period on an independently rendered photograph, 12 times above the
  // floor, kept 0.51.
  double min_weak_checker_share = 0.6;
  // A lattice is lines along the axis (the axial threads, λ/2 apart) with
  // at least this share of its power in lines at the same azimuths from
  // row to row (`aligned`). A plain weave's circumferential relief (under
  // stray light, say), whose neighbouring threads are half a period out of
  // step, repeats along a row with λ itself and keeps a share near what
  // unrelated rows give (about 5 in 128 rows); threads along the axis,
  // wandering, keep a third or more.
  double min_aligned_share = 0.1;
  // A lattice not in lines along the axis is a plain weave's relief when
  // its rows alternate from one circumferential thread to the next with at
  // least this share of its power (`checker`). Each thread's pattern along
  // the arc repeats with λ, and its neighbour's, half a period out of step,
  // is the same pattern with its fundamental's sign turned, so the rows
  // alternate at the lattice's pitch only where that pitch is λ itself (a
  // pattern repeating with λ/2, the relief seen alike on both flanks, turns
  // by a whole period from thread to thread and stands in lines along the
  // axis). Alternating rows put 8/π² ≈ 0.81 of their power at ± the
  // frequency of the threads along the axis (a square wave's fundamental),
  // less where the threads wander; rows of unrelated phase about 2·5/rows
  // in any such pair of windows (0.08 over 128 rows) and rarely twice that
  // in the strongest. Half the power lies well between the two.
  double min_checker_share = 0.5;
  // Groups of rows for the jackknife error.
  int jackknife_groups = 8;

  absl::Status Validate() const;
};

// The lattice's pitch along one stretch of arc (AxialPitch::local).
struct LocalPitch {
  double azimuth_rad = 0.0;  // the stretch's middle
  double pitch_mm = 0.0;
  double stderr_mm = 0.0;    // jackknife over groups of rows
};

struct AxialPitch {
  bool found = false;
  double pitch_mm = 0.0;         // arc length between neighbouring lines
  double pitch_stderr_mm = 0.0;  // jackknife over groups of rows
  double contrast = 0.0;         // the peak's power over the band's median
  // The same at half the fundamental frequency.
  double half_contrast = 0.0;
  // The share of the lattice's power in lines at the same azimuths from
  // row to row (0-1; the arcs' rows must be in image order and evenly
  // spaced): near 1 for threads running along the axis; low for a plain
  // weave's circumferential relief, whose neighbouring threads are half a
  // period out of step and whose period along a row is λ itself.
  double aligned = 0.0;
  // The largest share of it in one narrow band of frequencies along the
  // axis away from zero (0-1): high where neighbouring rows of threads
  // alternate (a plain weave's relief, half a period out of step from one
  // circumferential thread to the next), about 5/rows or a few times that
  // for rows of unrelated phase.
  double checker = 0.0;
  // The share in lines at half the fundamental frequency.
  double half_aligned = 0.0;
  // What the lattice is: lines along the axis (aligned ≥
  // min_aligned_share), or rows alternating from one circumferential thread
  // to the next, a plain weave's pattern repeating with λ (not lines, and
  // checker ≥ min_checker_share), or neither.
  bool lines = false;
  bool alternating = false;
  double pitches_in_arc = 0.0;   // how many pitches the analysed arc holds
  int rows_used = 0;
  // The pitch along stretches of the arcs at least 5 pitches long, where
  // their harmonics stand near the lattice's (within 5 %): the lines' pitch
  // changes across the cylinder (glints/round_threads.h).
  std::vector<LocalPitch> local;
  std::string reason;            // why none was found (empty when found)
};

// `arcs` are stretches of the lit surface on one azimuth step (the lobe's
// circumferential glints, which repeat with λ and not with the pitch, left
// out between them), `step_px` that step in pixels at the axis and
// `pixel_noise` one pixel's noise sigma in the signals' units.
// The weight of sample k of n under the Hann window every arc (and every
// stretch of one) is read through: the lattice's power weighs a sample by
// its square.
inline double HannWeight(int k, int n) {
  return 0.5 - 0.5 * std::cos(2.0 * M_PI * (k + 0.5) / n);
}

// Samples within the azimuth ranges `leave_out` (radians, from < to) count
// as their row's shading: structure there that is not the lattice's (a
// lobe's caustics) is left out while the rows stay one window, whose lines
// keep their phase across the gap.
absl::StatusOr<AxialPitch> EstimateAxialPitch(
    const std::vector<ArcSignals>& arcs, double step_px, double pixel_noise,
    const AxialPitchOptions& options,
    const std::vector<std::pair<double, double>>& leave_out = {});

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_GLINTS_WEAVE_LATTICE_H_
