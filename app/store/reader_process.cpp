#include "app/store/reader_process.hpp"

#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>

#include "app/store/address_sanitizer.hpp"
#include "app/store/atomic_file.hpp"
#if defined(COLLIDE_ASAN)
#include <dlfcn.h>
#include <execinfo.h>
#include <sanitizer/common_interface_defs.h>
#endif

namespace collide::app {

namespace {

/// A process is replaced after this many reads: what one process's library
/// state can gather from damaged files stays bounded, at one fork per 200
/// files.
constexpr int kReadsPerProcess = 200;

/// The reader's exit status when a sanitizer found an error in this
/// program's own code rather than inside libhdf5 (see onSanitizerReport).
constexpr int kOwnCodeFailed = 87;

#if defined(COLLIDE_ASAN)
/// A sanitizer report in the reader: the library's if any frame of the stack
/// that led to it is inside libhdf5 (an interceptor such as memcpy called by
/// the library, or the library's own code); otherwise the error is in this
/// program's code, which must not pass for a damaged file (a fuzz run would
/// never see it). Runs in the dying reader, after the report is printed.
void onSanitizerReport() {
  void* frames[128];
  const int n = ::backtrace(frames, 128);
  for (int i = 0; i < n; ++i) {
    Dl_info info{};
    if (::dladdr(frames[i], &info) != 0 && info.dli_fname &&
        std::strstr(info.dli_fname, "libhdf5") != nullptr)
      return;  // the library's: the reader ends as the sanitizer decides
  }
  ::_exit(kOwnCodeFailed);
}
#endif

/// The reader's answer to one request: one byte on the socket (whether the
/// strings are in the memory file), then the read's error as a length (0: it
/// gave a shot) and that many bytes.
constexpr char kJournalSaved = 'J';
constexpr char kJournalNotSaved = 'N';

/// The running reader process; guarded by the HDF5 lock the caller holds.
struct Reader {
  pid_t pid = -1;
  int socket = -1;   // the program's end of the request socket
  int journal = -1;  // memory file the reader writes each read's strings to
  int reads = 0;     // requests this process was sent
  pid_t owner = -1;  // the program process that started it (a forked copy of
                     // the program must not talk to its parent's reader)
};

Reader& reader() {
  static Reader r;
  return r;
}

ReaderProcessStats& stats() {
  static ReaderProcessStats s;
  return s;
}

/// What /proc says of a process: its state letter ('R' running or waiting
/// for a CPU, 'S' asleep, ...) and the CPU seconds (user + system) it used.
struct ProcStat {
  char state = '?';
  double cpu_s = NAN;
};

ProcStat procStat(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), {});
  const auto close = text.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return {};
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  ProcStat out;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 3) out.state = f.empty() ? '?' : f[0];
    if (i == 14 || i == 15) ticks += std::atof(f.c_str());  // utime, stime
  }
  out.cpu_s = ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
  return out;
}

