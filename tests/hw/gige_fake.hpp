#pragma once
// Test fixture: Aravis' GigE Vision camera simulator, `arv-fake-gv-camera-0.8
// -i 127.0.0.1` (Debian package aravis-tools), as a child process: real GVCP
// control and GVSP streaming over loopback. Started with a serial number of
// its own, and ready once a camera opened at 127.0.0.1 reports that serial
// (so a test never talks to another simulator left running on the machine).
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "hw/camera_aravis.hpp"

namespace collide::hw::testing {

class GigeFake {
 public:
  static constexpr const char* kProgram = "arv-fake-gv-camera-0.8";
  static constexpr const char* kAddress = "127.0.0.1";

  /// Starts the simulator with `extra` arguments (e.g. {"-r", "10"}: lose 10
  /// packets per thousand). ok() tells whether it answers; reason() why not.
  explicit GigeFake(const std::vector<std::string>& extra = {}) {
    const std::string program = onPath(kProgram);
    if (program.empty()) {
      reason_ = std::string(kProgram) + " is not installed (Debian package aravis-tools)";
      return;
    }
    serial_ = "CT" + std::to_string(::getpid() % 100000) + "-" + std::to_string(++instances());
    std::vector<std::string> args{kProgram, "-i", kAddress, "-s", serial_};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      // The child: dies with the test program, whatever happens to it; its
      // warnings (e.g. about resend requests it ignores) are noise here.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      ::execv(program.c_str(), argv.data());
      ::_exit(127);
    }
    if (pid_ < 0) {
      pid_ = -1;
      reason_ = std::string("cannot start ") + kProgram;
      return;
    }
    waitUntilReady();
  }

  ~GigeFake() { stop(SIGTERM); }
  GigeFake(const GigeFake&) = delete;
  GigeFake& operator=(const GigeFake&) = delete;

  bool ok() const { return ready_; }
  const std::string& reason() const { return reason_; }
  const std::string& serial() const { return serial_; }

  /// The camera dies at once (power cut, cable pulled).
  void kill() { stop(SIGKILL); }

 private:
  static int& instances() {
    static int n = 0;
    return n;
  }

  // The program's full path, or "" if it is not on PATH.
  static std::string onPath(const std::string& program) {
    const char* path = std::getenv("PATH");
    std::string p = path ? path : "/usr/bin:/bin";
    std::size_t start = 0;
    while (start <= p.size()) {
      const std::size_t end = std::min(p.find(':', start), p.size());
      const std::string candidate = p.substr(start, end - start) + "/" + program;
      if (::access(candidate.c_str(), X_OK) == 0) return candidate;
      start = end + 1;
    }
    return "";
  }

  bool alive() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    return true;
  }

  void waitUntilReady() {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    std::string seen = "nothing answered";
    while (std::chrono::steady_clock::now() < deadline) {
      if (!alive()) {
        reason_ = std::string(kProgram) + " exited at start (is 127.0.0.1:3956 taken?)";
        return;
      }
      CameraAravis probe(kAddress, {});
      if (probe.open()) {
        auto id = probe.feature("DeviceID");
        (void)probe.close();
        if (id && *id == serial_) {
          ready_ = true;
          return;
        }
        seen = "a camera with serial \"" + (id ? *id : std::string("?")) + "\" answered";
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    reason_ = std::string(kProgram) + " did not come up at 127.0.0.1 (" + seen + ")";
  }

  void stop(int signal) {
    if (pid_ <= 0) return;
    ::kill(pid_, signal);
    for (int i = 0; i < 100; ++i) {  // up to 2 s, then for sure
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  pid_t pid_ = -1;
  bool ready_ = false;
  std::string serial_;
  std::string reason_;
};

}  // namespace collide::hw::testing
