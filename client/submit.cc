#include "client/submit.h"

#include "client/plot.h"

#include <fcntl.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/files.h"
#include "client/report.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

// Prints a status the way every submit error is printed, and returns its
// code as the exit status.
int Fail(const absl::Status& status, bool json) {
  std::cerr << "weavefit: " << status.message() << "\n";
  if (json) std::cout << ErrorToJson(status) << "\n";
  return static_cast<int>(status.code());
}

// The results file, appended to record by record.
//
// Why appending rather than rewriting the file atomically: a batch of
// dozens of photographs takes minutes, and a run that is killed (Ctrl-C, a
// lost session, a full disk elsewhere) must keep every result it finished,
// or a re-run would do them all again. Each record goes out in one write(2)
// on an O_APPEND descriptor, so the file only ever grows by whole records
// except when the process dies inside that one call; such a torn last
// record has no line end, and the next run drops it (ParseResults) and
// estimates its image again. An atomic rewrite after every record would
// cost O(n²) bytes for the same guarantee. The file is rewritten atomically
// once, at the start (WriteFile: a temporary file and a rename), to drop a
// torn record and, with --no-skip, the records about to be redone, so it
// keeps one record per image. No fsync: a power cut costs at most the last
// records, which the next run redoes.
class ResultsSink {
 public:
  ~ResultsSink() {
    if (fd_ >= 0) close(fd_);
  }

  absl::Status Open(const std::string& path, const std::string& initial_text) {
    if (absl::Status s = WriteFile(path, initial_text); !s.ok()) return s;
    fd_ = open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
    if (fd_ < 0) {
      return absl::UnavailableError(absl::StrCat("cannot open ", path, ": ", std::strerror(errno)));
    }
    path_ = path;
    return absl::OkStatus();
  }

  absl::Status Append(const std::string& record) {
    if (fd_ < 0) return absl::OkStatus();
    std::size_t written = 0;
    while (written < record.size()) {
      const ssize_t n = write(fd_, record.data() + written, record.size() - written);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        return absl::UnavailableError(
            absl::StrCat("cannot write ", path_, ": ", std::strerror(errno)));
      }
      written += static_cast<std::size_t>(n);
    }
    return absl::OkStatus();
  }

 private:
  int fd_ = -1;
  std::string path_;
};

// Progress on stderr: on a terminal one line rewritten in place ("12/30
// done, 1 failed") with retries and failures printed above it; otherwise
// (a log, a pipe) one plain line per event. Not used for a single image.
// Called under RunBatch's lock, and by the output in between: no locking of
// its own.
class Progress {
 public:
  // `terminal`: stderr is one; `shared`: stdout is a terminal too, so the
  // progress line has to make way for what is printed there.
  Progress(std::size_t total, bool terminal, bool shared, bool quiet)
      : total_(total),
        terminal_(terminal),
        shared_(shared),
        enabled_(!quiet && total > 1),
        quiet_(quiet) {}

  void Start() { Draw(); }

  void Retry(const std::string& image, const absl::Status& failure, int retry, int max_retries,
             double wait_s) {
    if (quiet_) return;
    Note(absl::StrFormat("weavefit: %s: %s; retry %d of %d in %.1f s", image, StatusLine(failure),
                         retry, max_retries, wait_s));
  }

  void Reconnected(const std::string& image, const absl::Status& failure, double waited_s) {
    if (quiet_) return;
    Note(absl::StrFormat("weavefit: %s: %s; connected again after %.1f s, trying again", image,
                         StatusLine(failure), waited_s));
  }

  void Done(const std::string& image, const ImageOutcome& outcome) {
    ++done_;
    if (!outcome.reply.ok()) ++failed_;
    if (!enabled_) return;
    if (terminal_) {
      if (!outcome.reply.ok()) {
        Note(absl::StrCat("weavefit: ", image, ": ", StatusLine(outcome.reply.status())));
      }
      Draw();
      return;
    }
    std::cerr << absl::StrFormat("weavefit: [%d/%d] %s: %s (%.2f s%s)\n", done_, total_, image,
                                 outcome.reply.ok() ? "OK" : StatusLine(outcome.reply.status()),
                                 outcome.seconds,
                                 outcome.attempts > 1
                                     ? absl::StrCat(", ", outcome.attempts, " attempts")
                                     : std::string());
  }

  // Stdout text, with the terminal's progress line moved out of its way.
  void Print(const std::string& text) {
    if (text.empty()) return;
    if (shared_) Clear();
    std::cout << text << std::flush;
    if (shared_) Draw();
  }

