// Fixture regression suite (STYLE.md "Tests"): one parameterised test per
// photograph in fixtures/, estimated in-process with the library and compared
// with the truth in its sidecar, quantity by quantity, with the tolerances of
// tests/regression_tolerances.tsv (never bit-exact floats). At the end it
// prints one table a person can read: per fixture and quantity the truth, the
// estimate, the error, the reported standard error, the tolerance, the
// estimate's wall time and PASS / FAIL / XFAIL / XPASS / SKIP.
//
// Verdicts: PASS when |estimate − truth| <= abs + k·stderr; FAIL otherwise (a
// test failure); XFAIL when a row of the table's section 2 expects this
// fixture's quantity to fail and it does (no test failure, reason printed);
// XPASS when such a row expects a failure and the check passes: a test
// failure, so the override is tightened or deleted rather than forgotten.
// SKIP when the sidecar has no truth for the quantity. The pseudo-quantity
// "status" is the estimate's own success: a valid photograph must not be
// answered with an error, and when it is, nothing else can be checked.
//
// The fixture list is read from the directory when the test binary starts, so
// a new photograph with its sidecar joins by itself (tests/CMakeLists.txt also
// re-runs ctest's discovery when the list of images changes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "estimator/pipeline/estimate.h"
#include "proto/weavefit/v1/convert.h"
#include "tests/test_support.h"

namespace weavefit::testing {
namespace {

constexpr double kDeg = M_PI / 180.0;
const char kTolerancesPath[] = REGRESSION_TOLERANCES;

// The checked quantities in table order, with the unit the tolerance table
// must state for each and the decimals printed.
struct QuantitySpec {
  const char* name;
  const char* unit;
  int decimals;
};
constexpr QuantitySpec kQuantities[] = {
    {"status", "-", 0},
    {"model", "-", 0},
    {"splitResolved", "-", 0},
    {"peakSpacingDeg", "deg", 3},
    {"maxSlope", "spacing-deg", 4},
    {"specularAzimuthDeg", "deg", 3},
    {"centerXPx", "px", 2},
    {"radiusPx", "px", 2},
    {"axisAngleDeg", "deg", 3},
    {"wavelengthMm", "mm", 3},
    {"amplitudeMm", "mm", 4},
};

const QuantitySpec* FindQuantity(const std::string& name) {
  for (const QuantitySpec& q : kQuantities) {
    if (name == q.name) return &q;
  }
  return nullptr;
}

// ---------------------------------------------------------------------------
// The tolerance table.

struct Tolerance {
  double abs = 0.0;  // in the quantity's unit
  double k = 0.0;    // multiple of the reported stderr
};

// A section 2 row: a different tolerance, or an expected failure, for one
// fixture's quantity.
struct Override {
  std::string fixture;  // the image's file name
  std::string quantity;
  std::optional<double> abs;  // nullopt: section 1's
  std::optional<double> k;
  bool xfail = false;
  std::string reason;
  int line = 0;
};

struct ToleranceTable {
  std::map<std::string, Tolerance> defaults;
  std::vector<Override> overrides;

