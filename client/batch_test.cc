// Unit tests of client/batch: input expansion, the manifest, the metadata
// of each request, the results file and its skip logic, the retry policy and
// the batch runner. No daemon: the runner is given a fake estimate.
#include "client/batch.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <mutex>
#include <thread>

#include "client/report.h"
#include "tests/temp_dir.h"

namespace weavefit {
namespace {

std::string MakeTempDir() { return testing::MakeTempDir("batch_test_"); }

void Touch(const std::string& path, const std::string& text = "x") {
  std::ofstream(path, std::ios::binary) << text;
}

std::string Cwd() {
  char buffer[4096];
  return getcwd(buffer, sizeof(buffer)) != nullptr ? std::string(buffer) : std::string();
}

TEST(InputsTest, ImageExtensionsInAnyCase) {
  for (const char* yes : {"a.png", "b.PNG", "c.tif", "d.TIFF", "e.jpg", "f.JPEG", "g.exr",
                          "dir.x/h.png"}) {
    EXPECT_TRUE(HasImageExtension(yes)) << yes;
  }
  for (const char* no : {"a.json", "b", "dir.png/c", "d.png.txt", "e.csv"}) {
    EXPECT_FALSE(HasImageExtension(no)) << no;
  }
}

TEST(InputsTest, PathKeyIsAbsoluteAndNormal) {
  EXPECT_EQ(PathKey("a/./b/../c.png"), Cwd() + "/a/c.png");
  EXPECT_EQ(PathKey("/x//y/../z.png"), "/x/z.png");
  EXPECT_EQ(PathKey("./c.png"), PathKey("c.png"));
}

TEST(InputsTest, FoldersGlobsAndFilesInOrderEachOnce) {
  const std::string dir = MakeTempDir();
  Touch(dir + "/b.TIF");
  Touch(dir + "/a.png");
  Touch(dir + "/notes.txt");
  Touch(dir + "/a.json");
  Touch(dir + "/.hidden.png");
  mkdir((dir + "/sub").c_str(), 0755);
  Touch(dir + "/sub/c.exr");
  Touch(dir + "/sub/d.jpeg");

  // A folder: its images, sorted, no recursion, no dot files.
  absl::StatusOr<std::vector<std::string>> folder = ExpandInputs({dir});
  ASSERT_TRUE(folder.ok()) << folder.status();
  EXPECT_EQ(*folder, (std::vector<std::string>{dir + "/a.png", dir + "/b.TIF"}));
  // A trailing slash does not double it.
  EXPECT_EQ(*ExpandInputs({dir + "/"}), *folder);

  // A pattern the shell left alone: its images only (not notes.txt, a.json).
  absl::StatusOr<std::vector<std::string>> globbed = ExpandInputs({dir + "/*"});
  ASSERT_TRUE(globbed.ok()) << globbed.status();
  EXPECT_EQ(*globbed, (std::vector<std::string>{dir + "/a.png", dir + "/b.TIF"}));

  // Files as given, whatever their extension, in order.
  absl::StatusOr<std::vector<std::string>> mixed =
      ExpandInputs({dir + "/sub/d.jpeg", dir + "/notes.txt", dir, dir + "/./a.png",
                    dir + "/sub/../b.TIF", dir + "/sub/?.exr"});
  ASSERT_TRUE(mixed.ok()) << mixed.status();
  EXPECT_EQ(*mixed, (std::vector<std::string>{dir + "/sub/d.jpeg", dir + "/notes.txt",
                                              dir + "/a.png", dir + "/b.TIF",
                                              dir + "/./a.png", dir + "/sub/../b.TIF",
                                              dir + "/sub/c.exr"}));
  // A batch takes each image once, at its first mention, however spelled.
  EXPECT_EQ(DistinctImages(*mixed),
            (std::vector<std::string>{dir + "/sub/d.jpeg", dir + "/notes.txt", dir + "/a.png",
                                      dir + "/b.TIF", dir + "/sub/c.exr"}));

  // A missing file is that image's problem, later, not the batch's.
  absl::StatusOr<std::vector<std::string>> missing = ExpandInputs({dir + "/gone.png"});
  ASSERT_TRUE(missing.ok());
  EXPECT_EQ(*missing, std::vector<std::string>{dir + "/gone.png"});
}

TEST(InputsTest, EmptyFoldersAndPatternsThatMatchNothingAreErrors) {
  const std::string dir = MakeTempDir();
  Touch(dir + "/notes.txt");
  absl::StatusOr<std::vector<std::string>> empty = ExpandInputs({dir});
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(empty.status().message().find("holds no images"), absl::string_view::npos);
  absl::StatusOr<std::vector<std::string>> none = ExpandInputs({dir + "/*.png"});
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(none.status().message().find("no image matches"), absl::string_view::npos);
}

TEST(ManifestTest, ColumnsInAnyOrderQuotingAndEmptyCells) {
  const std::string text =
      "\xEF\xBB\xBF"
      "Sample_Name, path ,phase_angle_deg,diameter_mm,distance_mm\r\n"
      "\"gauze, coarse\",a.png,10,46,900\r\n"
      "\r\n"
      "silk,sub/b.tif,-60,,\r\n"
      ",/abs/c.exr,,40,\n"
      "\"say \"\"hi\"\"\",d.png,110.5,46,0";  // no line end at the end: fine
  absl::StatusOr<std::vector<ManifestRow>> rows = ParseManifest(text, "/lab/", "m.csv");
  ASSERT_TRUE(rows.ok()) << rows.status();
  ASSERT_EQ(rows->size(), 4u);
  const ManifestRow& a = (*rows)[0];
  EXPECT_EQ(a.path, "/lab/a.png");
  EXPECT_EQ(a.sample_name, "gauze, coarse");
  EXPECT_EQ(*a.phase_angle_deg, 10.0);
  EXPECT_EQ(*a.diameter_mm, 46.0);
  EXPECT_EQ(*a.distance_mm, 900.0);
  EXPECT_EQ(a.line, 2);
  const ManifestRow& b = (*rows)[1];
  EXPECT_EQ(b.path, "/lab/sub/b.tif");
  EXPECT_EQ(*b.phase_angle_deg, -60.0);
  EXPECT_FALSE(b.diameter_mm.has_value());
  EXPECT_FALSE(b.distance_mm.has_value());
  EXPECT_EQ(b.line, 4);
  const ManifestRow& c = (*rows)[2];
  EXPECT_EQ(c.path, "/abs/c.exr");  // absolute paths stay
  EXPECT_FALSE(c.phase_angle_deg.has_value());
  EXPECT_EQ(*c.diameter_mm, 40.0);
  EXPECT_EQ(c.sample_name, "");
  EXPECT_EQ((*rows)[3].sample_name, "say \"hi\"");
  EXPECT_EQ(*(*rows)[3].phase_angle_deg, 110.5);

  // Without a folder, paths are as written; only the path column is needed.
  absl::StatusOr<std::vector<ManifestRow>> bare = ParseManifest("path\nx.png\n", "", "m.csv");
  ASSERT_TRUE(bare.ok()) << bare.status();
  EXPECT_EQ((*bare)[0].path, "x.png");
}

TEST(ManifestTest, MistakesAreNamedWithTheirLine) {
  struct Case {
    std::string text;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"", "m.csv:1: empty"},
      {"\n\n", "m.csv:1: empty"},
      {"path,phase_angle\na.png,10\n", "m.csv:1: unknown column 'phase_angle'"},
      {"path,path\na.png,b.png\n", "m.csv:1: column 'path' twice"},
      {"phase_angle_deg\n10\n", "m.csv:1: no 'path' column"},
      {"path,phase_angle_deg\na.png,10\nb.png\n", "m.csv:3: 1 cells where the header has 2"},
      {"path,phase_angle_deg\na.png,ten\n", "m.csv:2: phase_angle_deg 'ten' is not a number"},
      {"path,diameter_mm\na.png,nan\n", "m.csv:2: diameter_mm 'nan' is not a number"},
      {"path\na.png\n./a.png\n", "m.csv:3: ./a.png is listed twice"},
      {"path,sample_name\n,x\n", "m.csv:2: empty path"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    absl::StatusOr<std::vector<ManifestRow>> rows = ParseManifest(c.text, "", "m.csv");
    ASSERT_FALSE(rows.ok());
    EXPECT_EQ(rows.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(rows.status().message().find(c.expect), absl::string_view::npos)
        << rows.status().message();
  }
}

TEST(ManifestTest, ReadRelativeToItsFolderAndFindRows) {
  const std::string dir = MakeTempDir();
  Touch(dir + "/manifest.csv", "path,phase_angle_deg\nimg/a.png,30\n");
  absl::StatusOr<std::vector<ManifestRow>> rows = ReadManifest(dir + "/manifest.csv");
  ASSERT_TRUE(rows.ok()) << rows.status();
  EXPECT_EQ((*rows)[0].path, dir + "/img/a.png");
  ASSERT_NE(FindRow(*rows, dir + "/img/./a.png"), nullptr);
  EXPECT_EQ(*FindRow(*rows, dir + "/img/./a.png")->phase_angle_deg, 30.0);
  EXPECT_EQ(FindRow(*rows, dir + "/img/b.png"), nullptr);
  EXPECT_EQ(ReadManifest(dir + "/none.csv").status().code(), absl::StatusCode::kNotFound);
}

// Each field: the manifest's cell, else --phase-angle (which also turns the
// sidecar off), else the sidecar, else the flags' defaults.
TEST(HeaderTest, ManifestThenFlagsThenSidecar) {
  const std::string dir = MakeTempDir();
  const std::string image = dir + "/s.png";
  Touch(image);
  Touch(dir + "/s.json",
        R"({"acquisition": {"phaseAngleDeg": 30, "cylinderDiameterMm": 40, "cameraDistanceMm": 800}})");
  MetadataFlags flags;
  flags.mode = "fast";

  absl::StatusOr<v1::RequestHeader> sidecar = HeaderFor(flags, image, 0, nullptr);
  ASSERT_TRUE(sidecar.ok()) << sidecar.status();
  EXPECT_EQ(sidecar->acquisition().phase_angle_deg(), 30.0);
  EXPECT_EQ(sidecar->acquisition().cylinder_diameter_mm(), 40.0);
  EXPECT_EQ(sidecar->acquisition().camera_distance_mm(), 800.0);
  EXPECT_EQ(sidecar->options().mode(), v1::FAST);
  EXPECT_EQ(sidecar->filename(), "s.png");
  EXPECT_EQ(sidecar->sample_name(), "s.png");

  ManifestRow row;
  row.path = image;
  row.phase_angle_deg = 60.0;
  row.sample_name = "silk 3";
  absl::StatusOr<v1::RequestHeader> manifest = HeaderFor(flags, image, 0, &row);
  ASSERT_TRUE(manifest.ok());
  EXPECT_EQ(manifest->acquisition().phase_angle_deg(), 60.0);
  EXPECT_EQ(manifest->acquisition().cylinder_diameter_mm(), 40.0);  // the sidecar's
  EXPECT_EQ(manifest->sample_name(), "silk 3");
  EXPECT_EQ(manifest->filename(), "s.png");

  flags.phase_angles_deg = {10.0};
  absl::StatusOr<v1::RequestHeader> given = HeaderFor(flags, image, 0, nullptr);
  ASSERT_TRUE(given.ok());
  EXPECT_EQ(given->acquisition().phase_angle_deg(), 10.0);
  EXPECT_EQ(given->acquisition().cylinder_diameter_mm(), 0.0);  // no sidecar read: not given
  EXPECT_EQ(given->acquisition().camera_distance_mm(), 0.0);

  ManifestRow diameter_only;
  diameter_only.path = image;
  diameter_only.diameter_mm = 50.0;
  absl::StatusOr<v1::RequestHeader> both = HeaderFor(flags, image, 0, &diameter_only);
  ASSERT_TRUE(both.ok());
  EXPECT_EQ(both->acquisition().phase_angle_deg(), 10.0);
  EXPECT_EQ(both->acquisition().cylinder_diameter_mm(), 50.0);
  EXPECT_EQ(both->sample_name(), "s.png");

  flags.phase_angles_deg = {10.0, 60.0, 110.0};
  EXPECT_EQ(HeaderFor(flags, image, 2, nullptr)->acquisition().phase_angle_deg(), 110.0);
  EXPECT_EQ(HeaderFor(flags, image, 3, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);

  const std::string bare = dir + "/bare.png";
  Touch(bare);
  absl::StatusOr<v1::RequestHeader> nothing = HeaderFor(MetadataFlags(), bare, 0, nullptr);
  EXPECT_EQ(nothing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(nothing.status().message().find("no phase angle for " + bare),
            absl::string_view::npos);
  EXPECT_NE(nothing.status().message().find("manifest"), absl::string_view::npos);
}

// --cylinder and --roi go into the acquisition as they are (the estimate
// checks their values); a wrong count of values is refused here.
TEST(HeaderTest, CylinderAndRegionFlags) {
  MetadataFlags flags;
  flags.phase_angles_deg = {10.0};
  flags.cylinder = {159.5, 128.0, -1.5};
  flags.roi = {0, 20, 320, 200};
  absl::StatusOr<v1::RequestHeader> h = HeaderFor(flags, "a.png", 0, nullptr);
  ASSERT_TRUE(h.ok()) << h.status();
  ASSERT_TRUE(h->acquisition().has_given_cylinder());
  const v1::GivenCylinder& g = h->acquisition().given_cylinder();
  EXPECT_EQ(g.center_x_px(), 159.5);
  EXPECT_EQ(g.radius_px(), 128.0);
  EXPECT_EQ(g.axis_angle_deg(), -1.5);
  EXPECT_EQ(g.radius_stderr_px(), 0.0);  // the default, 0.5 px
  EXPECT_EQ(g.source(), v1::GIVEN);
  EXPECT_EQ(h->acquisition().roi().y_px(), 20);
  EXPECT_EQ(h->acquisition().roi().height_px(), 200);
  flags.cylinder.push_back(0.25);
  EXPECT_EQ(HeaderFor(flags, "a.png", 0, nullptr)->acquisition().given_cylinder().radius_stderr_px(),
            0.25);
  flags.cylinder = {159.5, 128.0};
  absl::StatusOr<v1::RequestHeader> two = HeaderFor(flags, "a.png", 0, nullptr);
  EXPECT_EQ(two.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(two.status().message().find("--cylinder takes"), absl::string_view::npos);
  flags.cylinder.clear();
  flags.roi = {1, 2, 3};
  EXPECT_EQ(HeaderFor(flags, "a.png", 0, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  flags.roi.clear();
  EXPECT_FALSE(HeaderFor(flags, "a.png", 0, nullptr)->acquisition().has_given_cylinder());
}

v1::EstimateReply Reply(const std::string& sample, double slope) {
  v1::EstimateReply reply;
  reply.set_sample_name(sample);
  reply.set_model(v1::SINUSOID);
  reply.mutable_max_slope()->set_value(slope);
  reply.mutable_max_slope()->set_stderr(0.001);
  reply.mutable_max_slope()->set_resolved(true);
  reply.add_warnings("a warning, with a comma and \"quotes\"");
  return reply;
}

TEST(ResultsTest, FormatFromTheFileName) {
  EXPECT_EQ(ResultsFormatFor("out.csv"), ResultsFormat::kCsv);
  EXPECT_EQ(ResultsFormatFor("OUT.CSV"), ResultsFormat::kCsv);
  EXPECT_EQ(ResultsFormatFor("out.jsonl"), ResultsFormat::kJsonLines);
  EXPECT_EQ(ResultsFormatFor("out"), ResultsFormat::kJsonLines);
}

TEST(ResultsTest, JsonLinesRoundTripAndATornTailIsDropped) {
  const std::string a =
      ResultRecord(ResultsFormat::kJsonLines, "dir/a \"1\".png", Reply("a", 0.2), std::nullopt);
  const std::string b =
      ResultRecord(ResultsFormat::kJsonLines, "b.png", Reply("b", 0.3), std::nullopt);
  EXPECT_EQ(a.rfind("{\"image\":\"dir/a \\\"1\\\".png\",\"reply\":{", 0), 0u) << a;
  EXPECT_EQ(a.back(), '\n');
  EXPECT_EQ(std::count(a.begin(), a.end(), '\n'), 1);

  absl::StatusOr<ResultsFile> file =
      ParseResults(a + "\n" + b + b.substr(0, 30), ResultsFormat::kJsonLines, "out.jsonl");
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->images, (std::vector<std::string>{"dir/a \"1\".png", "b.png"}));
  EXPECT_EQ(file->records, (std::vector<std::string>{a, b}));
  EXPECT_TRUE(file->torn_tail);

  absl::StatusOr<ResultsFile> empty = ParseResults("", ResultsFormat::kJsonLines, "out.jsonl");
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->images.empty());
  EXPECT_FALSE(empty->torn_tail);
}

TEST(ResultsTest, AFileWeavefitDidNotWriteIsRefused) {
  for (const std::string& text :
       {std::string("not json\n"), std::string("{\"image\": \"a.png\"}\n"),
        std::string("{\"reply\": {}}\n"), std::string("[1, 2]\n")}) {
    absl::StatusOr<ResultsFile> file = ParseResults(text, ResultsFormat::kJsonLines, "x.jsonl");
    EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument) << text;
    EXPECT_NE(file.status().message().find("x.jsonl:1:"), absl::string_view::npos);
  }
  for (const std::string& text : {std::string("a,b,c\n1,2,3\n"),
                                  CsvHeader() + "a.png,x,OK\n"}) {
    absl::StatusOr<ResultsFile> file = ParseResults(text, ResultsFormat::kCsv, "x.csv");
    EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument) << text;
  }
}

TEST(ResultsTest, CsvRoundTripAndATornTailIsDropped) {
  const std::string a =
      ResultRecord(ResultsFormat::kCsv, "a,1.png", Reply("a", 0.2), std::nullopt);
  const std::string b = ResultRecord(ResultsFormat::kCsv, "b.png", Reply("b", 0.3), std::nullopt);
  absl::StatusOr<ResultsFile> file =
      ParseResults(CsvHeader() + a + b + b.substr(0, 20), ResultsFormat::kCsv, "out.csv");
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->images, (std::vector<std::string>{"a,1.png", "b.png"}));
  EXPECT_EQ(file->records, (std::vector<std::string>{a, b}));  // verbatim
  EXPECT_TRUE(file->torn_tail);
  // Only a header (a run that finished nothing) is an empty file.
  absl::StatusOr<ResultsFile> header = ParseResults(CsvHeader(), ResultsFormat::kCsv, "out.csv");
  ASSERT_TRUE(header.ok()) << header.status();
  EXPECT_TRUE(header->images.empty());
  EXPECT_FALSE(header->torn_tail);
}

TEST(ResultsTest, ImagesWithResultsAreSkippedUnlessNoSkip) {
  ResultsFile done;
  done.images = {"fixtures/a.png", "./fixtures/b.png"};
  done.records = {"A\n", "B\n"};
  done.failed = {false, false};
  const std::vector<std::string> batch = {"fixtures/./a.png", "fixtures/b.png", "fixtures/c.png"};
  EXPECT_EQ(AlreadyDone(batch, done, false), (std::vector<bool>{true, true, false}));
  EXPECT_EQ(AlreadyDone(batch, done, true), (std::vector<bool>{false, false, false}));
  // The file keeps one record per image: what is redone is dropped first.
  EXPECT_EQ(KeptResults(done, ResultsFormat::kJsonLines, {}), "A\nB\n");
  EXPECT_EQ(KeptResults(done, ResultsFormat::kJsonLines, {"fixtures/b.png"}), "A\n");
  EXPECT_EQ(KeptResults(done, ResultsFormat::kCsv, batch), CsvHeader());
}

TEST(ResultsTest, AFailedPhotographHasARecordAndIsTriedAgain) {
  v1::RequestHeader asked;
  asked.mutable_acquisition()->set_phase_angle_deg(10.0);
  asked.mutable_acquisition()->set_cylinder_diameter_mm(46.0);
  asked.mutable_options()->set_mode(v1::FAST);
  const absl::Status refused = absl::InvalidArgumentError("no cylinder found, nor a \"limb\"");
  for (ResultsFormat format : {ResultsFormat::kCsv, ResultsFormat::kJsonLines}) {
    const std::string ok = ResultRecord(format, "a.png", Reply("a", 0.2), std::nullopt);
    const std::string failed = ResultRecord(format, "b.png", refused, asked);
    EXPECT_NE(failed.find("INVALID_ARGUMENT"), std::string::npos) << failed;
    absl::StatusOr<ResultsFile> file =
        ParseResults((format == ResultsFormat::kCsv ? CsvHeader() : "") + ok + failed, format,
                     "out");
    ASSERT_TRUE(file.ok()) << file.status();
    EXPECT_EQ(file->images, (std::vector<std::string>{"a.png", "b.png"}));
    EXPECT_EQ(file->failed, (std::vector<bool>{false, true}));
    // The failed one is estimated again, the other skipped.
    EXPECT_EQ(AlreadyDone({"a.png", "b.png"}, *file, false), (std::vector<bool>{true, false}));
  }
  // The CSV's failed row says what was asked, and its message splits on
  // commas alone.
  const std::string row = ResultRecord(ResultsFormat::kCsv, "b.png", refused, asked);
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), CsvColumns().size() - 1) << row;
  EXPECT_NE(row.find(",10,46,0,fast,"), std::string::npos) << row;
  // The JSON record carries the request and this client's version.
  const std::string json = ResultRecord(ResultsFormat::kJsonLines, "b.png", refused, asked);
  EXPECT_NE(json.find("\"asked\":{"), std::string::npos) << json;
  EXPECT_NE(json.find("\"version\":"), std::string::npos) << json;
}

TEST(RetryTest, RetryableCodes) {
  EXPECT_TRUE(IsRetryable(absl::StatusCode::kUnavailable));
  EXPECT_TRUE(IsRetryable(absl::StatusCode::kResourceExhausted));
  EXPECT_TRUE(IsRetryable(absl::StatusCode::kDeadlineExceeded));
  for (absl::StatusCode code :
       {absl::StatusCode::kOk, absl::StatusCode::kInvalidArgument, absl::StatusCode::kNotFound,
        absl::StatusCode::kUnauthenticated, absl::StatusCode::kPermissionDenied,
        absl::StatusCode::kInternal, absl::StatusCode::kCancelled,
        absl::StatusCode::kUnimplemented}) {
    EXPECT_FALSE(IsRetryable(code)) << absl::StatusCodeToString(code);
  }
}

TEST(RetryTest, ExponentialBackoffWithEqualJitter) {
  const RetryPolicy policy;  // 0.5 s, ×2, at most 10 s
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 1, 0.0), 0.25);
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 1, 0.5), 0.375);
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 2, 0.0), 0.5);
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 3, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 3, 1.0), 2.0);
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 6, 0.0), 5.0);   // ceiling 10 reached (16 → 10)
  EXPECT_DOUBLE_EQ(BackoffSeconds(policy, 30, 0.99), 9.95);
  for (int retry = 1; retry < 10; ++retry) {
    EXPECT_LE(BackoffSeconds(policy, retry, 0.999), BackoffSeconds(policy, retry + 1, 0.999));
  }
}