  void Finish() {
    if (enabled_ && terminal_) std::cerr << "\n";
    enabled_ = false;
  }

 private:
  void Clear() {
    if (enabled_ && terminal_) std::cerr << "\r\x1b[K" << std::flush;
  }
  void Draw() {
    if (enabled_ && terminal_) {
      std::cerr << "\r\x1b[K" << ProgressLine(done_, total_, failed_) << std::flush;
    }
  }
  void Note(const std::string& line) {
    Clear();
    std::cerr << line << "\n";
    Draw();
  }

  std::size_t total_;
  bool terminal_;
  bool shared_;
  bool enabled_;
  bool quiet_;
  std::size_t done_ = 0;
  std::size_t failed_ = 0;
};

// submit --joint: every photograph in one EstimateJoint call, so the daemon
// combines them; a photograph it cannot estimate fails the call.
int RunJoint(const SubmitFlags& flags, const std::vector<std::string>& images,
             const std::vector<ManifestRow>& rows, bool json) {
  std::vector<v1::RequestHeader> headers;
  std::vector<std::string> files;
  absl::Status status;
  for (std::size_t index = 0; status.ok() && index < images.size(); ++index) {
    absl::StatusOr<std::string> bytes = ReadFile(images[index]);
    absl::StatusOr<v1::RequestHeader> header =
        bytes.ok() ? HeaderFor(flags.metadata, images[index], index, FindRow(rows, images[index]))
                   : absl::StatusOr<v1::RequestHeader>(bytes.status());
    if (!header.ok()) {
      status = absl::Status(header.status().code(),
                            absl::StrCat(images[index], ": ", header.status().message()));
      break;
    }
    headers.push_back(*std::move(header));
    files.push_back(*std::move(bytes));
  }
  // The series' cylinder, detected here on every photograph (ShareCylinder).
  absl::StatusOr<bool> share = SharesCylinder(flags.same_cylinder, flags.joint,
                                              flags.own_cylinders, flags.metadata, images.size());
  if (status.ok()) status = share.status();
  absl::StatusOr<SeriesCylinder> series = SeriesCylinder();
  if (status.ok() && *share) {
    series = ShareCylinder(headers, files);
    status = series.status();
  }
  if (status.ok() && series->given) {
    if (!flags.quiet) std::cerr << "weavefit: " << series->summary << "\n";
    for (v1::RequestHeader& h : headers) {
      *h.mutable_acquisition()->mutable_given_cylinder() = *series->given;
    }
  }
  absl::StatusOr<v1::JointEstimateReply> reply =
      status.ok() ? SubmitJoint(flags.connection, headers, files)
                  : absl::StatusOr<v1::JointEstimateReply>(status);
  if (!reply.ok()) {
    std::cerr << "weavefit: joint estimate: " << StatusLine(reply.status()) << "\n";
    if (json) std::cout << ErrorToJson(reply.status()) << "\n";
    return static_cast<int>(reply.status().code());
  }
  if (series->given) {
    reply->mutable_joint()->add_warnings(series->summary);
    for (int i = 0; i < reply->photographs_size(); ++i) {
      if (static_cast<std::size_t>(i) < series->notes.size()) {
        AddSeriesNote(series->notes[i], reply->mutable_photographs(i));
      }
    }
  }
  std::vector<ReportRow> table;
  for (int i = 0; i < reply->photographs_size(); ++i) {
    const v1::EstimateReply& one = reply->photographs(i);
    if (json) std::cout << JsonLine(one) << "\n";
    ReportRow row;
    row.image = images[i];
    row.reply = one;
    if (auto sidecar = ReadSidecar(row.image)) {
      row.truth_spacing_deg = StructNumber(*sidecar, "truth", "peakSpacingDeg");
    }
    table.push_back(std::move(row));
  }
  if (json) {
    std::cout << JointJsonLine(reply->joint());
  } else {
    std::cout << FormatTable(table) << FormatJoint(reply->joint());
  }
  return 0;
}

}  // namespace

