#include "estimator/glints/weave_lattice.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "estimator/stats/median.h"

namespace weavefit {
namespace {

// Samples per block of the shading taken out of a row: 32 px at the arc
// signals' half-pixel step, short enough to follow a Lambertian or stray-lit
// body's shading, long enough that one glint line (about 3 px wide) leaves
// its median on the body.
constexpr int kShadingBlock = 64;

// The row's shading: medians of blocks (of the samples not left out, when a
// block has any), interpolated linearly between the blocks' centres.
std::vector<double> RowShading(const float* v, const std::vector<bool>& left_out, int n) {
  const int blocks = std::max(1, n / kShadingBlock);
  std::vector<double> centre(blocks);
  std::vector<double> level(blocks);
  std::vector<double> part;
  for (int b = 0; b < blocks; ++b) {
    const int lo = b * n / blocks;
    const int hi = (b + 1) * n / blocks;
    part.clear();
    for (int k = lo; k < hi; ++k) {
      if (!left_out[k]) part.push_back(v[k]);
    }
    if (part.empty()) part.assign(v + lo, v + hi);
    level[b] = Median(part);
    centre[b] = 0.5 * (lo + hi - 1);
  }
  std::vector<double> shading(n);
  int b = 0;
  for (int k = 0; k < n; ++k) {
    while (b + 2 < blocks && k > centre[b + 1]) ++b;
    if (blocks == 1) {
      shading[k] = level[0];
      continue;
    }
    const double t = std::clamp((k - centre[b]) / (centre[b + 1] - centre[b]), 0.0, 1.0);
    shading[k] = level[b] + t * (level[b + 1] - level[b]);
  }
  return shading;
}

// One row's deviation from its shading in noise sigmas, clamped (a clipped
// sample counts as a glint), 0 where left out. (Each arc is its own
// window: its lines' phase is unrelated to another arc's across the lobe.)
std::vector<float> ClampedRow(const ArcSignals& signals, int row, double noise, double clamp,
                              const std::vector<std::pair<double, double>>& leave_out) {
  const int n = signals.num_samples;
  const float* v = signals.Row(row);
  const std::uint8_t* ok = &signals.valid[static_cast<std::size_t>(row) * n];
  std::vector<bool> left_out(n, false);
  for (const auto& [from, to] : leave_out) {
    if (!(signals.step_rad > 0.0) || !(to > from)) continue;
    const int lo = std::max(0, static_cast<int>(std::ceil(
                                   (from - signals.first_azimuth_rad) / signals.step_rad)));
    const int hi = std::min(n - 1, static_cast<int>(std::floor(
                                       (to - signals.first_azimuth_rad) / signals.step_rad)));
    for (int k = lo; k <= hi; ++k) left_out[k] = true;
  }
  const std::vector<double> shading = RowShading(v, left_out, n);
  std::vector<float> x(n, 0.0f);
  for (int k = 0; k < n; ++k) {
    if (left_out[k]) continue;
    x[k] = static_cast<float>(ok[k] ? std::clamp((v[k] - shading[k]) / noise, -clamp, clamp)
                                    : clamp);
  }
  return x;
}

// The Hann window over n samples (HannWeight), computed once per length.
const std::vector<double>& HannWindow(int n) {
  thread_local std::vector<double> window;
  if (static_cast<int>(window.size()) != n) {
    window.resize(n);
    for (int k = 0; k < n; ++k) window[k] = HannWeight(k, n);
  }
  return window;
}

// Samples [lo, hi) of a clamped row under a Hann window of their own.
std::vector<float> Windowed(const std::vector<float>& z, int lo, int hi) {
  const int n = hi - lo;
  const std::vector<double>& w = HannWindow(n);
  std::vector<float> x(n);
  for (int k = 0; k < n; ++k) x[k] = static_cast<float>(z[lo + k] * w[k]);
  return x;
}

// The power spectrum of a windowed row zero-padded to `size`, bins 0..size/2:
// OpenCV's real-input transform, its spectrum packed (CCS: the real parts of
// bins 0 and size/2 alone, then each bin's real and imaginary parts).
std::vector<double> PowerOf(const std::vector<float>& row, int size) {
  thread_local cv::Mat in;
  thread_local cv::Mat out;
  in.create(1, size, CV_32F);
  float* x = in.ptr<float>();
  std::copy(row.begin(), row.end(), x);
  std::fill(x + row.size(), x + size, 0.0f);
  cv::dft(in, out);
  const float* c = out.ptr<float>();
  std::vector<double> power(size / 2 + 1);
  power[0] = double(c[0]) * c[0];
  const int pairs = (size - 1) / 2;  // bins 1..pairs as (re, im) at 2k-1, 2k
  for (int k = 1; k <= pairs; ++k) {
    power[k] = double(c[2 * k - 1]) * c[2 * k - 1] + double(c[2 * k]) * c[2 * k];
  }
  if (size % 2 == 0) power[size / 2] = double(c[size - 1]) * c[size - 1];
  return power;
}

// How the lattice's power at `cycles` per sample is spread over the rows:
// each row's amplitude at that frequency, transformed along the rows (in
// image order), and the share of that power within ±kAlignedBins of zero
// frequency along the axis (`aligned`), and within ±kAlignedBins of the
// strongest frequency beyond them and of its negative (`checker`). Lines
// of threads running along the axis (wandering slowly) keep `aligned` near
// 1; a plain weave's circumferential relief, neighbouring threads half a
// period out of step, puts the power at the frequency with which those
// threads alternate along the axis (`checker`); rows of unrelated phase
// spread it evenly, each window holding about (2·kAlignedBins + 1)/rows of
// it. The arcs' powers add (every arc is read along the same rows).
constexpr int kAlignedBins = 2;

struct RowSpread {
  double aligned = 0.0;
  double checker = 0.0;
};

RowSpread SpreadOverRows(const std::vector<std::vector<std::vector<float>>>& arcs, double cycles) {
  std::vector<double> along_power;
  double reach = 0.0;
  for (const std::vector<std::vector<float>>& rows : arcs) {
    if (rows.size() < 8) continue;
    const int size = cv::getOptimalDFTSize(static_cast<int>(rows.size()));
    if (!along_power.empty() && static_cast<int>(along_power.size()) != size) continue;
    along_power.resize(size, 0.0);
    cv::Mat amplitude = cv::Mat::zeros(1, size, CV_64FC2);
    // The frequency's phasors, the same for every row of the arc.
    std::vector<std::complex<double>> phasor;
    for (std::size_t r = 0; r < rows.size(); ++r) {
      std::complex<double> at = 0.0;
      const std::vector<float>& x = rows[r];
      for (std::size_t k = phasor.size(); k < x.size(); ++k) {
        phasor.push_back(std::polar(1.0, -2.0 * M_PI * cycles * k));
      }
      for (std::size_t k = 0; k < x.size(); ++k) at += double(x[k]) * phasor[k];
      amplitude.at<cv::Vec2d>(0, static_cast<int>(r)) = {at.real(), at.imag()};
    }
    cv::Mat along;
    cv::dft(amplitude, along, cv::DFT_COMPLEX_OUTPUT);
    reach = kAlignedBins * static_cast<double>(size) / rows.size();
    for (int j = 0; j < size; ++j) {
      const cv::Vec2d c = along.at<cv::Vec2d>(0, j);
      along_power[j] += c[0] * c[0] + c[1] * c[1];
    }
  }
  RowSpread spread;
  const int size = static_cast<int>(along_power.size());
  double total = 0.0;
  for (double p : along_power) total += p;
  if (!(total > 0.0)) return spread;
  // Power within ±reach bins of bin j (circularly).
  const int half = static_cast<int>(std::floor(reach));
  auto window = [&](int j) {
    double sum = 0.0;
    for (int d = -half; d <= half; ++d) sum += along_power[((j + d) % size + size) % size];
    return sum;
  };
  spread.aligned = window(0) / total;
  // Rows that alternate put their power at ±their frequency alike (a real
  // pattern of signs along the axis): both windows count, once each where
  // they meet at the Nyquist frequency.
  for (int j = 2 * half + 1; 2 * j <= size; ++j) {
    const int overlap = std::max(0, 2 * half + 1 - (size - 2 * j));
    double both = window(j) + window(size - j);
    for (int b = 0; b < overlap; ++b) both -= along_power[j + half - b];
    spread.checker = std::max(spread.checker, both / total);
  }
  return spread;
}

// The local maximum of `power` nearest `k` within ±reach bins, refined by a
// parabola through the logarithms of it and its neighbours (a Hann window's
// main lobe is close to a Gaussian, whose logarithm is a parabola).
double RefinePeak(const std::vector<double>& power, double k, int reach) {
  const int last = static_cast<int>(power.size()) - 2;
  const int at = std::clamp(static_cast<int>(std::lround(k)), 1, last);
  int best = at;
  for (int j = std::max(1, at - reach); j <= std::min(last, at + reach); ++j) {
    if (power[j] > power[best]) best = j;
  }
  const double a = std::log(std::max(power[best - 1], 1e-300));
  const double b = std::log(std::max(power[best], 1e-300));
  const double c = std::log(std::max(power[best + 1], 1e-300));
  const double d = a - 2.0 * b + c;
  return best + (d < 0.0 ? std::clamp(0.5 * (a - c) / d, -0.5, 0.5) : 0.0);
}

// The lattice seen in a summed spectrum: bins of the band [k_lo, k_hi] and
// the power above the band's median (the floor of clamped noise, which a
// lattice's narrow harmonics barely move), in units of that floor.
struct Spectrum {
  int k_lo = 0;
  int k_hi = 0;
  std::vector<double> excess;  // per bin, 0 below the floor

