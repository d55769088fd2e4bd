// Batch submission (weavefit submit): which images, with what acquisition
// metadata, which to skip because their results are already written, how to
// retry, and running the calls on a bounded pool. Pure functions over plain
// data where possible, so each is tested without a daemon (batch_test.cc);
// the command itself is client/submit.cc.
#ifndef WEAVEFIT_CLIENT_BATCH_H_
#define WEAVEFIT_CLIENT_BATCH_H_

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

// ---------------------------------------------------------------- inputs

// True for the extensions folders and globs contribute: .png .tif .tiff
// .jpg .jpeg .exr, in any case.
bool HasImageExtension(const std::string& path);

// The images that command-line inputs name, in order:
// - a folder: its files with an image extension, sorted by name, without
//   recursing and without hidden (dot) files;
// - a pattern with *, ? or [ that is not itself an existing path (the shell
//   left it unexpanded): its glob(3) matches with an image extension, sorted;
// - anything else: the path as given, whatever its extension (a file that
//   is missing or unreadable fails as that image's error, not the batch's).
// INVALID_ARGUMENT for a folder without images or a pattern matching none.
absl::StatusOr<std::vector<std::string>> ExpandInputs(const std::vector<std::string>& inputs);

// Each image once, at its first mention (by PathKey): a batch estimates a
// photograph named twice (a folder and a file in it) once.
std::vector<std::string> DistinctImages(const std::vector<std::string>& images);

// The absolute, lexically normal path (against the current folder): how two
// mentions of one image are recognised (a.png, ./a.png, dir/../a.png).
std::string PathKey(const std::string& path);

// -------------------------------------------------------------- manifest

// One row of a CSV manifest: an image and what the lab knows about it.
// Empty cells are nullopt (or an empty sample name).
struct ManifestRow {
  std::string path;  // a relative path is joined to the manifest's folder
  std::optional<double> phase_angle_deg;
  std::optional<double> diameter_mm;
  std::optional<double> distance_mm;
  std::string sample_name;
  int line = 0;  // 1-based line in the manifest, for messages
};

// Parses a manifest: a header row naming the columns (path, phase_angle_deg,
// diameter_mm, distance_mm, sample_name: any order, any case, only path
// required), then one row per image. RFC 4180 quoting; blank lines skipped;
// a UTF-8 byte-order mark and CRLF line ends accepted. Relative paths are
// joined to `folder` ("" = as they are). INVALID_ARGUMENT naming `name` and
// the line for a missing header or path column, an unknown or repeated
// column, a row with another number of cells than the header, an empty
// path, a number that does not parse, or an image listed twice.
absl::StatusOr<std::vector<ManifestRow>> ParseManifest(const std::string& text,
                                                       const std::string& folder,
                                                       const std::string& name);

// ParseManifest of a file, relative to the file's own folder.
absl::StatusOr<std::vector<ManifestRow>> ReadManifest(const std::string& path);

// The row for `image` (by PathKey), or nullptr.
const ManifestRow* FindRow(const std::vector<ManifestRow>& rows, const std::string& image);

// ------------------------------------------------------ request metadata

// The acquisition flags shared by estimate and submit.
struct MetadataFlags {
  // One for all images, or one per image (--phase-angle 10,60,110).
  std::vector<double> phase_angles_deg;
  double diameter_mm = 0.0;    // cylinder diameter; 0 = not given (no mm lengths)
  double distance_mm = 0.0;    // camera distance from the axis; 0 = orthographic
  bool linear = false;         // pixels already linear
  double saturation_level = 0.0;  // file units; 0 = the format's maximum
  std::string mode = "balanced";  // fast, balanced or accurate
  // --cylinder CX,R,TILT[,RADIUS_STDERR]: the cylinder given instead of
  // detected (v1::GivenCylinder: axis column at the image's middle row, px;
  // radius, px; tilt, deg; the radius's standard error, px). Empty = detect.
  std::vector<double> cylinder;
  // --roi X,Y,W,H: the region of interest (v1::RegionOfInterest), px.
  // Empty = the whole image.
  std::vector<int> roi;
};

// The request header for image number `index` of the batch. Each field comes
// from the first of: the manifest row's cell (`row` may be null); --phase-angle
// (given, it also means no sidecar is read: the diameter and distance are
// then the flags'); the sidecar IMAGE-stem.json (acquisition.phaseAngleDeg,
// .cylinderDiameterMm, .cameraDistanceMm); the flags' --diameter-mm and
// --distance-mm. The sample name is the row's, else the file name.
// --cylinder sets acquisition.given_cylinder (its values are checked by the
// estimate). INVALID_ARGUMENT, naming the image, when no phase angle is
// found; naming --cylinder when it has other than 3 or 4 values, --roi when
// it has other than 4.
absl::StatusOr<v1::RequestHeader> HeaderFor(const MetadataFlags& flags, const std::string& image,
                                            std::size_t index, const ManifestRow* row);

