#include "client/files.h"

#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace weavefit {

absl::StatusOr<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return absl::DataLossError(absl::StrCat("cannot read ", path));
  return buffer.str();
}

absl::Status WriteFile(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", tmp));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    return absl::UnavailableError(absl::StrCat("cannot rename ", tmp, " to ", path));
  }
  return absl::OkStatus();
}

std::string SidecarPath(const std::string& image) {
  const std::size_t dot = image.find_last_of('.');
  const std::size_t slash = image.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) {
    return image + ".json";
  }
  return image.substr(0, dot) + ".json";
}

std::optional<google::protobuf::Struct> ReadSidecar(const std::string& image) {
  absl::StatusOr<std::string> text = ReadFile(SidecarPath(image));
  if (!text.ok()) return std::nullopt;
  google::protobuf::Struct sidecar;
  if (!google::protobuf::util::JsonStringToMessage(*text, &sidecar).ok()) {
    return std::nullopt;
  }
  return sidecar;
}

std::optional<double> StructNumber(const google::protobuf::Struct& s,
                                   const std::string& object,
                                   const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end() || !o->second.has_struct_value()) return std::nullopt;
  auto f = o->second.struct_value().fields().find(field);
  if (f == o->second.struct_value().fields().end() ||
      f->second.kind_case() != google::protobuf::Value::kNumberValue) {
    return std::nullopt;
  }
  return f->second.number_value();
}

}  // namespace weavefit
