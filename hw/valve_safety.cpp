#include "hw/valve_safety.hpp"

#include <signal.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <mutex>

namespace collide::hw {

namespace {

constexpr int kSlots = 64;
std::array<std::atomic<ValveLines*>, kSlots> g_slots{};
// Handlers running right now: unregistering waits for them, so a handler
// never uses lines that are being destroyed.
std::atomic<int> g_in_handler{0};
std::atomic<int> g_caught_signal{0};

constexpr std::array<int, 9> kSignals = {SIGINT,  SIGTERM, SIGHUP, SIGQUIT, SIGABRT,
                                         SIGSEGV, SIGBUS,  SIGFPE, SIGILL};
std::array<struct sigaction, kSignals.size()> g_previous{};
std::once_flag g_install_once;

void driveAllInactive() noexcept {
  g_in_handler.fetch_add(1);
  for (auto& slot : g_slots)
    if (ValveLines* lines = slot.load()) lines->setAllInactiveFromSignal();
  g_in_handler.fetch_sub(1);
}

void onExit() {
  driveAllInactive();
}

void onSignal(int sig, siginfo_t* info, void* context) {
  const int saved_errno = errno;
  driveAllInactive();
  g_caught_signal.store(sig);
  for (std::size_t i = 0; i < kSignals.size(); ++i) {
    if (kSignals[i] != sig) continue;
    const struct sigaction& prev = g_previous[i];
    if (prev.sa_flags & SA_SIGINFO) {
      if (prev.sa_sigaction) prev.sa_sigaction(sig, info, context);
    } else if (prev.sa_handler == SIG_DFL) {
      // Default action (end the process, maybe with a core): restore it and
      // re-raise; the signal is blocked in here and arrives when we return.
      sigaction(sig, &prev, nullptr);
      raise(sig);
    } else if (prev.sa_handler != SIG_IGN) {
      prev.sa_handler(sig);
    }
  }
  errno = saved_errno;
}

void install() {
  std::atexit(&onExit);
  for (std::size_t i = 0; i < kSignals.size(); ++i) {
    sigaction(kSignals[i], nullptr, &g_previous[i]);
    // A signal the program ignores (nohup's SIGHUP) stays ignored.
    if (!(g_previous[i].sa_flags & SA_SIGINFO) && g_previous[i].sa_handler == SIG_IGN) continue;
    struct sigaction sa {};
    sa.sa_sigaction = &onSignal;
    sa.sa_flags = SA_SIGINFO | SA_RESTART;
    sigemptyset(&sa.sa_mask);
    sigaction(kSignals[i], &sa, &g_previous[i]);
  }
}

}  // namespace

ValveSafetyGuard::ValveSafetyGuard(ValveLines* lines) {
  std::call_once(g_install_once, &install);
  for (int i = 0; i < kSlots; ++i) {
    ValveLines* expected = nullptr;
    if (g_slots[static_cast<std::size_t>(i)].compare_exchange_strong(expected, lines)) {
      slot_ = i;
      return;
    }
  }
}

ValveSafetyGuard::~ValveSafetyGuard() {
  if (slot_ < 0) return;
  g_slots[static_cast<std::size_t>(slot_)].store(nullptr);
  // A handler on another thread may still hold the pointer it loaded.
  while (g_in_handler.load() != 0) {
  }
}

int valveSafetySignal() {
  return g_caught_signal.load();
}

void clearValveSafetySignal() {
  g_caught_signal.store(0);
}

}  // namespace collide::hw
