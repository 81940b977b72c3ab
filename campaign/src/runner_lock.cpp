#include "lander/campaign/runner_lock.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "lander/campaign/runner.h"

namespace lander::campaign {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

// Who holds (or last held) a lock file: its record, {pid, host, runs}.
struct Holder {
  long pid{-1};  ///< -1: no record (empty file, or being written)
  std::string host;
  std::string runs;  ///< "every run", "shard K/M", ...
};

std::string this_host() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "?";
  return buf;
}

// A file opened for the lock, close-on-exec so that no run process inherits it.
int open_lock_file(const std::string& path) {
  const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw ConfigError(path + ": cannot open the runner lock: " + std::strerror(errno));
  return fd;
}

// flock(2) without waiting; false when another open file holds a conflicting lock.
bool try_flock(int fd, int op, const std::string& path) {
  while (flock(fd, op | LOCK_NB) != 0) {
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK) return false;
    throw ConfigError(path + ": cannot lock: " + std::strerror(errno));
  }
  return true;
}

Holder read_holder(int fd) {
  std::string text;
  char buf[512];
  ssize_t got = 0;
  off_t at = 0;
  while ((got = pread(fd, buf, sizeof buf, at)) > 0) {
    text.append(buf, static_cast<std::size_t>(got));
    at += got;
  }
  Holder h;
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("pid") && j["pid"].is_number_integer()) {
    h.pid = j["pid"].get<long>();
    h.host = j.value("host", "?");
    h.runs = j.value("runs", "");
  }
  return h;
}

void write_holder(int fd, const std::string& path, const std::string& runs) {
  const std::string text =
      json{{"pid", static_cast<long>(getpid())}, {"host", this_host()}, {"runs", runs}}.dump() + "\n";
  if (ftruncate(fd, 0) != 0 || pwrite(fd, text.data(), text.size(), 0) != static_cast<ssize_t>(text.size())) {
    throw ConfigError(path + ": cannot write the runner lock: " + std::strerror(errno));
  }
}

// A record of a runner that is not running: on this host, no such process.
bool holder_gone(const Holder& h) {
  return h.pid > 0 && h.host == this_host() && kill(static_cast<pid_t>(h.pid), 0) != 0 && errno == ESRCH;
}

// Just taken: a record left in the file (a runner that ended without clearing it) is noted.
std::string take_over_note(const Holder& h, const std::string& path) {
  if (h.pid <= 0) return "";
  return fmt::format("{}: the runner recorded there (pid {} on host {}) is {}; lock taken over", path,
                     h.pid, h.host, holder_gone(h) ? "gone" : "no longer holding it");
}

std::string describe(const Holder& h, const std::string& path) {
  if (h.pid <= 0) return "a runner that is just starting (lock " + path + ")";
  return fmt::format("pid {} on host {} ({}; lock {})", h.pid, h.host, h.runs, path);
}

[[noreturn]] void busy(const std::string& dir, const std::string& who) {
  throw RunnerBusyError(fmt::format(
      "{} is being run by another runner: {}; wait for it to end, or stop it, before running "
      "these runs again",
      dir, who));
}

// The runners of shards working in `dir` (whose lock files are held), for the message of a
// whole-campaign runner they keep out.
std::string shard_holders(const std::string& dir) {
  std::string out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name == "runner.lock" || name.rfind("runner.", 0) != 0 || e.path().extension() != ".lock") continue;
    const int fd = open(e.path().c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue;
    if (!try_flock(fd, LOCK_SH, e.path().string())) {
      out += (out.empty() ? "" : ", ") + describe(read_holder(fd), e.path().string());
    }
    close(fd);  // releases the probe's lock, if it got one
  }
  return out.empty() ? "runners of shards (their lock files are being taken)" : out;
}

// A shard runner's shared hold of DIR/runner.lock. Another shard runner started at the same
// instant (a Slurm array's tasks) holds it exclusively for the moment it takes to clear a
// stale record: waited for, up to kShardStartWait_s. A live runner of every run holds it for
// its whole campaign: refused at once.
constexpr double kShardStartWait_s = 5.0;