int RunSubmit(SubmitFlags flags) {
  if (flags.json) {
    if (flags.format != "table" && flags.format != "json") {
      return Fail(absl::InvalidArgumentError("--json is --format json; give one of them"), false);
    }
    flags.format = "json";
  }
  const bool json = flags.format == "json";
  if (absl::Status s = flags.connection.LoadToken(flags.token_file); !s.ok()) return Fail(s, json);

  // The images: the inputs expanded, then the manifest's rows not among them.
  std::vector<ManifestRow> rows;
  if (!flags.manifest.empty()) {
    absl::StatusOr<std::vector<ManifestRow>> read = ReadManifest(flags.manifest);
    if (!read.ok()) return Fail(read.status(), json);
    rows = *std::move(read);
  }
  absl::StatusOr<std::vector<std::string>> expanded = ExpandInputs(flags.inputs);
  if (!expanded.ok()) return Fail(expanded.status(), json);
  std::vector<std::string> images = *std::move(expanded);
  for (const ManifestRow& row : rows) {
    bool listed = false;
    for (const std::string& image : images) listed = listed || PathKey(image) == PathKey(row.path);
    if (!listed) images.push_back(row.path);
  }
  if (images.empty()) {
    return Fail(absl::InvalidArgumentError(
                    "no images: give files, folders or glob patterns, or --manifest FILE"),
                json);
  }
  if (!flags.joint) images = DistinctImages(images);  // a joint call may repeat one
  const std::size_t angles = flags.metadata.phase_angles_deg.size();
  if (angles > 1 && angles != images.size()) {
    return Fail(absl::InvalidArgumentError(absl::StrCat(
                    "--phase-angle gives ", angles, " angles for ", images.size(),
                    " images: give one for all or one per image")),
                json);
  }
  if (flags.joint) {
    if (flags.format == "csv" || !flags.out.empty()) {
      return Fail(absl::InvalidArgumentError(
                      "--joint prints a table or JSON: --format csv and --out are for batches"),
                  json);
    }
    return RunJoint(flags, images, rows, json);
  }

  // Results already written, and the file this run appends to.
  ResultsSink sink;
  std::vector<bool> skip(images.size(), false);
  const ResultsFormat out_format = ResultsFormatFor(flags.out);
  if (!flags.out.empty()) {
    absl::StatusOr<std::string> text = ReadFile(flags.out);
    if (!text.ok() && text.status().code() != absl::StatusCode::kNotFound) {
      return Fail(text.status(), json);
    }
    absl::StatusOr<ResultsFile> done =
        ParseResults(text.ok() ? *text : std::string(), out_format, flags.out);
    if (!done.ok()) return Fail(done.status(), json);
    if (done->torn_tail) {
      std::cerr << "weavefit: " << flags.out
                << ": dropped a last record cut off by an earlier run; its image is estimated "
                   "again\n";
    }
    skip = AlreadyDone(images, *done, flags.no_skip);
    // Every image estimated now (a failed one again) replaces its record.
    std::vector<std::string> redone;
    for (std::size_t i = 0; i < images.size(); ++i) {
      if (!skip[i]) redone.push_back(images[i]);
    }
    if (absl::Status s = sink.Open(flags.out, KeptResults(*done, out_format, redone)); !s.ok()) {
      return Fail(s, json);
    }
  }
  std::vector<std::size_t> todo;  // indices into images
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (!skip[i]) todo.push_back(i);
  }
  if (todo.size() < images.size() && !flags.quiet) {
    std::cerr << "weavefit: " << images.size() - todo.size() << " of " << images.size()
              << " images skipped: their results are already in " << flags.out
              << " (--no-skip to estimate them again)\n";
  }
  if (todo.empty()) return 0;

  // --same-cylinder: the series' cylinder, detected here on every image
  // (skipped or not: they are one set-up) before any is sent.
  absl::StatusOr<bool> share = SharesCylinder(flags.same_cylinder, false, flags.own_cylinders,
                                              flags.metadata, images.size());
  if (!share.ok()) return Fail(share.status(), json);
  absl::StatusOr<SeriesCylinder> series = SeriesCylinder();
  if (*share) series = ShareCylinderOfFiles(flags.metadata, images, rows);
  if (!series.ok()) return Fail(series.status(), json);
  if (!series->summary.empty() && !flags.quiet) {
    std::cerr << "weavefit: " << series->summary << "\n";
  }

  absl::StatusOr<Client> client = Client::Connect(flags.connection);
  if (!client.ok()) return Fail(client.status(), json);

  const bool terminal = isatty(STDERR_FILENO) == 1;
  Progress progress(todo.size(), terminal, terminal && isatty(STDOUT_FILENO) == 1, flags.quiet);
  if (flags.format == "csv") std::cout << CsvHeader() << std::flush;
  progress.Start();

  // Stdout in the inputs' order: each result as soon as all before it are in.
  std::vector<std::optional<ImageOutcome>> finished(todo.size());
  std::size_t printed = 0;
  absl::Status write_error;
  BatchHooks hooks;
  // Plot names over every input, skipped or not, so that a re-run keeps them.
  const std::vector<std::string> plot_names = PlotFileNames(images);
  // The request made for each image, for its record should it fail (each
  // k is written and read by the one worker that estimates it).
  std::vector<std::optional<v1::RequestHeader>> asked(todo.size());
  hooks.estimate = [&](std::size_t k) -> absl::StatusOr<v1::EstimateReply> {
    const std::string& image = images[todo[k]];
    absl::StatusOr<std::string> bytes = ReadFile(image);
    if (!bytes.ok()) return bytes.status();
    absl::StatusOr<v1::RequestHeader> header =
        HeaderFor(flags.metadata, image, todo[k], FindRow(rows, image));
    if (!header.ok()) return header.status();
    if (!flags.plot_dir.empty()) header->mutable_options()->set_include_curves(true);
    if (series->given) {
      *header->mutable_acquisition()->mutable_given_cylinder() = *series->given;
    }
    const v1::RequestHeader sent = *header;
    asked[k] = sent;
    absl::StatusOr<v1::EstimateReply> reply = client->Estimate(*std::move(header), *bytes);
    if (!reply.ok() && !flags.plot_dir.empty()) {
      ReportRefusalPlot(flags.plot_dir, plot_names[todo[k]], image, *bytes, sent, reply.status());
    }
    if (reply.ok() && series->given) AddSeriesNote(series->notes[todo[k]], &*reply);
    if (reply.ok() && !flags.plot_dir.empty()) {
      if (absl::Status s = PlotInto(flags.plot_dir, plot_names[todo[k]], image, *bytes, &*reply);
          !s.ok()) {
        return s;
      }
    }
    return reply;
  };
  hooks.on_retry = [&](std::size_t k, const absl::Status& failure, int retry, double wait_s) {
    progress.Retry(images[todo[k]], failure, retry, flags.retry.max_retries, wait_s);
  };
  hooks.await_daemon = [&](double timeout_s) {
    if (client->Connected()) return Reconnect::kConnected;
    return client->WaitForConnected(timeout_s) ? Reconnect::kBack : Reconnect::kGone;
  };
  hooks.on_reconnected = [&](std::size_t k, const absl::Status& failure, double waited_s) {
    progress.Reconnected(images[todo[k]], failure, waited_s);
  };
  hooks.on_done = [&](std::size_t k, const ImageOutcome& outcome) {
    const std::string& image = images[todo[k]];
    if (write_error.ok()) {
      write_error = sink.Append(ResultRecord(out_format, image, outcome.reply, asked[k]));
    }
    progress.Done(image, outcome);
    finished[k] = outcome;
    std::string text;
    for (; printed < todo.size() && finished[printed]; ++printed) {
      const ImageOutcome& o = *finished[printed];
      const std::string& name = images[todo[printed]];
      if (flags.format == "json") {
        text += o.reply.ok() ? JsonLine(*o.reply) : ImageErrorJson(name, o.reply.status());
        text += "\n";
      } else if (flags.format == "csv") {
        ReportRow row;
        row.image = name;
        if (o.reply.ok()) {
          row.reply = *o.reply;
        } else {
          row.error = StatusLine(o.reply.status());
        }
        row.header = asked[printed];
        text += CsvRow(row);
      }
    }
    progress.Print(text);
  };
  RunBatch(todo.size(), flags.jobs, flags.retry, hooks);
  progress.Finish();

  std::vector<ReportRow> table;
  std::vector<std::pair<std::string, absl::Status>> failures;
  for (std::size_t k = 0; k < todo.size(); ++k) {
    const std::string& image = images[todo[k]];
    const ImageOutcome& o = *finished[k];
    ReportRow row;
    row.image = image;
    if (o.reply.ok()) {
      row.reply = *o.reply;
    } else {
      row.error = StatusLine(o.reply.status());
      failures.push_back({image, o.reply.status()});
    }
    if (auto sidecar = ReadSidecar(image)) {
      row.truth_spacing_deg = StructNumber(*sidecar, "truth", "peakSpacingDeg");
    }
    table.push_back(std::move(row));
  }
  if (flags.format == "table") std::cout << FormatTable(table);
  std::cout << std::flush;
  if (todo.size() == 1 && !failures.empty()) {
    std::cerr << "weavefit: " << failures[0].first << ": " << StatusLine(failures[0].second)
              << "\n";
  } else if (!failures.empty()) {
    std::cerr << "weavefit: " << FailureSummary(failures, todo.size());
  }
  if (!write_error.ok()) {
    std::cerr << "weavefit: " << write_error.message() << "\n";
    if (failures.empty()) return static_cast<int>(write_error.code());
  }
  return failures.empty() ? 0 : static_cast<int>(failures[0].second.code());
}

}  // namespace weavefit