  // The excess at the harmonic nearest bin k, within ±1 bin (the Hann
  // window's main lobe spans ±2 bins at twofold zero padding).
  double Near(double k) const {
    const int at = static_cast<int>(std::lround(k));
    double e = 0.0;
    for (int j = std::max(0, at - 1); j <= std::min(static_cast<int>(excess.size()) - 1, at + 1); ++j) {
      e = std::max(e, excess[j]);
    }
    return e;
  }
  // The lattice's harmonics summed: every line of a lattice of fundamental
  // bin k lies at a multiple of k (epoch folding in the frequency domain).
  double Harmonics(double k) const {
    double h = 0.0;
    for (int j = 1; j * k <= k_hi + 1; ++j) h += Near(j * k);
    return h;
  }
};

Spectrum MakeSpectrum(const std::vector<double>& power, int k_lo, int k_hi) {
  Spectrum s;
  s.k_lo = k_lo;
  s.k_hi = k_hi;
  std::vector<double> band(power.begin() + k_lo, power.begin() + k_hi + 1);
  const double floor = std::max(Median(band), 1e-300);
  s.excess.assign(power.size(), 0.0);
  for (std::size_t k = 0; k < power.size(); ++k) s.excess[k] = std::max(0.0, power[k] / floor - 1.0);
  return s;
}

// A share of the strongest harmonic sum that the fundamental must reach:
// folded at twice its pitch a lattice keeps all its harmonics (and at half
// its pitch only the even ones, about half of them), so the shortest pitch
// whose harmonics hold most of the strongest sum is the lines' own.
constexpr double kFundamentalShare = 0.7;

// Steps of the harmonic sum's search, in bins: fine enough that the 10th
// harmonic of a step's fundamental lies within the ±1 bin Near() searches.
constexpr double kSearchStep = 0.1;

// The fundamental (in bins) of the lattice: the highest local maximum of the
// harmonic sum that reaches kFundamentalShare of the strongest; -1 if none.
double FundamentalBin(const Spectrum& s) {
  const int steps = static_cast<int>((s.k_hi - s.k_lo) / kSearchStep);
  std::vector<double> h(steps + 1, 0.0);
  double top = 0.0;
  for (int i = 0; i <= steps; ++i) {
    h[i] = s.Harmonics(s.k_lo + i * kSearchStep);
    top = std::max(top, h[i]);
  }
  for (int i = steps - 1; i > 0; --i) {
    if (h[i] >= h[i - 1] && h[i] >= h[i + 1] && h[i] >= kFundamentalShare * top && h[i] > 0.0) {
      return s.k_lo + i * kSearchStep;
    }
  }
  return -1.0;
}

// The fundamental refined from every harmonic that stands out, each weighed
// by its excess (the j-th harmonic places the fundamental j times better).
double RefineFundamental(const std::vector<double>& power, const Spectrum& s, double k0,
                         double min_excess) {
  double num = 0.0;
  double den = 0.0;
  for (int j = 1; j * k0 <= s.k_hi + 1; ++j) {
    const double e = s.Near(j * k0);
    if (e < min_excess) continue;
    const double kj = RefinePeak(power, j * RefinePeak(power, k0, 1), 2);
    num += e * j * kj;
    den += e * j * j;
  }
  return den > 0.0 ? num / den : k0;
}

// The jackknife's standard error from the estimates without each group.
double JackknifeError(const std::vector<double>& without) {
  const double n = static_cast<double>(without.size());
  double mean = 0.0;
  for (double k : without) mean += k / n;
  double var = 0.0;
  for (double k : without) var += (k - mean) * (k - mean);
  return std::sqrt(var * (n - 1.0) / n);
}

// The fundamental of a stretch's spectrum near bin k0, refined harmonic by
// harmonic: each harmonic is looked for where the fundamental so far puts
// it, so a local pitch a few percent from the lattice's is followed up to
// its highest harmonics. Each harmonic that stands out is weighed by its
// excess (the j-th places the fundamental j times better); -1 if none does.
double FollowHarmonics(const std::vector<double>& power, const Spectrum& s, double k0,
                       double min_excess) {
  double k = RefinePeak(power, k0, 1);
  double num = 0.0;
  double den = 0.0;
  for (int j = 1; j * k <= s.k_hi + 1; ++j) {
    const double e = s.Near(j * k);
    if (e < min_excess) continue;
    const double kj = RefinePeak(power, j * k, 2);
    num += e * j * kj;
    den += e * j * j;
    k = num / den;
  }
  return den > 0.0 ? k : -1.0;
}

// Stretches of arc along which the local pitch is read: at least this many
// of the lattice's pitches long (the harmonics then stand ±2 bins clear of
// each other's windows at fourfold padding).
constexpr double kLocalPitches = 5.0;
// How far a stretch's pitch may lie from the lattice's and still be its
// lines: a glint sliding over a round thread shortens the local pitch by at
// most ρ/R ≤ p/2R (glints/round_threads.h), 4 % for a 2 mm pitch on a 23 mm
// radius; a stretch whose harmonics lie further off holds other structure.
constexpr double kLocalReach = 0.05;

// The lattice's pitch along stretches of each arc (AxialPitch::local): each
// stretch's rows windowed on their own and their spectra summed, the
// fundamental followed from the lattice's, a jackknife error over the same
// groups of rows; a stretch whose harmonics do not stand out, or lie beyond
// kLocalReach, gives none.
std::vector<LocalPitch> LocalPitches(const std::vector<ArcSignals>& arcs,
                                     const std::vector<std::vector<std::vector<float>>>& clamped,
                                     double pitch_samples, int groups, double min_excess) {
  std::vector<LocalPitch> local;
  for (std::size_t a = 0; a < arcs.size(); ++a) {
    const int n = arcs[a].num_samples;
    const int stretches = static_cast<int>(n / (kLocalPitches * pitch_samples));
    if (stretches < 1 || clamped[a].size() < 2) continue;
    for (int t = 0; t < stretches; ++t) {
      const int lo = t * n / stretches;
      const int hi = (t + 1) * n / stretches;
      const int size = cv::getOptimalDFTSize(4 * (hi - lo));
      std::vector<std::vector<double>> group_power(groups, std::vector<double>(size / 2 + 1, 0.0));
      for (std::size_t r = 0; r < clamped[a].size(); ++r) {
        const std::vector<double> p = PowerOf(Windowed(clamped[a][r], lo, hi), size);
        std::vector<double>& g = group_power[r % groups];
        for (std::size_t k = 0; k < p.size(); ++k) g[k] += p[k];
      }
      std::vector<double> total(size / 2 + 1, 0.0);
      for (const std::vector<double>& g : group_power) {
        for (std::size_t k = 0; k < total.size(); ++k) total[k] += g[k];
      }
      const double k0 = size / pitch_samples;
      const int k_lo = std::max(2, static_cast<int>(0.5 * k0));
      if (size / 2 - 2 <= k_lo + 2) continue;
      const Spectrum spectrum = MakeSpectrum(total, k_lo, size / 2 - 2);
      const double k = FollowHarmonics(total, spectrum, k0, min_excess);
      if (k < 0.0 || std::fabs(k / k0 - 1.0) > kLocalReach) continue;
      std::vector<double> k_without;
      std::vector<double> rest(total.size());
      for (int g = 0; g < groups; ++g) {
        for (std::size_t j = 0; j < total.size(); ++j) rest[j] = total[j] - group_power[g][j];
        const double kg = FollowHarmonics(rest, spectrum, k0, min_excess);
        if (kg > 0.0) k_without.push_back(kg);
      }
      if (k_without.size() < 2) continue;
      const double k_se = JackknifeError(k_without);
      // No spread at all: every group stopped on the same bin, no reading.
      if (!(k_se > 0.0)) continue;
      LocalPitch lp;
      lp.azimuth_rad = arcs[a].first_azimuth_rad + 0.5 * (lo + hi - 1) * arcs[a].step_rad;
      lp.pitch_mm = size / k * arcs[a].StepMm();
      lp.stderr_mm = lp.pitch_mm * k_se / k;
      local.push_back(lp);
    }
  }
  return local;
}

// The rows' power spectra, clamped and windowed (EstimateAxialPitch), summed
// in groups of rows for the jackknife.
struct RowPower {
  int n = 0;             // the longest arc's samples
  double step_mm = 0.0;  // its step
  int size = 0;          // the transform's length
  int rows = 0;
  std::vector<std::vector<double>> group;
  std::vector<double> total;
  std::vector<std::vector<std::vector<float>>> clamped;
  std::vector<std::vector<std::vector<float>>> windowed;
};

RowPower SumRowPowers(const std::vector<ArcSignals>& arcs, double pixel_noise,
                      const AxialPitchOptions& options,
                      const std::vector<std::pair<double, double>>& leave_out) {
  RowPower rp;
  for (const ArcSignals& a : arcs) {
    if (a.rows.empty()) continue;
    if (a.num_samples > rp.n) rp.step_mm = a.StepMm();
    rp.n = std::max(rp.n, a.num_samples);
    rp.rows += static_cast<int>(a.rows.size());
  }
  rp.size = cv::getOptimalDFTSize(2 * rp.n);
  const int groups = std::clamp(rp.rows / 2, 2, options.jackknife_groups);
  rp.group.assign(groups, std::vector<double>(rp.size / 2 + 1, 0.0));
  // Noise of a sample interpolated between pixels is at most one pixel's.
  const double noise = std::max(pixel_noise, 1e-9);
  int count = 0;
  for (const ArcSignals& a : arcs) {
    rp.clamped.emplace_back();
    rp.windowed.emplace_back();
    for (std::size_t i = 0; i < a.rows.size(); ++i, ++count) {
      rp.clamped.back().push_back(
          ClampedRow(a, static_cast<int>(i), noise, options.clamp_sigmas, leave_out));
      rp.windowed.back().push_back(Windowed(rp.clamped.back().back(), 0, a.num_samples));
      const std::vector<double> p = PowerOf(rp.windowed.back().back(), rp.size);
      std::vector<double>& g = rp.group[count % groups];
      for (std::size_t k = 0; k < p.size(); ++k) g[k] += p[k];
    }
  }
  rp.total.assign(rp.size / 2 + 1, 0.0);
  for (const std::vector<double>& g : rp.group) {
    for (std::size_t k = 0; k < rp.total.size(); ++k) rp.total[k] += g[k];
  }
  return rp;
}

// The lattice over pitches from `shortest` samples up to the longest arc
// over min_pitches: its fundamental, contrast, spread over the rows and
// kind, and whether it is found.
AxialPitch ReadLattice(const RowPower& rp, const std::vector<ArcSignals>& arcs, double shortest,
                       const AxialPitchOptions& options) {
  AxialPitch result;
  result.rows_used = rp.rows;
  const int size = rp.size;
  const int k_lo = std::max(2, static_cast<int>(std::ceil(size * options.min_pitches / rp.n)));
  const int k_hi = std::min(size / 2 - 2, static_cast<int>(std::floor(size / shortest)));
  if (k_hi <= k_lo + 2) {
    result.reason = "the lit arc is too short to resolve a thread pitch";
    return result;
  }
  const Spectrum spectrum = MakeSpectrum(rp.total, k_lo, k_hi);
  const double k0 = FundamentalBin(spectrum);
  result.contrast = k0 > 0.0 ? spectrum.Near(k0) + 1.0 : 0.0;
  auto too_weak = [&](const std::string& rows) {
    return absl::StrFormat(
        "no lattice of thread glints: the rows' spectra peak at most %.1f times above their "
        "floor, %.0f needed (%.0f where the rows alternate from one circumferential thread to "
        "the next with %.0f%% of its power, as a plain weave's do%s)",
        result.contrast, options.min_contrast, options.min_alternating_contrast,
        100.0 * options.min_weak_checker_share, rows);
  };
  if (k0 < 0.0 ||
      result.contrast < std::min(options.min_contrast, options.min_alternating_contrast)) {
    result.reason = too_weak("");
    return result;
  }
  const bool strong = result.contrast >= options.min_contrast;
  result.half_contrast = spectrum.Near(0.5 * k0) + 1.0;
  // The harmonics that place the fundamental stand out as far as a lattice
  // must.
  const double min_excess =
      (strong ? options.min_contrast : options.min_alternating_contrast) - 1.0;
  const double k_peak = RefineFundamental(rp.total, spectrum, k0, min_excess);
  // Jackknife over the groups of rows, the harmonics chosen once.
  const int groups = static_cast<int>(rp.group.size());
  std::vector<double> k_without(groups);
  std::vector<double> rest(rp.total.size());
  for (int g = 0; g < groups; ++g) {
    for (std::size_t k = 0; k < rest.size(); ++k) rest[k] = rp.total[k] - rp.group[g][k];
    k_without[g] = RefineFundamental(rest, spectrum, k0, min_excess);
  }
  const double k_se = JackknifeError(k_without);
  const double pitch_samples = size / k_peak;
  result.pitches_in_arc = rp.n / pitch_samples;
  const RowSpread spread = SpreadOverRows(rp.windowed, k_peak / size);
  result.aligned = spread.aligned;
  result.checker = spread.checker;
  result.half_aligned = SpreadOverRows(rp.windowed, 0.5 * k_peak / size).aligned;
  result.lines = result.aligned >= options.min_aligned_share;
  result.alternating = !result.lines && result.checker >= options.min_checker_share;
  if (result.pitches_in_arc < options.min_pitches) {
    result.reason = absl::StrFormat(
        "the lit arc holds only %.1f pitches of the thread glints' lattice, %.0f needed",
        result.pitches_in_arc, options.min_pitches);
    return result;
  }
  if (!strong && !(result.alternating && result.checker >= options.min_weak_checker_share)) {
    result.reason = too_weak(absl::StrFormat("; these hold %.0f%%", 100.0 * result.checker));
    return result;
  }
  result.found = true;
  result.pitch_mm = pitch_samples * rp.step_mm;
  result.pitch_stderr_mm = result.pitch_mm * k_se / k_peak;
  result.local = LocalPitches(arcs, rp.clamped, pitch_samples, groups, min_excess);
  return result;
}

}  // namespace

absl::Status AxialPitchOptions::Validate() const {
  if (!(min_px_per_pitch > 0.0) || !(min_pitches >= 2.0) || !(clamp_sigmas > 0.0) ||
      !(min_contrast > 1.0) || !(min_alternating_contrast > 1.0) ||
      !(min_aligned_share > 0.0 && min_aligned_share <= 1.0) ||
      !(min_checker_share > 0.0 && min_checker_share <= 1.0) ||
      !(min_weak_checker_share > 0.0 && min_weak_checker_share <= 1.0) || jackknife_groups < 2) {
    return absl::InvalidArgumentError(
        "axial pitch options: min_px_per_pitch and clamp_sigmas must be positive, min_pitches at "
        "least 2, min_contrast and min_alternating_contrast above 1, min_aligned_share, "
        "min_checker_share and min_weak_checker_share within (0, 1] and jackknife_groups at least "
        "2");
  }
  return absl::OkStatus();
}

absl::StatusOr<AxialPitch> EstimateAxialPitch(
    const std::vector<ArcSignals>& arcs, double step_px, double pixel_noise,
    const AxialPitchOptions& options, const std::vector<std::pair<double, double>>& leave_out) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (!(step_px > 0.0)) return absl::InvalidArgumentError("axial pitch: step_px must be positive");
  int n = 0;  // the longest arc's samples
  int rows = 0;
  for (const ArcSignals& a : arcs) {
    n = std::max(n, a.rows.empty() ? 0 : a.num_samples);
    rows += static_cast<int>(a.rows.size());
  }
  // Pitches from min_px_per_pitch up to the longest arc over min_pitches, in
  // samples.
  const double shortest = options.min_px_per_pitch / step_px;
  if (rows < 2 || n / options.min_pitches <= shortest) {
    AxialPitch none;
    none.rows_used = rows;
    none.reason = absl::StrFormat(
        "the lit arc beside the lobe (%d samples at most) is too short to hold %.0f thread "
        "pitches",
        n, options.min_pitches);
    return none;
  }
  return ReadLattice(SumRowPowers(arcs, pixel_noise, options, leave_out), arcs, shortest, options);
}

}  // namespace weavefit
