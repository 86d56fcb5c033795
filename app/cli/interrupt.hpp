#pragma once
// Ctrl-C (SIGINT) and SIGTERM as a stop request for long commands: the work
// stops at the next safe point (after the current shot) and keeps everything
// done so far. One instance at a time; the previous handlers come back when it
// goes out of scope.
#include <csignal>
#include <stop_token>

namespace collide::cli {

class StopOnInterrupt {
 public:
  StopOnInterrupt() {
    current() = &stop_;
    old_int_ = std::signal(SIGINT, onSignal);
    old_term_ = std::signal(SIGTERM, onSignal);
  }
  ~StopOnInterrupt() {
    std::signal(SIGINT, old_int_);
    std::signal(SIGTERM, old_term_);
    current() = nullptr;
  }
  StopOnInterrupt(const StopOnInterrupt&) = delete;
  StopOnInterrupt& operator=(const StopOnInterrupt&) = delete;

  std::stop_token token() const { return stop_.get_token(); }
  bool interrupted() const { return stop_.stop_requested(); }

 private:
  static std::stop_source*& current() {
    static std::stop_source* s = nullptr;
    return s;
  }
  // request_stop is an atomic update: safe enough from a signal handler here.
  static void onSignal(int) {
    if (current()) current()->request_stop();
  }
  std::stop_source stop_;
  void (*old_int_)(int) = SIG_DFL;
  void (*old_term_)(int) = SIG_DFL;
};

}  // namespace collide::cli