  // The tolerance for one fixture's quantity; *override is the section 2 row
  // that applies, or nullptr.
  Tolerance For(const std::string& fixture, const std::string& quantity,
                const Override** override) const {
    Tolerance t = defaults.at(quantity);
    *override = nullptr;
    for (const Override& o : overrides) {
      if (o.fixture != fixture || o.quantity != quantity) continue;
      if (o.abs) t.abs = *o.abs;
      if (o.k) t.k = *o.k;
      *override = &o;
    }
    return t;
  }
};

absl::Status TableError(int line, const std::string& what) {
  return absl::InvalidArgumentError(
      absl::StrCat(kTolerancesPath, ":", line, ": ", what));
}

// A tolerance field: a number >= 0, or "-" (nullopt) where `dash_ok`.
absl::StatusOr<std::optional<double>> ParseField(const std::string& field,
                                                 const char* column, int line,
                                                 bool dash_ok) {
  if (dash_ok && field == "-") return std::optional<double>();
  double value = 0.0;
  if (!absl::SimpleAtod(field, &value) || !std::isfinite(value) || value < 0.0) {
    return TableError(line, absl::StrCat(column, " must be a number >= 0",
                                         dash_ok ? " or \"-\"" : "", ", got \"",
                                         field, "\""));
  }
  return std::optional<double>(value);
}

// Section 1 (header "quantity unit abs k comment", one row per quantity), then
// section 2 (header "fixture quantity abs k xfail reason"); # starts a
// comment line.
absl::StatusOr<ToleranceTable> ParseTolerances(const std::string& text) {
  const std::string kDefaultsHeader = "quantity\tunit\tabs\tk\tcomment";
  const std::string kOverridesHeader = "fixture\tquantity\tabs\tk\txfail\treason";
  ToleranceTable table;
  int section = 0;
  int line_number = 0;
  std::set<std::pair<std::string, std::string>> overridden;
  for (absl::string_view piece : absl::StrSplit(text, '\n')) {
    std::string line(piece);
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (line == kDefaultsHeader && section == 0) {
      section = 1;
      continue;
    }
    if (line == kOverridesHeader && section == 1) {
      section = 2;
      continue;
    }
    const std::vector<std::string> f = absl::StrSplit(line, '\t');
    if (section == 0) {
      return TableError(line_number, "expected the header " + kDefaultsHeader);
    }
    if (section == 1) {
      if (f.size() != 5) {
        return TableError(line_number, absl::StrCat(
                                           "a quantity row has 5 tab-separated fields, got ",
                                           f.size()));
      }
      const QuantitySpec* spec = FindQuantity(f[0]);
      if (spec == nullptr) return TableError(line_number, "unknown quantity \"" + f[0] + "\"");
      if (f[1] != spec->unit) {
        return TableError(line_number, absl::StrCat(f[0], " is checked in unit \"", spec->unit,
                                                    "\", the row says \"", f[1], "\""));
      }
      if (table.defaults.count(f[0]) > 0) return TableError(line_number, "second row for " + f[0]);
      absl::StatusOr<std::optional<double>> abs = ParseField(f[2], "abs", line_number, false);
      if (!abs.ok()) return abs.status();
      absl::StatusOr<std::optional<double>> k = ParseField(f[3], "k", line_number, false);
      if (!k.ok()) return k.status();
      table.defaults[f[0]] = Tolerance{**abs, **k};
      continue;
    }
    if (f.size() != 6) {
      return TableError(line_number, absl::StrCat(
                                         "an override row has 6 tab-separated fields, got ",
                                         f.size()));
    }
    Override o;
    o.fixture = f[0];
    o.quantity = f[1];
    o.line = line_number;
    if (FindQuantity(o.quantity) == nullptr) {
      return TableError(line_number, "unknown quantity \"" + o.quantity + "\"");
    }
    absl::StatusOr<std::optional<double>> abs = ParseField(f[2], "abs", line_number, true);
    if (!abs.ok()) return abs.status();
    absl::StatusOr<std::optional<double>> k = ParseField(f[3], "k", line_number, true);
    if (!k.ok()) return k.status();
    o.abs = *abs;
    o.k = *k;
    if (f[4] != "yes" && f[4] != "no") {
      return TableError(line_number, "xfail must be \"yes\" or \"no\", got \"" + f[4] + "\"");
    }
    o.xfail = f[4] == "yes";
    o.reason = f[5];
    if (o.reason.empty()) return TableError(line_number, "an override needs a reason");
    if (!overridden.insert({o.fixture, o.quantity}).second) {
      return TableError(line_number, "second override for " + o.fixture + " " + o.quantity);
    }
    table.overrides.push_back(o);
  }
  if (section == 0) return TableError(line_number, "no header " + kDefaultsHeader);
  for (const QuantitySpec& q : kQuantities) {
    if (table.defaults.count(q.name) == 0) {
      return TableError(line_number, absl::StrCat("no row for quantity ", q.name));
    }
  }
  return table;
}

const absl::StatusOr<ToleranceTable>& Tolerances() {
  static const absl::StatusOr<ToleranceTable> table =
      ParseTolerances(ReadFileOrDie(kTolerancesPath));
  return table;
}

// ---------------------------------------------------------------------------
// Checks and their results.

enum class Verdict { kPass, kFail, kXfail, kXpass, kSkip };

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kPass:
      return "PASS";
    case Verdict::kFail:
      return "FAIL";
    case Verdict::kXfail:
      return "XFAIL";
    case Verdict::kXpass:
      return "XPASS";
    case Verdict::kSkip:
      return "SKIP";
  }
  return "?";
}

