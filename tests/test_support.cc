#include "tests/test_support.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <fcntl.h>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

extern char** environ;

namespace weavefit::testing {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

// Appends the non-finite numbers of a resolved Measurement in `m` (itself
// at `path`), then walks every message field below.
void CollectNonFinite(const Message& m, const std::string& path,
                      std::vector<std::string>* out) {
  const google::protobuf::Descriptor* type = m.GetDescriptor();
  const google::protobuf::Reflection* reflection = m.GetReflection();
  if (type->full_name() == "weavefit.v1.Measurement") {
    const FieldDescriptor* resolved = type->FindFieldByName("resolved");
    if (resolved == nullptr || !reflection->GetBool(m, resolved)) return;
    for (int i = 0; i < type->field_count(); ++i) {
      const FieldDescriptor* f = type->field(i);
      if (f->cpp_type() != FieldDescriptor::CPPTYPE_DOUBLE) continue;
      if (!std::isfinite(reflection->GetDouble(m, f))) out->push_back(path + "." + f->name());
    }
    return;
  }
  std::vector<const FieldDescriptor*> fields;
  reflection->ListFields(m, &fields);
  for (const FieldDescriptor* f : fields) {
    if (f->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string at = path.empty() ? f->name() : path + "." + f->name();
    if (!f->is_repeated()) {
      CollectNonFinite(reflection->GetMessage(m, f), at, out);
      continue;
    }
    for (int k = 0; k < reflection->FieldSize(m, f); ++k) {
      CollectNonFinite(reflection->GetRepeatedMessage(m, f, k), at + "[" + std::to_string(k) + "]",
                       out);
    }
  }
}

}  // namespace

std::vector<std::string> NonFiniteResolvedFields(const Message& reply) {
  std::vector<std::string> fields;
  CollectNonFinite(reply, "", &fields);
  return fields;
}

void ExpectFiniteReply(const Message& reply) {
  const std::vector<std::string> fields = NonFiniteResolvedFields(reply);
  std::string names;
  for (const std::string& f : fields) names += (names.empty() ? "" : ", ") + f;
  EXPECT_TRUE(fields.empty()) << "resolved but not finite: " << names << "\n"
                              << reply.DebugString();
}

// Sends `request` to 127.0.0.1:port; the whole response, headers included.
std::string RawHttp(int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string response;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    if (write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
      char buffer[4096];
      ssize_t n;
      while ((n = read(fd, buffer, sizeof(buffer))) > 0) response.append(buffer, n);
    }
  }
  close(fd);
  return response;
}

std::string HttpGet(int port, const std::string& path) {
  return RawHttp(port, "GET " + path + " HTTP/1.0\r\nHost: localhost\r\n\r\n");
}

CommandResult RunCommand(const std::vector<std::string>& argv) {
  const std::string dir = MakeTempDir();
  const std::string out_path = dir + "/out";
  const std::string err_path = dir + "/err";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  CommandResult result;
  if (posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ) != 0) {
    ADD_FAILURE() << "cannot start " << argv[0];
    return result;
  }
  posix_spawn_file_actions_destroy(&actions);
  int status = 0;
  waitpid(pid, &status, 0);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = ReadFileOrDie(out_path);
  result.err = ReadFileOrDie(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  rmdir(dir.c_str());
  return result;
}

std::string ReadFileOrDie(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << "cannot read " << path;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void WriteFileOrDie(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << "cannot write " << path;
}

std::vector<std::string> FixtureImages(const std::string& dir) {
  std::vector<std::string> images;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* entry = readdir(d)) {
      const std::string name = entry->d_name;
      const std::size_t dot = name.find_last_of('.');
      if (dot == std::string::npos) continue;
      const std::string ext = name.substr(dot + 1);
      if (ext == "png" || ext == "tiff" || ext == "exr" || ext == "jpg") {
        images.push_back(dir + "/" + name);
      }
    }
    closedir(d);
  }
  std::sort(images.begin(), images.end());
  return images;
}

google::protobuf::Struct ReadSidecar(const std::string& image) {
  const std::string path = image.substr(0, image.find_last_of('.')) + ".json";
  google::protobuf::Struct sidecar;
  const auto status = google::protobuf::util::JsonStringToMessage(ReadFileOrDie(path), &sidecar);
  EXPECT_TRUE(status.ok()) << path << ": " << status.ToString();
  return sidecar;
}

std::optional<double> SidecarNumber(const google::protobuf::Struct& s,
                                    const std::string& object,
                                    const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end()) return std::nullopt;
  auto f = o->second.struct_value().fields().find(field);
  if (f == o->second.struct_value().fields().end()) return std::nullopt;
  return f->second.number_value();
}

std::string SidecarString(const google::protobuf::Struct& s,
                          const std::string& object, const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end()) return "";
  auto f = o->second.struct_value().fields().find(field);
  if (f == o->second.struct_value().fields().end()) return "";
  return f->second.string_value();
}

bool SidecarBool(const google::protobuf::Struct& s, const std::string& object,
                 const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end()) return false;
  auto f = o->second.struct_value().fields().find(field);
  return f != o->second.struct_value().fields().end() && f->second.bool_value();
}

Daemon::Daemon(const std::vector<std::string>& extra_flags) {
  dir_ = MakeTempDir();
  const std::string port_file = dir_ + "/port";
  std::vector<std::string> argv = {WEAVEFITD_PATH, "--port-file", port_file, "--workers", "2"};
  if (std::find(extra_flags.begin(), extra_flags.end(), "--listen") == extra_flags.end()) {
    argv.insert(argv.end(), {"--listen", "127.0.0.1:0"});
  }
  argv.insert(argv.end(), extra_flags.begin(), extra_flags.end());
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string log = dir_ + "/weavefitd.log";
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) {
    ADD_FAILURE() << "cannot start " << WEAVEFITD_PATH;
    pid_ = -1;
  }
  posix_spawn_file_actions_destroy(&actions);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (pid_ > 0 && std::chrono::steady_clock::now() < deadline) {
    std::ifstream in(port_file);
    if (in >> port_) {
      in >> metrics_port_ >> health_port_;  // 0 when off
      break;
    }
    if (!running()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (port_ == 0) ADD_FAILURE() << "weavefitd did not report a port";
}

std::string Daemon::Log() const {
  std::ifstream in(dir_ + "/weavefitd.log");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void Daemon::Signal(int signal) const {
  if (pid_ > 0) kill(pid_, signal);
}

bool Daemon::running() const {
  if (pid_ <= 0) return false;
  int status = 0;
  return waitpid(pid_, &status, WNOHANG) == 0;
}

int Daemon::Stop() {
  if (pid_ <= 0) return -1;
  kill(pid_, SIGTERM);
  int status = 0;
  const pid_t waited = waitpid(pid_, &status, 0);
  pid_ = -1;
  if (waited <= 0 || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

Daemon::~Daemon() {
  if (pid_ > 0) {
    kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

}  // namespace weavefit::testing
