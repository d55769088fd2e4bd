#include "client/batch.h"

#include <dirent.h>
#include <glob.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <random>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/files.h"
#include "client/report.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/pipeline/given_cylinder.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

bool IsDirectory(const std::string& path) {
  struct stat s;
  return stat(path.c_str(), &s) == 0 && S_ISDIR(s.st_mode);
}

bool IsRegularFile(const std::string& path) {
  struct stat s;
  return stat(path.c_str(), &s) == 0 && S_ISREG(s.st_mode);
}

bool Exists(const std::string& path) {
  struct stat s;
  return stat(path.c_str(), &s) == 0;
}

std::string Join(const std::string& folder, const std::string& name) {
  if (folder.empty() || folder == ".") return name;
  return absl::EndsWith(folder, "/") ? folder + name : folder + "/" + name;
}

// The image files of a folder, sorted by name.
std::vector<std::string> FolderImages(const std::string& folder) {
  std::vector<std::string> names;
  if (DIR* d = opendir(folder.c_str())) {
    while (const dirent* entry = readdir(d)) {
      const std::string name = entry->d_name;
      if (name.empty() || name[0] == '.' || !HasImageExtension(name)) continue;
      if (IsRegularFile(Join(folder, name))) names.push_back(name);
    }
    closedir(d);
  }
  std::sort(names.begin(), names.end());
  std::vector<std::string> paths;
  for (const std::string& name : names) paths.push_back(Join(folder, name));
  return paths;
}

// A CSV record (RFC 4180): its fields, the line it starts on, and whether
// its line end was read (a record cut off by the end of the text was not).
struct CsvRecord {
  std::vector<std::string> fields;
  int line = 0;
  bool terminated = false;
};

std::vector<CsvRecord> ParseCsv(const std::string& text) {
  std::vector<CsvRecord> records;
  std::size_t at = absl::StartsWith(text, "\xEF\xBB\xBF") ? 3 : 0;  // UTF-8 BOM
  int line = 1;
  while (at < text.size()) {
    CsvRecord record;
    record.line = line;
    std::string field;
    bool done = false;
    while (!done) {
      if (at < text.size() && text[at] == '"') {  // a quoted field
        ++at;
        for (;;) {
          if (at >= text.size()) break;  // cut off inside the quotes
          const char c = text[at++];
          if (c == '"') {
            if (at < text.size() && text[at] == '"') {
              field += '"';
              ++at;
              continue;
            }
            break;
          }
          if (c == '\n') ++line;
          field += c;
        }
      }
      // Up to the next comma or line end (the rest of an unquoted field, or
      // whatever follows a closing quote, kept as it is).
      while (at < text.size() && text[at] != ',' && text[at] != '\n') field += text[at++];
      if (at >= text.size()) {
        record.fields.push_back(field);
        done = true;
      } else if (text[at] == ',') {
        record.fields.push_back(field);
        field.clear();
        ++at;
      } else {  // '\n'
        if (absl::EndsWith(field, "\r")) field.pop_back();
        record.fields.push_back(field);
        record.terminated = true;
        ++at;
        ++line;
        done = true;
      }
    }
    records.push_back(std::move(record));
  }
  return records;
}

bool IsBlank(const CsvRecord& r) {
  return r.fields.size() == 1 && absl::StripAsciiWhitespace(r.fields[0]).empty();
}

absl::Status ManifestError(const std::string& name, int line, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat(name, ":", line, ": ", what));
}

// One batch's retries, shared by its workers: the jitter's generator, the
// hooks' lock and since when the daemon has been gone.
class BatchRun {
 public:
  BatchRun(const RetryPolicy& policy, const BatchHooks& hooks)
      : policy_(policy), hooks_(hooks), generator_(std::random_device{}()) {}

  // Image `index`, attempted until it succeeds, fails for good or runs out
  // of retries or of reconnect window; on_done called.
  ImageOutcome Image(std::size_t index) {
    const auto start = std::chrono::steady_clock::now();
    ImageOutcome outcome;
    int retries = 0;
    do {
      ++outcome.attempts;
      outcome.reply = hooks_.estimate(index);
    } while (TryAgain(index, &outcome.reply, &retries));
    outcome.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (hooks_.on_done) {
      std::lock_guard<std::mutex> lock(mutex_);
      hooks_.on_done(index, outcome);
    }
    return outcome;
  }