// One quantity of one fixture, formatted for the table.
struct Check {
  std::string quantity;
  std::string truth = "-";
  std::string estimate = "-";
  std::string error = "-";
  std::string stderr_text = "-";
  std::string tolerance = "-";
  Verdict verdict = Verdict::kPass;
  std::string note;    // why it failed (or passed, for an XPASS)
  std::string reason;  // the section 2 row's reason, for XFAIL and XPASS
};

struct FixtureResult {
  std::string fixture;
  double milliseconds = 0.0;
  std::string error;  // the sidecar is unusable
  std::vector<Check> checks;  // "status" first; the rest when the status is OK
};

std::vector<FixtureResult>& Results() {
  static std::vector<FixtureResult> results;
  return results;
}

std::string Number(double value, int decimals) {
  return absl::StrFormat("%.*f", decimals, value);
}
std::string Signed(double value, int decimals) {
  return absl::StrFormat("%+.*f", decimals, value);
}

// A truth bool (JSON true/false) at sidecar[object][field].
std::optional<bool> SidecarBool(const google::protobuf::Struct& s,
                                const std::string& object,
                                const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end()) return std::nullopt;
  const auto& fields = o->second.struct_value().fields();
  auto f = fields.find(field);
  if (f == fields.end() || !f->second.has_bool_value()) return std::nullopt;
  return f->second.bool_value();
}

// A number in API units as the estimate reports it.
struct Reported {
  double value = 0.0;
  double stderr_value = 0.0;
  bool resolved = false;
  bool has_stderr = true;
};

Reported InApiUnits(const Quantity& q, double unit) {
  return {q.value / unit, q.stderr_value / unit, q.resolved, true};
}
Reported Exact(double value) { return {value, 0.0, true, false}; }

// Compares a reported number with the truth. must_resolve: the truth says
// the photograph holds this quantity, so "unresolved" is a failure;
// otherwise "unresolved" passes and a resolved value must still be right.
// abs_factor converts the table's abs into the quantity's unit.
Check CompareNumber(const QuantitySpec& spec, std::optional<double> truth,
                    const Reported& reported, bool must_resolve,
                    const Tolerance& tolerance, double abs_factor = 1.0) {
  Check c;
  c.quantity = spec.name;
  const int d = spec.decimals;
  if (truth) c.truth = Number(*truth, d);
  if (!reported.resolved) {
    c.estimate = "unresolved";
    c.verdict = must_resolve ? Verdict::kFail : Verdict::kPass;
    if (must_resolve) c.note = "reported unresolved, but the truth says the photograph resolves it";
    return c;
  }
  c.estimate = Number(reported.value, d);
  if (reported.has_stderr) c.stderr_text = Number(reported.stderr_value, d);
  if (!truth) {
    c.verdict = Verdict::kSkip;
    c.note = absl::StrCat("the sidecar has no truth for ", spec.name);
    return c;
  }
  const double error = reported.value - *truth;
  const double allowed = tolerance.abs * abs_factor +
                         (reported.has_stderr ? tolerance.k * reported.stderr_value : 0.0);
  c.error = Signed(error, d);
  c.tolerance = Number(allowed, d);
  c.verdict = std::fabs(error) <= allowed ? Verdict::kPass : Verdict::kFail;
  if (c.verdict == Verdict::kFail) {
    c.note = absl::StrFormat("|error| %.*f > %.*f = abs %g%s", d, std::fabs(error), d, allowed,
                             tolerance.abs, abs_factor != 1.0 ? " (deg of spacing)" : "");
    if (reported.has_stderr) {
      c.note += absl::StrFormat(" + %g x stderr %.*f", tolerance.k, d, reported.stderr_value);
    }
  }
  return c;
}

