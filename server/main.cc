// weavefitd: the weavefit estimation daemon.
#include <glog/logging.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <fstream>
#include <iostream>
#include <thread>

#include <malloc.h>

#include "server/server.h"

int main(int argc, char** argv) {
  // glibc gives each thread that allocates its own arena and keeps what is
  // freed there; with gRPC's thread pool every request could leave a 12 Mpx
  // image's worth behind in another arena. Two arenas bound that.
  mallopt(M_ARENA_MAX, 2);
  weavefit::ServerOptions options;
  double max_upload_mb = 64.0;
  double max_megapixels = 64.0;
  double grace_s = 30.0;
  std::string port_file;
  options.service.workers =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));

  CLI::App app{"weavefitd: thread geometry of glossy woven materials, served over gRPC"};
  app.add_option("--listen", options.listen, "host:port to listen on (port 0 = any free port)")
      ->capture_default_str();
  app.add_option("--max-upload-mb", max_upload_mb, "largest accepted upload, MiB")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--max-megapixels", max_megapixels, "largest accepted decoded image, megapixels")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--workers", options.service.workers, "estimates that run at once")
      ->capture_default_str()->check(CLI::Range(1, 256));
  app.add_option("--max-joint-photographs", options.service.max_joint_photographs,
                 "most photographs in one EstimateJoint call")
      ->capture_default_str()->check(CLI::Range(1, 256));
  app.add_option("--shutdown-grace-s", grace_s, "time given to requests in flight on SIGINT/SIGTERM, s")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--port-file", port_file, "write the bound port to this file once serving");
  CLI11_PARSE(app, argc, argv);

  FLAGS_logtostderr = true;
  google::InitGoogleLogging(argv[0]);
  options.service.max_upload_bytes = static_cast<std::int64_t>(max_upload_mb * (1 << 20));
  options.service.estimate.max_pixels = static_cast<std::int64_t>(max_megapixels * 1e6);

  // SIGINT and SIGTERM are taken by sigwait below, in this thread only:
  // block them before gRPC starts its threads.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto server = weavefit::StartServer(options);
  if (!server.ok()) {
    std::cerr << "weavefitd: " << server.status().message() << "\n";
    return 1;
  }
  if (!port_file.empty()) {
    const std::string tmp = port_file + ".tmp";
    std::ofstream(tmp) << (*server)->port() << "\n";
    std::rename(tmp.c_str(), port_file.c_str());  // appears complete or not at all
  }
  int received = 0;
  sigwait(&signals, &received);
  LOG(INFO) << "signal " << received << ": draining (grace " << grace_s << " s)";
  (*server)->Shutdown(std::chrono::milliseconds(static_cast<long long>(grace_s * 1000)));
  LOG(INFO) << "weavefitd stopped";
  return 0;
}