 private:
  // Whether image `index` is tried again after `reply`: at once when a gone
  // daemon is back, after a backoff (one of `retries` spent) when retries
  // are left. A daemon not back within the window becomes the reply.
  bool TryAgain(std::size_t index, absl::StatusOr<v1::EstimateReply>* reply, int* retries) {
    const absl::StatusCode code = reply->status().code();
    // Anything but these means a daemon answered (or the image needed none,
    // as when its file is unreadable): an outage is over.
    if (code != absl::StatusCode::kUnavailable && code != absl::StatusCode::kDeadlineExceeded) {
      OutageOver();
    }
    if (reply->ok() || !IsRetryable(code)) return false;
    if (code == absl::StatusCode::kUnavailable && WaitsForDaemon()) {
      const Reconnect reconnect = AwaitDaemon(index, reply->status());
      if (reconnect == Reconnect::kBack) return true;  // no retry spent
      if (reconnect == Reconnect::kGone) {
        *reply = NotBack(reply->status());
        return false;
      }
    }
    if (*retries >= policy_.max_retries) return false;
    const int retry = ++*retries;
    const double wait_s = BackoffSeconds(policy_, retry, Uniform());
    if (hooks_.on_retry) {
      std::lock_guard<std::mutex> lock(mutex_);
      hooks_.on_retry(index, reply->status(), retry, wait_s);
    }
    Sleep(wait_s);
    return true;
  }

  bool WaitsForDaemon() const { return hooks_.await_daemon && policy_.reconnect_window_s > 0.0; }

  // Waits for the channel for what is left of the window, which starts at
  // the first UNAVAILABLE since a daemon last answered: one clock for the
  // whole batch, so that a daemon that stays away costs each later image
  // nothing more than a look at the channel.
  Reconnect AwaitDaemon(std::size_t index, const absl::Status& failure) {
    const double start_s = Now();
    double left_s;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!gone_since_s_) gone_since_s_ = start_s;
      left_s = std::max(0.0, *gone_since_s_ + policy_.reconnect_window_s - start_s);
    }
    const Reconnect reconnect = hooks_.await_daemon(left_s);
    if (reconnect == Reconnect::kBack && hooks_.on_reconnected) {
      const double waited_s = Now() - start_s;
      std::lock_guard<std::mutex> lock(mutex_);
      hooks_.on_reconnected(index, failure, waited_s);
    }
    return reconnect;
  }

  // Only an answer ends an outage, not a reconnection: a daemon that
  // crashes on every call would otherwise hold the batch forever.
  void OutageOver() {
    std::lock_guard<std::mutex> lock(mutex_);
    gone_since_s_.reset();
  }

  absl::Status NotBack(const absl::Status& failure) const {
    return absl::UnavailableError(absl::StrCat("the daemon did not come back within ",
                                               policy_.reconnect_window_s,
                                               " s (--reconnect-window-s): ", failure.message()));
  }

  double Uniform() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (hooks_.uniform) return hooks_.uniform();
    return std::uniform_real_distribution<double>(0.0, 1.0)(generator_);
  }

  void Sleep(double seconds) const {
    if (hooks_.sleep) {
      hooks_.sleep(seconds);
    } else {
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    }
  }

  double Now() const {
    if (hooks_.now) return hooks_.now();
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

  const RetryPolicy& policy_;
  const BatchHooks& hooks_;
  std::mutex mutex_;  // guards the generator, gone_since_s_ and the hooks' calls
  std::mt19937_64 generator_;
  std::optional<double> gone_since_s_;  // Now() at the outage's first UNAVAILABLE
};

}  // namespace

bool HasImageExtension(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return false;
  const std::string ext = absl::AsciiStrToLower(path.substr(dot + 1));
  return ext == "png" || ext == "tif" || ext == "tiff" || ext == "jpg" || ext == "jpeg" ||
         ext == "exr";
}

std::string PathKey(const std::string& path) {
  std::error_code error;
  const std::filesystem::path absolute = std::filesystem::absolute(path, error);
  return (error ? std::filesystem::path(path) : absolute).lexically_normal().string();
}