bool share_when_free(int fd, const std::string& path) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(kShardStartWait_s);
  while (!try_flock(fd, LOCK_SH, path)) {
    const Holder h = read_holder(fd);
    const bool whole_runner = h.pid > 0 && h.runs == "every run" && !holder_gone(h);
    if (whole_runner || std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

std::string selection_text(const RunnerOptions& o) {
  std::string s = o.shard_count == 1 ? "" : fmt::format("shard {}/{}", o.shard_index, o.shard_count);
  if (!o.only.empty()) s += (s.empty() ? "" : ", ") + fmt::format("--only {} runs", o.only.size());
  return s.empty() ? "every run" : s;
}

}  // namespace

std::string runner_lock_name(int shard_index, int shard_count, const std::vector<std::string>& only) {
  if (shard_count == 1 && only.empty()) return "runner.lock";
  std::string name = fmt::format("runner.shard-{}-of-{}", shard_index, shard_count);
  if (only.empty()) return name + ".lock";
  const std::set<std::string> ids(only.begin(), only.end());
  std::string joined;
  for (const std::string& id : ids) joined += (joined.empty() ? "" : "+") + id;
  const bool plain = std::all_of(joined.begin(), joined.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '+';
  });
  if (plain && joined.size() <= 100) return name + "-only-" + joined + ".lock";
  // Many ids (or odd ones): FNV-1a of the sorted list keeps the name short and the same.
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const std::string& id : ids) {
    for (unsigned char c : id + '\n') h = (h ^ c) * 0x100000001b3ull;
  }
  return name + fmt::format("-only-{:016x}.lock", h);
}

RunnerLock RunnerLock::acquire(const RunnerOptions& o) {
  fs::create_directories(o.out_dir);
  const bool whole = o.shard_count == 1 && o.only.empty();
  const std::string dir_path = o.out_dir + "/runner.lock";
  RunnerLock lock;
  lock.dir_fd_ = open_lock_file(dir_path);
  // The directory's lock: exclusive first, whatever the selection, so that the runner that
  // finds it free clears a record a gone runner left; a shard runner then shares it.
  if (try_flock(lock.dir_fd_, LOCK_EX, dir_path)) {
    lock.note_ = take_over_note(read_holder(lock.dir_fd_), dir_path);
    if (whole) {
      write_holder(lock.dir_fd_, dir_path, selection_text(o));
      lock.record_fd_ = lock.dir_fd_;
      lock.record_path_ = dir_path;
      return lock;
    }
    if (ftruncate(lock.dir_fd_, 0) != 0) throw ConfigError(dir_path + ": cannot clear: " + std::strerror(errno));
    // Not atomic (flock(2)): another runner may take it in between; a whole runner is then
    // named below, a shard runner's moment is waited for.
    if (!share_when_free(lock.dir_fd_, dir_path)) busy(o.out_dir, describe(read_holder(lock.dir_fd_), dir_path));
  } else if (whole) {
    const Holder h = read_holder(lock.dir_fd_);
    busy(o.out_dir, h.pid > 0 && !holder_gone(h) ? describe(h, dir_path) : shard_holders(o.out_dir));
  } else if (!share_when_free(lock.dir_fd_, dir_path)) {
    busy(o.out_dir, describe(read_holder(lock.dir_fd_), dir_path));
  }
  // This shard's own lock, exclusive.
  const std::string path = o.out_dir + "/" + runner_lock_name(o.shard_index, o.shard_count, o.only);
  lock.selection_fd_ = open_lock_file(path);
  if (!try_flock(lock.selection_fd_, LOCK_EX, path)) busy(o.out_dir, describe(read_holder(lock.selection_fd_), path));
  const std::string note = take_over_note(read_holder(lock.selection_fd_), path);
  if (!note.empty()) lock.note_ += (lock.note_.empty() ? "" : "; ") + note;
  write_holder(lock.selection_fd_, path, selection_text(o));
  lock.record_fd_ = lock.selection_fd_;
  lock.record_path_ = path;
  return lock;
}

RunnerLock::RunnerLock(RunnerLock&& other) noexcept
    : dir_fd_(other.dir_fd_),
      selection_fd_(other.selection_fd_),
      record_fd_(other.record_fd_),
      record_path_(std::move(other.record_path_)),
      note_(std::move(other.note_)) {
  other.dir_fd_ = other.selection_fd_ = other.record_fd_ = -1;
}

RunnerLock::~RunnerLock() {
  // An empty record: the next runner has nothing to take over. (The file stays: removing a
  // lock file another runner has just opened would let two runners hold "the" lock.)
  if (record_fd_ >= 0 && ftruncate(record_fd_, 0) != 0) {
    // Left as it is: the next runner notes a record of a runner that is gone.
  }
  if (selection_fd_ >= 0) close(selection_fd_);
  if (dir_fd_ >= 0) close(dir_fd_);
}

}  // namespace lander::campaign