Check CompareExact(const QuantitySpec& spec, const std::string& truth,
                   const std::string& estimate) {
  Check c;
  c.quantity = spec.name;
  c.truth = truth.empty() ? "-" : truth;
  c.estimate = estimate;
  if (truth.empty()) {
    c.verdict = Verdict::kSkip;
    c.note = absl::StrCat("the sidecar has no truth for ", spec.name);
  } else if (truth != estimate) {
    c.verdict = Verdict::kFail;
    c.note = absl::StrCat("expected ", truth, ", got ", estimate);
  }
  return c;
}

// Every quantity of one fixture, before section 2's expected failures.
std::vector<Check> CheckEstimate(const std::string& fixture,
                                 const google::protobuf::Struct& sidecar,
                                 const Estimate& estimate,
                                 const ToleranceTable& table) {
  const auto truth = [&](const char* field) { return SidecarNumber(sidecar, "truth", field); };
  const auto tolerance = [&](const char* quantity) {
    const Override* unused = nullptr;
    return table.For(fixture, quantity, &unused);
  };
  const auto spec = [](const char* name) { return *FindQuantity(name); };
  const std::optional<bool> split = SidecarBool(sidecar, "truth", "splitResolvable");
  const bool split_resolvable = split.value_or(false);
  const auto yes_no = [](bool b) { return std::string(b ? "yes" : "no"); };

  std::vector<Check> checks;
  checks.push_back(CompareExact(spec("model"), SidecarString(sidecar, "truth", "model"),
                                ProfileModelName(estimate.model)));
  checks.push_back(CompareExact(spec("splitResolved"), split ? yes_no(*split) : "",
                                yes_no(estimate.peak_spacing_rad.resolved)));
  checks.push_back(CompareNumber(spec("peakSpacingDeg"), truth("peakSpacingDeg"),
                                 InApiUnits(estimate.peak_spacing_rad, kDeg), split_resolvable,
                                 tolerance("peakSpacingDeg")));
  // The slope passes when the spacing it implies, 2·arctan(m), would: the
  // table's abs is in degrees of spacing, dm = (1 + m²)/2 · ds.
  const std::optional<double> true_slope = truth("maxSlope");
  const double m = true_slope.value_or(0.0);
  checks.push_back(CompareNumber(spec("maxSlope"), true_slope, InApiUnits(estimate.max_slope, 1.0),
                                 split_resolvable, tolerance("maxSlope"),
                                 (1.0 + m * m) / 2.0 * kDeg));
  checks.push_back(CompareNumber(spec("specularAzimuthDeg"), truth("mirrorAzimuthDeg"),
                                 InApiUnits(estimate.specular_azimuth_rad, kDeg), true,
                                 tolerance("specularAzimuthDeg")));
  checks.push_back(CompareNumber(spec("centerXPx"), truth("centerXPx"),
                                 Exact(estimate.cylinder.center_x_px), true,
                                 tolerance("centerXPx")));
  checks.push_back(CompareNumber(spec("radiusPx"), truth("radiusPx"),
                                 Exact(estimate.cylinder.radius_px), true, tolerance("radiusPx")));
  checks.push_back(CompareNumber(spec("axisAngleDeg"), truth("axisAngleDeg"),
                                 Exact(estimate.cylinder.axis_angle_rad / kDeg), true,
                                 tolerance("axisAngleDeg")));
  // Not measured by this version: "unresolved" passes; a value it claims must
  // be right, and must not be claimed where the truth says the period is
  // below the resolution limit.
  const std::optional<bool> period = SidecarBool(sidecar, "truth", "periodResolvable");
  using Named = std::pair<const char*, const Quantity*>;
  for (const auto& [name, q] : {Named{"wavelengthMm", &estimate.wavelength_mm},
                                Named{"amplitudeMm", &estimate.amplitude_mm}}) {
    Check c = CompareNumber(spec(name), truth(name), InApiUnits(*q, 1.0), false, tolerance(name));
    if (q->resolved && period && !*period) {
      c.verdict = Verdict::kFail;
      c.note = "resolved, but the truth says the thread period is below the resolution limit";
    }
    checks.push_back(c);
  }
  return checks;
}