absl::StatusOr<std::vector<std::string>> ExpandInputs(const std::vector<std::string>& inputs) {
  std::vector<std::string> images;
  auto add = [&](const std::string& image) { images.push_back(image); };
  for (const std::string& input : inputs) {
    if (IsDirectory(input)) {
      const std::vector<std::string> found = FolderImages(input);
      if (found.empty()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "folder ", input, " holds no images (.png .tif .tiff .jpg .jpeg .exr)"));
      }
      for (const std::string& image : found) add(image);
    } else if (input.find_first_of("*?[") != std::string::npos && !Exists(input)) {
      glob_t matches{};
      const int result = glob(input.c_str(), 0, nullptr, &matches);
      std::vector<std::string> found;
      for (std::size_t i = 0; result == 0 && i < matches.gl_pathc; ++i) {
        const std::string path = matches.gl_pathv[i];
        if (HasImageExtension(path) && IsRegularFile(path)) found.push_back(path);
      }
      globfree(&matches);
      if (found.empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat("no image matches '", input, "' (.png .tif .tiff .jpg .jpeg .exr)"));
      }
      for (const std::string& image : found) add(image);  // glob(3) sorts them
    } else {
      add(input);
    }
  }
  return images;
}

std::vector<std::string> DistinctImages(const std::vector<std::string>& images) {
  std::vector<std::string> distinct;
  std::vector<std::string> keys;
  for (const std::string& image : images) {
    std::string key = PathKey(image);
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) continue;
    keys.push_back(std::move(key));
    distinct.push_back(image);
  }
  return distinct;
}

absl::StatusOr<std::vector<ManifestRow>> ParseManifest(const std::string& text,
                                                       const std::string& folder,
                                                       const std::string& name) {
  std::vector<CsvRecord> records = ParseCsv(text);
  records.erase(std::remove_if(records.begin(), records.end(), IsBlank), records.end());
  if (records.empty()) {
    return ManifestError(name, 1, "empty: a header row naming the columns is needed");
  }
  enum Column { kPath, kPhase, kDiameter, kDistance, kSample };
  const std::vector<std::string> known = {"path", "phase_angle_deg", "diameter_mm",
                                          "distance_mm", "sample_name"};
  std::vector<int> columns;  // per cell: its Column
  for (const std::string& cell : records[0].fields) {
    const std::string column = absl::AsciiStrToLower(absl::StripAsciiWhitespace(cell));
    const auto it = std::find(known.begin(), known.end(), column);
    if (it == known.end()) {
      return ManifestError(name, records[0].line,
                           absl::StrCat("unknown column '", column, "' (the columns are ",
                                        absl::StrJoin(known, ", "), ")"));
    }
    const int c = static_cast<int>(it - known.begin());
    if (std::find(columns.begin(), columns.end(), c) != columns.end()) {
      return ManifestError(name, records[0].line, absl::StrCat("column '", column, "' twice"));
    }
    columns.push_back(c);
  }
  if (std::find(columns.begin(), columns.end(), kPath) == columns.end()) {
    return ManifestError(name, records[0].line,
                         "no 'path' column (the header row names the columns)");
  }
  std::vector<ManifestRow> rows;
  std::vector<std::string> keys;
  for (std::size_t r = 1; r < records.size(); ++r) {
    const CsvRecord& record = records[r];
    if (record.fields.size() != columns.size()) {
      return ManifestError(name, record.line,
                           absl::StrCat(record.fields.size(), " cells where the header has ",
                                        columns.size()));
    }
    ManifestRow row;
    row.line = record.line;
    for (std::size_t i = 0; i < columns.size(); ++i) {
      const std::string cell(absl::StripAsciiWhitespace(record.fields[i]));
      if (columns[i] == kPath) {
        if (cell.empty()) return ManifestError(name, record.line, "empty path");
        row.path = absl::StartsWith(cell, "/") ? cell : Join(folder, cell);
      } else if (columns[i] == kSample) {
        row.sample_name = cell;
      } else if (!cell.empty()) {
        double value = 0.0;
        if (!absl::SimpleAtod(cell, &value) || !std::isfinite(value)) {
          return ManifestError(name, record.line,
                               absl::StrCat(known[columns[i]], " '", cell, "' is not a number"));
        }
        (columns[i] == kPhase ? row.phase_angle_deg
                              : columns[i] == kDiameter ? row.diameter_mm : row.distance_mm) = value;
      }
    }
    std::string key = PathKey(row.path);
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) {
      return ManifestError(name, record.line, absl::StrCat(row.path, " is listed twice"));
    }
    keys.push_back(std::move(key));
    rows.push_back(std::move(row));
  }
  return rows;
}

