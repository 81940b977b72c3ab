#include "lander/sim/util/process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace lander::sim {

namespace {

ExitStatus from_wait_status(int st) {
  ExitStatus e;
  if (WIFSIGNALED(st)) {
    e.signaled = true;
    e.signal = WTERMSIG(st);
  } else if (WIFEXITED(st)) {
    e.code = WEXITSTATUS(st);
  }
  return e;
}

// posix_spawn file actions and attributes, freed on every path out.
struct SpawnSetup {
  posix_spawn_file_actions_t fa;
  posix_spawnattr_t attr;
  SpawnSetup() {
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&attr);
  }
  ~SpawnSetup() {
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
  }
};

}  // namespace

std::string ExitStatus::describe() const {
  if (signaled) {
    const char* name = strsignal(signal);
    return "killed by signal " + std::to_string(signal) + " (" + (name ? name : "?") + ")";
  }
  return "exit code " + std::to_string(code);
}

ChildProcess ChildProcess::spawn(const std::vector<std::string>& argv, const SpawnOptions& o) {
  if (argv.empty()) throw std::runtime_error("spawn: empty argument vector");
  SpawnSetup s;
  int pipe_fds[2] = {-1, -1};
  if (o.stdin_pipe) {
    if (pipe2(pipe_fds, O_CLOEXEC) != 0) {
      throw std::runtime_error("cannot start " + argv[0] + ": pipe: " + std::strerror(errno));
    }
    posix_spawn_file_actions_adddup2(&s.fa, pipe_fds[0], STDIN_FILENO);
  } else {
    posix_spawn_file_actions_addopen(&s.fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  }
  if (!o.stdout_path.empty()) {
    posix_spawn_file_actions_addopen(&s.fa, STDOUT_FILENO, o.stdout_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  } else if (o.stdout_to_null) {
    posix_spawn_file_actions_addopen(&s.fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  }
  if (!o.stderr_path.empty()) {
    posix_spawn_file_actions_addopen(&s.fa, STDERR_FILENO, o.stderr_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  // The child starts with default SIGPIPE/SIGINT/SIGTERM handling whatever the parent set.
  sigset_t def;
  sigemptyset(&def);
  sigaddset(&def, SIGPIPE);
  sigaddset(&def, SIGINT);
  sigaddset(&def, SIGTERM);
  sigaddset(&def, SIGCHLD);
  posix_spawnattr_setsigdefault(&s.attr, &def);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&s.attr, &none);
  short flags = POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK;
  if (o.own_process_group) {
    flags |= POSIX_SPAWN_SETPGROUP;
    posix_spawnattr_setpgroup(&s.attr, 0);
  }
  posix_spawnattr_setflags(&s.attr, flags);

  std::vector<char*> cargv;
  for (const std::string& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
  cargv.push_back(nullptr);
  // The environment: the parent's, with o.env's names replaced or added.
  std::vector<std::string> env_storage;
  for (char** e = environ; e && *e; ++e) {
    const std::string entry(*e);
    const std::string name = entry.substr(0, entry.find('='));
    bool replaced = false;
    for (const std::string& o_e : o.env) replaced |= o_e.substr(0, o_e.find('=')) == name;
    if (!replaced) env_storage.push_back(entry);
  }
  for (const std::string& o_e : o.env) env_storage.push_back(o_e);
  std::vector<char*> cenv;
  for (const std::string& e : env_storage) cenv.push_back(const_cast<char*>(e.c_str()));
  cenv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0].c_str(), &s.fa, &s.attr, cargv.data(), cenv.data());
  if (o.stdin_pipe) close(pipe_fds[0]);
  if (rc != 0) {
    if (o.stdin_pipe) close(pipe_fds[1]);
    throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  }
  ChildProcess c;
  c.pid_ = pid;
  c.stdin_fd_ = o.stdin_pipe ? pipe_fds[1] : -1;
  c.group_ = o.own_process_group;
  return c;
}

ChildProcess::ChildProcess(ChildProcess&& other) noexcept
    : pid_(other.pid_), stdin_fd_(other.stdin_fd_), group_(other.group_), status_(other.status_) {
  other.pid_ = -1;
  other.stdin_fd_ = -1;
}

ChildProcess& ChildProcess::operator=(ChildProcess&& other) noexcept {
  if (this != &other) {
    release();
    pid_ = other.pid_;
    stdin_fd_ = other.stdin_fd_;
    group_ = other.group_;
    status_ = other.status_;
    other.pid_ = -1;
    other.stdin_fd_ = -1;
  }
  return *this;
}

ChildProcess::~ChildProcess() { release(); }

void ChildProcess::release() {
  close_stdin();
  if (running()) {
    kill(SIGKILL);
    wait();
  }
  pid_ = -1;
}

bool ChildProcess::write_stdin(const void* data, std::size_t n) {
  if (stdin_fd_ < 0) return false;
  // Block SIGPIPE in this thread for the write: a closed pipe gives EPIPE, not a dead parent.
  sigset_t pipe_set, old;
  sigemptyset(&pipe_set);
  sigaddset(&pipe_set, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_set, &old);
  const char* p = static_cast<const char*>(data);
  bool ok = true;
  while (n > 0) {
    const ssize_t w = ::write(stdin_fd_, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      ok = false;
      break;
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  if (!ok) {
    // Consume the pending SIGPIPE so it does not fire when the mask is restored.
    sigset_t pending;
    sigpending(&pending);
    if (sigismember(&pending, SIGPIPE)) {
      const timespec zero{0, 0};
      sigtimedwait(&pipe_set, nullptr, &zero);
    }
  }
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
  return ok;
}

void ChildProcess::close_stdin() {
  if (stdin_fd_ >= 0) close(stdin_fd_);
  stdin_fd_ = -1;
}

std::optional<ExitStatus> ChildProcess::poll() {
  if (status_ || pid_ <= 0) return status_;
  int st = 0;
  pid_t r;
  do {
    r = waitpid(pid_, &st, WNOHANG);
  } while (r < 0 && errno == EINTR);
  if (r == pid_) status_ = from_wait_status(st);
  if (r < 0) status_ = ExitStatus{};  // not our child any more: nothing to wait for
  return status_;
}

ExitStatus ChildProcess::wait() {
  if (status_ || pid_ <= 0) return status_.value_or(ExitStatus{});
  int st = 0;
  pid_t r;
  do {
    r = waitpid(pid_, &st, 0);
  } while (r < 0 && errno == EINTR);
  status_ = r == pid_ ? from_wait_status(st) : ExitStatus{};
  return *status_;
}

std::optional<ExitStatus> ChildProcess::wait_for(double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    if (std::optional<ExitStatus> st = poll()) return st;
    if (std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::optional<ExitStatus> ChildProcess::kill_and_reap(double wait_s) {
  kill(SIGKILL);
  std::optional<ExitStatus> st = wait_for(wait_s);
  if (!st) abandon();
  return st;
}

std::optional<ExitStatus> ChildProcess::wait_or_kill(double limit_s) {
  if (std::optional<ExitStatus> st = wait_for(limit_s)) return st;
  kill_and_reap();
  return std::nullopt;
}

void ChildProcess::abandon() {
  close_stdin();
  pid_ = -1;
}

void ChildProcess::kill(int sig) {
  if (!running()) return;
  if (group_) ::kill(-pid_, sig);
  ::kill(pid_, sig);
}

bool on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream ss(path);
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (dir.empty()) continue;
    const std::string f = dir + "/" + name;
    struct stat st;
    if (stat(f.c_str(), &st) == 0 && S_ISREG(st.st_mode) && access(f.c_str(), X_OK) == 0) {
      return true;
    }
  }
  return false;
}

std::string self_executable() {
  std::vector<char> buf(4096);
  const ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  if (n <= 0) throw std::runtime_error("cannot read /proc/self/exe");
  return std::string(buf.data(), static_cast<std::size_t>(n));
}

}  // namespace lander::sim
