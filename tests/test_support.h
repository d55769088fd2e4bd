// Shared support for tests that span modules: running the real binaries,
// reading fixtures and their truth sidecars.
#ifndef WEAVEFIT_TESTS_TEST_SUPPORT_H_
#define WEAVEFIT_TESTS_TEST_SUPPORT_H_

#include <google/protobuf/message.h>
#include <google/protobuf/struct.pb.h>
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "tests/temp_dir.h"

namespace weavefit::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs argv[0] with arguments, no shell, capturing stdout and stderr.
CommandResult RunCommand(const std::vector<std::string>& argv);

// Sends `request` to 127.0.0.1:port and returns the whole response, headers
// included (empty when nothing answers).
std::string RawHttp(int port, const std::string& request);
// GET `path` over HTTP/1.0.
std::string HttpGet(int port, const std::string& path);

std::string ReadFileOrDie(const std::string& path);
void WriteFileOrDie(const std::string& path, const std::string& bytes);

// The fixture images (png, tiff, exr, jpg) in `dir`, sorted.
std::vector<std::string> FixtureImages(const std::string& dir);
// The parsed sidecar of an image (stem + ".json").
google::protobuf::Struct ReadSidecar(const std::string& image);
// A number at sidecar[object][field]; nullopt when absent.
std::optional<double> SidecarNumber(const google::protobuf::Struct& s,
                                    const std::string& object,
                                    const std::string& field);
std::string SidecarString(const google::protobuf::Struct& s,
                          const std::string& object, const std::string& field);
bool SidecarBool(const google::protobuf::Struct& s, const std::string& object,
                 const std::string& field);

// The fields of a reply (EstimateReply, JointEstimate, or any message that
// holds weavefit.v1.Measurement fields, at any depth) that are marked
// resolved but carry a NaN or an infinity, as paths such as
// "channels[1].peak_spacing_deg.stderr". Empty for a sound reply.
std::vector<std::string> NonFiniteResolvedFields(const google::protobuf::Message& reply);
// Fails the current test, naming them, unless NonFiniteResolvedFields is
// empty: every test that parses a reply calls it (issue 30).
void ExpectFiniteReply(const google::protobuf::Message& reply);

// A weavefitd child process on an ephemeral loopback port.
class Daemon {
 public:
  // Starts the daemon and waits for its port file; extra flags appended.
  explicit Daemon(const std::vector<std::string>& extra_flags = {});
  ~Daemon();
  int port() const { return port_; }
  // The Prometheus port when --metrics-listen was given, else 0.
  int metrics_port() const { return metrics_port_; }
  // The plaintext health port when --health-listen was given, else 0.
  int health_port() const { return health_port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  // The daemon's own temporary folder (its port file and log live there).
  const std::string& dir() const { return dir_; }
  std::string Log() const;
  bool running() const;
  void Signal(int signal) const;
  pid_t pid() const { return pid_; }
  // Sends SIGTERM and waits; returns the exit status (or -1).
  int Stop();

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  int metrics_port_ = 0;
  int health_port_ = 0;
  std::string dir_;
};

}  // namespace weavefit::testing

#endif  // WEAVEFIT_TESTS_TEST_SUPPORT_H_