absl::StatusOr<std::vector<ManifestRow>> ReadManifest(const std::string& path) {
  absl::StatusOr<std::string> text = ReadFile(path);
  if (!text.ok()) return text.status();
  const std::size_t slash = path.find_last_of('/');
  return ParseManifest(*text, slash == std::string::npos ? "" : path.substr(0, slash + 1), path);
}

const ManifestRow* FindRow(const std::vector<ManifestRow>& rows, const std::string& image) {
  const std::string key = PathKey(image);
  for (const ManifestRow& row : rows) {
    if (PathKey(row.path) == key) return &row;
  }
  return nullptr;
}

absl::StatusOr<v1::RequestHeader> HeaderFor(const MetadataFlags& flags, const std::string& image,
                                            std::size_t index, const ManifestRow* row) {
  v1::RequestHeader header;
  v1::Acquisition* acq = header.mutable_acquisition();
  acq->set_cylinder_diameter_mm(flags.diameter_mm);
  acq->set_camera_distance_mm(flags.distance_mm);
  acq->set_pixels_linear(flags.linear);
  acq->set_saturation_level(flags.saturation_level);
  std::optional<double> phase;
  if (!flags.phase_angles_deg.empty()) {
    const std::size_t n = flags.phase_angles_deg.size();
    if (n != 1 && index >= n) {
      return absl::InvalidArgumentError(
          absl::StrCat("--phase-angle gives ", n, " angles: none for image ", index + 1));
    }
    phase = flags.phase_angles_deg[n == 1 ? 0 : index];
  } else if (const auto sidecar = ReadSidecar(image)) {
    phase = StructNumber(*sidecar, "acquisition", "phaseAngleDeg");
    if (auto d = StructNumber(*sidecar, "acquisition", "cylinderDiameterMm")) {
      acq->set_cylinder_diameter_mm(*d);
    }
    if (auto d = StructNumber(*sidecar, "acquisition", "cameraDistanceMm")) {
      acq->set_camera_distance_mm(*d);
    }
  }
  if (row != nullptr) {
    if (row->phase_angle_deg) phase = row->phase_angle_deg;
    if (row->diameter_mm) acq->set_cylinder_diameter_mm(*row->diameter_mm);
    if (row->distance_mm) acq->set_camera_distance_mm(*row->distance_mm);
  }
  if (!phase) {
    return absl::InvalidArgumentError(absl::StrCat(
        "no phase angle for ", image, ": give --phase-angle, a manifest row with "
        "phase_angle_deg, or a sidecar ", SidecarPath(image), " with acquisition.phaseAngleDeg"));
  }
  acq->set_phase_angle_deg(*phase);
  if (!flags.cylinder.empty()) {
    if (flags.cylinder.size() != 3 && flags.cylinder.size() != 4) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--cylinder takes CX,R,TILT or CX,R,TILT,RADIUS_STDERR (px, px, deg, px), got ",
          flags.cylinder.size(), " values"));
    }
    v1::GivenCylinder* given = acq->mutable_given_cylinder();
    given->set_center_x_px(flags.cylinder[0]);
    given->set_radius_px(flags.cylinder[1]);
    given->set_axis_angle_deg(flags.cylinder[2]);
    if (flags.cylinder.size() == 4) given->set_radius_stderr_px(flags.cylinder[3]);
    given->set_source(v1::GIVEN);
  }
  if (!flags.roi.empty()) {
    if (flags.roi.size() != 4) {
      return absl::InvalidArgumentError(
          absl::StrCat("--roi takes X,Y,W,H (px), got ", flags.roi.size(), " values"));
    }
    v1::RegionOfInterest* roi = acq->mutable_roi();
    roi->set_x_px(flags.roi[0]);
    roi->set_y_px(flags.roi[1]);
    roi->set_width_px(flags.roi[2]);
    roi->set_height_px(flags.roi[3]);
  }
  if (flags.mode == "fast") {
    header.mutable_options()->set_mode(v1::FAST);
  } else if (flags.mode == "accurate") {
    header.mutable_options()->set_mode(v1::ACCURATE);
  } else {
    header.mutable_options()->set_mode(v1::BALANCED);
  }
  const std::size_t slash = image.find_last_of('/');
  header.set_filename(slash == std::string::npos ? image : image.substr(slash + 1));
  header.set_sample_name(row != nullptr && !row->sample_name.empty() ? row->sample_name
                                                                     : header.filename());
  return header;
}

