// weavefitd: the weavefit estimation daemon.
#include <glog/logging.h>
#include <malloc.h>
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include "server/server.h"
#include "proto/weavefit/v1/convert.h"

namespace {

// SIGHUP: re-reads the token file, and logs what that changed.
void ReloadTokens(const weavefit::ServerOptions& options, weavefit::RunningServer& server) {
  if (options.token_file.empty()) {
    LOG(INFO) << "SIGHUP: no --token-file to re-read; nothing changed";
    return;
  }
  const absl::StatusOr<int> tokens = server.ReloadTokens();
  if (!tokens.ok()) {
    LOG(ERROR) << "SIGHUP: " << tokens.status().message() << "; the previous tokens stay in force";
    return;
  }
  LOG(INFO) << "SIGHUP: token file re-read: " << *tokens << (*tokens == 1 ? " token" : " tokens")
            << " in force";
}

}  // namespace

int main(int argc, char** argv) {
  // glibc gives each thread that allocates its own arena and keeps what is
  // freed there; with gRPC's thread pool every request could leave a 12 Mpx
  // image's worth behind in another arena. Two arenas bound that.
  mallopt(M_ARENA_MAX, 2);
  // And glibc raises its mmap threshold to the largest block freed (up to
  // 32 MB), after which an upload or a saturation mask is carved from an
  // arena and its pages stay behind: after four requests of a 12 Mpx 16-bit
  // PNG the peak resident set was 168.7 MiB with glibc's default and
  // 153.1 MiB with this fixed threshold, which gives every large buffer
  // back when it is freed.
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  weavefit::ServerOptions options;
  weavefit::ServiceOptions& service = options.service;
  double max_upload_mb = 64.0;
  double max_call_mb = 256.0;
  double max_megapixels = 64.0;
  double max_upload_memory_mb = 1024.0;
  // Half the machine's memory by default: room for the uploads, gRPC and
  // the system beside the estimates.
  const double physical_mb = static_cast<double>(sysconf(_SC_PHYS_PAGES)) *
                             static_cast<double>(sysconf(_SC_PAGE_SIZE)) / (1 << 20);
  double memory_budget_mb = physical_mb > 0 ? std::floor(physical_mb / 2) : 4096.0;
  double grace_s = 30.0;
  std::string port_file;
  service.workers = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  service.max_queue = 2 * service.workers;

  CLI::App app{"weavefitd: thread geometry of glossy woven materials, served over gRPC"};
  app.set_version_flag("--version", std::string("weavefitd ") + weavefit::WeavefitVersion());
  app.add_option("--listen", options.listen,
                 "host:port to listen on (port 0 = any free port); an address other than "
                 "loopback needs TLS or --insecure-remote")
      ->capture_default_str();
  auto* limits = "Limits (checked before the work they protect)";
  app.add_option("--max-upload-mb", max_upload_mb, "largest accepted upload per photograph, MiB")
      ->capture_default_str()->check(CLI::Range(0.001, 65536.0))->group(limits);
  app.add_option("--max-call-mb", max_call_mb,
                 "largest total upload of one call (an EstimateJoint carries several), MiB")
      ->capture_default_str()->check(CLI::Range(0.001, 1048576.0))->group(limits);
  app.add_option("--max-megapixels", max_megapixels,
                 "largest decoded image, megapixels (read from the file's header before decoding)")
      ->capture_default_str()->check(CLI::Range(0.001, 100000.0))->group(limits);
  app.add_option("--max-chunks", service.max_chunks, "most chunk messages in one call")
      ->capture_default_str()->check(CLI::Range(1, 100000000))->group(limits);
  app.add_option("--max-uploads", service.max_uploads,
                 "uploads in progress at once (each holds no estimation slot until complete); "
                 "past that, RESOURCE_EXHAUSTED")
      ->capture_default_str()->check(CLI::Range(1, 100000))->group(limits);
  app.add_option("--max-upload-memory-mb", max_upload_memory_mb,
                 "image bytes all uploads in progress and waiting may hold together, MiB; a "
                 "chunk past that gets RESOURCE_EXHAUSTED")
      ->capture_default_str()->check(CLI::Range(1.0, 1048576.0))->group(limits);
  app.add_option("--upload-idle-s", service.upload_idle_s,
                 "an upload that sends nothing for this long is cut with DEADLINE_EXCEEDED, s")
      ->capture_default_str()->check(CLI::Range(0.01, 86400.0))->group(limits);
  app.add_option("--memory-budget-mb", memory_budget_mb,
                 "working memory of the estimates running at once, read from each image's "
                 "header before decoding, MiB (default: half the machine's memory); a "
                 "photograph that needs more alone gets RESOURCE_EXHAUSTED, others wait")
      ->capture_default_str()->check(CLI::Range(16.0, 16777216.0))->group(limits);
  app.add_option("--max-concurrent,--workers", service.workers,
                 "estimates that run at once (default: one per core)")
      ->capture_default_str()->check(CLI::Range(1, 256))->group(limits);
  app.add_option("--max-queue", service.max_queue,
                 "calls admitted beyond those running, waiting with their upload in memory; "
                 "past that, RESOURCE_EXHAUSTED at once (default: two per core)")
      ->capture_default_str()->check(CLI::Range(0, 4096))->group(limits);
  app.add_option("--deadline-s", service.deadline_s,
                 "longest a call may take, upload included, s (a client's shorter deadline wins)")
      ->capture_default_str()->check(CLI::Range(0.001, 86400.0))->group(limits);
  app.add_option("--max-joint-photographs", service.max_joint_photographs,
                 "most photographs in one EstimateJoint call")
      ->capture_default_str()->check(CLI::Range(1, 256))->group(limits);
  auto* access = "Access control";
  app.add_option("--tls-cert", options.tls_cert, "server certificate chain (PEM); enables TLS")
      ->check(CLI::ExistingFile)->group(access);
  app.add_option("--tls-key", options.tls_key, "server private key (PEM)")
      ->check(CLI::ExistingFile)->group(access);
  app.add_option("--tls-client-ca", options.tls_client_ca,
                 "CA (PEM) that signs client certificates; when given, clients must present one "
                 "(mutual TLS)")
      ->check(CLI::ExistingFile)->group(access);
  app.add_option("--token-file", options.token_file,
                 "bearer tokens, one per line ('#' comments); every WeaveFit call then needs "
                 "'authorization: Bearer <token>'. Re-read on SIGHUP")
      ->check(CLI::ExistingFile)->group(access);
  app.add_flag("--insecure-remote", options.insecure_remote,
               "allow a non-loopback --listen without TLS, and a non-loopback --metrics-listen "
               "(always plaintext); trusted networks only")
      ->group(access);
  app.add_flag("--reflection", options.reflection,
               "serve gRPC reflection on a non-loopback address too (always on for loopback)")
      ->group(access);
  auto* operation = "Operation";
  app.add_option("--metrics-listen", options.metrics_listen,
                 "host:port for Prometheus metrics at /metrics, plaintext HTTP (off when "
                 "empty); an address other than loopback needs --insecure-remote")
      ->group(operation);
  app.add_option("--health-listen", options.health_listen,
                 "host:port of a plaintext port serving only grpc.health.v1, for probes that "
                 "cannot speak TLS (off when empty)")
      ->group(operation);
  app.add_option("--shutdown-grace-s", grace_s,
                 "on SIGTERM/SIGINT, time given to calls in flight before they are cancelled, s")
      ->capture_default_str()->check(CLI::Range(0.0, 3600.0))->group(operation);
  app.add_option("--port-file", port_file,
                 "once serving, write the bound ports to this file: gRPC, then metrics and "
                 "health (0 when off), one per line")
      ->group(operation);
  CLI11_PARSE(app, argc, argv);

  FLAGS_logtostderr = true;
  google::InitGoogleLogging(argv[0]);
  service.max_upload_bytes = static_cast<std::int64_t>(max_upload_mb * (1 << 20));
  service.max_call_bytes = std::max(service.max_upload_bytes,
                                    static_cast<std::int64_t>(max_call_mb * (1 << 20)));
  service.estimate.max_pixels = static_cast<std::int64_t>(max_megapixels * 1e6);
  service.max_upload_memory_bytes = std::max(
      service.max_chunk_bytes, static_cast<std::int64_t>(max_upload_memory_mb * (1 << 20)));
  service.memory_budget_bytes = static_cast<std::int64_t>(memory_budget_mb * (1 << 20));
  if (!options.token_file.empty() && !options.tls() &&
      !weavefit::IsLoopbackAddress(options.listen)) {
    LOG(WARNING) << "bearer tokens will cross the network in clear text (no TLS)";
  }

  // SIGINT, SIGTERM and SIGHUP are taken by sigwait below, in this thread
  // only: block them before gRPC starts its threads.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto server = weavefit::StartServer(options);
  if (!server.ok()) {
    std::cerr << "weavefitd: " << server.status().message() << "\n";
    return 1;
  }
  if (!port_file.empty()) {
    const std::string tmp = port_file + ".tmp";
    {
      std::ofstream out(tmp);
      out << (*server)->port() << "\n";
      out << (*server)->metrics_port() << "\n" << (*server)->health_port() << "\n";
    }
    std::rename(tmp.c_str(), port_file.c_str());  // appears complete or not at all
  }
  for (;;) {
    int received = 0;
    sigwait(&signals, &received);
    if (received == SIGHUP) {
      ReloadTokens(options, **server);
      continue;
    }
    LOG(INFO) << "signal " << received << ": draining (grace " << grace_s << " s)";
    break;
  }
  (*server)->Shutdown(std::chrono::milliseconds(static_cast<long long>(grace_s * 1000)));
  LOG(INFO) << "weavefitd stopped";
  return 0;
}
