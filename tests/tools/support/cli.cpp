#include "tools/support/cli.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "common/run_binary.h"

namespace lander::test {

CliResult run_lander(const std::vector<std::string>& args) {
  const std::string dir = make_temp_dir("lander_cli_io");
  std::vector<std::string> argv = {LANDER_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  const BinaryRun b = run_binary(argv, dir);
  rmdir(dir.c_str());
  CliResult r;
  r.code = b.code;
  r.signal = b.signal;
  r.out = b.out;
  r.err = b.err;
  r.output = r.out + r.err;
  return r;
}

CliResult run_lander(const std::string& args) {
  std::vector<std::string> argv;
  std::istringstream in(args);
  for (std::string a; in >> a;) argv.push_back(a);
  return run_lander(argv);
}

std::string make_temp_dir(const std::string& prefix) {
  std::string tmpl = "/tmp/" + prefix + "_XXXXXX";
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  const char* dir = mkdtemp(buf.data());
  return dir ? dir : "";
}

std::string slurp(const std::string& path) { return sim::read_file_text(path, /*missing_ok=*/true); }

}  // namespace lander::test
