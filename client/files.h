// Files the client reads and writes: whole files, written atomically, and
// the truth/acquisition sidecar IMAGE-stem.json beside an image.
#ifndef WEAVEFIT_CLIENT_FILES_H_
#define WEAVEFIT_CLIENT_FILES_H_

#include <google/protobuf/struct.pb.h>

#include <optional>
#include <string>

#include "absl/status/statusor.h"

namespace weavefit {

absl::StatusOr<std::string> ReadFile(const std::string& path);

// Writes via a temporary file and a rename, so nothing is half-written.
absl::Status WriteFile(const std::string& path, const std::string& bytes);

// IMAGE-stem.json for IMAGE.ext.
std::string SidecarPath(const std::string& image);

// The sidecar, parsed, when it exists and is JSON.
std::optional<google::protobuf::Struct> ReadSidecar(const std::string& image);

// sidecar[object][field] when it is a number.
std::optional<double> StructNumber(const google::protobuf::Struct& s, const std::string& object,
                                   const std::string& field);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_FILES_H_