// Section 2: expected failures become XFAIL, and XPASS when they pass.
void ApplyExpectedFailures(const std::string& fixture, const ToleranceTable& table,
                           std::vector<Check>& checks) {
  for (Check& c : checks) {
    const Override* o = nullptr;
    table.For(fixture, c.quantity, &o);
    if (o == nullptr) continue;
    if (c.tolerance != "-" && (o->abs || o->k)) c.tolerance += "*";
    if (!o->xfail) {
      if (c.verdict == Verdict::kFail) {
        absl::StrAppend(&c.note, " (fixture tolerance: ", o->reason, ")");
      }
      continue;
    }
    c.reason = o->reason;
    if (c.verdict == Verdict::kFail) {
      c.verdict = Verdict::kXfail;
    } else if (c.verdict == Verdict::kPass) {
      c.verdict = Verdict::kXpass;
      c.note = absl::StrCat("expected to fail (", o->reason, ") but passes: tighten or delete ",
                            "the override at ", kTolerancesPath, ":", o->line);
    }
  }
}

// ---------------------------------------------------------------------------
// The printed table.

// Pads each column to its widest cell; numbers right-aligned.
void PrintColumns(std::ostream& out, const std::vector<std::vector<std::string>>& rows,
                  const std::vector<bool>& right_aligned) {
  std::vector<std::size_t> width(right_aligned.size(), 0);
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) width[i] = std::max(width[i], row[i].size());
  }
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t i = 0; i < row.size(); ++i) {
      const std::string pad(width[i] - row[i].size(), ' ');
      line += right_aligned[i] ? pad + row[i] : row[i] + pad;
      if (i + 1 < row.size()) line += "  ";
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out << line << "\n";
  }
}

void PrintTable(std::ostream& out, const std::vector<FixtureResult>& results) {
  out << "\nweavefit fixture regression: pass when |error| <= abs + k x stderr "
      << "(tolerances: tests/regression_tolerances.tsv)\n\n";
  std::vector<std::vector<std::string>> rows = {
      {"fixture", "ms", "quantity", "truth", "estimate", "error", "stderr", "tol", "result"}};
  std::map<Verdict, int> counts;
  double total_ms = 0.0;
  std::vector<std::string> notes;
  bool overridden = false;
  for (const FixtureResult& r : results) {
    total_ms += r.milliseconds;
    // This fixture's expected failures, grouped by reason: reason → quantities.
    std::vector<std::pair<std::string, std::string>> xfails;
    const std::string ms = Number(r.milliseconds, 0);
    if (!r.error.empty()) {
      rows.push_back({r.fixture, ms, "(sidecar)", "-", "-", "-", "-", "-", "FAIL"});
      ++counts[Verdict::kFail];
      notes.push_back(absl::StrCat("FAIL   ", r.fixture, ": ", r.error));
      continue;
    }
    bool first = true;
    for (const Check& c : r.checks) {
      ++counts[c.verdict];
      if (c.verdict == Verdict::kXfail) {
        auto same = std::find_if(xfails.begin(), xfails.end(),
                                 [&](const auto& x) { return x.first == c.reason; });
        if (same == xfails.end()) {
          xfails.push_back({c.reason, c.quantity});
        } else {
          absl::StrAppend(&same->second, ", ", c.quantity);
        }
      } else if (c.verdict != Verdict::kPass) {
        notes.push_back(absl::StrFormat("%-6s %s %s: %s", VerdictName(c.verdict), r.fixture,
                                        c.quantity, c.note));
      }
      // An estimate that returned OK needs no row of its own.
      if (c.quantity == "status" && c.verdict == Verdict::kPass) continue;
      if (!c.tolerance.empty() && c.tolerance.back() == '*') overridden = true;
      rows.push_back({first ? r.fixture : "", first ? ms : "", c.quantity, c.truth, c.estimate,
                      c.error, c.stderr_text, c.tolerance, VerdictName(c.verdict)});
      first = false;
    }
    for (const auto& [reason, quantities] : xfails) {
      notes.push_back(absl::StrFormat("XFAIL  %s %s: %s", r.fixture, quantities, reason));
    }
  }
  PrintColumns(out, rows, {false, true, false, true, true, true, true, true, false});
  out << "\n"
      << absl::StrFormat("%d fixtures, %d checks: %d PASS, %d FAIL, %d XFAIL, %d XPASS, "
                         "%d SKIP; estimates %.0f ms in all\n",
                         results.size(),
                         counts[Verdict::kPass] + counts[Verdict::kFail] + counts[Verdict::kXfail] +
                             counts[Verdict::kXpass] + counts[Verdict::kSkip],
                         counts[Verdict::kPass], counts[Verdict::kFail],
                         counts[Verdict::kXfail], counts[Verdict::kXpass], counts[Verdict::kSkip],
                         total_ms);
  for (const std::string& n : notes) out << n << "\n";
  if (overridden) out << "* a per-fixture tolerance from the table's section 2\n";
  out << std::endl;
}