bool sendAll(int fd, const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    // MSG_NOSIGNAL: a reader that died answers EPIPE, not SIGPIPE.
    const ssize_t n = ::send(fd, p, size, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

/// Closes every descriptor of the reader process but the standard three and
/// `keep`: a descriptor inherited from the program (a lock file, a socket, a
/// pipe to another process) must not outlive the program's own close.
void closeAllBut(std::vector<int> keep) {
  std::sort(keep.begin(), keep.end());
  unsigned first = 3;
  for (int fd : keep) {
    if (static_cast<unsigned>(fd) > first) ::close_range(first, static_cast<unsigned>(fd) - 1, 0);
    first = std::max(first, static_cast<unsigned>(fd) + 1);
  }
  ::close_range(first, ~0U, 0);
}

/// The reader process's loop: one request (work, frames flag, path length,
/// path) at a time; ends when the program closes its end of the socket. The
/// work is sent as its address: a forked process runs the same program at
/// the same addresses.
[[noreturn]] void serve(int socket, int journal_fd) {
  for (;;) {
    ReadWork work = nullptr;
    std::uint8_t frames = 0;
    std::uint32_t length = 0;
    if (!readAllFromFd(socket, &work, sizeof work) || !readAllFromFd(socket, &frames, 1) ||
        !readAllFromFd(socket, &length, sizeof length))
      ::_exit(0);
    std::string path(length, '\0');
    if (!readAllFromFd(socket, path.data(), length)) ::_exit(0);
    h5::VlenJournal journal;
    std::optional<std::string> error;
    {
      h5::JournalScope scope(journal);
      error = work(path, frames != 0);
    }
    const bool saved = ::ftruncate(journal_fd, 0) == 0 && journal.save(journal_fd);
    const char answer = saved ? kJournalSaved : kJournalNotSaved;
    // An empty message still marks an error: it is sent as one space.
    const std::string message = error ? (error->empty() ? " " : *error) : "";
    const auto size = static_cast<std::uint32_t>(message.size());
    if (!sendAll(socket, &answer, 1) || !sendAll(socket, &size, sizeof size) ||
        !sendAll(socket, message.data(), message.size()))
      ::_exit(0);
  }
}

void stop(Reader& r) {
  if (r.pid > 0 && r.owner == ::getpid()) {
    ::kill(r.pid, SIGKILL);
    while (::waitpid(r.pid, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  if (r.socket >= 0) ::close(r.socket);
  if (r.journal >= 0) ::close(r.journal);
  r = Reader{};
  stats().pid = -1;
}

/// Forks a reader process; false if the system would not (the caller then
/// reads unprotected rather than not at all).
bool start(Reader& r) {
  int ends[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, ends) != 0) return false;
  const int journal = ::memfd_create("collide-shot-strings", MFD_CLOEXEC);
  if (journal < 0) {
    ::close(ends[0]);
    ::close(ends[1]);
    return false;
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // The reader ends with the thread that started it; so a reader stuck in
    // a looping read does not outlive a killed program.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(0);
#if defined(COLLIDE_ASAN)
    // The reader just ends (the program reports it), without the death hook
    // a host such as libFuzzer installed for its own process; a report about
    // this program's own code ends it with kOwnCodeFailed.
    __sanitizer_set_death_callback(onSanitizerReport);
#endif
    // A host's handler for the abort a sanitizer ends with (libFuzzer's
    // writes the input as a crash-* file and exits) is the host's, not the
    // reader's: the reader dies of SIGABRT.
    std::signal(SIGABRT, SIG_DFL);
    closeAllBut({ends[1], journal});
    serve(ends[1], journal);
  }
  ::close(ends[1]);
  if (pid < 0) {
    ::close(ends[0]);
    ::close(journal);
    return false;
  }
  r = Reader{.pid = pid, .socket = ends[0], .journal = journal, .reads = 0, .owner = parent};
  ++stats().started;
  stats().pid = pid;
  return true;
}

std::string describeEnd(int status) {
  if (WIFSIGNALED(status)) return std::string("SIG") + sigabbrev_np(WTERMSIG(status));
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  return "status " + std::to_string(status);
}

bool sendRequest(const Reader& r, ReadWork work, const std::string& path, bool frames) {
  const std::uint8_t flag = frames ? 1 : 0;
  const auto length = static_cast<std::uint32_t>(path.size());
  return sendAll(r.socket, &work, sizeof work) && sendAll(r.socket, &flag, 1) &&
         sendAll(r.socket, &length, sizeof length) && sendAll(r.socket, path.data(), path.size());
}

/// Waits for the reader's answer to one request, for `limit_s` seconds.
ProbeResult awaitAnswer(Reader& r, double limit_s, double cpu_before) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<long long>(limit_s * 1000));
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd p{.fd = r.socket, .events = POLLIN, .revents = 0};
    const int ready = left.count() > 0 ? ::poll(&p, 1, static_cast<int>(left.count() + 1)) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready > 0) {
      char answer = 0;
      std::uint32_t size = 0;
      std::string message;
      if (readAllFromFd(r.socket, &answer, 1) && readAllFromFd(r.socket, &size, sizeof size) &&
          (message.resize(size), readAllFromFd(r.socket, message.data(), size))) {
        ProbeResult finished;
        if (answer == kJournalSaved) finished.strings = h5::VlenJournal::load(r.journal);
        if (size > 0) finished.error = std::move(message);
        return finished;
      }
      // The reader ended without answering: the library crashed (a signal,
      // or a sanitizer's exit status).
      int status = 0;
      while (::waitpid(r.pid, &status, 0) < 0 && errno == EINTR) {
      }
      r.pid = -1;
      if (WIFEXITED(status) && WEXITSTATUS(status) == kOwnCodeFailed)
        return ProbeResult{.end = ProbeResult::End::OwnCodeFailed};
      return ProbeResult{.end = ProbeResult::End::Crashed, .how = describeEnd(status)};
    }
    if (ready == 0 && std::chrono::steady_clock::now() < deadline) continue;  // woke early
    // Past the limit: a reader that worked is reading a file the library
    // loops on; one asleep that hardly ran inherited another thread's lock
    // at the fork (seen under AddressSanitizer with analysis threads busy).
    // A reader that hardly ran because other processes had the CPUs is still
    // runnable ('R'): not idle, or a looping file would be read here next.
    const ProcStat now = procStat(r.pid);
    const double cpu = now.cpu_s - cpu_before;
    const bool idle = now.state == 'S' && std::isfinite(cpu) && cpu < 0.1 * limit_s;
    return ProbeResult{.end = idle ? ProbeResult::End::Stalled : ProbeResult::End::Looped};
  }
}

}  // namespace

ProbeResult probeInReaderProcess(const std::string& path, bool frames, double limit_s,
                                 ReadWork work) {
  Reader& r = reader();
  if (r.pid > 0 && r.owner != ::getpid()) stop(r);  // inherited by a fork: not ours
  for (;;) {
    if (r.pid > 0 && ::waitpid(r.pid, nullptr, WNOHANG) == r.pid) {
      r.pid = -1;  // it ended between requests (the thread that started it ended)
      stop(r);
    }
    if (r.pid <= 0 && !start(r)) return ProbeResult{};
    const bool fresh = r.reads == 0;
    ++r.reads;
    ++stats().reads;
    const double cpu_before = procStat(r.pid).cpu_s;
    if (!sendRequest(r, work, path, frames)) {
      stop(r);  // it ended while idle: a new one takes the request
      if (fresh) return ProbeResult{};
      continue;
    }
    ProbeResult result = awaitAnswer(r, limit_s, cpu_before);
    if (result.end == ProbeResult::End::Finished) {
      if (r.reads >= kReadsPerProcess) stop(r);
      return result;
    }
    stop(r);
    // A crash or a loop after other files may be their doing: only a fresh
    // process's verdict is the file's.
    if (fresh || result.end == ProbeResult::End::Stalled ||
        result.end == ProbeResult::End::OwnCodeFailed)
      return result;
  }
}

ReaderProcessStats readerProcessStats() {
  return stats();
}

}  // namespace collide::app
