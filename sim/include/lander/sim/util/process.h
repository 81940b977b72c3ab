// Starting other programs without a shell. A child is started from an argument vector with
// posix_spawnp: no command line is ever parsed, so quotes, `$()`, spaces or newlines in a path
// are just bytes of that path. Used by the video writer (ffmpeg) and the campaign runner (one
// `lander run` process per run).
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace lander::sim {

// How a child ended.
struct ExitStatus {
  bool signaled{false};  ///< ended by a signal (then `signal` is set, `code` is -1)
  int code{-1};          ///< exit code when it exited normally
  int signal{0};         ///< the signal that ended it
  bool ok() const { return !signaled && code == 0; }
  // "exit code 3", "killed by signal 6 (Aborted)".
  std::string describe() const;
};

struct SpawnOptions {
  bool stdin_pipe{false};    ///< the parent writes the child's stdin (write_stdin); else /dev/null
  std::string stdout_path;   ///< file for the child's stdout (created/truncated); "" inherits
  std::string stderr_path;   ///< file for the child's stderr (created/truncated); "" inherits
  bool stdout_to_null{false};  ///< discard stdout (when stdout_path is empty)
  bool own_process_group{false};  ///< the child leads a new process group (kill takes its children)
  std::vector<std::string> env;   ///< "NAME=value" entries added to (or replacing) the parent's
};

// A started child process. Destroying a running child kills it (SIGKILL) and reaps it.
class ChildProcess {
 public:
  // Starts argv[0] (looked up on PATH when it has no '/') with the arguments argv[1..].
  // Throws std::runtime_error naming the program when it cannot be started.
  static ChildProcess spawn(const std::vector<std::string>& argv, const SpawnOptions& o = {});

  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&& other) noexcept;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ~ChildProcess();

  pid_t pid() const { return pid_; }
  bool running() const { return pid_ > 0 && !status_; }

  // Writes all bytes to the child's stdin; false when the child closed it (EPIPE) or is gone.
  // SIGPIPE is not raised in the parent.
  bool write_stdin(const void* data, std::size_t n);
  void close_stdin();

  // Non-blocking: the exit status once the child has ended, else nullopt.
  std::optional<ExitStatus> poll();
  // Blocks until the child ends.
  ExitStatus wait();
  // Waits up to `timeout_s` for the child to end: its exit status, or nullopt if it has not.
  std::optional<ExitStatus> wait_for(double timeout_s);
  // How long a killed child may take to end before the caller stops waiting for it (s).
  static constexpr double kKillWait_s = 30.0;
  // Kills the child (SIGKILL) and waits up to `wait_s` for it to end: its exit status, or
  // nullopt (and the child abandoned) when it did not end (stuck in the kernel).
  std::optional<ExitStatus> kill_and_reap(double wait_s = kKillWait_s);
  // Waits up to `limit_s`; a child still running then is killed and reaped (kill_and_reap)
  // and nullopt is returned. (The tests' command helpers: a hang fails with its output.)
  std::optional<ExitStatus> wait_or_kill(double limit_s);
  // Forgets the child without killing or waiting for it (one that would not end after
  // SIGKILL): the destructor no longer blocks on it.
  void abandon();
  // Sends a signal to the child (to its process group when it leads one).
  void kill(int sig);

 private:
  ChildProcess() = default;
  void release();
  pid_t pid_{-1};
  int stdin_fd_{-1};
  bool group_{false};
  std::optional<ExitStatus> status_;
};

// True when `name` is an executable file in one of the PATH directories.
bool on_path(const std::string& name);

// The absolute path of the running executable (/proc/self/exe).
std::string self_executable();

}  // namespace lander::sim
