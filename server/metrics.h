// weavefitd's Prometheus metrics: counters, gauges and histograms kept in
// memory, rendered in the Prometheus text exposition format (version 0.0.4),
// and served over HTTP on --metrics-listen (civetweb). prometheus-cpp is not
// packaged in Debian bookworm, so the few metric types needed are here.
#ifndef WEAVEFIT_SERVER_METRICS_H_
#define WEAVEFIT_SERVER_METRICS_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

struct mg_context;

namespace weavefit {

// A cumulative histogram with fixed upper bounds (the "le" labels).
class Histogram {
 public:
  explicit Histogram(std::vector<double> upper_bounds);
  void Observe(double value);
  // "name_bucket{le=...} n", "name_sum", "name_count" lines.
  std::string Render(const std::string& name) const;

 private:
  std::vector<double> bounds_;
  mutable std::mutex mutex_;
  std::vector<long long> counts_;  // per bucket, not cumulative; last = +Inf
  double sum_ = 0.0;
  long long count_ = 0;
};

class Metrics {
 public:
  Metrics();

  // One finished call of `method` ("Estimate", "EstimateJoint") with its
  // gRPC status code name ("OK", "INVALID_ARGUMENT", ...).
  void CountRequest(const std::string& method, const std::string& code);
  void AddInFlight(int delta) { in_flight_ += delta; }
  // What the service holds, read at render time.
  struct Load {
    int queue_depth = 0;             // complete uploads waiting for a worker
    int uploads = 0;                 // uploads in progress
    std::int64_t upload_bytes = 0;   // image bytes uploads hold (until decoded)
    std::int64_t memory_bytes = 0;   // working memory of the running estimates
  };
  void SetLoadSource(std::function<Load()> source);

  Histogram queue_seconds;     // admitted until a worker slot is held
  Histogram decode_seconds;    // decoding the upload
  Histogram fit_seconds;       // every stage after decoding
  Histogram request_seconds;   // the whole call
  Histogram received_bytes;    // upload size per photograph

  std::string Render() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, std::string>, long long> requests_;
  std::atomic<int> in_flight_{0};
  std::function<Load()> load_;
};

// GET /metrics on `listen` (host:port; port 0 = any free port), from a
// civetweb thread; stopped when destroyed.
class MetricsEndpoint {
 public:
  static absl::StatusOr<std::unique_ptr<MetricsEndpoint>> Start(const std::string& listen,
                                                                const Metrics* metrics);
  ~MetricsEndpoint();
  int port() const { return port_; }

 private:
  MetricsEndpoint() = default;
  mg_context* context_ = nullptr;
  int port_ = 0;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_METRICS_H_