// ------------------------------------------------------ series' cylinder

// The cylinder a series of photographs of one set-up shares (issue 31: the
// lamp moves, the camera and sample stay). The client detects it on each
// photograph in this process (DetectCylinderInBytes, with the request
// header's acquisition), before any estimate, and combines the detections
// (CombineCylinders); every request then carries it as its given cylinder,
// source SHARED, so the daemon and the in-process estimate read each
// photograph through the same cylinder. Detecting here rather than asking
// the daemon keeps each detection's limb errors and lens blur, which a
// reply does not carry, at the cost of decoding each photograph twice.
struct SeriesCylinder {
  // nullopt when no photograph showed the cylinder (each is then estimated
  // with its own detection, and fails as it would alone).
  std::optional<v1::GivenCylinder> given;
  // Per photograph: "" when its own detection entered the shared cylinder,
  // else a sentence why not (its detection failed, its limb was inferred,
  // it disagreed), for that photograph's warnings.
  std::vector<std::string> notes;
  // One paragraph on the series: the cylinder, its errors, which
  // photographs made it.
  std::string summary;
};

// The series' cylinder for `headers[i]` and `files[i]` (the encoded
// photographs, aligned). A photograph whose detection fails is left out
// (an undecodable one too: its estimate reports that). INVALID_ARGUMENT
// when photographs that showed the cylinder differ in size: they cannot be
// one set-up.
absl::StatusOr<SeriesCylinder> ShareCylinder(const std::vector<v1::RequestHeader>& headers,
                                             const std::vector<std::string>& files);

// The same for image files, each with its HeaderFor header (`rows` as
// there). An image that cannot be read is left out like a failed detection.
absl::StatusOr<SeriesCylinder> ShareCylinderOfFiles(const MetadataFlags& flags,
                                                    const std::vector<std::string>& images,
                                                    const std::vector<ManifestRow>& rows);

// Whether a run shares one cylinder over its images: --same-cylinder, or
// --joint, unless --own-cylinders, --cylinder (the cylinder is given) or a
// single image. INVALID_ARGUMENT for --same-cylinder with --own-cylinders.
absl::StatusOr<bool> SharesCylinder(bool same_cylinder, bool joint, bool own_cylinders,
                                    const MetadataFlags& flags, std::size_t images);

// The reply of a photograph estimated with the series' cylinder, with its
// note (SeriesCylinder::notes) added to its warnings when there is one.
void AddSeriesNote(const std::string& note, v1::EstimateReply* reply);

// --------------------------------------------------------- results file

// The results file's format, from its name: .csv is CSV, anything else
// JSON lines.
enum class ResultsFormat { kJsonLines, kCsv };
ResultsFormat ResultsFormatFor(const std::string& path);

// One record of the results file, "\n" included: CsvRow, or the JSON line
// {"image": PATH, "reply": {protobuf's JSON mapping of the reply}}; for a
// failed photograph its CsvRow, or {"image": PATH, "error": {"code",
// "message"}, "asked": {the request header, where one was made},
// "version": this client's}. `asked` is the request made, if any.
std::string ResultRecord(ResultsFormat format, const std::string& image,
                         const absl::StatusOr<v1::EstimateReply>& reply,
                         const std::optional<v1::RequestHeader>& asked);

// What a results file holds: its complete records, verbatim ("\n" included)
// and the image each is for. A record is complete when its line end was
// written: a run killed in the middle of a write leaves a torn last record,
// which is dropped (and its image estimated again).
struct ResultsFile {
  std::vector<std::string> images;   // as written
  std::vector<std::string> records;  // aligned with images
  std::vector<bool> failed;          // aligned with images: an error record
  bool torn_tail = false;
};

// Parses a results file's text ("" = no file yet). INVALID_ARGUMENT naming
// `name` and the line when a complete record is not a weavefit result (a
// CSV header other than CsvHeader(), a line that is not such a JSON object):
// a file weavefit did not write is never taken over.
absl::StatusOr<ResultsFile> ParseResults(const std::string& text, ResultsFormat format,
                                         const std::string& name);

// For each of `images`: true when its result is already in `done` (by
// PathKey), not as a failure (a failed photograph is tried again), and
// `no_skip` is false.
std::vector<bool> AlreadyDone(const std::vector<std::string>& images, const ResultsFile& done,
                              bool no_skip);

// The text the results file starts this run with: the CSV header, then the
// records kept, those of `redone` images (by PathKey) left out so that the
// file keeps one record per image.
std::string KeptResults(const ResultsFile& done, ResultsFormat format,
                        const std::vector<std::string>& redone);