namespace {

// ShareCylinder over `count` photographs named `names`, `detect(i)` giving
// photograph i's own detection (one at a time: a batch holds one decoded
// photograph at once).
absl::StatusOr<SeriesCylinder> ShareFrom(
    const std::vector<std::string>& names,
    const std::function<absl::StatusOr<DetectedCylinder>(std::size_t)>& detect) {
  SeriesCylinder series;
  series.notes.assign(names.size(), "");
  std::vector<CylinderGeometry> detections;
  std::vector<std::size_t> photograph;  // detection → photograph index
  int width = 0;
  int height = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    absl::StatusOr<DetectedCylinder> d = detect(i);
    if (!d.ok()) {
      series.notes[i] = absl::StrCat(
          "its own detection of the cylinder failed (", d.status().message(),
          "), so it was read through the cylinder its series shares");
      continue;
    }
    if (!detections.empty() && (d->width != width || d->height != height)) {
      return absl::InvalidArgumentError(absl::StrCat(
          names[i], " is ", d->width, "x", d->height, ", ", names[photograph[0]], " ", width,
          "x", height, ": photographs of different sizes cannot share one cylinder"));
    }
    width = d->width;
    height = d->height;
    detections.push_back(d->cylinder);
    photograph.push_back(i);
  }
  if (detections.empty()) {
    series.summary = "no photograph of the series showed its cylinder: each is estimated alone";
    return series;
  }
  absl::StatusOr<SharedCylinder> shared = CombineCylinders(detections);
  if (!shared.ok()) return shared.status();
  std::vector<std::string> used;
  for (std::size_t k = 0; k < detections.size(); ++k) {
    const std::size_t i = photograph[k];
    const bool in = std::find(shared->used.begin(), shared->used.end(), static_cast<int>(k)) !=
                    shared->used.end();
    if (in) {
      used.push_back(names[i]);
    } else {
      series.notes[i] = absl::StrFormat(
          "its own detection (axis at column %.2f, radius %.2f +- %.2f px%s) was not among "
          "those the series' cylinder was made of",
          detections[k].center_x_px, detections[k].radius_px, detections[k].radius_stderr_px,
          detections[k].left_observed && detections[k].right_observed ? "" : ", a limb inferred");
    }
  }
  const GivenCylinder given = GivenFromGeometry(shared->cylinder, height, CylinderSource::kShared);
  series.given = GivenCylinderToProto(given);
  series.summary = absl::StrFormat(
      "series cylinder from %d of %d photographs (%s): axis at column %.2f +- %.2f px, radius "
      "%.2f +- %.2f px, tilt %.3f deg, lens blur %.2f px",
      used.size(), names.size(), absl::StrJoin(used, ", "), given.center_x_px,
      given.center_stderr_px, given.radius_px, given.radius_stderr_px,
      given.axis_angle_rad * 180.0 / M_PI, given.lens_blur_px);
  // Which detections were left out, and why, the notes say per photograph.
  for (const std::string& w : shared->warnings) {
    if (!absl::StartsWith(w, "the series' cylinder leaves out")) {
      absl::StrAppend(&series.summary, "; ", w);
    }
  }
  return series;
}

}  // namespace

absl::StatusOr<SeriesCylinder> ShareCylinder(const std::vector<v1::RequestHeader>& headers,
                                             const std::vector<std::string>& files) {
  std::vector<std::string> names;
  for (const v1::RequestHeader& h : headers) names.push_back(h.filename());
  return ShareFrom(names, [&](std::size_t i) -> absl::StatusOr<DetectedCylinder> {
    if (i >= files.size()) return absl::InvalidArgumentError("no file");
    absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(headers[i].acquisition());
    if (!acquisition.ok()) return acquisition.status();
    return DetectCylinderInBytes(files[i], *acquisition, EstimateOptions());
  });
}

