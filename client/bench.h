// `weavefit bench`: every estimator mode over a folder of photographs with
// truth sidecars (the fixtures by default), in-process. Writes one CSV row
// per image and method (time per stage, error and stated error per
// quantity, resolved flags), a per-method summary, and a chart of median
// time against median peak-spacing error drawn with gnuplot (PNG and SVG).
#ifndef WEAVEFIT_CLIENT_BENCH_H_
#define WEAVEFIT_CLIENT_BENCH_H_

#include <string>
#include <vector>

namespace weavefit {

struct BenchFlags {
  std::vector<std::string> inputs;  // images or folders; default fixtures/
  std::string out_dir = "bench-out";
  std::vector<std::string> modes = {"fast", "balanced", "accurate"};
  int repeats = 3;                  // timed runs per image and mode (median kept)
  bool no_chart = false;            // CSV only
  // The stability study instead: scenes rendered along the axes where
  // methods fail, `seeds` noise draws per point.
  bool sweep = false;
  int seeds = 3;
  // The speed report instead: a 4096×3072 16-bit PNG and the same image as
  // EXR (rendered once into out_dir), timed against the targets.
  bool perf = false;
  std::string daemon_path;  // weavefitd; default: beside this client's build
};

// Returns the process exit status: 0, or a gRPC-style code on failure.
int RunBench(const BenchFlags& flags);

// `weavefit bench --sweep`: renders a sinusoid scene (coarse weave, m 0.24,
// 320×240) along six axes — max slope toward zero, noise up, source blur up,
// pixels per thread period down, phase angle toward grazing, axis tilt up —
// and runs every mode on each; writes sweep.csv (one row per render and
// mode), sweep_summary.csv (per axis point and mode: median |spacing error|,
// the share of wrong answers — a wrong model or a spacing more than 3 stated
// errors off — and of unresolved ones where the truth is resolvable) and two
// charts, sweep_error and sweep_failures (PNG and SVG).
int RunSweep(const BenchFlags& flags);

// `weavefit bench --perf`: decoding alone, the in-process estimate per mode
// (and the stages after decoding), through a weavefitd on loopback, the
// daemon's peak memory against the decoded image, and two concurrent clients
// against one; each figure printed beside its target (issue 6) and written
// to perf.csv. Timings are medians of `repeats` runs on this machine.
int RunPerf(const BenchFlags& flags);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_BENCH_H_
