// Temporary folders for tests that go away with the test.
#ifndef WEAVEFIT_TESTS_TEMP_DIR_H_
#define WEAVEFIT_TESTS_TEMP_DIR_H_

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace weavefit::testing {

// Removes every folder MakeTempDir made once the last test has run, unless a
// test failed: then they stay (with any daemon's log) and are named on stderr.
class TempDirCleaner : public ::testing::Environment {
 public:
  void Add(const std::string& dir) { dirs_.push_back(dir); }
  void TearDown() override {
    if (::testing::UnitTest::GetInstance()->Failed()) {
      for (const std::string& dir : dirs_) std::fprintf(stderr, "kept %s\n", dir.c_str());
      return;
    }
    std::error_code ignored;
    for (const std::string& dir : dirs_) std::filesystem::remove_all(dir, ignored);
  }

 private:
  std::vector<std::string> dirs_;
};

// A fresh folder under gtest's TempDir(), removed after the run.
inline std::string MakeTempDir(const std::string& prefix = "weavefit_") {
  // gtest owns an environment once it is added, and tears it down after the
  // last test even when it was added during one.
  static TempDirCleaner* const cleaner =
      static_cast<TempDirCleaner*>(::testing::AddGlobalTestEnvironment(new TempDirCleaner));
  std::string pattern = ::testing::TempDir() + prefix + "XXXXXX";
  if (mkdtemp(pattern.data()) == nullptr) {
    ADD_FAILURE() << "mkdtemp failed for " << pattern;
    return pattern;
  }
  cleaner->Add(pattern);
  return pattern;
}

}  // namespace weavefit::testing

#endif  // WEAVEFIT_TESTS_TEMP_DIR_H_
