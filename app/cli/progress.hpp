#pragma once
// A progress bar on stderr for long commands: redrawn in place on a terminal,
// one line per step otherwise (logs, CI), so both stay readable.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace collide::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, int total)
      : label_(std::move(label)),
        total_(total),
        tty_(isatty(fileno(stderr))),
        start_(std::chrono::steady_clock::now()) {}

  /// `done` of total finished; `note` says what the last one was.
  void update(int done, const std::string& note = {}) {
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double eta = done > 0 ? elapsed / done * (total_ - done) : 0.0;
    constexpr int kWidth = 30;
    const int filled = total_ > 0 ? kWidth * done / total_ : kWidth;
    std::string bar(filled, '#');
    bar.resize(kWidth, '.');
    if (tty_) {
      std::fprintf(stderr, "\r%s [%s] %d/%d  %.0f s left  %-40.40s", label_.c_str(), bar.c_str(),
                   done, total_, eta, note.c_str());
      if (done >= total_) std::fputc('\n', stderr);
    } else {
      std::fprintf(stderr, "%s %d/%d (%.1f s) %s\n", label_.c_str(), done, total_, elapsed,
                   note.c_str());
    }
    std::fflush(stderr);
  }

 private:
  std::string label_;
  int total_;
  bool tty_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace collide::cli