TEST(RunBatchTest, RetriesRetryableFailuresOnlyAndReportsEachImageOnce) {
  RetryPolicy policy;
  policy.max_retries = 3;
  std::mutex mutex;
  std::vector<int> calls(4, 0);
  std::vector<double> waits;
  std::vector<int> done(4, 0);
  std::vector<std::string> retried;
  BatchHooks hooks;
  hooks.estimate = [&](std::size_t i) -> absl::StatusOr<v1::EstimateReply> {
    int call;
    {
      std::lock_guard<std::mutex> lock(mutex);
      call = ++calls[i];
    }
    switch (i) {
      case 0:  // a daemon goes away twice, then one answers
        if (call <= 2) return absl::UnavailableError("Socket closed");
        return Reply("zero", 0.2);
      case 1:  // bad input: no retry
        return absl::InvalidArgumentError("not an image");
      case 2:  // never a daemon: given up after the retries
        return absl::UnavailableError("connection refused");
      default:  // a full queue once
        if (call == 1) return absl::ResourceExhaustedError("queue full");
        return Reply("three", 0.3);
    }
  };
  hooks.on_retry = [&](std::size_t i, const absl::Status& failure, int retry, double wait_s) {
    retried.push_back(std::to_string(i) + ":" + std::to_string(retry) + ":" +
                      std::string(absl::StatusCodeToString(failure.code())));
    EXPECT_GT(wait_s, 0.0);
  };
  hooks.sleep = [&](double seconds) {
    std::lock_guard<std::mutex> lock(mutex);
    waits.push_back(seconds);
  };
  hooks.uniform = [] { return 0.0; };
  hooks.on_done = [&](std::size_t i, const ImageOutcome&) { ++done[i]; };
  const std::vector<ImageOutcome> outcomes = RunBatch(4, 2, policy, hooks);
  ASSERT_EQ(outcomes.size(), 4u);
  EXPECT_TRUE(outcomes[0].reply.ok());
  EXPECT_EQ(outcomes[0].attempts, 3);
  EXPECT_EQ(outcomes[1].reply.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(outcomes[1].attempts, 1);
  EXPECT_EQ(outcomes[2].reply.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(outcomes[2].attempts, 4);  // the first and three retries
  EXPECT_TRUE(outcomes[3].reply.ok());
  EXPECT_EQ(outcomes[3].attempts, 2);
  EXPECT_EQ(calls, (std::vector<int>{3, 1, 4, 2}));
  EXPECT_EQ(done, (std::vector<int>{1, 1, 1, 1}));
  EXPECT_EQ(retried.size(), 2u + 3u + 1u);
  EXPECT_NE(std::find(retried.begin(), retried.end(), "2:3:UNAVAILABLE"), retried.end());
  EXPECT_NE(std::find(retried.begin(), retried.end(), "3:1:RESOURCE_EXHAUSTED"), retried.end());
  // Half the ceiling each (uniform draw 0): image 0 waits 0.25 and 0.5 s,
  // image 2 0.25, 0.5 and 1 s, image 3 0.25 s.
  std::sort(waits.begin(), waits.end());
  EXPECT_EQ(waits, (std::vector<double>{0.25, 0.25, 0.25, 0.5, 0.5, 1.0}));
}

TEST(RunBatchTest, NoMoreCallsInFlightThanJobs) {
  std::atomic<int> active{0};
  std::atomic<int> most{0};
  BatchHooks hooks;
  hooks.estimate = [&](std::size_t) -> absl::StatusOr<v1::EstimateReply> {
    const int now = ++active;
    int seen = most.load();
    while (now > seen && !most.compare_exchange_weak(seen, now)) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
    --active;
    return v1::EstimateReply();
  };
  const std::vector<ImageOutcome> outcomes = RunBatch(24, 3, RetryPolicy(), hooks);
  EXPECT_EQ(outcomes.size(), 24u);
  for (const ImageOutcome& o : outcomes) EXPECT_TRUE(o.reply.ok());
  EXPECT_LE(most.load(), 3);
  EXPECT_GE(most.load(), 2);  // they did overlap
  EXPECT_TRUE(RunBatch(0, 4, RetryPolicy(), hooks).empty());
}

// A daemon on a fake clock, s: gone during the outages [from, to), up
// otherwise; each answered call takes 1 s. One worker (jobs 1) drives it.
struct FakeDaemon {
  std::vector<std::pair<double, double>> outages;
  double now = 0.0;
  std::vector<double> wait_timeouts;  // what await_daemon was given

  bool Up() const {
    for (const auto& [from, to] : outages) {
      if (now >= from && now < to) return false;
    }
    return true;
  }
  // When the outage around `now` ends.
  double BackAt() const {
    for (const auto& [from, to] : outages) {
      if (now >= from && now < to) return to;
    }
    return now;
  }
  BatchHooks Hooks() {
    BatchHooks hooks;
    hooks.estimate = [this](std::size_t i) -> absl::StatusOr<v1::EstimateReply> {
      if (!Up()) return absl::UnavailableError("failed to connect: Connection refused");
      now += 1.0;
      return Reply(std::to_string(i), 0.2);
    };
    hooks.await_daemon = [this](double timeout_s) {
      wait_timeouts.push_back(timeout_s);
      if (Up()) return Reconnect::kConnected;
      if (BackAt() - now <= timeout_s) {
        now = BackAt();
        return Reconnect::kBack;
      }
      now += timeout_s;
      return Reconnect::kGone;
    };
    hooks.sleep = [this](double seconds) { now += seconds; };
    hooks.now = [this] { return now; };
    hooks.uniform = [] { return 0.0; };
    return hooks;
  }
};

// Issue 30: a daemon restarted 12 s after it went away, longer than the
// three retries' backoff (0.25 + 0.5 + 1 s) lasts.
TEST(ReconnectTest, AnImageWaitsForTheDaemonWithinTheWindowSpendingNoRetries) {
  FakeDaemon daemon;
  daemon.outages = {{0.0, 12.0}};
  BatchHooks hooks = daemon.Hooks();
  int retries = 0;
  std::vector<double> reconnected_after_s;
  hooks.on_retry = [&](std::size_t, const absl::Status&, int, double) { ++retries; };
  hooks.on_reconnected = [&](std::size_t i, const absl::Status& failure, double waited_s) {
    EXPECT_EQ(i, 0u);
    EXPECT_EQ(failure.code(), absl::StatusCode::kUnavailable);
    reconnected_after_s.push_back(waited_s);
  };
  const std::vector<ImageOutcome> outcomes = RunBatch(3, 1, RetryPolicy(), hooks);
  for (const ImageOutcome& o : outcomes) EXPECT_TRUE(o.reply.ok()) << o.reply.status();
  EXPECT_EQ(outcomes[0].attempts, 2);
  EXPECT_EQ(retries, 0);
  EXPECT_EQ(reconnected_after_s, std::vector<double>{12.0});
  EXPECT_EQ(daemon.wait_timeouts, std::vector<double>{30.0});  // the default window

  // Without the window, the retries run out while the daemon is away.
  FakeDaemon again;
  again.outages = {{0.0, 12.0}};
  RetryPolicy no_window;
  no_window.reconnect_window_s = 0.0;
  const std::vector<ImageOutcome> lost = RunBatch(3, 1, no_window, again.Hooks());
  EXPECT_EQ(lost[0].reply.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(lost[0].attempts, 4);
  EXPECT_TRUE(again.wait_timeouts.empty());
}

TEST(ReconnectTest, AnImageIsLostWhenTheDaemonIsNotBackWithinTheWindow) {
  FakeDaemon daemon;
  daemon.outages = {{0.0, 45.0}};
  RetryPolicy policy;
  policy.reconnect_window_s = 20.0;
  const std::vector<ImageOutcome> outcomes = RunBatch(3, 1, policy, daemon.Hooks());
  for (const ImageOutcome& o : outcomes) {
    EXPECT_EQ(o.reply.status().code(), absl::StatusCode::kUnavailable);
    EXPECT_EQ(o.attempts, 1);  // no retries spent on a gone daemon either
    EXPECT_EQ(o.reply.status().message(),
              "the daemon did not come back within 20 s (--reconnect-window-s): failed to "
              "connect: Connection refused");
  }
  // The window is the batch's: the images after the first only look.
  EXPECT_EQ(daemon.wait_timeouts, (std::vector<double>{20.0, 0.0, 0.0}));
  EXPECT_EQ(daemon.now, 20.0);
}

TEST(ReconnectTest, AnAnswerStartsTheWindowAfresh) {
  FakeDaemon daemon;
  daemon.outages = {{0.0, 25.0}, {30.0, 55.0}};  // 25 s each, 5 images between
  const std::vector<ImageOutcome> outcomes = RunBatch(10, 1, RetryPolicy(), daemon.Hooks());
  for (const ImageOutcome& o : outcomes) EXPECT_TRUE(o.reply.ok()) << o.reply.status();
  EXPECT_EQ(daemon.wait_timeouts, (std::vector<double>{30.0, 30.0}));
}

// A connected channel with UNAVAILABLE calls (a daemon says so itself, or
// one of several is down) and other retryable codes keep the backoff.
TEST(ReconnectTest, OtherFailuresKeepTheBackoff) {
  int awaits = 0;
  std::vector<double> waits;
  BatchHooks hooks;
  hooks.estimate = [](std::size_t i) -> absl::StatusOr<v1::EstimateReply> {
    if (i == 0) return absl::UnavailableError("shutting down");
    return absl::ResourceExhaustedError("queue full");
  };
  hooks.await_daemon = [&](double) {
    ++awaits;
    return Reconnect::kConnected;
  };
  hooks.sleep = [&](double s) { waits.push_back(s); };
  hooks.uniform = [] { return 0.0; };
  const std::vector<ImageOutcome> outcomes = RunBatch(2, 1, RetryPolicy(), hooks);
  EXPECT_EQ(outcomes[0].reply.status().message(), "shutting down");
  EXPECT_EQ(outcomes[0].attempts, 4);
  EXPECT_EQ(outcomes[1].reply.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(outcomes[1].attempts, 4);
  EXPECT_EQ(awaits, 4);  // after each of image 0's attempts only
  EXPECT_EQ(waits, (std::vector<double>{0.25, 0.5, 1.0, 0.25, 0.5, 1.0}));
}

TEST(ReportingTest, ProgressAndFailureSummary) {
  EXPECT_EQ(ProgressLine(12, 30, 1), "12/30 done, 1 failed");
  EXPECT_EQ(FailureSummary({}, 30), "");
  EXPECT_EQ(FailureSummary({{"a.png", absl::InvalidArgumentError("no cylinder found")},
                            {"b.png", absl::UnavailableError("connection refused")}},
                           30),
            "2 of 30 images failed:\n"
            "  a.png: INVALID_ARGUMENT: no cylinder found\n"
            "  b.png: UNAVAILABLE: connection refused\n");
}

}  // namespace
}  // namespace weavefit