absl::StatusOr<SeriesCylinder> ShareCylinderOfFiles(const MetadataFlags& flags,
                                                    const std::vector<std::string>& images,
                                                    const std::vector<ManifestRow>& rows) {
  MetadataFlags detect_flags = flags;
  detect_flags.cylinder.clear();
  std::vector<std::string> names;  // as the headers name them
  for (const std::string& image : images) {
    const std::size_t slash = image.find_last_of('/');
    names.push_back(slash == std::string::npos ? image : image.substr(slash + 1));
  }
  return ShareFrom(names, [&](std::size_t i) -> absl::StatusOr<DetectedCylinder> {
    absl::StatusOr<v1::RequestHeader> header =
        HeaderFor(detect_flags, images[i], i, FindRow(rows, images[i]));
    if (!header.ok()) return header.status();
    absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(header->acquisition());
    if (!acquisition.ok()) return acquisition.status();
    absl::StatusOr<std::string> bytes = ReadFile(images[i]);
    if (!bytes.ok()) return bytes.status();
    return DetectCylinderInBytes(*bytes, *acquisition, EstimateOptions());
  });
}

absl::StatusOr<bool> SharesCylinder(bool same_cylinder, bool joint, bool own_cylinders,
                                    const MetadataFlags& flags, std::size_t images) {
  if (same_cylinder && own_cylinders) {
    return absl::InvalidArgumentError(
        "--same-cylinder shares one cylinder, --own-cylinders detects each: give one");
  }
  return (same_cylinder || joint) && !own_cylinders && flags.cylinder.empty() && images > 1;
}

void AddSeriesNote(const std::string& note, v1::EstimateReply* reply) {
  if (!note.empty()) reply->add_warnings(note);
}

ResultsFormat ResultsFormatFor(const std::string& path) {
  return absl::EndsWithIgnoreCase(path, ".csv") ? ResultsFormat::kCsv : ResultsFormat::kJsonLines;
}

std::string ResultRecord(ResultsFormat format, const std::string& image,
                         const absl::StatusOr<v1::EstimateReply>& reply,
                         const std::optional<v1::RequestHeader>& asked) {
  if (format == ResultsFormat::kCsv) {
    ReportRow row;
    row.image = image;
    if (reply.ok()) {
      row.reply = *reply;
    } else {
      row.error = StatusLine(reply.status());
    }
    row.header = asked;
    return CsvRow(row);
  }
  const auto json_string = [](const std::string& text) {
    google::protobuf::Value value;
    value.set_string_value(text);
    std::string quoted;
    (void)google::protobuf::util::MessageToJsonString(value, &quoted);
    return quoted;
  };
  if (reply.ok()) {
    return absl::StrCat("{\"image\":", json_string(image), ",\"reply\":", JsonLine(*reply),
                        "}\n");
  }
  const absl::Status& failure = reply.status();
  return absl::StrCat("{\"image\":", json_string(image), ",\"error\":{\"code\":",
                      json_string(absl::StatusCodeToString(failure.code())), ",\"message\":",
                      json_string(std::string(failure.message())), "}",
                      asked ? absl::StrCat(",\"asked\":", JsonLine(*asked)) : std::string(),
                      ",\"version\":", json_string(WeavefitVersion()), "}\n");
}

absl::StatusOr<ResultsFile> ParseResults(const std::string& text, ResultsFormat format,
                                         const std::string& name) {
  ResultsFile out;
  const auto not_ours = [&](int line, const std::string& why) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ":", line, ": ", why,
        "; weavefit did not write this file (give --out a new file or weavefit's own)"));
  };
  if (format == ResultsFormat::kCsv) {
    const std::vector<CsvRecord> records = ParseCsv(text);
    const std::vector<std::string> columns = CsvColumns();
    bool header = false;
    for (const CsvRecord& r : records) {
      if (!r.terminated) {
        out.torn_tail = true;
        break;
      }
      if (IsBlank(r)) continue;
      if (!header) {
        if (r.fields != columns) return not_ours(r.line, "not weavefit's CSV header");
        header = true;
        continue;
      }
      if (r.fields.size() != columns.size() || r.fields[0].empty()) {
        return not_ours(r.line, absl::StrCat(r.fields.size(), " cells where weavefit writes ",
                                             columns.size()));
      }
      // The record as it was written: re-encoded from its fields, which
      // gives back the same text for what CsvRow wrote.
      std::string record;
      for (std::size_t f = 0; f < r.fields.size(); ++f) {
        if (f > 0) record += ',';
        record += CsvField(r.fields[f]);
      }
      out.images.push_back(r.fields[0]);
      out.records.push_back(record + "\n");
      out.failed.push_back(r.fields[2] != "OK");  // the status column
    }
    return out;
  }
  std::size_t at = 0;
  int line = 0;
  while (at < text.size()) {
    ++line;
    const std::size_t end = text.find('\n', at);
    if (end == std::string::npos) {
      out.torn_tail = true;
      break;
    }
    const std::string record = text.substr(at, end - at);
    at = end + 1;
    if (absl::StripAsciiWhitespace(record).empty()) continue;
    google::protobuf::Struct parsed;
    if (!google::protobuf::util::JsonStringToMessage(record, &parsed).ok()) {
      return not_ours(line, "not a JSON object");
    }
    const auto image = parsed.fields().find("image");
    const auto reply = parsed.fields().find("reply");
    const auto error = parsed.fields().find("error");
    const bool replied = reply != parsed.fields().end() && reply->second.has_struct_value();
    const bool failed = error != parsed.fields().end() && error->second.has_struct_value();
    if (image == parsed.fields().end() || !image->second.has_string_value() ||
        image->second.string_value().empty() || replied == failed) {
      return not_ours(line,
                      "not a {\"image\": ..., \"reply\" or \"error\": {...}} record");
    }
    out.images.push_back(image->second.string_value());
    out.records.push_back(record + "\n");
    out.failed.push_back(failed);
  }
  return out;
}

