#include "tools/support/cli.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

#include "lander/sim/util/process.h"

namespace lander::test {

CliResult run_lander(const std::vector<std::string>& args) {
  const std::string dir = make_temp_dir("lander_cli_io");
  std::vector<std::string> argv = {LANDER_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  sim::SpawnOptions o;
  o.stdout_path = dir + "/stdout";
  o.stderr_path = dir + "/stderr";
  sim::ChildProcess p = sim::ChildProcess::spawn(argv, o);
  // Bounded below ctest's 1500 s timeout: a command that never ends fails with its output.
  constexpr double kCommandLimit_s = 1200.0;
  const std::optional<sim::ExitStatus> st = p.wait_or_kill(kCommandLimit_s);
  CliResult r;
  r.code = !st ? -2 : st->signaled ? -1 : st->code;
  r.signal = st && st->signaled ? st->signal : 0;
  r.out = slurp(o.stdout_path);
  r.err = slurp(o.stderr_path);
  if (!st) r.err = "[still running after 1200 s: killed]\n" + r.err;
  r.output = r.out + r.err;
  std::remove(o.stdout_path.c_str());
  std::remove(o.stderr_path.c_str());
  rmdir(dir.c_str());
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

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace lander::test
