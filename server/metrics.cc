#include "server/metrics.h"

#include <civetweb.h>

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

std::string FormatValue(double value) {
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  return absl::StrFormat("%.15g", value);
}

// Seconds from 1 ms to 2 min; bytes from 64 KiB to 256 MiB.
std::vector<double> SecondsBounds() {
  return {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 120};
}
std::vector<double> BytesBounds() {
  std::vector<double> bounds;
  for (double b = 64.0 * 1024; b <= 256.0 * 1024 * 1024; b *= 4) bounds.push_back(b);
  return bounds;
}

// Every reply is formatted here and written whole: civetweb's mg_printf runs
// glibc's vsnprintf on civetweb's own threads, whose stacks are small and
// fixed (Debian's build) and share their top with the process's static
// TLS. Under AddressSanitizer a few hundred bytes more TLS elsewhere in the
// daemon made that vsnprintf overflow the stack on the first /metrics
// request, and the daemon died.
void Send(mg_connection* connection, const std::string& text) {
  mg_write(connection, text.data(), text.size());
}

int ServeMetrics(mg_connection* connection, void* data) {
  const auto* metrics = static_cast<const Metrics*>(data);
  const std::string body = metrics->Render();
  Send(connection,
       absl::StrCat("HTTP/1.1 200 OK\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\n"
                    "Content-Length: ",
                    body.size(), "\r\nConnection: close\r\n\r\n", body));
  return 200;
}

// Every other path, and every error civetweb would report itself: Debian's
// civetweb 1.15 crashes formatting its own error pages, so none is left to it.
int ServeNotFound(mg_connection* connection, void*) {
  static const char kBody[] = "only /metrics is served here\n";
  Send(connection, absl::StrCat("HTTP/1.1 404 Not Found\r\nContent-Type: text/plain\r\n"
                                "Content-Length: ",
                                sizeof(kBody) - 1, "\r\nConnection: close\r\n\r\n", kBody));
  return 404;
}

int ServeError(mg_connection* connection, int status, const char*) {
  Send(connection, absl::StrCat("HTTP/1.1 ", status,
                                " Error\r\nContent-Type: text/plain\r\nContent-Length: 0\r\n"
                                "Connection: close\r\n\r\n"));
  return 0;  // handled
}

}  // namespace

Histogram::Histogram(std::vector<double> upper_bounds)
    : bounds_(std::move(upper_bounds)), counts_(bounds_.size() + 1, 0) {}

void Histogram::Observe(double value) {
  std::size_t bucket = 0;
  while (bucket < bounds_.size() && value > bounds_[bucket]) ++bucket;
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_[bucket];
  sum_ += value;
  ++count_;
}

std::string Histogram::Render(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  long long cumulative = 0;
  for (std::size_t i = 0; i <= bounds_.size(); ++i) {
    cumulative += counts_[i];
    const double le = i < bounds_.size() ? bounds_[i] : INFINITY;
    absl::StrAppend(&out, name, "_bucket{le=\"", FormatValue(le), "\"} ", cumulative, "\n");
  }
  absl::StrAppend(&out, name, "_sum ", FormatValue(sum_), "\n", name, "_count ", count_, "\n");
  return out;
}

Metrics::Metrics()
    : queue_seconds(SecondsBounds()),
      decode_seconds(SecondsBounds()),
      fit_seconds(SecondsBounds()),
      request_seconds(SecondsBounds()),
      received_bytes(BytesBounds()) {}

void Metrics::CountRequest(const std::string& method, const std::string& code) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++requests_[{method, code}];
}

void Metrics::SetLoadSource(std::function<Load()> source) {
  std::lock_guard<std::mutex> lock(mutex_);
  load_ = std::move(source);
}