std::vector<bool> AlreadyDone(const std::vector<std::string>& images, const ResultsFile& done,
                              bool no_skip) {
  std::vector<bool> skip(images.size(), false);
  if (no_skip) return skip;
  std::vector<std::string> keys;
  for (std::size_t i = 0; i < done.images.size(); ++i) {
    if (i >= done.failed.size() || !done.failed[i]) keys.push_back(PathKey(done.images[i]));
  }
  std::sort(keys.begin(), keys.end());
  for (std::size_t i = 0; i < images.size(); ++i) {
    skip[i] = std::binary_search(keys.begin(), keys.end(), PathKey(images[i]));
  }
  return skip;
}

std::string KeptResults(const ResultsFile& done, ResultsFormat format,
                        const std::vector<std::string>& redone) {
  std::vector<std::string> keys;
  for (const std::string& image : redone) keys.push_back(PathKey(image));
  std::sort(keys.begin(), keys.end());
  std::string text = format == ResultsFormat::kCsv ? CsvHeader() : std::string();
  for (std::size_t i = 0; i < done.records.size(); ++i) {
    if (!std::binary_search(keys.begin(), keys.end(), PathKey(done.images[i]))) {
      text += done.records[i];
    }
  }
  return text;
}

bool IsRetryable(absl::StatusCode code) {
  return code == absl::StatusCode::kUnavailable || code == absl::StatusCode::kResourceExhausted ||
         code == absl::StatusCode::kDeadlineExceeded;
}

double BackoffSeconds(const RetryPolicy& policy, int retry, double uniform01) {
  const double ceiling =
      std::min(policy.max_backoff_s,
               policy.initial_backoff_s * std::pow(policy.multiplier, std::max(0, retry - 1)));
  return ceiling * (0.5 + 0.5 * std::clamp(uniform01, 0.0, 1.0));
}

std::vector<ImageOutcome> RunBatch(std::size_t count, int jobs, const RetryPolicy& policy,
                                   const BatchHooks& hooks) {
  std::vector<ImageOutcome> outcomes(count);
  BatchRun batch(policy, hooks);
  std::atomic<std::size_t> next{0};
  const auto work = [&]() {
    for (std::size_t index = next++; index < count; index = next++) {
      outcomes[index] = batch.Image(index);
    }
  };
  const std::size_t threads = std::min<std::size_t>(std::max(1, jobs), count);
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  if (count > 0) work();  // this thread is one of the workers
  for (std::thread& t : pool) t.join();
  return outcomes;
}

std::string ProgressLine(std::size_t done, std::size_t total, std::size_t failed) {
  return absl::StrCat(done, "/", total, " done, ", failed, " failed");
}

std::string FailureSummary(const std::vector<std::pair<std::string, absl::Status>>& failures,
                           std::size_t total) {
  if (failures.empty()) return "";
  std::string out = absl::StrCat(failures.size(), " of ", total,
                                 total == 1 ? " image" : " images", " failed:\n");
  for (const auto& [image, status] : failures) {
    absl::StrAppend(&out, "  ", image, ": ", absl::StatusCodeToString(status.code()), ": ",
                    status.message(), "\n");
  }
  return out;
}

}  // namespace weavefit