class ReportEnvironment : public ::testing::Environment {
 public:
  void TearDown() override {
    if (!Results().empty()) PrintTable(std::cout, Results());
  }
};

// ---------------------------------------------------------------------------
// The tests.

std::string FileName(const std::string& path) {
  return path.substr(path.find_last_of('/') + 1);
}

// The test name of a fixture: its file name with every other character than
// a letter or digit replaced by '_' (gauze_sinusoid_p30.exr →
// gauze_sinusoid_p30_exr).
std::string TestName(const ::testing::TestParamInfo<std::string>& info) {
  std::string name = FileName(info.param);
  for (char& ch : name) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return name;
}

TEST(RegressionTolerances, TableParsesAndNamesExistingFixtures) {
  const absl::StatusOr<ToleranceTable>& table = Tolerances();
  ASSERT_TRUE(table.ok()) << table.status();
  std::set<std::string> fixtures;
  for (const std::string& image : FixtureImages(FIXTURES_DIR)) fixtures.insert(FileName(image));
  EXPECT_FALSE(fixtures.empty()) << "no fixture images in " << FIXTURES_DIR;
  for (const Override& o : table->overrides) {
    EXPECT_EQ(fixtures.count(o.fixture), 1u)
        << kTolerancesPath << ":" << o.line << ": no fixture " << o.fixture << " in "
        << FIXTURES_DIR << " (a stale override: delete it)";
  }
}

TEST(RegressionTolerances, ParserRejectsMalformedRows) {
  const std::string header = "quantity\tunit\tabs\tk\tcomment\n";
  std::string all;
  for (const QuantitySpec& q : kQuantities) {
    absl::StrAppend(&all, q.name, "\t", q.unit, "\t1\t3\tc\n");
  }
  const std::string overrides = "fixture\tquantity\tabs\tk\txfail\treason\n";
  ASSERT_TRUE(ParseTolerances(header + all + overrides + "a.png\tradiusPx\t-\t-\tyes\twhy\n").ok());
  EXPECT_FALSE(ParseTolerances(all).ok()) << "no header";
  EXPECT_FALSE(ParseTolerances(header + "radiusPx\tpx\t1\t0\tc\n").ok()) << "missing rows";
  EXPECT_FALSE(ParseTolerances(header + all + "radiusPx\tpx\t1\t0\tc\n").ok()) << "duplicate";
  EXPECT_FALSE(ParseTolerances(header + "radiusPx\tmm\t1\t0\tc\n" + all).ok()) << "wrong unit";
  EXPECT_FALSE(ParseTolerances(header + "radiusPx\tpx\t-1\t0\tc\n" + all).ok()) << "negative";
  EXPECT_FALSE(
      ParseTolerances(header + all + overrides + "a.png\tradiusPx\t-\t-\tmaybe\twhy\n").ok())
      << "xfail neither yes nor no";
  EXPECT_FALSE(ParseTolerances(header + all + overrides + "a.png\tradiusPx\t-\t-\tyes\t\n").ok())
      << "no reason";
  EXPECT_FALSE(ParseTolerances(header + all + overrides + "a.png\tradius\t-\t-\tyes\twhy\n").ok())
      << "unknown quantity";
  const absl::StatusOr<ToleranceTable> t =
      ParseTolerances(header + all + overrides + "a.png\tradiusPx\t2\t-\tno\twhy\n");
  ASSERT_TRUE(t.ok()) << t.status();
  const Override* o = nullptr;
  const Tolerance overridden = t->For("a.png", "radiusPx", &o);
  ASSERT_NE(o, nullptr);
  EXPECT_EQ(overridden.abs, 2.0);
  EXPECT_EQ(overridden.k, 3.0);
  t->For("b.png", "radiusPx", &o);
  EXPECT_EQ(o, nullptr);
}

class RegressionTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RegressionTest, MatchesTruth) {
  const std::string image = GetParam();
  const std::string fixture = FileName(image);
  const absl::StatusOr<ToleranceTable>& table = Tolerances();
  ASSERT_TRUE(table.ok()) << table.status();
  FixtureResult result;
  result.fixture = fixture;

  const google::protobuf::Struct sidecar = ReadSidecar(image);
  const std::optional<double> phase_deg = SidecarNumber(sidecar, "acquisition", "phaseAngleDeg");
  if (!phase_deg) {
    result.error = "the sidecar has no acquisition.phaseAngleDeg";
    Results().push_back(result);
    FAIL() << fixture << ": " << result.error;
  }
  Acquisition acquisition;
  acquisition.phase_angle_rad = *phase_deg * kDeg;
  if (auto d = SidecarNumber(sidecar, "acquisition", "cylinderDiameterMm")) {
    acquisition.cylinder_diameter_mm = *d;
  }
  if (auto d = SidecarNumber(sidecar, "acquisition", "cameraDistanceMm")) {
    acquisition.camera_distance_mm = *d;
  }

  const std::string bytes = ReadFileOrDie(image);
  const auto start = std::chrono::steady_clock::now();
  const absl::StatusOr<Estimate> estimate =
      EstimateFromBytes(bytes, acquisition, EstimateOptions());
  result.milliseconds = std::chrono::duration<double, std::milli>(
                            std::chrono::steady_clock::now() - start).count();
  // A valid photograph must be estimated; "no peak found" is a failure of the
  // estimator here, not of the input.
  Check status = CompareExact(
      *FindQuantity("status"), "OK",
      estimate.ok() ? "OK" : absl::StatusCodeToString(estimate.status().code()));
  if (!estimate.ok()) status.note = estimate.status().ToString();
  result.checks.push_back(status);
  if (estimate.ok()) {
    ExpectFiniteReply(ReplyFromEstimate(*estimate, fixture));
    for (Check& c : CheckEstimate(fixture, sidecar, *estimate, *table)) {
      result.checks.push_back(std::move(c));
    }
  }
  ApplyExpectedFailures(fixture, *table, result.checks);
  for (const Check& c : result.checks) {
    const std::string what = absl::StrCat(fixture, " ", c.quantity, ": truth ", c.truth,
                                          ", estimate ", c.estimate, ", error ", c.error,
                                          ", stderr ", c.stderr_text, ", tol ", c.tolerance);
    if (c.verdict == Verdict::kFail) {
      ADD_FAILURE() << what << "\n  " << c.note;
    } else if (c.verdict == Verdict::kXpass) {
      ADD_FAILURE() << "XPASS " << what << "\n  " << c.note;
    } else if (c.verdict == Verdict::kXfail) {
      RecordProperty(absl::StrCat("xfail_", c.quantity), c.reason);
    }
  }
  Results().push_back(result);
}

INSTANTIATE_TEST_SUITE_P(Fixtures, RegressionTest,
                         ::testing::ValuesIn(FixtureImages(FIXTURES_DIR)), TestName);
// An empty fixtures/ is reported by TableParsesAndNamesExistingFixtures.
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(RegressionTest);

}  // namespace
}  // namespace weavefit::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new weavefit::testing::ReportEnvironment);
  return RUN_ALL_TESTS();
}
