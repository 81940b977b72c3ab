// No code path runs a shell: no source file of the project calls system(), popen() or an
// exec*() function, or names /bin/sh. Programs are started only by ChildProcess
// (sim/src/process.cpp, posix_spawnp with an argument vector).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace {

TEST(NoShell, NoSourceCallsAShell) {
  const std::filesystem::path root = std::filesystem::path(LANDER_MODELS_DIR).parent_path();
  const std::regex shell_call(R"((\bsystem|\bpopen|\bexecl[pe]?|\bexecv[pe]?|\bexecvpe)\s*\(|/bin/sh)");
  int files = 0;
  for (const char* dir : {"estimator", "controller", "sim", "tools", "tests", "campaign"}) {
    if (!std::filesystem::exists(root / dir)) continue;
    for (const auto& e : std::filesystem::recursive_directory_iterator(root / dir)) {
      const std::string ext = e.path().extension().string();
      if (ext != ".cpp" && ext != ".h" && ext != ".hpp") continue;
      if (e.path().filename() == "no_shell_test.cpp") continue;  // names them to find them
      std::ifstream f(e.path());
      std::stringstream ss;
      ss << f.rdbuf();
      const std::string text = ss.str();
      ++files;
      std::smatch m;
      EXPECT_FALSE(std::regex_search(text, m, shell_call))
          << e.path() << " contains '" << m.str() << "'";
    }
  }
  EXPECT_GT(files, 50);
}

}  // namespace