// ---------------------------------------------------------------- retries

struct RetryPolicy {
  int max_retries = 3;             // retries after the first attempt
  double initial_backoff_s = 0.5;  // ceiling of the first retry's wait
  double multiplier = 2.0;         // the ceiling's growth per retry
  double max_backoff_s = 10.0;     // ceiling of any wait
  // How long the batch waits for a daemon that is gone (calls UNAVAILABLE
  // and the channel not connected) to be reachable again, s, from when it
  // was found gone; such waits spend no retries. 0 = UNAVAILABLE is retried
  // with the backoff above like the other retryable codes.
  double reconnect_window_s = 30.0;
};

// UNAVAILABLE (no daemon answered, or one went away mid-call), RESOURCE_
// EXHAUSTED (a daemon's admission queue is full; the permanent size limits
// too, which cost little to try again: the daemon refuses them from the
// header) and DEADLINE_EXCEEDED (the call ran out of time, e.g. on a daemon
// that vanished without closing its connection). An estimate is a pure
// function of the upload, so repeating any call is safe; the other codes
// would only fail again.
bool IsRetryable(absl::StatusCode code);

// The wait before retry number `retry` (1 = the first), s: "equal jitter",
// uniform in [c/2, c) where c = min(max_backoff_s, initial_backoff_s ·
// multiplier^(retry−1)), from a uniform draw `uniform01` in [0, 1). The half
// always waited gives a restarting daemon time; the random half spreads out
// clients that failed together.
double BackoffSeconds(const RetryPolicy& policy, int retry, double uniform01);

// ----------------------------------------------------------------- runner

// What became of one image.
struct ImageOutcome {
  absl::StatusOr<v1::EstimateReply> reply = absl::UnknownError("not run");
  int attempts = 0;
  double seconds = 0.0;  // wall time, retries and waits included
};

// What became of a wait for the daemon after an UNAVAILABLE call.
enum class Reconnect {
  kConnected,  // the channel was connected all along: a daemon answered
               // UNAVAILABLE itself, or another daemon is up; plain backoff
  kBack,       // it was not connected and now is: retry at once
  kGone,       // still not connected when the wait ran out
};

struct BatchHooks {
  // One attempt at image `index`. Called from the worker threads.
  std::function<absl::StatusOr<v1::EstimateReply>(std::size_t index)> estimate;
  // After an UNAVAILABLE attempt: waits up to `timeout_s` (≥ 0) for the
  // channel to connect. Called from several workers at once; it must block,
  // not poll. Optional: without it UNAVAILABLE gets the plain backoff.
  std::function<Reconnect(double timeout_s)> await_daemon;
  // Before each retry: the image, the failure, the retry number and the
  // wait, s. Optional.
  std::function<void(std::size_t index, const absl::Status& failure, int retry,
                     double wait_s)> on_retry;
  // After a wait for the daemon that saw it back: the image, the failure
  // that started the wait and the wait, s. Optional.
  std::function<void(std::size_t index, const absl::Status& failure, double waited_s)>
      on_reconnected;
  // Once per image when it is finished. Never two calls at once. Optional.
  std::function<void(std::size_t index, const ImageOutcome& outcome)> on_done;
  // Waits; default std::this_thread::sleep_for (tests record instead).
  std::function<void(double seconds)> sleep;
  // Uniform draws in [0, 1) for the jitter; default a generator seeded from
  // std::random_device (the jitter exists to differ between clients).
  std::function<double()> uniform;
  // A monotonic clock, s; default std::chrono::steady_clock (tests give one
  // that their await_daemon advances).
  std::function<double()> now;
};

// Estimates images 0 … count−1 on min(jobs, count) threads (jobs ≥ 1),
// each retried per `policy` while its status IsRetryable. An UNAVAILABLE
// attempt, with await_daemon given and a reconnect window, first waits for
// the daemon: back, the image is tried again at once, without spending a
// retry; not back within the window, counted from when the batch found the
// daemon gone (and reset when one answers), the image fails UNAVAILABLE,
// "the daemon did not come back within N s". The outcomes by index.
std::vector<ImageOutcome> RunBatch(std::size_t count, int jobs, const RetryPolicy& policy,
                                   const BatchHooks& hooks);

// --------------------------------------------------------------- reporting

// "12/30 done, 1 failed".
std::string ProgressLine(std::size_t done, std::size_t total, std::size_t failed);

// The end-of-batch summary of failures for stderr, one "image: CODE:
// message" line per failure under a count; "" when none failed.
std::string FailureSummary(const std::vector<std::pair<std::string, absl::Status>>& failures,
                           std::size_t total);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_BATCH_H_
