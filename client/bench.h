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
};

// Returns the process exit status: 0, or a gRPC-style code on failure.
int RunBench(const BenchFlags& flags);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_BENCH_H_