std::string Metrics::Render() const {
  std::string out;
  absl::StrAppend(&out,
                  "# HELP weavefit_requests_total Finished calls by method and gRPC status code.\n"
                  "# TYPE weavefit_requests_total counter\n");
  Load load;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [key, count] : requests_) {
      absl::StrAppend(&out, "weavefit_requests_total{method=\"", key.first, "\",code=\"",
                      key.second, "\"} ", count, "\n");
    }
    if (load_) load = load_();
  }
  absl::StrAppend(&out,
                  "# HELP weavefit_requests_in_flight Calls being read, queued or estimated.\n"
                  "# TYPE weavefit_requests_in_flight gauge\n"
                  "weavefit_requests_in_flight ", in_flight_.load(), "\n",
                  "# HELP weavefit_queue_depth Complete uploads admitted, not yet holding a "
                  "worker.\n"
                  "# TYPE weavefit_queue_depth gauge\n"
                  "weavefit_queue_depth ", load.queue_depth, "\n");
  absl::StrAppend(&out,
                  "# HELP weavefit_uploads_in_progress Calls still receiving their upload.\n"
                  "# TYPE weavefit_uploads_in_progress gauge\n"
                  "weavefit_uploads_in_progress ", load.uploads, "\n",
                  "# HELP weavefit_upload_bytes_held Image bytes received and not yet decoded.\n"
                  "# TYPE weavefit_upload_bytes_held gauge\n"
                  "weavefit_upload_bytes_held ", load.upload_bytes, "\n",
                  "# HELP weavefit_estimate_memory_bytes Working memory reserved by the running "
                  "estimates (against --memory-budget-mb).\n"
                  "# TYPE weavefit_estimate_memory_bytes gauge\n"
                  "weavefit_estimate_memory_bytes ", load.memory_bytes, "\n");
  const std::pair<const char*, const Histogram*> histograms[] = {
      {"weavefit_queue_seconds", &queue_seconds},
      {"weavefit_decode_seconds", &decode_seconds},
      {"weavefit_fit_seconds", &fit_seconds},
      {"weavefit_request_seconds", &request_seconds},
      {"weavefit_received_bytes", &received_bytes},
  };
  const char* help[] = {
      "Time from admission to holding a worker slot.",
      "Time to decode one photograph.",
      "Time of every stage after decoding, per photograph.",
      "Time of the whole call.",
      "Size of one uploaded photograph.",
  };
  for (std::size_t i = 0; i < std::size(histograms); ++i) {
    absl::StrAppend(&out, "# HELP ", histograms[i].first, " ", help[i], "\n# TYPE ",
                    histograms[i].first, " histogram\n",
                    histograms[i].second->Render(histograms[i].first));
  }
  return out;
}

absl::StatusOr<std::unique_ptr<MetricsEndpoint>> MetricsEndpoint::Start(
    const std::string& listen, const Metrics* metrics) {
  // civetweb takes "host:port" as listening_ports; it wants no brackets for
  // IPv4 and a plain port for all interfaces.
  mg_init_library(0);
  const char* options[] = {"listening_ports", listen.c_str(), "num_threads", "2",
                           "request_timeout_ms", "5000", nullptr};
  mg_callbacks callbacks{};
  callbacks.http_error = ServeError;
  std::unique_ptr<MetricsEndpoint> endpoint(new MetricsEndpoint());
  endpoint->context_ = mg_start(&callbacks, nullptr, options);
  if (endpoint->context_ == nullptr) {
    return absl::UnavailableError(absl::StrCat("could not serve metrics on ", listen));
  }
  mg_set_request_handler(endpoint->context_, "/metrics$", ServeMetrics,
                         const_cast<Metrics*>(metrics));
  mg_set_request_handler(endpoint->context_, "/", ServeNotFound, nullptr);
  mg_server_port ports[4];
  const int n = mg_get_server_ports(endpoint->context_, 4, ports);
  if (n > 0) endpoint->port_ = ports[0].port;
  return endpoint;
}

MetricsEndpoint::~MetricsEndpoint() {
  if (context_ != nullptr) mg_stop(context_);
}

}  // namespace weavefit
